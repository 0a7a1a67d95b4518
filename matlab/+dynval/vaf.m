function value = vaf(tau_meas, tau_pred, varargin)
%VAF Variance accounted for, in percent: 100 (1 - var(e)/var(tau_meas)).
%   value = dynval.vaf(tau_meas, tau_pred, 'multioutput', mo, 'nan_policy', np)
%   mo: 'pooled' (the lesson: all N*m values, one global mean) | 'raw_values' (1-by-m) |
%       'uniform_average' | 'variance_weighted' (weights TSS_j; constant joints left out).
%   The lesson's var(y, 1) and var(e, 1) use the same ddof, which cancels in the ratio, so the
%   ratio of centred sums of squares is computed. A constant target gives -Inf, or NaN when
%   the residual is constant too.
%
%   Example:
%     dynval.vaf([1; 2; 3; 4], [1.1; 1.9; 3.1; 3.9])      % 99.2
  value = dynval.internal.normalized_fit('vaf', tau_meas, tau_pred, varargin{:});
end

%!assert (dynval.vaf ([1; 2; 3; 4], [1.1; 1.9; 3.1; 3.9]), 99.2, 1e-12)
%!assert (dynval.vaf ([1; 1; 1], [0; 1; 1]), -Inf)
%!assert (dynval.vaf ([1; 1; 1], [0; 0; 0]), NaN)
