function lp = chi2_logsf(q, k)
%CHI2_LOGSF ln P(X > q) for X ~ chi2(k); finite where the probability underflows.
%   Below 1e-280 the logarithm of gammainc loses digits in the subnormal range or is -Inf,
%   so the regularised upper incomplete gamma is evaluated in log space there.
  q = double(q);
  k = double(k) + zeros(size(q));
  p = dynval.internal.chi2_sf(q, k);
  lp = log(p);
  deep = find(isfinite(q) & p < 1e-280 & q / 2 > k / 2 + 1);
  for i = deep(:)'
    lp(i) = dynval.internal.log_upper_gamma_q(k(i) / 2, q(i) / 2);
  end
end

%!test
%! % Where gammainc is still accurate (p ~ 1e-250) the continued fraction agrees with it.
%! q = 1180;  k = 12;
%! p = dynval.internal.chi2_sf (q, k);
%! assert (p > 1e-280 && p < 1e-240);
%! assert (dynval.internal.log_upper_gamma_q (k / 2, q / 2), log (p), 1e-12 * abs (log (p)));
%!test
%! assert (dynval.internal.chi2_logsf ([0 NaN Inf], 3), [0 NaN -Inf]);
