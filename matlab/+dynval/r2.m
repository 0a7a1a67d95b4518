function value = r2(tau_meas, tau_pred, varargin)
%R2 Coefficient of determination 1 - SSE/TSS (a fraction).
%   value = dynval.r2(tau_meas, tau_pred, 'multioutput', mo, 'nan_policy', np)
%   'pooled' (default) uses all N*m values with one global mean (the lesson); 'raw_values',
%   'uniform_average' and 'variance_weighted' match scikit-learn's r2_score.
%
%   Example:
%     dynval.r2([1; 2; 3], [1; 2; 4])      % 0.5
  value = dynval.internal.normalized_fit('r2', tau_meas, tau_pred, varargin{:});
end

%!assert (dynval.r2 ([1; 2; 3], [1; 2; 4]), 0.5)
%!assert (dynval.r2 ([1 5; 2 5; 3 5], [1 5; 2 5; 4 6], 'multioutput', 'raw_values'), [0.5 -Inf])
%!assert (dynval.r2 ([1 5; 2 5; 3 5], [1 5; 2 5; 4 6], 'multioutput', 'variance_weighted'), 0.5)
%!assert (dynval.r2 ([1 5; 2 5; 3 5], [1 5; 2 5; 4 6], 'multioutput', 'uniform_average'), -Inf)
%!error <r2 needs at least 2 samples, got N=1> dynval.r2 ([1 2], [1 2])
%!error <tau_meas must have at least one column, got shape \(3, 0\)> dynval.r2 (zeros (3, 0), zeros (3, 0))
%!error <tau_meas must be 1-D \(N,\) or 2-D \(N, m\), got shape \(2, 2, 2\)> dynval.r2 (ones (2, 2, 2), ones (2, 2, 2))
%!error <tau_meas has a value out of range \(1e\+145\) at row 2, column 1> dynval.r2 ([1 2; 3 4; 5 1e145], ones (3, 2))
%!error <nan_policy must be one of 'raise', 'omit', got 'ignore'> dynval.r2 (ones (3, 2), ones (3, 2), 'nan_policy', 'ignore')
%!error <tau_meas has a non-finite value \(nan\)> dynval.r2 ([NaN 1; 2 3; 4 5], ones (3, 2), 'multioutput', 'bogus')
%!error <r2 needs at least 2 samples, got N=1> dynval.r2 ([NaN; 1; Inf], [1; 2; 3], 'nan_policy', 'omit')
