function values = fit_values(metric, sse, ssc_e, tss, constant, e_constant)
%FIT_VALUES vaf (percent), fit_percent (percent) or r2 (fraction) with the contract's
%   degenerate values: a constant target gives -Inf, or NaN when the fit is exact.
  switch metric
    case 'vaf'
      values = 100 * (1 - ssc_e ./ tss);
      exact = e_constant;
    case 'fit_percent'
      values = 100 * (1 - sqrt(sse ./ tss));
      exact = sse == 0;
    otherwise
      values = 1 - sse ./ tss;
      exact = sse == 0;
  end
  values(constant & exact) = NaN;
  values(constant & ~exact) = -Inf;
end
