function check = min_samples(fname, n)
%MIN_SAMPLES Raise TooFewSamples when N is below the function's minimum (contract 2.2).
  switch fname
    case {'residuals', 'sse', 'rmse', 'max_abs_error', 'residual_mean'}
      k = 1;
    otherwise
      k = 2;
  end
  check = k;
  if n < k
    dynval.internal.raise('TooFewSamples', sprintf('%s needs at least %d samples, got N=%d', fname, k, n));
  end
end
