classdef ValidationAccumulator
%VALIDATIONACCUMULATOR Validation metrics of data that arrive in chunks (contract §4.1).
%   acc = dynval.ValidationAccumulator(n_params, max_lag)
%   acc = dynval.ValidationAccumulator(n_params, max_lag, 'noise_model', 'full')
%
%   A value object: every method returns the updated accumulator, so assign it back.
%     acc = acc.update(tau_meas_chunk, tau_pred_chunk)             next rows, c-by-m
%     acc = acc.update(tau_meas_chunk, tau_pred_chunk, Y_chunk)    with the regressor, c-by-m-by-p
%     acc = acc.break_segment()     a new record starts: no lagged product joins the two
%     acc = acc.merge(later)        later's rows come after acc's (later itself is unchanged)
%     r   = acc.result()            metrics of every row so far (acc stays usable)
%     acc.n_samples()               rows so far
%
%   The result equals the in-memory functions on the concatenated rows with the same records
%   (within rounding): per joint (1-by-m) sse, rmse, max_abs_error, vaf, fit_percent, r2,
%   residual_mean, residual_variance (ddof 1); autocorrelation ((max_lag+1)-by-m, adjusted),
%   rho (m-by-p-by-(max_lag+1), adjusted; [] without a regressor) and criteria (aic, bic, aicc,
%   fpe, naic, n_obs under 'noise_model': 'pooled' (default), 'per_joint' or 'full').
%   Chunks of any length are accepted (0 rows, 1 row, fewer rows than max_lag): lags join
%   across chunks and across a merge, unless a break_segment lies between. Merging is
%   associative, so accumulators of consecutive time ranges may be combined in any tree.
%
%   The state does not grow with the number of rows: O(max_lag*m*p + m^2) centred sums, the
%   first and last max_lag rows, and a buffer that pools small chunks before they are summed.
%   Unlike the in-memory functions, the sums are not rescaled by powers of two: data whose
%   squares leave float64's normal range (|x| beyond about 1e+150 or below 1e-150) lose digits.
%
%   Errors: identifiers dynval:<kind>, as the in-memory functions; a chunk's message starts
%   with 'chunk <i>: ' (i counts update calls from 0), a rejected chunk changes nothing.
%
%   Example:
%     t = cumsum(ones(100, 2));  y = t + [sin(1:100)' cos(1:100)'];
%     acc = dynval.ValidationAccumulator(4, 5);
%     for k = 1:10:100
%       acc = acc.update(t(k:k + 9, :), y(k:k + 9, :));
%     end
%     r = acc.result();  r.r2             % = dynval.r2(t, y, 'multioutput', 'raw_values')

  properties (SetAccess = private)
    n_params      % the criteria's p
    max_lag       % lags of the autocorrelation and cross-correlation
    noise_model   % 'pooled', 'per_joint' or 'full'
  end

  properties (Access = private)
    m = []             % joints, known from the first chunk with rows
    p = []             % regressor columns (0: none)
    sums = []          % stream_block / stream_merge sums; [] until rows have been summed
    break_first = false  % break_segment() before any summed row
    pending_e = []     % rows of the current record not yet summed
    pending_t = []
    pending_y = []
    block_rows = 0
    chunks = 0
    rows_seen = 0
  end

  methods
    function obj = ValidationAccumulator(n_params, max_lag, varargin)
      opt = dynval.internal.options('ValidationAccumulator', varargin, struct('noise_model', 'pooled'));
      if ~dynval.internal.is_integer(n_params) || n_params < 0
        dynval.internal.param_error('n_params', 'an integer with n_params >= 0', n_params);
      end
      if ~dynval.internal.is_integer(max_lag) || max_lag < 0
        dynval.internal.param_error('max_lag', 'an integer with max_lag >= 0', max_lag);
      end
      obj.noise_model = dynval.internal.check_choice('noise_model', opt.noise_model, {'pooled', 'per_joint', 'full'});
      obj.n_params = double(n_params);
      obj.max_lag = double(max_lag);
    end

    function n = n_samples(obj)
      n = size(obj.pending_e, 1);
      if ~isempty(obj.sums)
        n = n + obj.sums.n;
      end
    end

    function obj = update(obj, tau_meas, tau_pred, regressor)
      has_y = nargin > 3;
      if isempty(tau_meas) && isempty(tau_pred) && (~has_y || isempty(regressor))
        obj.chunks = obj.chunks + 1;  % no rows: nothing to check against, nothing to add
        return;
      end
      try
        meas = dynval.internal.check_type(tau_meas, 'tau_meas');
        pred = dynval.internal.check_type(tau_pred, 'tau_pred');
        if has_y
          regressor = dynval.internal.check_type(regressor, 'regressor');
        end
        dynval.internal.check_signal_shape(meas, 'tau_meas');
        dynval.internal.check_signal_shape(pred, 'tau_pred');
        if ~isequal(size(meas), size(pred))
          dynval.internal.raise('ShapeMismatch', sprintf('tau_meas and tau_pred must have the same shape, got %s and %s', ...
            dynval.internal.format_shape(size(meas)), dynval.internal.format_shape(size(pred))));
        end
        [c, m] = size(meas);
        if ~isempty(obj.m) && m ~= obj.m
          dynval.internal.raise('ShapeMismatch', sprintf('tau_meas must have m=%d columns like the chunks before it, got shape %s', ...
            obj.m, dynval.internal.format_shape(size(meas))));
        end
        if ~isempty(obj.m) && has_y ~= (obj.p > 0)
          before = 'one';
          if obj.p == 0
            before = 'none';
          end
          dynval.internal.raise('ShapeMismatch', ['regressor must be given with every chunk or with none; ' ...
            'the chunks before it had ' before]);
        end
        y = zeros(c, 0);
        p = 0;
        if has_y
          [y, p] = regressor_columns(regressor, c, m);
          if ~isempty(obj.p) && p ~= obj.p
            dynval.internal.raise('ShapeMismatch', sprintf('regressor must have p=%d columns like the chunks before it, got shape %s', ...
              obj.p, dynval.internal.format_shape(size(regressor))));
          end
        end
        obj.check_finite(meas, 'tau_meas', 0);
        obj.check_finite(pred, 'tau_pred', 0);
        obj.check_finite(y, 'regressor', p);
      catch err
        if strncmp(err.identifier, 'dynval:', 7)
          error(err.identifier, 'chunk %d: %s', obj.chunks, err.message);
        end
        rethrow(err);
      end
      if isempty(obj.m)
        obj.m = m;
        obj.p = p;
        % a block costs its junction products (L^2) however short it is: pool small chunks
        obj.block_rows = max(256, 4 * (obj.max_lag + 1));
        obj.pending_e = zeros(0, m);
        obj.pending_t = zeros(0, m);
        obj.pending_y = zeros(0, m * p);
      end
      obj.chunks = obj.chunks + 1;
      obj.rows_seen = obj.rows_seen + c;
      obj.pending_e = [obj.pending_e; meas - pred];
      obj.pending_t = [obj.pending_t; meas];
      obj.pending_y = [obj.pending_y; y];
      if size(obj.pending_e, 1) >= obj.block_rows
        obj = obj.flush();
      end
    end

    function obj = break_segment(obj)
      % Breaks before any row, or repeated, make no empty record.
      obj = obj.flush();
      if isempty(obj.sums)
        obj.break_first = true;
      else
        obj.sums.end_break = true;
      end
    end

    function obj = merge(obj, later)
      if ~isa(later, 'dynval.ValidationAccumulator')
        dynval.internal.param_error('other', 'a ValidationAccumulator', later);
      end
      same_setting('n_params', later.n_params, obj.n_params);
      same_setting('max_lag', later.max_lag, obj.max_lag);
      same_setting('noise_model', later.noise_model, obj.noise_model);
      if ~isempty(obj.m) && ~isempty(later.m) && (obj.m ~= later.m || obj.p ~= later.p)
        dynval.internal.raise('ShapeMismatch', sprintf(['other must hold data of the same shape, got m=%d joints and ' ...
          'p=%d regressor columns where this one has m=%d and p=%d'], later.m, later.p, obj.m, obj.p));
      end
      later = later.flush();
      obj = obj.flush();
      if isempty(obj.m) && ~isempty(later.m)
        obj.m = later.m;
        obj.p = later.p;
        obj.block_rows = later.block_rows;
        obj.pending_e = later.pending_e;
        obj.pending_t = later.pending_t;
        obj.pending_y = later.pending_y;
      end
      if isempty(later.sums)
        if later.break_first
          obj = obj.break_segment();
        end
      elseif isempty(obj.sums)
        obj.sums = later.sums;
        obj.sums.start_break = obj.sums.start_break || obj.break_first;
      else
        obj.sums = dynval.internal.stream_merge(obj.sums, later.sums);
      end
      obj.chunks = obj.chunks + later.chunks;
      obj.rows_seen = obj.rows_seen + later.rows_seen;
    end

    function r = result(obj)
      % TooFewSamples below 2 rows; InvalidParameter when max_lag is not below the longest record.
      obj = obj.flush();
      n = 0;
      if ~isempty(obj.sums)
        n = obj.sums.n;
      end
      if n < 2
        dynval.internal.raise('TooFewSamples', sprintf('ValidationAccumulator.result needs at least 2 samples, got N=%d', n));
      end
      dynval.internal.check_max_lag(obj.max_lag, obj.sums.longest);
      r = dynval.internal.stream_metrics(obj.sums, obj.max_lag, obj.n_params, obj.noise_model);
    end
  end

  methods (Access = private)
    function obj = flush(obj)
      % The pooled rows of the current record become one block of sums.
      if isempty(obj.pending_e)
        return;
      end
      block = dynval.internal.stream_block(obj.p, obj.max_lag, strcmp(obj.noise_model, 'full'), ...
        obj.pending_e, obj.pending_t, obj.pending_y);
      obj.pending_e = obj.pending_e([], :);
      obj.pending_t = obj.pending_t([], :);
      obj.pending_y = obj.pending_y([], :);
      if isempty(obj.sums)
        block.start_break = obj.break_first;
        obj.sums = block;
      else
        obj.sums = dynval.internal.stream_merge(obj.sums, block);
      end
    end

    function check_finite(obj, a, name, n_columns)
      % NonFiniteInput at the chunk's first bad value, with its row in the whole stream too.
      try
        dynval.internal.check_finite(a, name, n_columns);
      catch err
        row = dynval.internal.first_bad(a);
        error(err.identifier, '%s (row %d of the stream)', err.message, obj.rows_seen + row);
      end
    end
  end
