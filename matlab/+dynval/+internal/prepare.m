function [data, starts, omitted] = prepare(fname, data, names, n_columns, nan_policy, segments)
%PREPARE The start of the parameter step shared by every function that takes data.
%   nan_policy first, then segments (lengths or starts), then omission of bad rows. With
%   nan_policy 'raise' (or an invalid nan_policy) a value out of range wins over any parameter
%   error, so the data are searched here, before any parameter is judged.
%   data: cell of 2-D arrays sharing the sample axis (a regressor viewed as N-by-m*p);
%   n_columns(i) is p for a regressor, 0 otherwise. Without segments the data are one record.
  valid_policy = ischar(nan_policy) && any(strcmp(nan_policy, {'raise', 'omit'}));
  if ~valid_policy || strcmp(nan_policy, 'raise')
    for i = 1:numel(data)
      dynval.internal.check_finite(data{i}, names{i}, n_columns(i));
    end
  end
  if ~valid_policy
    dynval.internal.check_choice('nan_policy', nan_policy, {'raise', 'omit'});
  end
  n = size(data{1}, 1);
  if nargin > 5
    starts = dynval.internal.parse_segments(segments, n);
  else
    starts = 0;
  end
  omitted = 0;
  if strcmp(nan_policy, 'omit')
    keep = true(n, 1);
    for i = 1:numel(data)
      keep = keep & all(abs(data{i}) <= 1e144, 2);
    end
    omitted = n - sum(keep);
    if omitted > 0
      is_start = false(n, 1);
      is_start(starts + 1) = true;
      % A kept row opens a segment if it opened one before or if the row before it was deleted.
      previous_deleted = [true; ~keep(1:end - 1)];
      opens = is_start | previous_deleted;
      opens = opens(keep);
      starts = find(opens)' - 1;
      if isempty(starts)
        starts = 0;
      end
      for i = 1:numel(data)
        data{i} = data{i}(keep, :);
      end
    end
    dynval.internal.min_samples(fname, size(data{1}, 1));
  end
end

%!test
%! % omit deletes the row and refines the caller's starts (as dynval._segments.omit_nonfinite).
%! [data, starts, omitted] = dynval.internal.prepare ('autocorrelation', {[1; NaN; 3; 4; 5]}, {'e'}, 0, 'omit', [0 3]);
%! assert (data{1}, [1; 3; 4; 5]);
%! assert (starts, [0 1 2]);
%! assert (omitted, 1);
%!test
%! % A row is deleted when any array holds a bad value in it; 1e145 is out of range.
%! data = dynval.internal.prepare ('r2', {[1; 2; 3; 4], [1; 1e145; 3; Inf]}, {'tau_meas', 'tau_pred'}, [0 0], 'omit');
%! assert (data, {[1; 3], [1; 3]});
%!error <tau_pred has a non-finite value \(inf\) at row 3, column 0> dynval.internal.prepare ('r2', {[1; 2; 3; 4], [1; 2; 3; Inf]}, {'tau_meas', 'tau_pred'}, [0 0], 'bogus')
%!error <nan_policy must be one of 'raise', 'omit', got 'bogus'> dynval.internal.prepare ('r2', {[1; 2; 3; 4], [1; 2; 3; 4]}, {'tau_meas', 'tau_pred'}, [0 0], 'bogus')
