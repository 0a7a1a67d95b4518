function ic = assemble_criteria(f, n_vec, n, p, size_term)
%ASSEMBLE_CRITERIA aic, bic, aicc, fpe, naic from the fit term (aicc, fpe NaN where p >= n - 1).
  ic = struct();
  ic.aic = f + 2 * p;
  ic.bic = f + p * log(n);
  if p < n - 1
    ic.aicc = ic.aic + 2 * p * (p + 1) / (n - p - 1);
    ic.fpe = size_term * (1 + p / n) / (1 - p / n);
  else
    ic.aicc = NaN;
    ic.fpe = NaN;
  end
  ic.naic = f / n_vec + 2 * p / n;
end
