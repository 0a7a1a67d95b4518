function c = comp_add(c, x)
%COMP_ADD Add x to a compensated sum c (struct with hi, lo of one size), element by element.
%   x is an array of c's size, or another compensated sum (its hi and lo are both added).
%   lo keeps what each addition rounded away (TwoSum), so that a stream of many small chunks
%   sums as accurately as one block.
  if isstruct(x)
    lo = x.lo;
    x = x.hi;
  else
    lo = 0;
  end
  s = c.hi + x;
  b = s - c.hi;
  c.lo = c.lo + ((c.hi - (s - b)) + (x - b)) + lo;
  c.hi = s;
end

%!test
%! % 1 + 1e-16 + ... : a plain sum keeps 1, the compensated one every small term.
%! c = struct ('hi', 1, 'lo', 0);
%! for i = 1:1000
%!   c = dynval.internal.comp_add (c, 1e-16);
%! end
%! assert (c.hi, 1);
%! assert (c.hi + c.lo, 1 + 1e-13, 1e-28);
%!test
%! a = struct ('hi', [1 2], 'lo', [1e-20 0]);
%! b = dynval.internal.comp_add (a, struct ('hi', [3 4], 'lo', [0 1e-20]));
%! assert ([b.hi; b.lo], [4 6; 1e-20 1e-20]);
