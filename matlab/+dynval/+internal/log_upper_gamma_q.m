function lq = log_upper_gamma_q(a, x)
%LOG_UPPER_GAMMA_Q ln Q(a, x), the regularised upper incomplete gamma function, for x > a + 1.
%   Modified Lentz evaluation of the continued fraction for Gamma(a, x); only its logarithm
%   is formed, so p-values far below 1e-308 keep full relative precision in ln p.
  tiny = 1e-300;
  b = x + 1 - a;
  c = 1 / tiny;
  d = 1 / b;
  h = d;
  for i = 1:10000
    an = -i * (i - a);
    b = b + 2;
    d = an * d + b;
    if abs(d) < tiny
      d = tiny;
    end
    c = b + an / c;
    if abs(c) < tiny
      c = tiny;
    end
    d = 1 / d;
    delta = d * c;
    h = h * delta;
    if abs(delta - 1) < 1e-16
      break;
    end
  end
  lq = -x + a * log(x) - gammaln(a) + log(h);
end
