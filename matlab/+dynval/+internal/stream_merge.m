function a = stream_merge(a, b)
%STREAM_MERGE The sums of a's rows followed by b's (both from stream_block or stream_merge).
%   Both operands are first moved to their combined mean (Chan's pairwise update, extended to
%   lagged products), so every sum stays centred and a large offset costs no digits. Lags join
%   across the junction unless a ended, or b started, with a break; the junction's products
%   pair b's first rows (current element) with a's last rows (lagged element).
  % both operands in the units of the larger exponent of each column (exact: powers of two)
  ee = max(a.exp_e, b.exp_e);
  et = max(a.exp_t, b.exp_t);
  ey = max(a.exp_y, b.exp_y);
  a = rescale(a, ee, et, ey);
  b = rescale(b, ee, et, ey);
  w = b.n / (a.n + b.n);
  [ea, ta, ya] = means(a);
  [eb, tb, yb] = means(b);
  ke = ea + w * (eb - ea);
  kt = ta + w * (tb - ta);
  ky = ya + w * (yb - ya);
  a = recentre(a, ke, kt, ky);
  b = recentre(b, ke, kt, ky);
  join = ~(a.end_break || b.start_break);
  if join
    a = add_junction(a, b);
  end
  names = {'prod_e', 'cur_e', 'lag_e', 'products', 'sum_t', 'sq_t', 'sq_y', 'lag_y', 'prod_ey'};
  for i = 1:numel(names)
    a.(names{i}) = dynval.internal.comp_add(a.(names{i}), b.(names{i}));
  end
  a.pairs = a.pairs + b.pairs;
  a.n = a.n + b.n;
  for x = {'e', 't', 'y'}
    a.(['min_' x{1}]) = min(a.(['min_' x{1}]), b.(['min_' x{1}]));
    a.(['max_' x{1}]) = max(a.(['max_' x{1}]), b.(['max_' x{1}]));
  end
  a = join_boundaries(a, b, join);
end

