function value = rmse(tau_meas, tau_pred, varargin)
%RMSE Root mean squared error.
%   value = dynval.rmse(tau_meas, tau_pred)     pooled, per_element: sqrt(SSE/(N m))
%   Options:
%     'multioutput'  'pooled' (default) | 'raw_values' (sqrt(SSE_j/N), 1-by-m) |
%                    'uniform_average' (mean over joints of the per-joint values)
%     'convention'   [] (default: 'per_element') | 'per_element' | 'per_sample' (sqrt(SSE/N),
%                    what the lesson's code computes); only with 'pooled'
%     'nan_policy'   'raise' | 'omit'
%
%   Example:
%     dynval.rmse(ones(2), zeros(2), 'convention', 'per_sample')    % sqrt(2)
  opt = dynval.internal.options('rmse', varargin, ...
    struct('multioutput', 'pooled', 'convention', [], 'nan_policy', 'raise'));
  [meas, pred] = dynval.internal.signal_pair('rmse', tau_meas, tau_pred);
  data = dynval.internal.prepare('rmse', {meas, pred}, {'tau_meas', 'tau_pred'}, [0 0], opt.nan_policy);
  mo = dynval.internal.check_multioutput(opt.multioutput, {'pooled', 'raw_values', 'uniform_average'}, 'rmse');
  convention = opt.convention;
  if isempty(convention) && (isnumeric(convention) || ischar(convention))
    convention = 'per_element';
  elseif ~strcmp(mo, 'pooled')
    dynval.internal.param_error('convention', 'None unless multioutput=''pooled''', convention);
  else
    dynval.internal.check_choice('convention', convention, {'per_element', 'per_sample'});
  end
  e = data{1} - data{2};
  [n, m] = size(e);
  if strcmp(mo, 'pooled')
    [es, k] = dynval.internal.scale_columns(e(:));  % contract §1.3: the root is scaled back
    total = sum(es .^ 2);
    if strcmp(convention, 'per_sample')
      value = dynval.internal.ldexp(sqrt(total / n), k);
    else
      value = dynval.internal.ldexp(sqrt(total / (n * m)), k);
    end
  else
    [es, k] = dynval.internal.scale_columns(e);
    value = dynval.internal.ldexp(sqrt(sum(es .^ 2, 1) / n), k);
    if strcmp(mo, 'uniform_average')
      value = mean(value);
    end
  end
end

%!assert (dynval.rmse (ones (2), zeros (2)), 1)
%!assert (dynval.rmse (ones (2), zeros (2), 'convention', 'per_sample'), sqrt (2))
%!assert (dynval.rmse ([1 2; 1 2], [0 0; 0 0], 'multioutput', 'raw_values'), [1 2])
%!assert (dynval.rmse ([1 2; 1 2], [0 0; 0 0], 'multioutput', 'uniform_average'), 1.5)
%!error <convention must be None unless multioutput='pooled', got 'per_sample'> dynval.rmse (ones (3, 2), ones (3, 2), 'multioutput', 'raw_values', 'convention', 'per_sample')
%!error <convention must be one of 'per_element', 'per_sample', got 'per_joint'> dynval.rmse (ones (3, 2), ones (3, 2), 'convention', 'per_joint')
