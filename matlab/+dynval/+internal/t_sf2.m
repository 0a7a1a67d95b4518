function p = t_sf2(t, df)
%T_SF2 Two-sided Student t p-value 2 P(T > |t|), elementwise (df broadcast).
%   P = I_x(df/2, 1/2) with x = df/(df + t^2); where x is near 1 the complementary form
%   in t^2/(df + t^2) is used, which has no cancellation.
  t = double(t);
  df = double(df) + zeros(size(t));
  p = NaN(size(t));
  t2 = t .^ 2;
  big = isinf(t);
  p(big & ~isnan(df)) = 0;
  ok = isfinite(t) & ~isnan(df);
  x = df ./ (df + t2);
  y = t2 ./ (df + t2);
  low = ok & x < 0.5;
  high = ok & ~(x < 0.5);
  if any(low(:))
    p(low) = betainc(x(low), df(low) / 2, 0.5);
  end
  if any(high(:))
    p(high) = betainc(y(high), 0.5, df(high) / 2, 'upper');
  end
end

%!test
%! % 2 * scipy.stats.t.sf(|t|, df)
%! assert (dynval.internal.t_sf2 (2, 5), 0.10193947882985835, 1e-15);
%! assert (dynval.internal.t_sf2 (-0.01, 3.5), 0.9925647124519241, 1e-15);
%! assert (dynval.internal.t_sf2 (40, 100), 2.462107602140071e-63, 1e-74);
%! assert (dynval.internal.t_sf2 (1e-9, 10), 0.9999999992217833, 1e-15);
%! assert (dynval.internal.t_sf2 ([Inf -Inf NaN], 4), [0 0 NaN]);