end

function [y, p] = regressor_columns(regressor, c, m)
  % The c-by-(m*p) view of a c-by-m-by-p chunk (column (j-1)*p + k: joint j, column k). MATLAB
  % drops a trailing singleton, so a c-by-m matrix is p = 1, as in dynval.cross_correlation.
  shape = dynval.internal.format_shape(size(regressor));
  if ndims(regressor) > 3 || (ndims(regressor) == 2 && ~isequal(size(regressor), [c m]))
    if ndims(regressor) == 2 && size(regressor, 1) ~= c && size(regressor, 2) == m
      dynval.internal.raise('ShapeMismatch', sprintf( ...
        'regressor must have shape (c, m, p) = (%d, %d, p) to match tau_meas, got %s', c, m, shape));
    end
    dynval.internal.raise('InvalidShape', sprintf('regressor must be 3-D (c, m, p), got shape %s', shape));
  end
  p = size(regressor, 3);
  if p == 0
    dynval.internal.raise('InvalidShape', sprintf('regressor must have at least one column, got shape %s', shape));
  end
  if size(regressor, 1) ~= c || size(regressor, 2) ~= m
    dynval.internal.raise('ShapeMismatch', sprintf( ...
      'regressor must have shape (c, m, p) = (%d, %d, p) to match tau_meas, got %s', c, m, shape));
  end
  y = reshape(permute(regressor, [1 3 2]), c, m * p);
