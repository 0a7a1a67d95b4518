"""Convention profiles of :func:`dynval.validate`, as data.

A profile fills every default of a validation report so that the numbers match
one tool: the lesson (the default), MATLAB's System Identification Toolbox,
statsmodels or scikit-learn (contract §4). Explicit keywords of ``validate``
(``max_lag``, ``level``) win over the profile. Each profile also records what
the test suite checks against the tool itself and, for MATLAB, which cases
have no published number to check against (they are marked, not guessed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..checks._errors import InvalidParameter

__all__ = ["Profile", "PROFILES", "PROFILE_NAMES", "get_profile"]


@dataclass(frozen=True)
class Profile:
    """Every convention a validation report depends on.

    Attributes
    ----------
    name : str
        Profile name (``lesson``, ``matlab``, ``statsmodels``, ``sklearn``).
    tool : str
        The tool whose conventions the profile reproduces.
    multioutput : str
        Headline aggregation over joints (``pooled``, ``raw_values``, ``uniform_average``).
    units : str
        Units of ``vaf`` and ``fit_percent``: ``percent`` or ``fraction``. ``r2`` is
        always a fraction.
    constant_target : str
        ``ieee`` (−inf / nan, contract §3.2) or ``force_finite`` (scikit-learn: 1.0
        when the prediction is exact, else 0.0).
    ddof : int
        Delta degrees of freedom of the reported residual variance.
    adjusted : bool
        Autocorrelation denominator: ``True`` lag ℓ over N − ℓ (the lesson),
        ``False`` every lag over N (biased).
    max_lag_cap : int or None
        Default ``max_lag`` is ``min(cap, longest segment − 1)``; ``None`` means
        statsmodels' rule ``min(⌊10·log10 N⌋, longest segment − 1)``.
    band : str
        Autocorrelation band: ``white`` (z/√N) or ``bartlett``.
    level : float
        Confidence level of the bands.
    ljung_box_rule : str
        ``max_lag`` (one Ljung–Box statistic at ``max_lag``) or ``statsmodels``
        (one statistic at ``min(10, N // 5)``, at least 1).
    noise_model : str
        Information-criteria noise model (``pooled``, ``per_joint``, ``full``).
    ic_constant : str
        ``dropped`` (the lesson's form) or ``included`` (N·m·(ln 2π + 1) added to
        aic, aicc and bic, as MATLAB's raw AIC and statsmodels' llf-based AIC do).
    checked_against : tuple of str
        What the test suite compares with the tool.
    unverified : tuple of str
        Quantities of the tool with no published number to test against.
    """

    name: str
    tool: str
    multioutput: str
    units: str
    constant_target: str
    ddof: int
    adjusted: bool
    max_lag_cap: int | None
    band: str
    level: float
    ljung_box_rule: str
    noise_model: str
    ic_constant: str
    checked_against: tuple = field(default=())
    unverified: tuple = field(default=())

    def default_max_lag(self, n_samples: int, longest_segment: int) -> int:
        """The profile's ``max_lag`` for N samples whose longest segment has the given length.

        Examples
        --------
        >>> PROFILES["statsmodels"].default_max_lag(1000, 1000)
        30
        >>> PROFILES["matlab"].default_max_lag(1000, 10)
        9
        """
        if self.max_lag_cap is None:
            cap = int(math.floor(10.0 * math.log10(n_samples))) if n_samples > 0 else 0
        else:
            cap = self.max_lag_cap
        return max(0, min(cap, longest_segment - 1))

    def motion_max_lag(self, period: float, n_samples: int, longest_segment: int) -> int:
        """The default ``max_lag`` with a sample rate: the motion's time scale, one period of the
        information band's edge (``period`` samples: lags within it see one phenomenon), at most four
        times the profile's count and below the longest segment.

        Examples
        --------
        >>> PROFILES["lesson"].motion_max_lag(40.5, 1000, 1000)
        41
        >>> PROFILES["matlab"].motion_max_lag(1e300, 1000, 50)
        49
        """
        # a band far below the rate (bandwidth=1e-307) gives more lags than any cap: capped before int
        lags = int(math.ceil(min(period, float(longest_segment))))
        cap = 4 * max(self.default_max_lag(n_samples, n_samples + 1), 1)
        return int(max(1, min(lags, cap, longest_segment - 1)))

    def ljung_box_lags(self, n_samples: int, max_lag: int, longest_segment: int) -> list:
        """Lags of the report's Ljung–Box statistics (empty: no statistic).

        ``max_lag = 0`` means no lag analysis at all, so the list is then empty
        for every profile.

        Examples
        --------
        >>> PROFILES["lesson"].ljung_box_lags(1000, 50, 1000)
        [50]
        >>> PROFILES["statsmodels"].ljung_box_lags(1000, 30, 1000)
        [10]
        """
        if max_lag < 1:
            return []
        if self.ljung_box_rule == "max_lag":
            return [max_lag]
        lag = min(10, n_samples // 5, longest_segment - 1)
        return [max(1, lag)] if longest_segment > 1 else []

    def conventions(self) -> dict:
        """The profile's switches by name (the report's ``provenance.conventions`` before
        the values that depend on the data are filled in)."""
        return {
            "multioutput": self.multioutput,
            "units": self.units,
            "constant_target": self.constant_target,
            "ddof": self.ddof,
            "adjusted": self.adjusted,
            "band": self.band,
            "level": self.level,
            "ljung_box_lags_rule": self.ljung_box_rule,
            "noise_model": self.noise_model,
            "ic_constant": self.ic_constant,
        }


_MATLAB_UNVERIFIED = (
    "MSE and BIC for more than one output: the Gaussian constant is taken as N·ny·(ln 2π + 1) "
    "(verified for ny = 1 only; the documentation consulted does not show ny > 1)",
    "the band formula of resid's residual-input cross-correlation (not stated in the documentation)",
    "whether resid removes the mean before the autocorrelation (xcorr does not; dynval always does)",
    "Ljung–Box: MATLAB reports no portmanteau test; the statistic is dynval's at max_lag",
)

PROFILES: dict = {
    "lesson": Profile(
        name="lesson",
        tool="the lesson (Chapter 19, Lesson 4)",
        multioutput="pooled",
        units="percent",
        constant_target="ieee",
        ddof=1,
        adjusted=True,
        max_lag_cap=50,
        band="white",
        level=0.95,
        ljung_box_rule="max_lag",
        noise_model="pooled",
        ic_constant="dropped",
        checked_against=(
            "Problem 4 AIC/BIC at full precision",
            "the lesson's compute_basic_metrics and residual_autocorrelation",
        ),
    ),
    "matlab": Profile(
        name="matlab",
        tool="MATLAB System Identification Toolbox (compare, goodnessOfFit, resid, Report.Fit)",
        multioutput="raw_values",
        units="percent",
        constant_target="ieee",
        ddof=0,
        adjusted=False,
        max_lag_cap=25,
        band="white",
        level=0.99,
        ljung_box_rule="max_lag",
        noise_model="full",
        ic_constant="included",
        checked_against=(
            "documented tfest(iddata1, 2) example: N = 300, MSE = 1.6575, np = 6 -> AIC 1.0150e3, "
            "AICc 1.0153e3, nAIC 0.5453, BIC 1.0372e3, FPE 1.7252 (compared at the printed precision)",
            "goodnessOfFit relation fit = 100 (1 - NRMSE)",
        ),
        unverified=_MATLAB_UNVERIFIED,
    ),
    "statsmodels": Profile(
        name="statsmodels",
        tool="statsmodels (OLS llf-based aic/bic, tsa.stattools.acf, acorr_ljungbox, eval_measures.vare)",
        multioutput="pooled",
        units="percent",
        constant_target="ieee",
        ddof=0,
        adjusted=False,
        max_lag_cap=None,
        band="bartlett",
        level=0.95,
        ljung_box_rule="statsmodels",
        noise_model="pooled",
        ic_constant="included",
        checked_against=(
            "sm.OLS(y, X).fit().aic / .bic on a stacked least-squares fit (same k)",
            "tsa.stattools.acf (adjusted=False) and its Bartlett confint half-widths",
            "stats.diagnostic.acorr_ljungbox at min(10, N // 5)",
        ),
    ),
    "sklearn": Profile(
        name="sklearn",
        tool="scikit-learn (r2_score, explained_variance_score, root_mean_squared_error)",
        multioutput="uniform_average",
        units="fraction",
        constant_target="force_finite",
        ddof=1,
        adjusted=True,
        max_lag_cap=50,
        band="white",
        level=0.95,
        ljung_box_rule="max_lag",
        noise_model="pooled",
        ic_constant="dropped",
        checked_against=(
            "r2_score, explained_variance_score, root_mean_squared_error with raw_values, "
            "uniform_average and variance_weighted, force_finite=True",
        ),
    ),
}

PROFILE_NAMES = tuple(PROFILES)


def get_profile(name) -> Profile:
    """Return the profile called `name`.

    Raises
    ------
    InvalidParameter
        If `name` is not a profile name.

    Examples
    --------
    >>> get_profile("matlab").level
    0.99
    """
    if isinstance(name, str) and name in PROFILES:
        return PROFILES[name]
    raise InvalidParameter(
        "profile must be one of 'lesson', 'matlab', 'statsmodels', 'sklearn', got " + repr(name))
