function s = stream_block(p, lags, gram, e, t, y)
%STREAM_BLOCK The mergeable sums of one record of c >= 1 consecutive rows (contract §4.1, State).
%   e, t: c-by-m residual and target; y: c-by-(m*p) regressor, column (j-1)*p + k for joint j,
%   column k (c-by-0 without one); lags = L; gram: keep E'E for the 'full' noise model.
%   Sums are centred on the block's means K (fields k_e, k_t, k_y); lag-major arrays have
%   L+1 rows (row l+1 is lag l). Compensated sums are structs with hi and lo (comp_add).
%   The first and last L raw rows are kept: a later merge forms the lagged products that
%   cross the junction from them.
%   Every centre and sum is in units of a power of two per column (contract §4.1, Scale):
%   exp_e, exp_t, exp_y are the exponents k of each column's largest |x| ([~, k] = log2(x),
%   0 for a zero column), and the sums are those of x .* 2^-k (pow2, exact); extremes and
%   boundary rows stay raw.
  [c, m] = size(e);
  mp = m * p;
  s = struct('m', m, 'p', p, 'lags', lags, 'gram', gram, 'n', c, 'start_break', false, ...
    'end_break', false, 'segments', 1, 'first_length', c, 'last_length', c, 'longest', c);
  top = min(lags, c - 1);
  joint = reshape(repmat(1:m, p, 1), 1, mp);  % the joint of each regressor column

  s.min_e = min(e, [], 1);
  s.max_e = max(e, [], 1);
  [s.exp_e, es] = unit_columns(e, s.min_e, s.max_e);
  s.k_e = sum(es, 1) / c;
  xe = es - s.k_e;
  prod_e = zeros(lags + 1, m);
  cur_e = zeros(lags + 1, m);
  lag_e = zeros(lags + 1, m);
  for l = 0:top
    prod_e(l + 1, :) = sum(xe(l + 1:c, :) .* xe(1:c - l, :), 1);
    cur_e(l + 1, :) = sum(xe(l + 1:c, :), 1);
    lag_e(l + 1, :) = sum(xe(1:c - l, :), 1);
  end
  s.prod_e = compensated(prod_e);
  s.cur_e = compensated(cur_e);
  s.lag_e = compensated(lag_e);
  s.pairs = max(c - (0:lags)', 0);
  if gram
    s.products = compensated(xe' * xe);
  else
    s.products = compensated(zeros(0, 0));
  end

  s.min_t = min(t, [], 1);
  s.max_t = max(t, [], 1);
  [s.exp_t, ts] = unit_columns(t, s.min_t, s.max_t);
  s.k_t = sum(ts, 1) / c;
  xt = ts - s.k_t;
  s.sum_t = compensated(sum(xt, 1));
  s.sq_t = compensated(sum(xt .^ 2, 1));

  s.min_y = min(y, [], 1);
  s.max_y = max(y, [], 1);
  [s.exp_y, ys] = unit_columns(y, s.min_y, s.max_y);
  s.k_y = sum(ys, 1) / c;
  xy = ys - s.k_y;
  lag_y = zeros(lags + 1, mp);
  prod_ey = zeros(lags + 1, mp);
  if mp > 0
    for l = 0:top
      lag_y(l + 1, :) = sum(xy(1:c - l, :), 1);
      prod_ey(l + 1, :) = sum(xe(l + 1:c, joint) .* xy(1:c - l, :), 1);
    end
  end
  s.sq_y = compensated(sum(xy .^ 2, 1));
  s.lag_y = compensated(lag_y);
  s.prod_ey = compensated(prod_ey);

  kept = min(lags, c);
  s.head_e = e(1:kept, :);
  s.tail_e = e(c - kept + 1:c, :);
  s.tail_y = y(c - kept + 1:c, :);
end

function [k, xs] = unit_columns(x, lo, hi)
  % The exponent k of each column's largest |x| and the columns times 2^-k (exact).
  [~, k] = log2(max(abs(lo), abs(hi)));
  k(~isfinite(k)) = 0;
  xs = pow2(x, -k);
end

function c = compensated(x)
  c = struct('hi', x, 'lo', zeros(size(x)));
end

%!test
%! % Lag sums of one block by their definitions: e_t with e_(t-l), pairs inside the block.
%! e = [1 4; -2 0; 3 1; 0.5 -1; 2 2];  t = e + 10;
%! s = dynval.internal.stream_block (0, 2, true, e, t, zeros (5, 0));
%! x = e - mean (e);
%! k = s.exp_e;   % the sums are in units 2^k per joint: put back exactly
%! assert (k, [2 3]);
%! assert (pow2 (s.prod_e.hi(3, :), 2 * k), sum (x(3:5, :) .* x(1:3, :)), 1e-14);
%! assert (pow2 (s.cur_e.hi(2, :), k), sum (x(2:5, :)), 1e-14);
%! assert (pow2 (s.lag_e.hi(2, :), k), sum (x(1:4, :)), 1e-14);
%! assert (s.pairs, [5; 4; 3]);
%! assert (pow2 (s.products.hi, k' + k), x' * x, 1e-14);
%! assert ([s.head_e; s.tail_e], [e(1:2, :); e(4:5, :)]);
%!test
%! % A block shorter than the lags: no pair beyond its length, every row kept.
%! s = dynval.internal.stream_block (1, 4, false, [1; 2], [0; 0], [5; 7]);
%! assert (s.pairs, [2; 1; 0; 0; 0]);
%! assert (s.prod_e.hi(3:5), [0; 0; 0]);
%! assert (pow2 (s.prod_ey.hi(2), s.exp_e + s.exp_y), (2 - 1.5) * (5 - 6));
%! assert (size (s.tail_y), [2 1]);
%!test
%! % Data times 2^-1000 (about 1e-301, whose squares underflow): the same sums to the bit, every
%! % exponent moved by -1000 (contract §4.1).
%! e = [1 4; -2 0; 3 1; 0.5 -1; 2 2];  t = e + 10;  y = [e(:, 1) .^ 2, e(:, 2) - 1];
%! a = dynval.internal.stream_block (1, 2, true, e, t, y);
%! b = dynval.internal.stream_block (1, 2, true, pow2 (e, -1000), pow2 (t, -1000), pow2 (y, -1000));
%! assert ([b.exp_e b.exp_t b.exp_y], [a.exp_e a.exp_t a.exp_y] - 1000);
%! for name = {'prod_e', 'cur_e', 'lag_e', 'products', 'sum_t', 'sq_t', 'sq_y', 'lag_y', 'prod_ey'}
%!   assert (b.(name{1}).hi, a.(name{1}).hi);
%! end
