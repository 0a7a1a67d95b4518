function e = residuals(tau_meas, tau_pred, varargin)
%RESIDUALS Residuals e = tau_meas - tau_pred, N-by-m.
%   e = dynval.residuals(tau_meas, tau_pred)
%   e = dynval.residuals(..., 'nan_policy', 'omit')   rows holding NaN/Inf are deleted
%
%   tau_meas, tau_pred: N-by-m (samples by joints; a column vector is one joint).
%
%   Example:
%     dynval.residuals([1; 2], [0.5; 2.5])      % [0.5; -0.5]
  opt = dynval.internal.options('residuals', varargin, struct('nan_policy', 'raise'));
  [meas, pred] = dynval.internal.signal_pair('residuals', tau_meas, tau_pred);
  data = dynval.internal.prepare('residuals', {meas, pred}, {'tau_meas', 'tau_pred'}, [0 0], opt.nan_policy);
  e = data{1} - data{2};
end

%!test
%! assert (dynval.residuals ([1; 2], [0.5; 2.5]), [0.5; -0.5]);
%!test
%! assert (dynval.residuals ([1 2; NaN 4; 5 6], [0 0; 0 0; 1 1], 'nan_policy', 'omit'), [1 2; 4 5]);
%!error <tau_meas and tau_pred must have the same shape, got \(3, 2\) and \(2, 2\)> dynval.residuals (ones (3, 2), ones (2, 2))
%!error <needs at least 1 samples, got N=0> dynval.residuals (zeros (0, 2), zeros (0, 2))
%!error <tau_pred has a non-finite value \(-inf\) at row 1, column 0> dynval.residuals ([1 2; 3 4], [1 2; -Inf 4])
