function value = check_adjusted(value)
%CHECK_ADJUSTED adjusted is exactly true or false (a logical scalar, not 0 or 1).
  if ~(islogical(value) && isscalar(value))
    dynval.internal.param_error('adjusted', 'True or False', value);
  end
end
