function res = ljung_box(e, lags, varargin)
%LJUNG_BOX Ljung-Box test Q(h) = N (N+2) sum_{l<=h} rho_l^2 / n_l on the biased autocorrelation.
%   res = dynval.ljung_box(e, lags)
%   res = dynval.ljung_box(e, [5 10 20], 'model_df', 2, 'segments', [500 300])
%   lags: one h, or a vector of them (one statistic per entry, in the given order).
%   Options: 'model_df' (0 <= model_df < min(lags)), 'segments', 'nan_policy'.
%
%   res has fields test, lags (n_lags-by-1), model_df, statistic, pvalue, log_pvalue
%   (n_lags-by-m) and df = lags - model_df. pvalue is the chi-square survival function;
%   log_pvalue stays finite where pvalue underflows to 0 (real robot residuals).
%
%   Example:
%     r = dynval.ljung_box([1; -1; 1; -1; 1; -1], 1);  r.df      % 1
  res = dynval.internal.portmanteau('ljung_box', e, lags, varargin{:});
end

%!test
%! r = dynval.ljung_box ([1; -1; 1; -1; 1; -1], 1);
%! assert (r.df, 1);
%! % rho_1 = -5/6 (biased), Q = 6 * 8 * (25/36) / 5
%! assert (r.statistic, 6 * 8 * (25 / 36) / 5, 1e-12);
%! assert (r.pvalue, gammainc (r.statistic / 2, 0.5, 'upper'), 1e-15);
%!test
%! % A p-value far below the smallest double keeps a finite logarithm.
%! lp = dynval.internal.chi2_logsf (5000, 10);
%! assert (isfinite (lp));
%! % mpmath: log(gammainc(5, 2500, inf, regularized=True))
%! assert (lp, -2471.8802691470938532859, 1e-9);
%!error <lags must be a positive integer or a non-empty sequence of positive integers less than 5, got \[2, 5\]> dynval.ljung_box (rand (5, 2), [2 5])
%!error <lags must be a positive integer or a non-empty sequence of positive integers less than 5, got 0> dynval.ljung_box (rand (5, 2), 0)
