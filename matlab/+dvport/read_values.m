function values = read_values(text)
%READ_VALUES The numbers of an array line (blank-separated tokens) as a column vector.
%   One sscanf over the whole text (strtod, correctly rounded) is the fast path; when it stops
%   before the end of the text (a form it does not read, such as 'nan(ind)', or garbage such
%   as '1,5'), each token is read by dvport.read_real, which also rejects what is not a number.
  [values, ~, ~, next] = sscanf(text, '%f');
  tokens = regexp(text, '\S+', 'match');
  if numel(values) ~= numel(tokens) || any(~isspace(text(next:end)))
    values = zeros(numel(tokens), 1);
    for i = 1:numel(tokens)
      values(i) = dvport.read_real(tokens{i});
    end
  end
end

%!assert (dvport.read_values (' 1.0000000000000000e+00 nan -inf 2.5e-3 '), [1; NaN; -Inf; 2.5e-3])
%!assert (dvport.read_values ('infinity nan(ind) -Infinity 4'), [Inf; NaN; -Inf; 4])
%!assert (size (dvport.read_values ('')), [0 1])
%!error <not a protocol number> dvport.read_values ('1.5 1,5')
%!test
%! % Every double survives %.16e and back: 100000 random bit patterns, subnormals included.
%! rand ('seed', 42);
%! bits = uint64 (floor (rand (100000, 1) * 2^32)) * uint64 (2^32) + uint64 (floor (rand (100000, 1) * 2^32));
%! x = typecast (bits, 'double');
%! x = x(isfinite (x));
%! back = dvport.read_values (dvport.format_values (x));
%! assert (isequal (typecast (back, 'uint64'), typecast (x, 'uint64')));
