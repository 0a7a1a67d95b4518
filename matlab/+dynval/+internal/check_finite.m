function check_finite(a, name, n_columns)
%CHECK_FINITE Raise NonFiniteInput at the first value out of range (contract 1.2).
%   With n_columns (a regressor viewed as N-by-m*p) the place is written as sample, joint, column.
  [row, col, value] = dynval.internal.first_bad(a);
  if isempty(row)
    return;
  end
  if nargin > 2 && n_columns > 0
    where = sprintf('at sample %d, joint %d, column %d', row, floor(col / n_columns), mod(col, n_columns));
  else
    where = sprintf('at row %d, column %d', row, col);
  end
  if isfinite(value)
    msg = sprintf('%s has a value out of range (%s) %s: |x| must be at most 1e+144', ...
      name, dynval.internal.float_repr(value), where);
  else
    if isnan(value)
      token = 'nan';
    elseif value > 0
      token = 'inf';
    else
      token = '-inf';
    end
    msg = sprintf('%s has a non-finite value (%s) %s', name, token, where);
  end
  dynval.internal.raise('NonFiniteInput', msg);
end
