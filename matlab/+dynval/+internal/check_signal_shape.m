function check_signal_shape(x, name)
%CHECK_SIGNAL_SHAPE A signal is N-by-m with at least one column (a column vector is one joint).
  if ndims(x) > 2
    dynval.internal.raise('InvalidShape', sprintf('%s must be 1-D (N,) or 2-D (N, m), got shape %s', ...
      name, dynval.internal.format_shape(size(x))));
  end
  if size(x, 2) == 0
    dynval.internal.raise('InvalidShape', sprintf('%s must have at least one column, got shape %s', ...
      name, dynval.internal.format_shape(size(x))));
  end
end