function s = rescale(s, ee, et, ey)
  % Every centre and sum moved to the exponents given (each at least the state's own): a sum
  % of products of columns a and b times 2^-(da + db), a sum or centre times 2^-da.
  de = ee - s.exp_e;
  dt = et - s.exp_t;
  dy = ey - s.exp_y;
  s.k_e = pow2(s.k_e, -de);
  s.prod_e = scale(s.prod_e, -2 * de);
  s.cur_e = scale(s.cur_e, -de);
  s.lag_e = scale(s.lag_e, -de);
  if s.gram
    s.products = scale(s.products, -(de' + de));
  end
  s.k_t = pow2(s.k_t, -dt);
  s.sum_t = scale(s.sum_t, -dt);
  s.sq_t = scale(s.sq_t, -2 * dt);
  if s.p > 0
    joint = reshape(repmat(1:s.m, s.p, 1), 1, s.m * s.p);
    s.k_y = pow2(s.k_y, -dy);
    s.sq_y = scale(s.sq_y, -2 * dy);
    s.lag_y = scale(s.lag_y, -dy);
    s.prod_ey = scale(s.prod_ey, -(de(joint) + dy));
  end
  s.exp_e = ee;
  s.exp_t = et;
  s.exp_y = ey;
end

function c = scale(c, k)
  c.hi = pow2(c.hi, k);
  c.lo = pow2(c.lo, k);
end

function [me, mt, my] = means(s)
  me = s.k_e + (s.cur_e.hi(1, :) + s.cur_e.lo(1, :)) / s.n;
  mt = s.k_t + (s.sum_t.hi + s.sum_t.lo) / s.n;
  my = s.k_y + (s.lag_y.hi(1, :) + s.lag_y.lo(1, :)) / s.n;
end

function s = recentre(s, ke, kt, ky)
  % x - K' = (x - K) - d: sum (x_t - K')(y_(t-l) - K'') = P - d_y H - d_x T + n_l d_x d_y,
  % every correction taken from the sums before any of them moves.
  n = s.n;
  nl = s.pairs;
  d = ke - s.k_e;
  cur = s.cur_e.hi + s.cur_e.lo;
  lag = s.lag_e.hi + s.lag_e.lo;
  if s.gram
    c0 = cur(1, :);
    s.products = dynval.internal.comp_add(s.products, -(d' * c0 + c0' * d) + n * (d' * d));
  end
  if s.p > 0
    joint = reshape(repmat(1:s.m, s.p, 1), 1, s.m * s.p);
    dy = ky - s.k_y;
    ly = s.lag_y.hi + s.lag_y.lo;
    dj = d(joint);
    s.prod_ey = dynval.internal.comp_add(s.prod_ey, -dy .* cur(:, joint) - dj .* ly + nl .* (dj .* dy));
    s.sq_y = dynval.internal.comp_add(s.sq_y, -2 * dy .* ly(1, :) + n * dy .^ 2);
    s.lag_y = dynval.internal.comp_add(s.lag_y, -nl .* dy);
    s.k_y = ky;
  end
  s.prod_e = dynval.internal.comp_add(s.prod_e, -d .* (cur + lag) + nl .* d .^ 2);
  s.cur_e = dynval.internal.comp_add(s.cur_e, -nl .* d);
  s.lag_e = dynval.internal.comp_add(s.lag_e, -nl .* d);
  s.k_e = ke;
  dt = kt - s.k_t;
  st = s.sum_t.hi + s.sum_t.lo;
  s.sq_t = dynval.internal.comp_add(s.sq_t, -2 * dt .* st + n * dt .^ 2);
  s.sum_t = dynval.internal.comp_add(s.sum_t, -n * dt);
  s.k_t = kt;
end

function a = add_junction(a, b)
  % Lag l pairs b's head row i (0-based, i < l) with a's tail row tail_rows - l + i.
  lags = a.lags;
  m = a.m;
  mp = a.m * a.p;
  joint = reshape(repmat(1:m, a.p, 1), 1, mp);
  tail_rows = size(a.tail_e, 1);
  head_rows = size(b.head_e, 1);
  prod = zeros(lags + 1, m);
  cur = zeros(lags + 1, m);
  lag = zeros(lags + 1, m);
  py = zeros(lags + 1, mp);
  sy = zeros(lags + 1, mp);
  for l = 1:lags
    i = (max(0, l - tail_rows):min(l, head_rows) - 1)';
    if isempty(i)
      continue;
    end
    t = tail_rows - l + i;
    h = pow2(b.head_e(i + 1, :), -a.exp_e) - a.k_e;
    g = pow2(a.tail_e(t + 1, :), -a.exp_e) - a.k_e;
    prod(l + 1, :) = sum(h .* g, 1);
    cur(l + 1, :) = sum(h, 1);
    lag(l + 1, :) = sum(g, 1);
    if mp > 0
      gy = pow2(a.tail_y(t + 1, :), -a.exp_y) - a.k_y;
      py(l + 1, :) = sum(h(:, joint) .* gy, 1);
      sy(l + 1, :) = sum(gy, 1);
    end
    a.pairs(l + 1) = a.pairs(l + 1) + numel(i);
  end
  a.prod_e = dynval.internal.comp_add(a.prod_e, prod);
  a.cur_e = dynval.internal.comp_add(a.cur_e, cur);
  a.lag_e = dynval.internal.comp_add(a.lag_e, lag);
  a.prod_ey = dynval.internal.comp_add(a.prod_ey, py);
  a.lag_y = dynval.internal.comp_add(a.lag_y, sy);
end

function a = join_boundaries(a, b, join)
  % The first L rows of the first record and the last L rows of the last one, and the record
  % lengths, of the concatenation.
  lags = a.lags;
  single_a = a.segments == 1;
  single_b = b.segments == 1;
  if join && single_a && size(a.head_e, 1) < lags
    extra = min(lags - size(a.head_e, 1), size(b.head_e, 1));
    a.head_e = [a.head_e; b.head_e(1:extra, :)];
  end
  if join && single_b
    from_a = min(size(a.tail_e, 1), lags - size(b.tail_e, 1));
    keep = size(a.tail_e, 1) - from_a + 1:size(a.tail_e, 1);
    a.tail_e = [a.tail_e(keep, :); b.tail_e];
    a.tail_y = [a.tail_y(keep, :); b.tail_y];
  else
    a.tail_e = b.tail_e;
    a.tail_y = b.tail_y;
  end
  if join
    joined = a.last_length + b.first_length;
    a.longest = max([a.longest, b.longest, joined]);
    if single_a
      a.first_length = joined;
    end
    if single_b
      a.last_length = joined;
    else
      a.last_length = b.last_length;
    end
    a.segments = a.segments + b.segments - 1;
  else
    a.longest = max(a.longest, b.longest);
    a.last_length = b.last_length;
    a.segments = a.segments + b.segments;
  end
  a.end_break = b.end_break;
end

%!test
%! % Two blocks merged hold the sums of the one block of all their rows, at every cut.
%! e = [1 4; -2 0; 3 1; 0.5 -1; 2 2; -1 3; 0 0.5];  t = 2 * e + 7;  y = [e(:, 1) .^ 2, e(:, 2) - 1];
%! whole = dynval.internal.stream_block (1, 3, true, e, t, y);
%! names = {'prod_e', 'cur_e', 'lag_e', 'products', 'sum_t', 'sq_t', 'sq_y', 'lag_y', 'prod_ey'};
%! for cut = 1:6
%!   a = dynval.internal.stream_block (1, 3, true, e(1:cut, :), t(1:cut, :), y(1:cut, :));
%!   b = dynval.internal.stream_block (1, 3, true, e(cut+1:end, :), t(cut+1:end, :), y(cut+1:end, :));
%!   s = dynval.internal.stream_merge (a, b);
%!   assert (s.k_e, whole.k_e, 1e-14);
%!   for k = 1:numel (names)
%!     assert (s.(names{k}).hi + s.(names{k}).lo, whole.(names{k}).hi, 1e-13);
%!   end
%!   assert (s.pairs, whole.pairs);
%!   assert ([s.head_e; s.tail_e; s.tail_y], [whole.head_e; whole.tail_e; whole.tail_y]);
%!   assert ([s.n s.segments s.longest], [7 1 7]);
%! end
%!test
%! % A break at the junction: no lagged product across it, two records.
%! e = [1; -1; 2; 0; 3];
%! a = dynval.internal.stream_block (0, 2, false, e(1:2), e(1:2), zeros (2, 0));
%! a.end_break = true;
%! b = dynval.internal.stream_block (0, 2, false, e(3:5), e(3:5), zeros (3, 0));
%! s = dynval.internal.stream_merge (a, b);
%! x = e - mean (e);
%! assert (s.pairs, [5; 3; 1]);
%! assert (pow2 (s.prod_e.hi(2) + s.prod_e.lo(2), 2 * s.exp_e), x(2) * x(1) + x(4) * x(3) + x(5) * x(4), 1e-14);
%! assert ([s.segments s.first_length s.last_length s.longest], [2 2 3 3]);
%!test
%! % A first block near 1e-250 and a later one near 1e100: the merge moves the first block's sums
%! % to the larger exponent, and the whole equals the sums of the one block of all the rows.
%! e = [1 4; -2 0; 3 1; 0.5 -1; 2 2; -1 3; 0 0.5];  e(1:3, :) = e(1:3, :) * 1e-250;  e(4:end, :) = e(4:end, :) * 1e100;
%! t = e;  y = e(:, [2 1]);
%! whole = dynval.internal.stream_block (1, 3, true, e, t, y);
%! s = dynval.internal.stream_merge (dynval.internal.stream_block (1, 3, true, e(1:3, :), t(1:3, :), y(1:3, :)), ...
%!                                   dynval.internal.stream_block (1, 3, true, e(4:end, :), t(4:end, :), y(4:end, :)));
%! assert (s.exp_e, whole.exp_e);
%! for name = {'prod_e', 'cur_e', 'lag_e', 'products', 'sq_t', 'sq_y', 'prod_ey'}
%!   v = s.(name{1}).hi + s.(name{1}).lo;
%!   assert (v, whole.(name{1}).hi, 1e-13 * max (abs (whole.(name{1}).hi(:))));
%! end
