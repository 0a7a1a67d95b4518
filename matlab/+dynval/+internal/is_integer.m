function ok = is_integer(v)
%IS_INTEGER True for a real whole number that fits in int64; false for logicals.
%   MATLAB literals are doubles, so an integral double counts as an integer here (the
%   corpus lists integral floats as 'acceptable' for exactly this reason).
  ok = isnumeric(v) && isscalar(v) && isreal(v) && isfinite(double(v)) ...
    && double(v) == fix(double(v)) && abs(double(v)) < 2^63;
end
