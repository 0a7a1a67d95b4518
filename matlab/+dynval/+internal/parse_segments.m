function starts = parse_segments(segments, n)
%PARSE_SEGMENTS Segment lengths or starts (contract 1.1) as 0-based starts, first element 0.
%   [] means one segment; an empty list of any other size (zeros(1, 0)) is invalid.
  if isnumeric(segments) && isequal(size(segments), [0 0])
    starts = 0;
    return;
  end
  requirement = sprintf('positive lengths summing to N=%d, or increasing starts beginning at 0 and below N=%d', n, n);
  ok = isnumeric(segments) && isreal(segments) && isvector(segments) && ~isempty(segments);
  if ok
    v = double(segments(:)');
    ok = all(isfinite(v)) && all(v == fix(v)) && all(abs(v) < 2^63);
  end
  if ok
    if v(1) == 0
      ok = all(diff(v) > 0) && v(end) < n;
      starts = v;
    else
      ok = all(v > 0) && sum(v) == n;
      starts = [0, cumsum(v(1:end - 1))];
    end
  end
  if ~ok
    dynval.internal.param_error('segments', requirement, segments);
  end
end

%!assert (dynval.internal.parse_segments ([], 800), 0)
%!assert (dynval.internal.parse_segments ([500 300], 800), [0 500])
%!assert (dynval.internal.parse_segments ([0 500], 800), [0 500])
%!assert (dynval.internal.parse_segments (800, 800), 0)
%!error <segments must be positive lengths summing to N=5> dynval.internal.parse_segments ([3 0 2], 5)
%!error <segments must be> dynval.internal.parse_segments ([0 3 2], 5)
%!error <segments must be> dynval.internal.parse_segments ([0 5], 5)
%!error <segments must be> dynval.internal.parse_segments ([2.5 2.5], 5)
%!error <segments must be> dynval.internal.parse_segments (zeros (1, 0), 5)
