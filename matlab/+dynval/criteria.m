function ic = criteria(tau_meas, tau_pred, n_params, varargin)
%CRITERIA Information criteria of a model's residuals under an explicit noise model.
%   ic = dynval.criteria(tau_meas, tau_pred, n_params)
%   ic = dynval.criteria(tau_meas, tau_pred, n_params, 'noise_model', 'per_joint')
%   n_params: number of identified parameters p (always given: the lesson's p = 30 was a bug).
%   'noise_model': 'pooled' (one sigma^2 for all N*m values, the lesson) | 'per_joint' |
%                  'full' (m-by-m covariance, MATLAB's multi-output AIC)
%   Fields: aic, bic, aicc, fpe, naic (aicc, fpe NaN when p >= n - 1), n_obs, n_params,
%   noise_model. The Gaussian constant is dropped. An exact fit gives -Inf (fpe 0).
%
%   Example:
%     ic = dynval.criteria([1; 2; 3; 4], [1.1; 1.9; 3.1; 3.9], 1);  ic.n_obs      % 4
  opt = dynval.internal.options('criteria', varargin, struct('noise_model', 'pooled', 'nan_policy', 'raise'));
  ic = dynval.internal.criteria_kernel('criteria', tau_meas, tau_pred, n_params, opt);
end

%!test
%! ic = dynval.criteria ([1; 2; 3; 4], [1.1; 1.9; 3.1; 3.9], 1);
%! assert (ic.n_obs, 4);
%! assert (ic.aic, 4 * log (0.01) + 2, 1e-12);
%!test
%! % One joint: the three noise models agree.
%! t = [1; 2.5; 3.2; 4.1; 4.8; 6.1];  y = [1.1; 2.4; 3.0; 4.3; 4.7; 6.0];
%! a = dynval.criteria (t, y, 2);
%! b = dynval.criteria (t, y, 2, 'noise_model', 'per_joint');
%! c = dynval.criteria (t, y, 2, 'noise_model', 'full');
%! assert ([b.aic c.aic b.fpe c.fpe], [a.aic a.aic a.fpe a.fpe], 1e-12);
%!test
%! % Two identical joints make the full covariance singular.
%! t = [1 1; 2 2; 3 3];  y = [1.5 1.5; 2 2; 2.5 2.5];
%! ic = dynval.criteria (t, y, 0, 'noise_model', 'full');
%! assert ([ic.aic ic.fpe], [-Inf 0]);
%!error <noise_model must be one of 'pooled', 'per_joint', 'full', got 'diagonal'> dynval.criteria (rand (3, 2), rand (3, 2), 1, 'noise_model', 'diagonal')
%!error <n_params must be an integer with n_params .= 0, got -1> dynval.criteria (rand (3, 2), rand (3, 2), -1)
