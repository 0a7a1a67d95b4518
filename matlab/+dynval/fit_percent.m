function value = fit_percent(tau_meas, tau_pred, varargin)
%FIT_PERCENT Normalised fit in percent: 100 (1 - ||e|| / ||tau_meas - mean||).
%   value = dynval.fit_percent(tau_meas, tau_pred, 'multioutput', mo, 'nan_policy', np)
%   Options as dynval.vaf. An exact fit gives 100.
%
%   Example:
%     dynval.fit_percent([0; 2], [0; 2])      % 100
  value = dynval.internal.normalized_fit('fit_percent', tau_meas, tau_pred, varargin{:});
end

%!assert (dynval.fit_percent ([0; 2], [0; 2]), 100)
%!assert (dynval.fit_percent ([0 1; 2 3], [1 1; 1 3], 'multioutput', 'raw_values'), [100 * (1 - 1), 100])
