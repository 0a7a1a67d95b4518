function d = centred(x)
%CENTRED x minus its column means, with the rounding of each mean removed by a second pass.
%   Lagged products of the deviations do not cancel an error in the mean, so the mean of the
%   first deviations (small, hence exact to full precision) is subtracted as well.
  n = size(x, 1);
  d = x - sum(x, 1) / n;
  d = d - sum(d, 1) / n;
end
