function e = residual_signal(fname, e)
%RESIDUAL_SIGNAL Type, shape and size checks of a residual e.
  e = dynval.internal.check_type(e, 'e');
  dynval.internal.check_signal_shape(e, 'e');
  dynval.internal.min_samples(fname, size(e, 1));
end
