function x = check_type(x, name)
%CHECK_TYPE An array argument must hold real numbers; logical and integer data become double.
  if ~(isnumeric(x) || islogical(x))
    if iscell(x) && isempty(x)
      what = 'NoneType';
    elseif ischar(x)
      what = 'str';
    else
      what = class(x);
    end
    dynval.internal.raise('InvalidType', sprintf('%s must be an array of real numbers, got %s', name, what));
  end
  if ~isreal(x)
    dynval.internal.raise('InvalidType', sprintf('%s must be an array of real numbers, got complex128', name));
  end
  x = double(x);
end
