function band = normal_quantile_band(level, n)
%NORMAL_QUANTILE_BAND z/sqrt(n) with z = Phi^-1((1 + level)/2) = sqrt(2) erfinv(level).
  band = sqrt(2) * erfinv(level) / sqrt(n);
end
