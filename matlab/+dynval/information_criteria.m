function ic = information_criteria(rss, n_obs, n_params)
%INFORMATION_CRITERIA AIC, BIC, AICc, FPE and nAIC from a residual sum of squares (constants dropped).
%   ic = dynval.information_criteria(rss, n_obs, n_params)
%   sigma2 = rss/n; aic = 2p + n ln sigma2; bic = p ln n + n ln sigma2;
%   aicc = aic + 2p(p+1)/(n-p-1); fpe = sigma2 (1 + p/n)/(1 - p/n); naic = ln sigma2 + 2p/n.
%   Requires p < n - 1 (aicc and fpe are undefined beyond).
%
%   Example (the lesson's Problem 4):
%     ic = dynval.information_criteria(10, 1000, 6);  ic.aic      % -4593.170185988091
  if ~dynval.internal.is_real_number(rss) || ~isfinite(rss) || rss < 0
    dynval.internal.param_error('rss', 'a finite number >= 0', rss);
  end
  if ~dynval.internal.is_integer(n_obs) || n_obs < 1
    dynval.internal.param_error('n_obs', 'an integer with n_obs >= 1', n_obs);
  end
  if ~dynval.internal.is_integer(n_params) || n_params < 0
    dynval.internal.param_error('n_params', 'an integer with n_params >= 0', n_params);
  end
  n = double(n_obs);
  p = double(n_params);
  if ~(p < n - 1)
    dynval.internal.param_error('n_params', sprintf('less than n_obs - 1 = %d', n - 1), n_params);
  end
  variance = double(rss) / n;
  if variance == 0
    f = -Inf;
  else
    f = n * log(variance);
  end
  ic = dynval.internal.assemble_criteria(f, n, n, p, variance);
  ic.n_obs = n;
  ic.n_params = p;
  ic.noise_model = 'pooled';
end

%!test
%! % The lesson's Problem 4 (golden/README.md): RSS 10 with p 6, RSS 8.5 with p 10, N 1000.
%! ic = dynval.information_criteria (10, 1000, 6);
%! assert (ic.aic, -4593.170185988091, 1e-9);
%! assert (ic.bic, -4563.723654314199, 1e-9);
%! ic = dynval.information_criteria (8.5, 1000, 10);
%! assert (ic.aic, -4747.689115485866, 1e-9);
%! assert (ic.bic, -4698.6115626960445, 1e-9);
%!test
%! ic = dynval.information_criteria (0, 10, 1);
%! assert ([ic.aic ic.bic ic.aicc ic.fpe], [-Inf -Inf -Inf 0]);
%!error <n_params must be less than n_obs - 1 = 9, got 9> dynval.information_criteria (1, 10, 9)
%!error <rss must be a finite number .= 0, got nan> dynval.information_criteria (NaN, 10, 1)
%!error <n_obs must be an integer with n_obs .= 1, got 0> dynval.information_criteria (1, 0, 0)
