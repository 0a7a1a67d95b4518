function metrics = validate_dynamics_model(tau_meas, tau_pred, p_params, varargin)
%VALIDATE_DYNAMICS_MODEL Every point metric, residual statistic and criterion of a model, in one call.
%   metrics = dynval.validate_dynamics_model(tau_meas, tau_pred, p_params)
%   metrics = dynval.validate_dynamics_model(..., 'ddof', 0, 'noise_model', 'full', 'nan_policy', 'omit')
%
%   The lesson's validate_dynamics_model, multi-joint and with the contract's names.
%   tau_meas, tau_pred: N-by-m measured and predicted torques (N >= 2); p_params: number of
%   identified parameters. Options:
%     'ddof'         of residual_variance: 1 (default) or 0, the population form the lesson's
%                    var(y, 1) used (for VAF the ddof cancels; it only matters here)
%     'noise_model'  of the criteria: 'pooled' (default, the lesson) | 'per_joint' | 'full'
%     'nan_policy'   'raise' | 'omit'
%
%   Fields (per joint: 1-by-m): n_samples, n_joints, n_params; sse, rmse, max_abs_error, vaf,
%   fit_percent, r2, residual_mean, residual_variance, constant_target; pooled scalars
%   sse_total, rmse_per_element (sqrt(SSE/(N m)), the lesson's formula), rmse_per_sample
%   (sqrt(SSE/N), what the lesson's code computed), max_abs_error_pooled, vaf_pooled,
%   fit_percent_pooled, r2_pooled, constant_target_pooled; aggregates rmse_uniform_average,
%   vaf_uniform_average, fit_percent_uniform_average, r2_uniform_average,
%   vaf_variance_weighted, fit_percent_variance_weighted, r2_variance_weighted; criteria of
%   the noise model (constants dropped) aic, bic, aicc, fpe, naic (aicc, fpe NaN when
%   p >= n - 1, where the lesson's formulas are undefined).
%
%   Example:
%     t = [1 2; 2 1; 3 5; 4 4];  y = [1.1 2.2; 1.9 0.8; 3.2 5.1; 3.9 4.1];
%     m = dynval.validate_dynamics_model(t, y, 2);  m.r2          % per joint
  opt = dynval.internal.options('validate_dynamics_model', varargin, ...
    struct('ddof', 1, 'noise_model', 'pooled', 'nan_policy', 'raise'));
  [meas, pred] = dynval.internal.signal_pair('validate_dynamics_model', tau_meas, tau_pred);
  data = dynval.internal.prepare('validate_dynamics_model', {meas, pred}, {'tau_meas', 'tau_pred'}, [0 0], opt.nan_policy);
  meas = data{1};
  pred = data{2};
  [n, m] = size(meas);
  if ~dynval.internal.is_integer(p_params) || p_params < 0
    dynval.internal.param_error('n_params', 'an integer with n_params >= 0', p_params);
  end
  ddof = opt.ddof;
  if ~dynval.internal.is_integer(ddof) || ~(ddof >= 0 && ddof < n)
    dynval.internal.param_error('ddof', sprintf('an integer with 0 <= ddof < N=%d', n), ddof);
  end
  noise_model = dynval.internal.check_choice('noise_model', opt.noise_model, {'pooled', 'per_joint', 'full'});

  e = meas - pred;
  [mean_e, ssc_e, e_constant] = dynval.internal.moments(e);
  [~, tss, constant] = dynval.internal.moments(meas);
  sse = sum(e .^ 2, 1);
  [~, ssc_e_pooled, e_constant_pooled] = dynval.internal.moments(e(:));
  [~, tss_pooled, constant_pooled] = dynval.internal.moments(meas(:));
  sse_total = sum(sse);

  metrics = struct();
  metrics.n_samples = n;
  metrics.n_joints = m;
  metrics.n_params = double(p_params);
  metrics.sse = sse;
  metrics.rmse = sqrt(sse / n);
  metrics.max_abs_error = max(abs(e), [], 1);
  metrics.vaf = dynval.internal.fit_values('vaf', sse, ssc_e, tss, constant, e_constant);
  metrics.fit_percent = dynval.internal.fit_values('fit_percent', sse, ssc_e, tss, constant, e_constant);
  metrics.r2 = dynval.internal.fit_values('r2', sse, ssc_e, tss, constant, e_constant);
  metrics.residual_mean = mean_e;
  metrics.residual_variance = ssc_e / (n - double(ddof));
  metrics.constant_target = constant;
  metrics.sse_total = sse_total;
  metrics.rmse_per_element = sqrt(sse_total / (n * m));
  metrics.rmse_per_sample = sqrt(sse_total / n);
  metrics.max_abs_error_pooled = max(metrics.max_abs_error);
  metrics.vaf_pooled = dynval.internal.fit_values('vaf', sse_total, ssc_e_pooled, tss_pooled, ...
    constant_pooled, e_constant_pooled);
  metrics.fit_percent_pooled = dynval.internal.fit_values('fit_percent', sse_total, ssc_e_pooled, ...
    tss_pooled, constant_pooled, e_constant_pooled);
  metrics.r2_pooled = dynval.internal.fit_values('r2', sse_total, ssc_e_pooled, tss_pooled, ...
    constant_pooled, e_constant_pooled);
  metrics.constant_target_pooled = constant_pooled;
  metrics.rmse_uniform_average = mean(metrics.rmse);
  metrics.vaf_uniform_average = mean(metrics.vaf);
  metrics.fit_percent_uniform_average = mean(metrics.fit_percent);
  metrics.r2_uniform_average = mean(metrics.r2);
  metrics.vaf_variance_weighted = weighted(metrics.vaf, tss, constant);
  metrics.fit_percent_variance_weighted = weighted(metrics.fit_percent, tss, constant);
  metrics.r2_variance_weighted = weighted(metrics.r2, tss, constant);
  [f, n_ic, n_vec, size_term] = dynval.internal.fit_term(e, noise_model);
  ic = dynval.internal.assemble_criteria(f, n_vec, n_ic, double(p_params), size_term);
  metrics.aic = ic.aic;
  metrics.bic = ic.bic;
  metrics.aicc = ic.aicc;
  metrics.fpe = ic.fpe;
  metrics.naic = ic.naic;
end

function value = weighted(values, tss, constant)
  % TSS weights; constant joints get weight 0, and all-constant data the uniform average.
  live = ~constant;
  if ~any(live)
    value = mean(values);
  else
    value = sum(tss(live) .* values(live)) / sum(tss(live));
  end
end

%!test
%! % The fused metrics equal the single-metric functions.
%! t = [1 2; 2 1; 3 5; 4 4; 0 2];  y = [1.1 2.2; 1.9 0.8; 3.2 5.1; 3.9 4.1; 0.2 1.5];
%! m = dynval.validate_dynamics_model (t, y, 2);
%! assert (m.r2, dynval.r2 (t, y, 'multioutput', 'raw_values'), 1e-14);
%! assert (m.vaf_pooled, dynval.vaf (t, y), 1e-12);
%! assert (m.fit_percent_variance_weighted, dynval.fit_percent (t, y, 'multioutput', 'variance_weighted'), 1e-12);
%! assert (m.rmse_per_element, dynval.rmse (t, y), 1e-15);
%! assert (m.rmse_per_sample, dynval.rmse (t, y, 'convention', 'per_sample'), 1e-15);
%! assert (m.residual_variance, dynval.residual_variance (t - y), 1e-15);
%! assert (m.aic, dynval.aic (t, y, 2), 1e-12);
%! assert (m.bic, dynval.bic (t, y, 2), 1e-12);
%!test
%! % The lesson's formulas, transcribed (pooled, population variance).
%! t = [1 2; 2 1; 3 5; 4 4; 0 2];  y = [1.1 2.2; 1.9 0.8; 3.2 5.1; 3.9 4.1; 0.2 1.5];
%! m = dynval.validate_dynamics_model (t, y, 3, 'ddof', 0);
%! e = t - y;  yy = t(:);  ef = e(:);
%! assert (m.vaf_pooled, 100 * (1 - var (ef, 1) / var (yy, 1)), 1e-12);
%! assert (m.fit_percent_pooled, 100 * (1 - norm (ef) / norm (yy - mean (yy))), 1e-12);
%! assert (m.aic, 2 * 3 + 10 * log (mean (ef .^ 2)), 1e-12);
%! assert (m.bic, 3 * log (10) + 10 * log (mean (ef .^ 2)), 1e-12);
%! assert (m.residual_variance, var (e, 1), 1e-15);
%! assert (m.rmse_per_sample, sqrt (mean (sum (e .^ 2, 2))), 1e-15);
