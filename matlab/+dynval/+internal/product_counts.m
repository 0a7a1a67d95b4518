function counts = product_counts(starts, n, max_lag)
%PRODUCT_COUNTS n_l = sum over segments of max(n_s - l, 0), for l = 0..max_lag (a column).
  lengths = diff([starts(:); n]);
  lags = 0:max_lag;
  counts = sum(max(lengths - lags, 0), 1)';
end
