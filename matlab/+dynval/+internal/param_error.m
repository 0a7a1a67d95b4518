function param_error(param, requirement, value)
%PARAM_ERROR Raise the contract's InvalidParameter: '{param} must be {requirement}, got {value!r}'.
  dynval.internal.raise('InvalidParameter', sprintf('%s must be %s, got %s', ...
    param, requirement, dynval.internal.format_value(value)));
end
