function [mu, ss, constant] = moments(x)
%MOMENTS Per column: the mean, the centred sum of squares and constancy (min == max).
%   Corrected two-pass algorithm: with d = x - fl(mean), the mean is fl(mean) + sum(d)/n and
%   the centred sum is sum(d.^2) - sum(d)^2/n. The correction removes the rounding of the
%   first mean, which matters for data riding on a large offset (NIST StRD NumAcc4). A
%   constant column gets exactly 0, decided on the data rather than on a rounded sum.
  n = size(x, 1);
  constant = min(x, [], 1) == max(x, [], 1);
  first = sum(x, 1) / n;
  d = x - first;
  shift = sum(d, 1);
  ss = max(sum(d .^ 2, 1) - shift .^ 2 / n, 0);
  ss(constant) = 0;
  mu = first + shift / n;
end

%!test
%! % NIST StRD NumAcc-like data on a 1e7 offset: the centred sum keeps full precision.
%! x = 1e7 + [0.1; 0.2; 0.3; 0.2; 0.1];
%! [mu, ss, constant] = dynval.internal.moments (x);
%! d = x - 1e7;  % exact (Sterbenz), so the reference below works on small numbers
%! want = sum ((d - mean (d)) .^ 2);
%! assert (ss, want, 1e-12 * want);
%! assert (mu - 1e7, mean (d), 1e-15);
%! assert (constant, false);
%! % while the one-pass formula sum(x^2) - N mean^2 loses every digit here
%! naive = sum (x .^ 2) - 5 * mean (x) ^ 2;
%! assert (abs (naive - want) > 1e-3 * want);
%!test
%! [mu, ss, constant] = dynval.internal.moments ([0.1 1; 0.1 2; 0.1 3]);
%! assert (ss(1), 0);
%! assert (constant, [true false]);
