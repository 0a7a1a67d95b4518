function p = chi2_sf(q, k)
%CHI2_SF Chi-square survival function P(X > q), X ~ chi2(k), elementwise (k broadcast).
  q = double(q);
  k = double(k) + zeros(size(q));
  p = NaN(size(q));
  ok = ~isnan(q);
  p(ok) = gammainc(q(ok) / 2, k(ok) / 2, 'upper');
end
