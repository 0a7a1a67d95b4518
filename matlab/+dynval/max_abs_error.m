function value = max_abs_error(tau_meas, tau_pred, varargin)
%MAX_ABS_ERROR Largest absolute residual: pooled scalar or per joint (1-by-m).
%   value = dynval.max_abs_error(tau_meas, tau_pred, 'multioutput', 'raw_values')
%   Options: 'multioutput' ('pooled' | 'raw_values'), 'nan_policy' ('raise' | 'omit').
%
%   Example:
%     dynval.max_abs_error([1; 2; 3], [1.5; 2; 1])     % 2
  opt = dynval.internal.options('max_abs_error', varargin, struct('multioutput', 'pooled', 'nan_policy', 'raise'));
  [meas, pred] = dynval.internal.signal_pair('max_abs_error', tau_meas, tau_pred);
  data = dynval.internal.prepare('max_abs_error', {meas, pred}, {'tau_meas', 'tau_pred'}, [0 0], opt.nan_policy);
  mo = dynval.internal.check_multioutput(opt.multioutput, {'pooled', 'raw_values'}, 'max_abs_error');
  e = abs(data{1} - data{2});
  if strcmp(mo, 'pooled')
    value = max(e(:));
  else
    value = max(e, [], 1);
  end
end

%!assert (dynval.max_abs_error ([1; 2; 3], [1.5; 2; 1]), 2)
%!assert (dynval.max_abs_error ([1 2; 3 4], [0 2; 3 1], 'multioutput', 'raw_values'), [1 3])
