function limit = segment_limit(starts, n)
%SEGMENT_LIMIT Length of the longest segment: the bound on every lag.
  limit = max(diff([starts(:); n]));
end