end

function same_setting(name, theirs, mine)
  if ~isequal(theirs, mine)
    dynval.internal.raise('InvalidParameter', sprintf(['other must be a ValidationAccumulator with the same ' ...
      'settings, got %s=%s where this one has %s=%s'], name, dynval.internal.format_value(theirs), ...
      name, dynval.internal.format_value(mine)));
  end
end

%!function [t, y, Y] = data (n, offset)
%!  % Deterministic torques of two joints, a prediction with a coloured error, two regressor columns.
%!  k = (1:n)';
%!  t = offset + [5 * sin(0.3 * k) + k / 20, 3 * cos(0.17 * k) - 2];
%!  y = t + [0.4 * sin(1.3 * k) + 0.05, 0.3 * cos(2.9 * k + 1) - 0.1 * sin(0.5 * k)];
%!  Y = cat (3, [sin(0.2 * k), k / n], [cos(0.11 * k) .^ 2, 1 + sin(0.7 * k)]);
%!endfunction
%!function want = in_memory (t, y, Y, max_lag, n_params, noise_model, segments)
%!  % The port's own in-memory functions on the whole series: what every stream must equal.
%!  e = t - y;
%!  raw = {'multioutput', 'raw_values'};
%!  want.sse = dynval.sse (t, y, raw{:});
%!  want.rmse = dynval.rmse (t, y, raw{:});
%!  want.max_abs_error = dynval.max_abs_error (t, y, raw{:});
%!  want.vaf = dynval.vaf (t, y, raw{:});
%!  want.fit_percent = dynval.fit_percent (t, y, raw{:});
%!  want.r2 = dynval.r2 (t, y, raw{:});
%!  want.residual_mean = dynval.residual_mean (e);
%!  want.residual_variance = dynval.residual_variance (e);
%!  want.autocorrelation = dynval.autocorrelation (e, max_lag, 'segments', segments);
%!  if isempty (Y)
%!    want.rho = [];
%!  else
%!    cc = dynval.cross_correlation (e, Y, max_lag, 'segments', segments);
%!    want.rho = cc.rho;
%!  end
%!  want.criteria = dynval.criteria (t, y, n_params, 'noise_model', noise_model);
%!endfunction
%!function same (r, want, tol)
%!  % Values within tol of each quantity's natural size (1 for correlations and percents
%!  % divided by 100, the data's scale for the others).
%!  names = {'sse', 'rmse', 'max_abs_error', 'residual_mean', 'residual_variance'};
%!  for i = 1:numel (names)
%!    assert (r.(names{i}), want.(names{i}), -tol);
%!  end
%!  assert (r.vaf / 100, want.vaf / 100, tol);
%!  assert (r.fit_percent / 100, want.fit_percent / 100, tol);
%!  assert (r.r2, want.r2, tol);
%!  assert (r.autocorrelation, want.autocorrelation, tol);
%!  assert (r.rho, want.rho, tol);
%!  c = {'aic', 'bic', 'aicc', 'fpe', 'naic', 'n_obs'};
%!  for i = 1:numel (c)
%!    assert (r.criteria.(c{i}), want.criteria.(c{i}), -tol);
%!  end
%!endfunction
%!function acc = fed (acc, t, y, Y, lengths)
%!  % One update per chunk of the given lengths.
%!  a = 0;
%!  for c = lengths
%!    if isempty (Y)
%!      acc = acc.update (t(a+1:a+c, :), y(a+1:a+c, :));
%!    else
%!      acc = acc.update (t(a+1:a+c, :), y(a+1:a+c, :), Y(a+1:a+c, :, :));
%!    end
%!    a = a + c;
%!  end
%!endfunction

