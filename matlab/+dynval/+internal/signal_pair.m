function [meas, pred] = signal_pair(fname, tau_meas, tau_pred)
%SIGNAL_PAIR Type, shape and size checks of (tau_meas, tau_pred), in the contract's order.
  meas = dynval.internal.check_type(tau_meas, 'tau_meas');
  pred = dynval.internal.check_type(tau_pred, 'tau_pred');
  dynval.internal.check_signal_shape(meas, 'tau_meas');
  dynval.internal.check_signal_shape(pred, 'tau_pred');
  if ~isequal(size(meas), size(pred))
    dynval.internal.raise('ShapeMismatch', sprintf('tau_meas and tau_pred must have the same shape, got %s and %s', ...
      dynval.internal.format_shape(size(meas)), dynval.internal.format_shape(size(pred))));
  end
  dynval.internal.min_samples(fname, size(meas, 1));
end
