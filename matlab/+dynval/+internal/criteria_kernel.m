function ic = criteria_kernel(fname, tau_meas, tau_pred, n_params, opt)
%CRITERIA_KERNEL Shared body of dynval.criteria, dynval.aic and dynval.bic.
  [meas, pred] = dynval.internal.signal_pair(fname, tau_meas, tau_pred);
  data = dynval.internal.prepare(fname, {meas, pred}, {'tau_meas', 'tau_pred'}, [0 0], opt.nan_policy);
  if ~dynval.internal.is_integer(n_params) || n_params < 0
    dynval.internal.param_error('n_params', 'an integer with n_params >= 0', n_params);
  end
  p = double(n_params);
  noise_model = dynval.internal.check_choice('noise_model', opt.noise_model, {'pooled', 'per_joint', 'full'});
  [f, n, n_vec, size_term] = dynval.internal.fit_term(data{1} - data{2}, noise_model);
  ic = dynval.internal.assemble_criteria(f, n_vec, n, p, size_term);
  ic.n_obs = n;
  ic.n_params = p;
  ic.noise_model = noise_model;
end