%!test
%! % One accumulator, several chunkings: one block, one-row chunks, chunks shorter than
%! % max_lag = 7, and uneven ones; every output equals the in-memory functions.
%! [t, y, Y] = data (60, 0);
%! want = in_memory (t, y, Y, 7, 4, 'pooled', []);
%! chunkings = {60, ones(1, 60), [3 2 4 1 6 2 3 5 7 7 1 1 2 16], [29 31], [1 58 1]};
%! for i = 1:numel (chunkings)
%!   acc = fed (dynval.ValidationAccumulator (4, 7), t, y, Y, chunkings{i});
%!   same (acc.result (), want, 1e-12);
%!   assert (acc.n_samples (), 60);
%! end
%!test
%! % Without a regressor rho is [], and a one-joint (column vector) stream works alike.
%! [t, y] = data (50, 0);
%! acc = fed (dynval.ValidationAccumulator (2, 4), t(:, 1), y(:, 1), [], [10 3 37]);
%! same (acc.result (), in_memory (t(:, 1), y(:, 1), [], 4, 2, 'pooled', []), 1e-12);
%!test
%! % Merge orders: one accumulator per chunk (chunks of 1 to 5 rows, max_lag = 6), combined
%! % left to right, right to left and pairwise; merging is associative.
%! [t, y, Y] = data (45, 0);
%! want = in_memory (t, y, Y, 6, 3, 'per_joint', []);
%! lengths = [5 1 1 3 2 4 1 5 5 2 3 4 1 2 3 1 2];
%! parts = {};
%! a = 0;
%! for c = lengths
%!   parts{end + 1} = fed (dynval.ValidationAccumulator (3, 6, 'noise_model', 'per_joint'), ...
%!     t(a+1:a+c, :), y(a+1:a+c, :), Y(a+1:a+c, :, :), c);
%!   a = a + c;
%! end
%! left = parts{1};
%! for i = 2:numel (parts)
%!   left = left.merge (parts{i});
%! end
%! right = parts{end};
%! for i = numel (parts) - 1:-1:1
%!   right = merge (parts{i}, right);
%! end
%! level = parts;
%! while numel (level) > 1
%!   next = {};
%!   for k = 1:2:numel (level) - 1
%!     next{end + 1} = merge (level{k}, level{k + 1});
%!   end
%!   if mod (numel (level), 2) == 1
%!     next{end + 1} = level{end};
%!   end
%!   level = next;
%! end
%! same (left.result (), want, 1e-12);
%! same (right.result (), want, 1e-12);
%! same (level{1}.result (), want, 1e-12);
%! % merging leaves the later accumulator as it was (a value object)
%! assert (parts{2}.n_samples (), 1);
%!test
%! % Records by break_segment: inside a chunk, at a chunk boundary, and at a merge junction;
%! % the lags never join two records, the means stay overall ('segments' in memory).
%! [t, y, Y] = data (60, 0);
%! want = in_memory (t, y, Y, 5, 4, 'full', [20 15 25]);
%! acc = dynval.ValidationAccumulator (4, 5, 'noise_model', 'full');
%! acc = fed (acc, t(1:20, :), y(1:20, :), Y(1:20, :, :), [7 13]);
%! acc = acc.break_segment ();
%! acc = fed (acc, t(21:35, :), y(21:35, :), Y(21:35, :, :), [2 2 11]);
%! later = fed (dynval.ValidationAccumulator (4, 5, 'noise_model', 'full'), t(36:60, :), y(36:60, :), Y(36:60, :, :), [1 24]);
%! later = later.break_segment ().break_segment ();   % repeated breaks make no empty record
%! same (merge (acc.break_segment (), later).result (), want, 1e-12);
%! % a break opening the later accumulator is the same junction
%! later = fed (dynval.ValidationAccumulator (4, 5, 'noise_model', 'full').break_segment (), ...
%!   t(36:60, :), y(36:60, :), Y(36:60, :, :), [1 24]);
%! same (acc.merge (later).result (), want, 1e-12);
%!test
%! % More rows than the pooling buffer (256): blocks are summed while chunks keep coming.
%! [t, y, Y] = data (700, 0);
%! want = in_memory (t, y, Y, 10, 4, 'pooled', []);
%! same (fed (dynval.ValidationAccumulator (4, 10), t, y, Y, [37 * ones(1, 18), 34]).result (), want, 1e-12);
%! same (fed (dynval.ValidationAccumulator (4, 10), t, y, Y, ones (1, 700)).result (), want, 1e-12);
%!test
%! % A large offset (torques about 1e7, spread of a few units): the sums stay centred.
%! [t, y, Y] = data (80, 1e7);
%! want = in_memory (t, y, Y, 3, 4, 'pooled', []);
%! r = fed (dynval.ValidationAccumulator (4, 3), t, y, Y, [17 23 1 39]).result ();
%! assert (r.r2, want.r2, 1e-9);
%! assert (r.vaf / 100, want.vaf / 100, 1e-9);
%! assert (r.autocorrelation, want.autocorrelation, 1e-9);
%! assert (r.residual_variance, want.residual_variance, -1e-9);
%!test
%! % Degenerate values as in memory: an exact fit and a constant target.
%! t = [1 5; 2 5; 3 5; 4 5; 5 5];  y = [1 4; 2 4.5; 3 5.5; 4 5; 5 6];
%! r = fed (dynval.ValidationAccumulator (1, 1), t, y, [], [2 3]).result ();
%! assert (r.r2, dynval.r2 (t, y, 'multioutput', 'raw_values'));
%! assert (r.vaf, dynval.vaf (t, y, 'multioutput', 'raw_values'));
%! assert (isnan (r.autocorrelation(:, 1)));
%!test
%! % Empty chunks and breaks before any row change nothing.
%! [t, y] = data (30, 0);
%! acc = dynval.ValidationAccumulator (2, 3).break_segment ();
%! acc = acc.update (zeros (0, 2), zeros (0, 2));
%! acc = fed (acc, t, y, [], [30]);
%! same (acc.result (), in_memory (t, y, [], 3, 2, 'pooled', []), 1e-12);
%!error <chunk 1: tau_meas must have m=2 columns like the chunks before it, got shape \(3, 1\)> dynval.ValidationAccumulator (1, 1).update (ones (3, 2), ones (3, 2)).update (ones (3, 1), ones (3, 1))
%!error <chunk 0: tau_meas and tau_pred must have the same shape> dynval.ValidationAccumulator (1, 1).update (ones (3, 2), ones (3, 1))
%!error <chunk 1: regressor must be given with every chunk or with none; the chunks before it had none> dynval.ValidationAccumulator (1, 1).update (ones (3, 2), ones (3, 2)).update (ones (3, 2), ones (3, 2), ones (3, 2, 2))
%!error <chunk 1: tau_pred has a non-finite value \(nan\) at row 1, column 0 \(row 4 of the stream\)> dynval.ValidationAccumulator (1, 1).update (ones (3, 2), ones (3, 2)).update (ones (2, 2), [1 1; NaN 1])
%!error <ValidationAccumulator.result needs at least 2 samples, got N=1> dynval.ValidationAccumulator (1, 0).update (1, 2).result ()
%!error <max_lag must be an integer with 0 <= max_lag < 3, got 3> dynval.ValidationAccumulator (1, 3).update ([1; 2; 3], [0; 0; 0]).result ()
%!error <other must be a ValidationAccumulator with the same settings, got max_lag=2 where this one has max_lag=1> merge (dynval.ValidationAccumulator (1, 1), dynval.ValidationAccumulator (1, 2))
%!error <other must hold data of the same shape> merge (dynval.ValidationAccumulator (1, 1).update (ones (3, 2), ones (3, 2)), dynval.ValidationAccumulator (1, 1).update (ones (3, 1), ones (3, 1)))
%!error <n_params must be an integer with n_params .= 0, got -1> dynval.ValidationAccumulator (-1, 1)
%!error <noise_model must be one of 'pooled', 'per_joint', 'full', got 'diagonal'> dynval.ValidationAccumulator (1, 1, 'noise_model', 'diagonal')
%!test
%! try
%!   dynval.ValidationAccumulator (1, 1).update (ones (3, 2), ones (3, 2)).update (ones (3, 1), ones (3, 1));
%!   error ('no error');
%! catch err
%!   assert (err.identifier, 'dynval:ShapeMismatch');
%! end
