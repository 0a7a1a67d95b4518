function value = normalized_fit(metric, tau_meas, tau_pred, varargin)
%NORMALIZED_FIT Shared body of dynval.vaf, dynval.fit_percent and dynval.r2.
  opt = dynval.internal.options(metric, varargin, struct('multioutput', 'pooled', 'nan_policy', 'raise'));
  [meas, pred] = dynval.internal.signal_pair(metric, tau_meas, tau_pred);
  data = dynval.internal.prepare(metric, {meas, pred}, {'tau_meas', 'tau_pred'}, [0 0], opt.nan_policy);
  meas = data{1};
  pred = data{2};
  mo = dynval.internal.check_multioutput(opt.multioutput, ...
    {'pooled', 'raw_values', 'uniform_average', 'variance_weighted'}, metric);
  e = meas - pred;
  if strcmp(mo, 'pooled')
    % The lesson's pooled form: all N*m values as one series with one global mean.
    meas = meas(:);
    e = e(:);
  end
  sse = sum(e .^ 2, 1);
  [~, ssc_e, e_constant] = dynval.internal.moments(e);
  [~, tss, constant] = dynval.internal.moments(meas);
  values = dynval.internal.fit_values(metric, sse, ssc_e, tss, constant, e_constant);
  switch mo
    case {'pooled', 'raw_values'}
      value = values;
    case 'uniform_average'
      value = mean(values);
    otherwise
      live = ~constant;
      if ~any(live)
        value = mean(values);
      else
        value = sum(tss(live) .* values(live)) / sum(tss(live));
      end
  end
end
