function mu = residual_mean(e, varargin)
%RESIDUAL_MEAN Mean of each joint's residual (1-by-m).
%   mu = dynval.residual_mean(e, 'nan_policy', 'raise' | 'omit')
%
%   Example:
%     dynval.residual_mean([1 0; 3 1])      % [2 0.5]
  opt = dynval.internal.options('residual_mean', varargin, struct('nan_policy', 'raise'));
  e = dynval.internal.residual_signal('residual_mean', e);
  data = dynval.internal.prepare('residual_mean', {e}, {'e'}, 0, opt.nan_policy);
  [es, k] = dynval.internal.scale_columns(data{1});  % contract §1.3
  mu = dynval.internal.ldexp(dynval.internal.moments(es), k);
end

%!assert (dynval.residual_mean ([1 0; 3 1]), [2 0.5])
%!assert (dynval.residual_mean ([1; NaN; 3], 'nan_policy', 'omit'), 2)
%!test
%! % The corrected two-pass mean holds data riding on a large offset.
%! x = 1e7 + [0.1; 0.2; 0.3];
%! assert (abs (dynval.residual_mean (x) - (1e7 + 0.2)) <= 2e-9);
