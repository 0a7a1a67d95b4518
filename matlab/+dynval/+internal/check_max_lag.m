function max_lag = check_max_lag(max_lag, limit)
%CHECK_MAX_LAG max_lag is an integer with 0 <= max_lag < limit (the longest segment).
  if ~dynval.internal.is_integer(max_lag) || ~(max_lag >= 0 && max_lag < limit)
    dynval.internal.param_error('max_lag', sprintf('an integer with 0 <= max_lag < %d', limit), max_lag);
  end
  max_lag = double(max_lag);
end
