function s = lagged_sums(dx, dy, max_lag, starts)
%LAGGED_SUMS s(l+1, j) = sum over k of dx(k, j) * dy(k - l, j), both samples in one segment.
%   One vectorised product per lag; pairs that straddle a segment break are masked out.
  n = size(dx, 1);
  seg = zeros(n, 1);
  seg(starts + 1) = 1;
  seg = cumsum(seg);
  s = zeros(max_lag + 1, size(dx, 2));
  for lag = 0:max_lag
    if lag >= n
      break;
    end
    same = seg(lag + 1:n) == seg(1:n - lag);
    products = dx(lag + 1:n, :) .* dy(1:n - lag, :);
    if all(same)
      s(lag + 1, :) = sum(products, 1);
    else
      s(lag + 1, :) = sum(products(same, :), 1);
    end
  end
end
