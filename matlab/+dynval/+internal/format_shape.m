function s = format_shape(sz)
%FORMAT_SHAPE Write an array size as a Python tuple, the contract's notation: (5,) or (3, 2).
  if numel(sz) == 1
    s = sprintf('(%d,)', sz);
  else
    s = ['(' strjoin(arrayfun(@(d) sprintf('%d', d), sz, 'UniformOutput', false), ', ') ')'];
  end
end
