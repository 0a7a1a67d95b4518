function [f, n, n_vec, size_term] = fit_term(e, noise_model)
%FIT_TERM The fit term F of the information criteria, the n they use, N_vec and sigma^2 size S.
%   pooled: F = N m ln(SSE/(N m)); per_joint: F = N sum_j ln(SSE_j/N); full: F = N ln det S,
%   S = E'E/N (not demeaned), from its eigenvalues. A zero SSE, or a numerically singular S
%   (lambda_min <= m eps lambda_max, numpy's matrix_rank tolerance), gives F = -Inf and S = 0.
  [n_samples, m] = size(e);
  switch noise_model
    case 'pooled'
      n = n_samples * m;
      % Scaled sums (contract §1.3): ln σ² = ln(s/n) + 2k ln 2 stays finite when σ² underflows.
      [es, k] = dynval.internal.scale_columns(e(:));
      total = sum(es .^ 2);
      if total == 0
        f = -Inf;
        size_term = 0;
      else
        f = n * (log(total / n) + 2 * k * log(2));
        size_term = dynval.internal.ldexp(total / n, 2 * k);
      end
      n_vec = n;
    case 'per_joint'
      n = n_samples;
      n_vec = n;
      [es, k] = dynval.internal.scale_columns(e);
      variances = sum(es .^ 2, 1) / n_samples;
      if any(variances == 0)
        f = -Inf;
        size_term = 0;
      else
        log_size = sum(log(variances) + 2 * k * log(2));
        f = n_samples * log_size;
        size_term = exp(log_size);
      end
    otherwise
      n = n_samples;
      n_vec = n;
      % One power of two for every joint: eigenvalue ratios stay, ln det gains 2k·m·ln 2.
      [~, k] = dynval.internal.scale_columns(e(:));
      e = dynval.internal.ldexp(e, -k);
      log_det = dynval.internal.log_det_term((e' * e) / n_samples);
      if log_det == -Inf
        f = -Inf;
        size_term = 0;
      else
        log_det = log_det + 2 * k * m * log(2);
        f = n_samples * log_det;
        size_term = exp(log_det);
      end
  end
end
