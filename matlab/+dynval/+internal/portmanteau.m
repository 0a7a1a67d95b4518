function res = portmanteau(test, e, lags, varargin)
%PORTMANTEAU Shared body of dynval.ljung_box and dynval.box_pierce.
  opt = dynval.internal.options(test, varargin, struct('model_df', 0, 'segments', [], 'nan_policy', 'raise'));
  e = dynval.internal.residual_signal(test, e);
  [data, starts] = dynval.internal.prepare(test, {e}, {'e'}, 0, opt.nan_policy, opt.segments);
  e = data{1};
  n = size(e, 1);
  limit = dynval.internal.segment_limit(starts, n);
  requirement = sprintf('a positive integer or a non-empty sequence of positive integers less than %d', limit);
  ok = isnumeric(lags) && isreal(lags) && isvector(lags) && ~isempty(lags);
  if ok
    for v = lags(:)'
      ok = ok && dynval.internal.is_integer(v) && v > 0 && v < limit;
    end
  end
  if ~ok
    dynval.internal.param_error('lags', requirement, lags);
  end
  lags = double(lags(:));
  model_df = opt.model_df;
  if ~dynval.internal.is_integer(model_df) || ~(model_df >= 0 && model_df < min(lags))
    dynval.internal.param_error('model_df', sprintf('an integer with 0 <= model_df < %d', min(lags)), model_df);
  end
  model_df = double(model_df);
  h_max = max(lags);
  % The biased autocorrelation, as Ljung & Box, R and statsmodels use it.
  e = dynval.internal.scale_columns(e);  % rho does not depend on the scale (contract §1.3)
  constant = min(e, [], 1) == max(e, [], 1);
  d = dynval.internal.centred(e);
  ss = sum(d .^ 2, 1);
  ss(constant) = 0;
  s = dynval.internal.lagged_sums(d, d, h_max, starts);
  rho = s(2:end, :) ./ ss;
  rho(:, ss == 0) = NaN;
  if strcmp(test, 'ljung_box')
    counts = dynval.internal.product_counts(starts, n, h_max);
    cumulative = n * (n + 2) * cumsum(rho .^ 2 ./ counts(2:end), 1);
  else
    cumulative = n * cumsum(rho .^ 2, 1);
  end
  res = struct();
  res.test = test;
  res.lags = lags;
  res.model_df = model_df;
  res.statistic = cumulative(lags, :);
  res.df = lags - model_df;
  res.pvalue = dynval.internal.chi2_sf(res.statistic, res.df);
  res.log_pvalue = dynval.internal.chi2_logsf(res.statistic, res.df);
end
