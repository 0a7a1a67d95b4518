function res = zero_mean_test(e, varargin)
%ZERO_MEAN_TEST Does each joint's residual have zero mean? i.i.d. and autocorrelation-corrected t-tests.
%   res = dynval.zero_mean_test(e)
%   res = dynval.zero_mean_test(e, 'segments', [500 300], 'nan_policy', 'omit')
%
%   Fields of res (per-joint values are 1-by-m):
%     mean, std (ddof 1), n_samples;
%     statistic_iid, pvalue_iid, df_iid = N - 1: the Student t-test, as scipy's ttest_1samp;
%     statistic_eff, pvalue_eff, df_eff, n_eff, bandwidth: Newey-West (Bartlett) correction,
%       K = floor(4 (N/100)^(2/9)), N_eff = N / (1 + 2 sum_k (1 - k/(K+1)) rho_k) clipped to
%       [2, N]. Robot residuals are autocorrelated; the corrected p-value is the one to read.
%
%   Example:
%     r = dynval.zero_mean_test([0.1; -0.2; 0.15; -0.05; 0; 0.02]);  r.df_iid   % 5
  opt = dynval.internal.options('zero_mean_test', varargin, struct('segments', [], 'nan_policy', 'raise'));
  e = dynval.internal.residual_signal('zero_mean_test', e);
  [data, starts] = dynval.internal.prepare('zero_mean_test', {e}, {'e'}, 0, opt.nan_policy, opt.segments);
  e = data{1};
  n = size(e, 1);
  % t is a ratio: computed on e scaled by a power of two per joint (contract §1.3).
  [es, scale] = dynval.internal.scale_columns(e);
  [mu, ss] = dynval.internal.moments(es);
  sd = sqrt(ss / (n - 1));
  k = min(floor(4 * (n / 100) ^ (2 / 9)), n - 1);
  % Lags past the longest segment have no products: their rho is 0 and adds nothing.
  k_used = min(k, dynval.internal.segment_limit(starts, n) - 1);
  if k_used > 0
    rho = dynval.internal.acf(e, k_used, false, starts);
    weights = 1 - (1:k_used)' / (k + 1);
    total = sum(weights .* rho(2:end, :), 1);
  else
    total = zeros(1, size(e, 2));
  end
  n_eff = min(max(n ./ (1 + 2 * total), 2), n);
  n_eff(isnan(total) | total <= 0) = n;
  res = struct();
  res.mean = dynval.internal.ldexp(mu, scale);
  res.std = dynval.internal.ldexp(sd, scale);
  res.n_samples = n;
  res.statistic_iid = mu * sqrt(n) ./ sd;
  res.pvalue_iid = dynval.internal.t_sf2(res.statistic_iid, n - 1);
  res.df_iid = n - 1;
  res.statistic_eff = mu .* sqrt(n_eff) ./ sd;
  res.pvalue_eff = dynval.internal.t_sf2(res.statistic_eff, n_eff - 1);
  res.df_eff = n_eff - 1;
  res.n_eff = n_eff;
  res.bandwidth = k;
end

%!test
%! r = dynval.zero_mean_test ([0.1; -0.2; 0.15; -0.05; 0; 0.02]);
%! assert (r.df_iid, 5);
%! assert (r.n_samples, 6);
%! % scipy.stats.ttest_1samp([0.1, -0.2, 0.15, -0.05, 0, 0.02], 0)
%! assert (r.statistic_iid, 0.06651901052377387, 1e-14);
%! assert (r.pvalue_iid, 0.9495425219429324, 1e-13);
%!test
%! r = dynval.zero_mean_test ([1 2; 1 3; 1 4]);
%! assert (r.statistic_iid(1), Inf);
%! assert (r.pvalue_iid(1), 0);
%! assert (r.n_eff(1), 3);
%!test
%! r = dynval.zero_mean_test ([0; 0; 0]);
%! assert (isnan (r.statistic_iid) && isnan (r.pvalue_iid));
