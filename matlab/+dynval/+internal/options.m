function opt = options(fname, args, defaults)
%OPTIONS Name-value options of a dynval function, filled with the contract's defaults.
%   Values are not checked here: each function checks them later, in the contract's order,
%   so that a bad value never hides an earlier error in the data.
  opt = defaults;
  if mod(numel(args), 2) ~= 0
    dynval.internal.raise('InvalidParameter', ...
      sprintf('%s options must be name-value pairs', fname));
  end
  names = fieldnames(defaults);
  for i = 1:2:numel(args)
    key = args{i};
    if ~ischar(key) || ~any(strcmp(key, names))
      dynval.internal.raise('InvalidParameter', sprintf('%s has no option %s; options: %s', ...
        fname, dynval.internal.format_value(key), strjoin(names', ', ')));
    end
    opt.(key) = args{i + 1};
  end
end
