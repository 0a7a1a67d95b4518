function x = read_real(token)
%READ_REAL One number of the protocol grammar (golden/PROTOCOL.md section 3), or an error.
%   Decimals go through sscanf('%f'), which is C's strtod: correctly rounded, so every
%   17-digit decimal the runner writes becomes exactly the double it was written from.
%   NaN in any of its forms (nan, -nan, nan(ind)) and inf/infinity with a sign are mapped by
%   hand; anything else (1,5  0x1p3  1.5*^-3  1d0) is rejected.
  t = lower(token);
  if ~isempty(regexp(t, '^[+-]?nan(\(\w*\))?$', 'once'))
    x = NaN;
  elseif any(strcmp(t, {'inf', '+inf', 'infinity', '+infinity'}))
    x = Inf;
  elseif any(strcmp(t, {'-inf', '-infinity'}))
    x = -Inf;
  elseif ~isempty(regexp(t, '^[+-]?(\d+(\.\d*)?|\.\d+)(e[+-]?\d+)?$', 'once'))
    x = sscanf(t, '%f');
  else
    error('dvport:number', 'not a protocol number: %s', token);
  end
end

%!test
%! % Correctly rounded decimals, bit patterns from Python's float() (halfway cases, subnormals).
%! cases = {'2.4703282292062328e-324', '0000000000000001'; '2.4703282292062327e-324', '0000000000000000';
%!          '2.2250738585072011e-308', '000fffffffffffff'; '2.2250738585072012e-308', '0010000000000000';
%!          '9.0071992547409930e+15', '4340000000000000'; '9.0071992547409950e+15', '4340000000000002';
%!          '1.0000000000000001e+00', '3ff0000000000000'; '1.0000000000000002e+00', '3ff0000000000001';
%!          '1.7976931348623157e+308', '7fefffffffffffff'; '1.7976931348623158e+308', '7fefffffffffffff';
%!          '4.9406564584124654e-324', '0000000000000001'; '-0.0000000000000000e+00', '8000000000000000';
%!          '1.5e-3', '3f589374bc6a7efa'; '.5', '3fe0000000000000'; '-7', 'c01c000000000000';
%!          '1e5', '40f86a0000000000'; '8.98846567431158e307', '7fe0000000000000'; '0.1', '3fb999999999999a'};
%! for i = 1:rows (cases)
%!   assert (num2hex (dvport.read_real (cases{i, 1})), cases{i, 2});
%! end
%!test
%! assert (isnan (dvport.read_real ('nan')) && isnan (dvport.read_real ('-nan')));
%! assert (isnan (dvport.read_real ('NaN(ind)')) && isnan (dvport.read_real ('+nan')));
%! assert ([dvport.read_real('inf'), dvport.read_real('-INF'), dvport.read_real('Infinity'), dvport.read_real('+inf')], [Inf -Inf Inf Inf]);
%!error <not a protocol number> dvport.read_real ('1,5')
%!error <not a protocol number> dvport.read_real ('0x1p3')
%!error <not a protocol number> dvport.read_real ('1.5*^-3')
%!error <not a protocol number> dvport.read_real ('1d0')
%!error <not a protocol number> dvport.read_real ('1e')
%!error <not a protocol number> dvport.read_real ('.')
%!error <not a protocol number> dvport.read_real ('Indeterminate')
