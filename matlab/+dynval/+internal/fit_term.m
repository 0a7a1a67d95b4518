function [f, n, n_vec, size_term] = fit_term(e, noise_model)
%FIT_TERM The fit term F of the information criteria, the n they use, N_vec and sigma^2 size S.
%   pooled: F = N m ln(SSE/(N m)); per_joint: F = N sum_j ln(SSE_j/N); full: F = N ln det S,
%   S = E'E/N (not demeaned), from its eigenvalues. A zero SSE, or a numerically singular S
%   (lambda_min <= m eps lambda_max, numpy's matrix_rank tolerance), gives F = -Inf and S = 0.
  [n_samples, m] = size(e);
  switch noise_model
    case 'pooled'
      n = n_samples * m;
      variance = sum(e(:) .^ 2) / n;
      if variance == 0
        f = -Inf;
      else
        f = n * log(variance);
      end
      n_vec = n;
      size_term = variance;
    case 'per_joint'
      n = n_samples;
      n_vec = n;
      variances = sum(e .^ 2, 1) / n_samples;
      if any(variances == 0)
        f = -Inf;
        size_term = 0;
      else
        log_size = sum(log(variances));
        f = n_samples * log_size;
        size_term = exp(log_size);
      end
    otherwise
      n = n_samples;
      n_vec = n;
      sigma = (e' * e) / n_samples;
      sigma = (sigma + sigma') / 2;
      lambda = sort(eig(sigma));
      largest = lambda(end);
      if largest <= 0 || lambda(1) <= m * eps * largest
        f = -Inf;
        size_term = 0;
      else
        log_det = sum(log(lambda));
        f = n_samples * log_det;
        size_term = exp(log_det);
      end
  end
end
