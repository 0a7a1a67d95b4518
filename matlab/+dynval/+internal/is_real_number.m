function ok = is_real_number(v)
%IS_REAL_NUMBER True for a real numeric scalar (NaN and Inf included); false for logicals.
  ok = isnumeric(v) && isscalar(v) && isreal(v);
end
