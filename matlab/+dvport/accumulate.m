function r = accumulate(tau_meas, tau_pred, n_params, max_lag, conventions, regressor, regressor_dims)
%ACCUMULATE The protocol operation accumulate (family streaming, golden/PROTOCOL.md §11).
%   r = dvport.accumulate(tau_meas, tau_pred, n_params, max_lag, conventions)
%   r = dvport.accumulate(tau_meas, tau_pred, n_params, max_lag, conventions, regressor, regressor_dims)
%   feeds dynval.ValidationAccumulator the rows in the blocks of conventions.chunks (a block is
%   split where a record of conventions.segments starts, with a break_segment between the two
%   parts), combines the blocks' accumulators in the order conventions.merge names and returns
%   its result. regressor_dims is the shape the case declared for the regressor
%   (MATLAB drops a trailing singleton, so the declared shape decides the regressor's checks).
%   conventions: struct of chunks, merge, segments, noise_model, nan_policy (absent: default).
  order = convention(conventions, 'merge', 'none');
  segments = convention(conventions, 'segments', []);
  noise_model = convention(conventions, 'noise_model', 'pooled');
  nan_policy = convention(conventions, 'nan_policy', 'raise');
  chunks = convention(conventions, 'chunks', []);
  has_y = nargin > 5;
  if ~has_y
    regressor = [];
  end

  % The data checks of criteria and cross_correlation, in the protocol's order. "omit" is
  % refused below, after the data: a refused policy must not hide a non-finite value.
  meas = dynval.internal.check_type(tau_meas, 'tau_meas');
  pred = dynval.internal.check_type(tau_pred, 'tau_pred');
  if has_y
    regressor = dynval.internal.check_type(regressor, 'regressor');
  end
  dynval.internal.check_signal_shape(meas, 'tau_meas');
  dynval.internal.check_signal_shape(pred, 'tau_pred');
  if has_y && (numel(regressor_dims) ~= 3 || regressor_dims(3) == 0)
    dynval.internal.raise('InvalidShape', sprintf('regressor must be 3-D (N, m, p) with p >= 1, got shape %s', ...
      dynval.internal.format_shape(regressor_dims)));
  end
  if ~isequal(size(meas), size(pred))
    dynval.internal.raise('ShapeMismatch', sprintf('tau_meas and tau_pred must have the same shape, got %s and %s', ...
      dynval.internal.format_shape(size(meas)), dynval.internal.format_shape(size(pred))));
  end
  [n, m] = size(meas);
  if has_y && (regressor_dims(1) ~= n || regressor_dims(2) ~= m)
    dynval.internal.raise('ShapeMismatch', sprintf('regressor must have shape (N, m, p) = (%d, %d, p) to match tau_meas, got %s', ...
      n, m, dynval.internal.format_shape(regressor_dims)));
  end
  dynval.internal.min_samples('accumulate', n);
  dynval.internal.check_finite(meas, 'tau_meas', 0);
  dynval.internal.check_finite(pred, 'tau_pred', 0);
  if has_y
    p = regressor_dims(3);
    regressor = reshape(regressor, n, m, p);
    dynval.internal.check_finite(reshape(permute(regressor, [1 3 2]), n, m * p), 'regressor', p);
  end

  dynval.internal.check_choice('nan_policy', nan_policy, {'raise'});
  ends = block_ends(chunks, n);
  order = dynval.internal.check_choice('merge', order, {'none', 'left', 'right', 'tree'});
  starts = dynval.internal.parse_segments(segments, n);
  if ~dynval.internal.is_integer(n_params) || n_params < 0
    dynval.internal.param_error('n_params', 'an integer with n_params >= 0', n_params);
  end
  max_lag = dynval.internal.check_max_lag(max_lag, dynval.internal.segment_limit(starts, n));
  noise_model = dynval.internal.check_choice('noise_model', noise_model, {'pooled', 'per_joint', 'full'});

  record_starts = starts(starts > 0);
  empty = dynval.ValidationAccumulator(n_params, max_lag, 'noise_model', noise_model);
  parts = {};
  a = 0;
  for b = ends
    if isempty(parts) || ~strcmp(order, 'none')
      parts{end + 1} = empty; %#ok<AGROW>
    end
    parts{end} = feed(parts{end}, meas, pred, regressor, has_y, a, b, record_starts);
    a = b;
  end
  acc = combine(parts, order);
  r = acc.result();
end

function v = convention(conventions, key, default)
  if isfield(conventions, key)
    v = conventions.(key);
  else
    v = default;
  end
end

function ends = block_ends(chunks, n)
  % Exclusive ends (0-based) of the blocks: chunks is a non-empty list of positive lengths summing to N.
  ok = isnumeric(chunks) && isreal(chunks) && isvector(chunks) && ~isempty(chunks);
  if ok
    v = double(chunks(:)');
    ok = all(isfinite(v)) && all(v == fix(v)) && all(v >= 1) && sum(v) == n;
  end
  if ~ok
    dynval.internal.param_error('chunks', sprintf('a non-empty list of positive lengths summing to N=%d', n), chunks);
  end
  ends = cumsum(v);
end

function acc = feed(acc, meas, pred, regressor, has_y, a, b, record_starts)
  % Rows a+1..b to one accumulator, split where a record starts inside the block, with a break
  % between the parts; a record starting at the block's first row is a break before it.
  if any(record_starts == a)
    acc = acc.break_segment();
  end
  cuts = [record_starts(record_starts > a & record_starts < b), b];
  lo = a;
  for k = 1:numel(cuts)
    rows = lo + 1:cuts(k);
    if has_y
      acc = acc.update(meas(rows, :), pred(rows, :), regressor(rows, :, :));
    else
      acc = acc.update(meas(rows, :), pred(rows, :));
    end
    if k < numel(cuts)
      acc = acc.break_segment();
    end
    lo = cuts(k);
  end
end

function acc = combine(parts, order)
  % One accumulator from the blocks' own, in the order the merge convention names (a + b is
  % a.merge(b)).
  switch order
    case {'none', 'left'}
      acc = parts{1};
      for i = 2:numel(parts)
        acc = merge(acc, parts{i});
      end
    case 'right'
      acc = parts{end};
      for i = numel(parts) - 1:-1:1
        acc = merge(parts{i}, acc);
      end
    otherwise
      % tree: adjacent pairs level by level, an odd last one passed up unchanged
      level = parts;
      while numel(level) > 1
        next = cell(1, ceil(numel(level) / 2));
        for k = 1:2:numel(level)
          if k < numel(level)
            next{(k + 1) / 2} = merge(level{k}, level{k + 1});
          else
            next{(k + 1) / 2} = level{k};
          end
        end
        level = next;
      end
      acc = level{1};
  end
end

%!test
%! % Every merge order, a record starting inside a block and one at a block's first row:
%! % the in-memory values with the same segments.
%! k = (1:40)';
%! t = [sin(0.3 * k) * 4, cos(0.2 * k) + k / 10];
%! y = t + [0.3 * sin(1.7 * k), 0.2 * cos(2.3 * k)];
%! e = t - y;
%! rho = dynval.autocorrelation (e, 4, 'segments', [12 9 19]);
%! for order = {'none', 'left', 'right', 'tree'}
%!   c = struct ('chunks', [5 7 3 2 4 19], 'merge', order{1}, 'segments', [0 12 21]);
%!   r = dvport.accumulate (t, y, 2, 4, c);
%!   assert (r.autocorrelation, rho, 1e-12);
%!   assert (r.r2, dynval.r2 (t, y, 'multioutput', 'raw_values'), 1e-12);
%! end
%!test
%! % A regressor declared (N, m, 1) arrives as an N-by-m matrix.
%! k = (1:30)';
%! t = [sin(k), cos(k)];  y = t + 0.1 * [cos(3 * k), sin(5 * k)];  Y = [k / 30, sin(0.4 * k)];
%! r = dvport.accumulate (t, y, 1, 3, struct ('chunks', [4 26], 'merge', 'tree'), Y, [30 2 1]);
%! cc = dynval.cross_correlation (t - y, Y, 3);
%! assert (r.rho, cc.rho, 1e-12);
%!error <chunks must be a non-empty list of positive lengths summing to N=4, got \[1, 2\]> dvport.accumulate (ones (4, 1), zeros (4, 1), 1, 1, struct ('chunks', [1 2]))
%!error <chunks must be> dvport.accumulate (ones (4, 1), zeros (4, 1), 1, 1, struct ('chunks', [4 0]))
%!error <chunks must be> dvport.accumulate (ones (4, 1), zeros (4, 1), 1, 1, struct ())
%!error <merge must be one of 'none', 'left', 'right', 'tree', got 'sideways'> dvport.accumulate (ones (4, 1), zeros (4, 1), 1, 1, struct ('chunks', 4, 'merge', 'sideways'))
%!error <nan_policy must be one of 'raise', got 'omit'> dvport.accumulate (ones (4, 1), zeros (4, 1), 1, 1, struct ('chunks', 4, 'nan_policy', 'omit'))
%!error <tau_meas has a non-finite value> dvport.accumulate ([1; NaN; 1; 1], zeros (4, 1), 1, 1, struct ('chunks', 4, 'nan_policy', 'omit'))
%!error <regressor must have shape \(N, m, p\) = \(4, 1, p\)> dvport.accumulate (ones (4, 1), zeros (4, 1), 1, 1, struct ('chunks', 4), ones (3, 1, 2), [3 1 2])
