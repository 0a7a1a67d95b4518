function band = confidence_band(n, varargin)
%CONFIDENCE_BAND Half-width z/sqrt(n) of the white-noise band, z = Phi^-1((1 + level)/2).
%   band = dynval.confidence_band(n)                     level 0.95
%   band = dynval.confidence_band(n, 'level', 0.99)
%
%   Example:
%     dynval.confidence_band(100)      % 0.1959963984540054
  opt = dynval.internal.options('confidence_band', varargin, struct('level', 0.95));
  if ~dynval.internal.is_integer(n) || n < 1
    dynval.internal.param_error('n', 'an integer with n >= 1', n);
  end
  level = dynval.internal.check_level(opt.level);
  band = dynval.internal.normal_quantile_band(level, double(n));
end

%!assert (dynval.confidence_band (100), 0.1959963984540054, 1e-15)
%!assert (dynval.confidence_band (1, 'level', 0.99), 2.5758293035489004, 1e-14)
%!error <level must be a number with 0 < level < 1, got 1> dynval.confidence_band (10, 'level', 1)
%!error <n must be an integer with n .= 1, got 0> dynval.confidence_band (0)
