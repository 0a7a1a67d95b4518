function level = check_level(level)
%CHECK_LEVEL level is a number with 0 < level < 1.
  if ~dynval.internal.is_real_number(level) || ~(level > 0 && level < 1)
    dynval.internal.param_error('level', 'a number with 0 < level < 1', level);
  end
  level = double(level);
end
