function text = format_values(values)
%FORMAT_VALUES The writer of the protocol: ' v1 v2 ...' with 17 significant digits (%.16e).
%   Non-finite values are written nan, inf, -inf (sprintf writes NaN, Inf, -Inf, which the
%   runner accepts too; the lower-case forms are those of the writers' grammar).
  if isempty(values)
    text = '';  % sprintf would still write the format's literal blank once
    return;
  end
  text = sprintf(' %.16e', values);
  text = regexprep(text, '-?NaN', 'nan');
  text = strrep(text, 'Inf', 'inf');
end

%!assert (dvport.format_values ([1.5 -0 NaN -Inf Inf 5e-324]), ' 1.5000000000000000e+00 -0.0000000000000000e+00 nan -inf inf 4.9406564584124654e-324')
%!assert (dvport.format_values (-4593.170185988091), ' -4.5931701859880914e+03')
%!assert (isempty (dvport.format_values ([])))
