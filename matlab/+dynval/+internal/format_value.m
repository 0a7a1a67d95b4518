function s = format_value(v)
%FORMAT_VALUE Write a parameter value the way the contract's messages show it (Python repr).
%   MATLAB stores whole numbers as doubles, so an integral value is written as an integer.
  if isempty(v) && isnumeric(v) && all(size(v) == 0)
    s = 'None';
  elseif ischar(v)
    s = ['''' v ''''];
  elseif islogical(v) && isscalar(v)
    if v, s = 'True'; else, s = 'False'; end
  elseif (isnumeric(v) || islogical(v)) && isscalar(v)
    s = number_repr(double(v));
  elseif isnumeric(v) || islogical(v)
    parts = arrayfun(@(x) number_repr(double(x)), v(:)', 'UniformOutput', false);
    s = ['[' strjoin(parts, ', ') ']'];
  elseif iscell(v) && isempty(v)
    s = 'None';
  else
    s = sprintf('<%s>', class(v));
  end
end

function s = number_repr(x)
  if isnan(x)
    s = 'nan';
  elseif isinf(x)
    if x > 0, s = 'inf'; else, s = '-inf'; end
  elseif x == fix(x) && abs(x) <= 2^64
    % Integer parameters arrive as doubles: write them as integers. '%.0f' prints the exact
    % value of the double; '%d' would saturate at intmax('int64') in Octave.
    s = sprintf('%.0f', x);
    if strcmp(s, '-0')
      s = '0';
    end
  else
    s = dynval.internal.float_repr(x);
  end
end

%!assert (dynval.internal.format_value ('pooled'), '''pooled''')
%!assert (dynval.internal.format_value (true), 'True')
%!assert (dynval.internal.format_value ([]), 'None')
%!assert (dynval.internal.format_value ([2 5]), '[2, 5]')
%!assert (dynval.internal.format_value (0.95), '0.95')
%!assert (dynval.internal.format_value (2^63), '9223372036854775808')
