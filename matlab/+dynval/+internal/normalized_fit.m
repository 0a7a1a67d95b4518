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
  % Sums of squares of e and tau each scaled by a power of two (contract §1.3); the residual's
  % sums are then put on the target's scale (pow2: exact, IEEE where the ratio leaves float64).
  [es, ke] = dynval.internal.scale_columns(e);
  [ms, kt] = dynval.internal.scale_columns(meas);
  sse = dynval.internal.ldexp(sum(es .^ 2, 1), 2 * (ke - kt));
  [~, ssc_e, e_constant] = dynval.internal.moments(es);
  ssc_e = dynval.internal.ldexp(ssc_e, 2 * (ke - kt));
  [~, tss, constant] = dynval.internal.moments(ms);
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
        % The TSS at the largest live joint's scale, so that tiny joints keep their weight.
        weights = dynval.internal.ldexp(tss(live), 2 * (kt(live) - max(kt(live))));
        value = sum(weights .* values(live)) / sum(weights);
      end
  end
end
