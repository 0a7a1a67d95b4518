function res = box_pierce(e, lags, varargin)
%BOX_PIERCE Box-Pierce test Q(h) = N sum_{l<=h} rho_l^2 on the biased autocorrelation.
%   res = dynval.box_pierce(e, lags, 'model_df', k, 'segments', s, 'nan_policy', np)
%   Arguments and result fields as dynval.ljung_box.
%
%   Example:
%     r = dynval.box_pierce([1; -1; 1; -1], 1);  r.statistic      % 2.25
  res = dynval.internal.portmanteau('box_pierce', e, lags, varargin{:});
end

%!test
%! r = dynval.box_pierce ([1; -1; 1; -1], 1);
%! assert (r.statistic, 2.25, 1e-14);
%! assert (r.test, 'box_pierce');
%!error <model_df must be an integer with 0 <= model_df < 2, got 2> dynval.box_pierce (rand (5, 2), 2, 'model_df', 2)
%!error <model_df must be an integer with 0 <= model_df < 2, got 3> dynval.box_pierce (rand (5, 2), [4 2], 'model_df', 3)
