function s = float_repr(x)
%FLOAT_REPR Shortest decimal that reads back as x, in Python's repr layout (1e+145, 0.001, 2.5).
  if isnan(x)
    s = 'nan'; return;
  elseif isinf(x)
    if x > 0, s = 'inf'; else, s = '-inf'; end
    return;
  elseif x == 0
    if 1 / x < 0, s = '-0.0'; else, s = '0.0'; end
    return;
  end
  for p = 1:17
    t = sprintf('%.*e', p - 1, x);
    if str2double(t) == x
      break;
    end
  end
  k = find(t == 'e', 1);
  mantissa = t(1:k - 1);
  exponent = str2double(t(k + 1:end));
  sign = '';
  if mantissa(1) == '-'
    sign = '-';
    mantissa = mantissa(2:end);
  end
  digits = mantissa(mantissa ~= '.');
  digits = regexprep(digits, '0+$', '');
  if isempty(digits)
    digits = '0';
  end
  if exponent >= -4 && exponent < 16
    if exponent >= 0
      if numel(digits) <= exponent + 1
        whole = [digits repmat('0', 1, exponent + 1 - numel(digits))];
        frac = '0';
      else
        whole = digits(1:exponent + 1);
        frac = digits(exponent + 2:end);
      end
      s = [sign whole '.' frac];
    else
      s = [sign '0.' repmat('0', 1, -exponent - 1) digits];
    end
  else
    if numel(digits) > 1
      body = [digits(1) '.' digits(2:end)];
    else
      body = digits;
    end
    if exponent < 0, esign = '-'; else, esign = '+'; end
    s = sprintf('%s%se%s%02d', sign, body, esign, abs(exponent));
  end
end

%!test
%! % Python's repr of the same doubles.
%! cases = {1e145, '1e+145'; 0.001, '0.001'; 2.5, '2.5'; 1e-05, '1e-05'; 123456789012345680, '1.2345678901234568e+17';
%!          1e16, '1e+16'; 0.1, '0.1'; -2.5e-300, '-2.5e-300'; 1234.5, '1234.5'; 100, '100.0';
%!          0.0001, '0.0001'; 9999999999999998, '9999999999999998.0'; 5e-324, '5e-324'; -0, '-0.0'};
%! for i = 1:rows (cases)
%!   assert (dynval.internal.float_repr (cases{i, 1}), cases{i, 2});
%! end
