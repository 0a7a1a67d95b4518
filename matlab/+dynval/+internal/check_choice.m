function value = check_choice(param, value, choices)
%CHECK_CHOICE Accept one of the option strings, else InvalidParameter listing them.
  if ~ischar(value) || ~any(strcmp(value, choices))
    quoted = cellfun(@(c) ['''' c ''''], choices, 'UniformOutput', false);
    dynval.internal.param_error(param, ['one of ' strjoin(quoted, ', ')], value);
  end
end
