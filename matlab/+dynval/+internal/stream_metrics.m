function r = stream_metrics(s, max_lag, n_params, noise_model)
%STREAM_METRICS The metrics of dynval.ValidationAccumulator.result from the accumulated sums.
%   Every sum is moved to the overall mean first (means are overall, lags stay inside records,
%   contract §1.1), with the identity of stream_merge; then the in-memory definitions apply,
%   with the same degenerate values (fit_values, assemble_criteria, log_det_term). The sums are
%   in the power-of-two units of their columns (stream_block): ratios are formed in them, and
%   sums of squares, means and variances are put back with their exponents (pow2).
  m = s.m;
  p = s.p;
  n = s.n;
  rows = 1:max_lag + 1;
  nl = s.pairs(rows);
  cur = s.cur_e.hi(rows, :) + s.cur_e.lo(rows, :);
  lag = s.lag_e.hi(rows, :) + s.lag_e.lo(rows, :);
  prod = s.prod_e.hi(rows, :) + s.prod_e.lo(rows, :);
  % a = mean - K: small, because the centres follow the running means
  a = cur(1, :) / n;
  mean_e = s.k_e + a;
  e_constant = s.min_e == s.max_e;
  cov = prod - a .* (cur + lag) + nl .* a .^ 2;   % sum (e_t - mean)(e_(t-l) - mean) over the pairs
  ssc = max(cov(1, :), 0);
  ssc(e_constant) = 0;
  sum_t = s.sum_t.hi + s.sum_t.lo;
  sq_t = s.sq_t.hi + s.sq_t.lo;
  t_constant = s.min_t == s.max_t;
  tss = max(sq_t - sum_t .^ 2 / n, 0);
  tss(t_constant) = 0;

  r = struct();
  r.n_samples = n;
  ke = s.exp_e;
  sse = ssc + n * mean_e .^ 2;   % in units 4^exp_e; two terms >= 0: nothing cancels
  r.sse = pow2(sse, 2 * ke);
  r.rmse = pow2(sqrt(sse / n), ke);
  r.max_abs_error = max(abs(s.min_e), abs(s.max_e));
  tss_e = pow2(tss, 2 * (s.exp_t - ke));   % the TSS in the residual's units (ratios only)
  r.vaf = dynval.internal.fit_values('vaf', sse, ssc, tss_e, t_constant, e_constant);
  r.fit_percent = dynval.internal.fit_values('fit_percent', sse, ssc, tss_e, t_constant, e_constant);
  r.r2 = dynval.internal.fit_values('r2', sse, ssc, tss_e, t_constant, e_constant);
  r.residual_mean = pow2(mean_e, ke);
  r.residual_variance = pow2(ssc / (n - 1), 2 * ke);
  acf = (cov ./ nl) ./ (ssc / n);
  acf(1, :) = 1;
  acf(:, e_constant | ssc == 0) = NaN;
  r.autocorrelation = acf;

  if p > 0
    joint = reshape(repmat(1:m, p, 1), 1, m * p);
    lag_y = s.lag_y.hi(rows, :) + s.lag_y.lo(rows, :);
    prod_ey = s.prod_ey.hi(rows, :) + s.prod_ey.lo(rows, :);
    sq_y = s.sq_y.hi + s.sq_y.lo;
    b = lag_y(1, :) / n;
    y_constant = s.min_y == s.max_y;
    ss_y = max(sq_y - lag_y(1, :) .^ 2 / n, 0);
    ss_y(y_constant) = 0;
    aj = a(joint);
    c0 = prod_ey - b .* cur(:, joint) - aj .* lag_y + nl .* (aj .* b);
    % two roots, not the root of the product (contract §1.3), as dynval.cross_correlation
    rho = (c0 ./ nl) ./ (sqrt(ssc(joint) / n) .* sqrt(ss_y / n));
    rho(:, y_constant | e_constant(joint) | ssc(joint) == 0 | ss_y == 0) = NaN;
    r.rho = permute(reshape(rho.', p, m, max_lag + 1), [2 1 3]);
  else
    r.rho = [];
  end

  switch noise_model
    case 'pooled'
      n_obs = n * m;
      n_vec = n_obs;
      live = sse > 0;
      top = 0;
      if any(live)
        top = max(ke(live));
      end
      total = sum(pow2(sse, 2 * (ke - top)));   % in units 4^top
      if total == 0
        f = -Inf;
        size_term = 0;
      else
        size_term = pow2(total / n_obs, 2 * top);
        f = n_obs * (log(total / n_obs) + 2 * top * log(2));
      end
    case 'per_joint'
      n_obs = n;
      n_vec = n;
      if any(sse == 0)
        f = -Inf;
        size_term = 0;
      else
        log_size = sum(log(sse / n) + 2 * ke * log(2));
        f = n * log_size;
        size_term = exp(log_size);
      end
    otherwise
      n_obs = n;
      n_vec = n;
      % E'E/N is not demeaned: the centred products plus the outer product of the means.
      % One exponent for the whole matrix, the largest joint's.
      g = s.products.hi + s.products.lo;
      c = cur(1, :);
      top = max(ke);
      sh = ke - top;
      mc = pow2(mean_e, sh);
      sigma = pow2(g - c' * c / n, sh' + sh) / n + mc' * mc;
      log_det = dynval.internal.log_det_term(sigma) + 2 * top * m * log(2);
      f = n * log_det;
      size_term = exp(log_det);
  end
  ic = dynval.internal.assemble_criteria(f, n_vec, n_obs, double(n_params), size_term);
  ic.n_obs = n_obs;
  ic.n_params = double(n_params);
  ic.noise_model = noise_model;
  r.criteria = ic;
end
