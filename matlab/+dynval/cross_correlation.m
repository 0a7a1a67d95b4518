function res = cross_correlation(e, Y, max_lag, varargin)
%CROSS_CORRELATION Cross-correlation of each joint's residual with that joint's regressor columns.
%   res = dynval.cross_correlation(e, Y, max_lag)
%   res = dynval.cross_correlation(e, Ys, max_lag, 'n_joints', m)
%
%   e   N-by-m residuals.
%   Y   N-by-m-by-p regressor (sample, joint, column); an N-by-m matrix is p = 1.
%   Ys  the stacked (N*m)-by-p form, row (k-1)*m + j holding sample k, joint j; needs 'n_joints'.
%   Options: 'n_joints', 'adjusted' (true: divide lag sums by n_l; false: by N), 'level'
%   (0.95), 'segments', 'nan_policy'. Lag l pairs e at sample k with Y at sample k - l.
%
%   res.rho            m-by-p-by-(max_lag+1): R_eY(l) / sqrt(R_e(0) R_Y(0)), overall means
%   res.constant_mask  m-by-p logical: column constant on that joint (its rho is NaN)
%   res.band           z/sqrt(N); res.level
%   res.outside        rows [joint column lag rho ratio] (0-based joint, column and lag) with
%                      |rho| > band, sorted by ratio = |rho|/band, largest first
%
%   Example:
%     r = dynval.cross_correlation([1; -1; 2; 0], [1; -1; 2; 0], 0);  r.rho    % 1
  opt = dynval.internal.options('cross_correlation', varargin, struct('n_joints', [], 'adjusted', true, ...
    'level', 0.95, 'segments', [], 'nan_policy', 'raise'));
  e = dynval.internal.check_type(e, 'e');
  Y = dynval.internal.check_type(Y, 'regressor');
  dynval.internal.check_signal_shape(e, 'e');
  [n, m] = size(e);
  n_joints = opt.n_joints;
  shape = dynval.internal.format_shape(size(Y));
  three_d = false;
  if ndims(Y) == 3 || (isempty(n_joints) && ismatrix(Y) && isequal(size(Y), [n m]))
    % N-by-m-by-p; MATLAB drops a trailing singleton, so an N-by-m matrix is p = 1.
    three_d = true;
    p = size(Y, 3);
    if p == 0
      dynval.internal.raise('InvalidShape', sprintf('regressor must have at least one column, got shape %s', shape));
    end
    if size(Y, 1) ~= n || size(Y, 2) ~= m
      dynval.internal.raise('ShapeMismatch', sprintf( ...
        'regressor must have shape (N, m, p) = (%d, %d, p) to match e, got %s', n, m, shape));
    end
  elseif ismatrix(Y) && ~isempty(n_joints)
    p = size(Y, 2);
    if p == 0
      dynval.internal.raise('InvalidShape', sprintf('regressor must have at least one column, got shape %s', shape));
    end
    if size(Y, 1) ~= n * m
      dynval.internal.raise('ShapeMismatch', sprintf('regressor has %d rows, which is not N*m = %d*%d', size(Y, 1), n, m));
    end
  else
    dynval.internal.raise('InvalidShape', sprintf( ...
      'regressor must be 3-D (N, m, p) or 2-D (N*m, p) with n_joints, got shape %s', shape));
  end
  rows = size(Y, 1);
  dynval.internal.min_samples('cross_correlation', n);
  % The N-by-(m*p) view: column j*p + c (0-based) is joint j, regressor column c.
  if three_d
    y2 = reshape(permute(Y, [1 3 2]), n, m * p);
  else
    y2 = reshape(Y.', m * p, n).';
  end
  [data, starts] = dynval.internal.prepare('cross_correlation', {e, y2}, {'e', 'regressor'}, [0 p], ...
    opt.nan_policy, opt.segments);
  e = data{1};
  y2 = data{2};
  n = size(e, 1);
  max_lag = dynval.internal.check_max_lag(max_lag, dynval.internal.segment_limit(starts, n));
  if ~(three_d && isempty(n_joints))
    if ~dynval.internal.is_integer(n_joints) || n_joints <= 0 || (~three_d && mod(rows, n_joints) ~= 0)
      dynval.internal.param_error('n_joints', 'a positive integer dividing the regressor rows', n_joints);
    end
    if n_joints ~= m
      dynval.internal.param_error('n_joints', sprintf('equal to the number of joints of e (m=%d)', m), n_joints);
    end
  end
  adjusted = dynval.internal.check_adjusted(opt.adjusted);
  level = dynval.internal.check_level(opt.level);

  % Each column scaled by a power of two before centring (contract §1.3): rho does not depend
  % on it, and no square underflows.
  e = dynval.internal.scale_columns(e);
  y2 = dynval.internal.scale_columns(y2);
  e_constant = min(e, [], 1) == max(e, [], 1);
  de = dynval.internal.centred(e);
  ss_e = sum(de .^ 2, 1);
  ss_e(e_constant) = 0;
  columns = reshape(repmat(1:m, p, 1), 1, m * p);
  de = de(:, columns);
  ss_e = ss_e(columns);
  e_constant = e_constant(columns);
  y_constant = min(y2, [], 1) == max(y2, [], 1);
  dy = dynval.internal.centred(y2);
  ss_y = sum(dy .^ 2, 1);
  ss_y(y_constant) = 0;
  s = dynval.internal.lagged_sums(de, dy, max_lag, starts);
  if adjusted
    denominators = dynval.internal.product_counts(starts, n, max_lag);
  else
    denominators = n * ones(max_lag + 1, 1);
  end
  rho = (s ./ denominators) ./ (sqrt(ss_e / n) .* sqrt(ss_y / n));
  rho(:, y_constant | e_constant | ss_e == 0 | ss_y == 0) = NaN;
  % rho is (max_lag+1)-by-(m*p) with column j*p + c; reorder to m-by-p-by-(max_lag+1).
  res = struct();
  res.rho = permute(reshape(rho.', p, m, max_lag + 1), [2 1 3]);
  res.constant_mask = reshape(y_constant, p, m).';
  res.band = dynval.internal.normal_quantile_band(level, n);
  res.level = level;
  [j, c, l] = ind2sub(size(res.rho), find(abs(res.rho) > res.band));
  values = res.rho(abs(res.rho) > res.band);
  outside = [j(:) - 1, c(:) - 1, l(:) - 1, values(:), abs(values(:)) / res.band];
  outside = sortrows(outside, [-5 1 2 3]);
  res.outside = outside;
end

%!test
%! r = dynval.cross_correlation ([1; -1; 2; 0], [1; -1; 2; 0], 0);
%! assert (r.rho, 1, 1e-15);
%! assert (r.constant_mask, false);
%!test
%! % The 3-D and the stacked forms are the same regressor.
%! e = [1 0; -1 2; 2 1; 0 -3; 1 1];
%! Y = reshape (1:20, 5, 2, 2) .^ 1.5;
%! Y(:, 2, 1) = 4;
%! r3 = dynval.cross_correlation (e, Y, 2, 'adjusted', false);
%! stacked = reshape (permute (Y, [3 2 1]), 2, 10).';
%! rs = dynval.cross_correlation (e, stacked, 2, 'n_joints', 2, 'adjusted', false);
%! assert (rs.rho, r3.rho, 1e-15);
%! assert (r3.constant_mask, [false false; true false]);
%! assert (all (isnan (r3.rho(2, 1, :))));
%! % lag 1 of joint 1, column 1 by the definition
%! de = e(:, 1) - mean (e(:, 1));  dy = Y(:, 1, 1) - mean (Y(:, 1, 1));
%! want = sum (de(2:end) .* dy(1:end-1)) / 5 / sqrt (sum (de .^ 2) / 5 * sum (dy .^ 2) / 5);
%! assert (r3.rho(1, 1, 2), want, 1e-14);
%!error <regressor must be 3-D \(N, m, p\) or 2-D \(N\*m, p\) with n_joints, got shape \(5, 1\)> dynval.cross_correlation (rand (5, 2), rand (5, 1), 1)
%!error <regressor has 9 rows, which is not N\*m = 5\*2> dynval.cross_correlation (rand (5, 2), rand (9, 2), 1, 'n_joints', 2)
%!error <regressor has a non-finite value \(nan\) at sample 1, joint 0, column 1> dynval.cross_correlation (rand (5, 1), [1 2; 3 NaN; 4 5; 6 7; 8 9], 1, 'n_joints', 1)
