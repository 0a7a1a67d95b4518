function rho = acf(e, max_lag, adjusted, starts)
%ACF Normalised autocorrelation R(l)/R(0) per column, l = 0..max_lag ((max_lag+1)-by-m).
%   adjusted: R(l) divides by the number of products n_l (true) or by N (false); R(0) by N.
%   Means are overall (one per joint); a constant residual, or one whose centred sum of
%   squares underflows to 0, gives a column of NaN.
  n = size(e, 1);
  e = dynval.internal.scale_columns(e);  % rho does not depend on the scale (contract §1.3)
  constant = min(e, [], 1) == max(e, [], 1);
  d = dynval.internal.centred(e);
  ss = sum(d .^ 2, 1);
  ss(constant) = 0;
  s = dynval.internal.lagged_sums(d, d, max_lag, starts);
  s(1, :) = ss;
  if adjusted
    denominators = dynval.internal.product_counts(starts, n, max_lag);
  else
    denominators = n * ones(max_lag + 1, 1);
  end
  rho = (s ./ denominators) ./ (ss / n);
  rho(1, :) = 1;
  rho(:, constant | ss == 0) = NaN;
end
