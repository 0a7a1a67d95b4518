function v = residual_variance(e, varargin)
%RESIDUAL_VARIANCE Variance of each joint's residual, sum((e - mean)^2) / (N - ddof) (1-by-m).
%   v = dynval.residual_variance(e)                  ddof = 1 (sample variance, the default)
%   v = dynval.residual_variance(e, 'ddof', 0)       population form: the lesson's var(e, 1)
%   Options: 'ddof' (an integer, 0 <= ddof < N), 'nan_policy' ('raise' | 'omit').
%
%   Example:
%     dynval.residual_variance([1; 2; 3])      % 1
  opt = dynval.internal.options('residual_variance', varargin, struct('ddof', 1, 'nan_policy', 'raise'));
  e = dynval.internal.residual_signal('residual_variance', e);
  data = dynval.internal.prepare('residual_variance', {e}, {'e'}, 0, opt.nan_policy);
  n = size(data{1}, 1);
  ddof = opt.ddof;
  if ~dynval.internal.is_integer(ddof) || ~(ddof >= 0 && ddof < n)
    dynval.internal.param_error('ddof', sprintf('an integer with 0 <= ddof < N=%d', n), ddof);
  end
  [es, k] = dynval.internal.scale_columns(data{1});  % contract §1.3
  [~, ss] = dynval.internal.moments(es);
  v = dynval.internal.ldexp(ss / (n - double(ddof)), 2 * k);
end

%!assert (dynval.residual_variance ([1; 2; 3]), 1)
%!assert (dynval.residual_variance ([1; 2; 3], 'ddof', 0), 2 / 3, eps)
%!assert (dynval.residual_variance ([1 4; 2 4; 3 4]), [1 0])
%!error <ddof must be an integer with 0 <= ddof < N=5, got 5> dynval.residual_variance (rand (5, 2), 'ddof', 5)
%!error <ddof must be an integer with 0 <= ddof < N=5, got True> dynval.residual_variance (rand (5, 2), 'ddof', true)
%!error <ddof must be an integer with 0 <= ddof < N=5, got -1> dynval.residual_variance (rand (5, 2), 'ddof', -1)
