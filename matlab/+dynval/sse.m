function value = sse(tau_meas, tau_pred, varargin)
%SSE Sum of squared errors: pooled scalar or per joint (1-by-m).
%   value = dynval.sse(tau_meas, tau_pred)                            sum over all joints
%   value = dynval.sse(tau_meas, tau_pred, 'multioutput', 'raw_values')   SSE_j per joint
%   Options: 'multioutput' ('pooled' | 'raw_values'), 'nan_policy' ('raise' | 'omit').
%
%   Example:
%     dynval.sse([1 2; 3 4], [1 1; 3 2])        % 5
  opt = dynval.internal.options('sse', varargin, struct('multioutput', 'pooled', 'nan_policy', 'raise'));
  [meas, pred] = dynval.internal.signal_pair('sse', tau_meas, tau_pred);
  data = dynval.internal.prepare('sse', {meas, pred}, {'tau_meas', 'tau_pred'}, [0 0], opt.nan_policy);
  mo = dynval.internal.check_multioutput(opt.multioutput, {'pooled', 'raw_values'}, 'sse');
  e = data{1} - data{2};
  if strcmp(mo, 'pooled')
    e = e(:);
  end
  [es, k] = dynval.internal.scale_columns(e);  % contract §1.3: no square underflows
  value = dynval.internal.ldexp(sum(es .^ 2, 1), 2 * k);
end

%!assert (dynval.sse ([1 2; 3 4], [1 1; 3 2]), 5)
%!assert (dynval.sse ([1 2; 3 4], [1 1; 3 2], 'multioutput', 'raw_values'), [0 5])
%!error <multioutput must be one of 'pooled', 'raw_values' for sse, got 'uniform_average'> dynval.sse (ones (3, 2), ones (3, 2), 'multioutput', 'uniform_average')
%!error <tau_meas must be an array of real numbers, got str> dynval.sse ('abc', ones (3, 1))
