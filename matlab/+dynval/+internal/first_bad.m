function [row, col, value] = first_bad(a)
%FIRST_BAD First value (row-major order, 0-based indices) that is NaN, +-Inf or |x| > 1e144.
%   row is empty when every value is in range.
  row = []; col = []; value = [];
  at = a.';
  idx = find(~(abs(at) <= 1e144), 1);
  if ~isempty(idx)
    [c, r] = ind2sub(size(at), idx);
    row = r - 1;
    col = c - 1;
    value = a(r, c);
  end
end
