function log_det = log_det_term(sigma)
%LOG_DET_TERM ln det of a symmetric m-by-m covariance from its eigenvalues, or -Inf when it
%   is numerically singular: lambda_min <= m eps lambda_max (numpy's matrix_rank tolerance),
%   the rule of the 'full' noise model in memory and in a stream alike.
  m = size(sigma, 1);
  sigma = (sigma + sigma') / 2;
  lambda = sort(eig(sigma));
  largest = lambda(end);
  if largest <= 0 || lambda(1) <= m * eps * largest
    log_det = -Inf;
  else
    log_det = sum(log(lambda));
  end
end

%!assert (dynval.internal.log_det_term ([2 0; 0 3]), log (6), 1e-15)
%!assert (dynval.internal.log_det_term ([1 1; 1 1]), -Inf)
%!assert (dynval.internal.log_det_term (0), -Inf)
