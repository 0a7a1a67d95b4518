function value = bic(tau_meas, tau_pred, n_params, varargin)
%BIC Bayesian information criterion (constant dropped); options as dynval.criteria.
%   value = dynval.bic(tau_meas, tau_pred, n_params, 'noise_model', 'pooled')
%
%   Example:
%     dynval.bic([1; 2.5; 3.2; 4.1; 4.8; 6.1], [1.1; 2.4; 3.0; 4.3; 4.7; 6.0], 2)   % -19.888619094...
  opt = dynval.internal.options('bic', varargin, struct('noise_model', 'pooled', 'nan_policy', 'raise'));
  ic = dynval.internal.criteria_kernel('bic', tau_meas, tau_pred, n_params, opt);
  value = ic.bic;
end

%!assert (dynval.bic ([1; 2.5; 3.2; 4.1; 4.8; 6.1], [1.1; 2.4; 3.0; 4.3; 4.7; 6.0], 2), -19.888619094, 1e-9)
