function value = aic(tau_meas, tau_pred, n_params, varargin)
%AIC Akaike information criterion (constant dropped); options as dynval.criteria.
%   value = dynval.aic(tau_meas, tau_pred, n_params, 'noise_model', 'pooled')
%
%   Example:
%     dynval.aic([1; 2.5; 3.2; 4.1; 4.8; 6.1], [1.1; 2.4; 3.0; 4.3; 4.7; 6.0], 2)   % -19.472138033...
  opt = dynval.internal.options('aic', varargin, struct('noise_model', 'pooled', 'nan_policy', 'raise'));
  ic = dynval.internal.criteria_kernel('aic', tau_meas, tau_pred, n_params, opt);
  value = ic.aic;
end

%!assert (dynval.aic ([1; 2.5; 3.2; 4.1; 4.8; 6.1], [1.1; 2.4; 3.0; 4.3; 4.7; 6.0], 2), -19.472138033, 1e-9)
%!error <aic needs at least 2 samples, got N=1> dynval.aic ([1 2], [1 2], 0)
