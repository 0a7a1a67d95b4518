function y = ldexp(x, e)
%LDEXP x .* 2.^e without forming 2.^e, which overflows to Inf (or underflows to 0) for the
%   exponents of scaled sums (contract §1.3): applied in steps of at most 2^1000, each exact
%   unless the result itself leaves float64. e is a scalar or broadcasts against x.
  y = x;
  e = e + zeros(size(x));
  while any(e(:) ~= 0)
    step = max(min(e, 1000), -1000);
    y = y .* 2 .^ step;
    e = e - step;
  end
end
