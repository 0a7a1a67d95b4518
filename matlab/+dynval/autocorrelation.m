function rho = autocorrelation(e, max_lag, varargin)
%AUTOCORRELATION Normalised autocorrelation rho(l) = R(l)/R(0), l = 0..max_lag, (max_lag+1)-by-m.
%   rho = dynval.autocorrelation(e, max_lag)
%   rho = dynval.autocorrelation(e, max_lag, 'adjusted', false, 'segments', [500 300])
%   Options:
%     'adjusted'    true (default, the lesson): R(l) divides by the number of products n_l;
%                   false (biased: NIST StRD, R, statsmodels): by N at every lag
%     'segments'    [] (one record), lengths ([500 300]) or 0-based starts ([0 500]) of
%                   records concatenated along the samples; no product joins two of them
%     'nan_policy'  'raise' | 'omit' (rows deleted, a segment break inserted)
%   Means are overall (one per joint). A constant residual gives a column of NaN.
%
%   Example:
%     dynval.autocorrelation([1; -1; 1; -1], 1, 'adjusted', false)    % [1; -0.75]
  opt = dynval.internal.options('autocorrelation', varargin, ...
    struct('adjusted', true, 'segments', [], 'nan_policy', 'raise'));
  e = dynval.internal.residual_signal('autocorrelation', e);
  [data, starts] = dynval.internal.prepare('autocorrelation', {e}, {'e'}, 0, opt.nan_policy, opt.segments);
  e = data{1};
  n = size(e, 1);
  max_lag = dynval.internal.check_max_lag(max_lag, dynval.internal.segment_limit(starts, n));
  adjusted = dynval.internal.check_adjusted(opt.adjusted);
  rho = dynval.internal.acf(e, max_lag, adjusted, starts);
end

%!assert (dynval.autocorrelation ([1; -1; 1; -1], 1, 'adjusted', false), [1; -0.75], eps)
%!assert (dynval.autocorrelation ([1; -1; 1; -1], 1), [1; -1], eps)
%!assert (dynval.autocorrelation ([1 2; 1 -2; 1 2; 1 -2], 1, 'adjusted', false), [NaN 1; NaN -0.75], eps)
%!test
%! % Two records [1 -1] and [1 -1]: no product joins them (lag 1: two products, not three).
%! rho = dynval.autocorrelation ([1; -1; 1; -1], 1, 'segments', [2 2], 'adjusted', false);
%! assert (rho(2), -0.5, eps);
%! assert (dynval.autocorrelation ([1; -1; 1; -1], 1, 'segments', [0 2], 'adjusted', false), rho);
%!error <max_lag must be an integer with 0 <= max_lag < 5, got 5> dynval.autocorrelation (rand (5, 2), 5)
%!error <max_lag must be an integer with 0 <= max_lag < 5, got True> dynval.autocorrelation (rand (5, 2), true)
%!error <segments must be positive lengths summing to N=5> dynval.autocorrelation (rand (5, 2), 1, 'segments', [2 2])
%!error <segments must be positive lengths> dynval.autocorrelation (rand (5, 2), 1, 'segments', zeros (1, 0))
%!error <adjusted must be True or False, got 'yes'> dynval.autocorrelation (rand (5, 2), 1, 'adjusted', 'yes')
