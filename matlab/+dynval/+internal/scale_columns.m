function [xs, k] = scale_columns(x)
%SCALE_COLUMNS Each column times 2^-k, k the exponent of its largest |x| (contract §1.3).
%   The largest |xs| of a column lies in [0.5, 1), so its squares neither underflow (data near
%   1e-160, subnormal data) nor overflow, and the scaling is exact (see ldexp). k is 0 for
%   an all-zero column.
  big = max(abs(x), [], 1);
  % log2's exponent is wrong for subnormals in Octave: measure those after an exact shift.
  subnormal = big > 0 & big < realmin;
  big(subnormal) = big(subnormal) * 2 ^ 64;
  [~, k] = log2(big);
  k(subnormal) = k(subnormal) - 64;
  k(big == 0) = 0;
  xs = dynval.internal.ldexp(x, -k);
end
