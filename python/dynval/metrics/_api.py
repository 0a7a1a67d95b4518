"""Public functions of dynval: check the data, pick the backend, call its kernel.

Every function checks in the contract's order (§2.1): type -> shape -> size -> finiteness ->
parameters. Type, shape and size are checked here. Finiteness is checked by the kernel in its
pass over the data; parameters are checked here *deferred* (``_checks.CheckedCall``, shared with
``validate``): when one is bad, the data are first searched for a non-finite value, so
NonFiniteInput still wins. Within the parameter
step the order is ``nan_policy``, ``backend``, ``segments`` (they decide which data the other
parameters are checked against), then the remaining keywords in signature order.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

from ..checks._checks import CheckedCall
from ..checks._typing import (
    ArrayLike,
    BackendName,
    Convention,
    FloatArray,
    IntArray,
    Integer,
    Kernels,
    LagsLike,
    MultiOutput,
    NanPolicy,
    NoiseModel,
    SegmentsLike,
)
from ..checks._validation import (
    MULTIOUTPUT_OPTIONS,
    check_adjusted,
    check_convention,
    check_ddof,
    check_lags,
    check_level,
    check_max_lag,
    check_min_samples,
    check_model_df,
    check_multioutput,
    check_n,
    check_n_joints,
    check_n_obs,
    check_n_params,
    check_noise_model,
    check_rss,
    promote_signal,
    regressor_shape,
    regressor_to_2d,
    to_float_array,
    torque_pair,
)
from ..kernels import _backend
from ..statistics._stats import iid_t_test, newey_west_bandwidth, newey_west_n_eff, z_two_sided
from ._results import CrossCorrelation, InformationCriteria, PortmanteauTest, ZeroMeanTest

__all__ = [
    "residuals",
    "sse",
    "rmse",
    "max_abs_error",
    "vaf",
    "fit_percent",
    "r2",
    "residual_mean",
    "residual_variance",
    "zero_mean_test",
    "autocorrelation",
    "confidence_band",
    "ljung_box",
    "box_pierce",
    "cross_correlation",
    "information_criteria",
    "criteria",
    "aic",
    "bic",
]

_NO_SEGMENTS = object()


# --------------------------------------------------------------------------- plumbing


def signal_pair(function: str, tau_meas: ArrayLike, tau_pred: ArrayLike) -> tuple[FloatArray, FloatArray, bool]:
    """Type, shape and size checks of ``(tau_meas, tau_pred)``; returns the 2-D pair and 1-D flag."""
    t = torque_pair(tau_meas, tau_pred)
    check_min_samples(function, t.meas.shape[0])
    return t.meas, t.pred, t.one_d


def residual_signal(function: str, e: ArrayLike) -> tuple[FloatArray, bool]:
    """Type, shape and size checks of a residual ``e``; returns the 2-D array and 1-D flag."""
    a = to_float_array(e, "e")
    a2 = promote_signal(a, "e")
    check_min_samples(function, a2.shape[0])
    return a2, a.ndim == 1


def _call(function: str, arrays: list[tuple[str, FloatArray, int | None]], nan_policy: object, backend: object,
          segments: object = _NO_SEGMENTS) -> CheckedCall:
    """The parameter step's head, in the contract's order: ``nan_policy``, ``backend``, ``segments``
    (absent for functions without lags), each deferred; then the omission under "omit". The
    function's own parameters follow through ``call.check``."""
    call = CheckedCall(function, arrays)
    call.nan_policy(nan_policy)
    call.resolve_backend(backend, _backend.resolve)
    if segments is not _NO_SEGMENTS:
        call.segments(segments)
    if call.omitting:
        call.omit()
    return call


def _pair_call(function: str, tau_meas: ArrayLike, tau_pred: ArrayLike, nan_policy: object,
               backend: object) -> tuple[CheckedCall, bool]:
    meas, pred, one_d = signal_pair(function, tau_meas, tau_pred)
    call = _call(function, [("tau_meas", meas, None), ("tau_pred", pred, None)], nan_policy, backend)
    return call, one_d


def _residual_call(function: str, e: ArrayLike, nan_policy: object, backend: object,
                   segments: object = _NO_SEGMENTS) -> tuple[CheckedCall, bool]:
    e2, one_d = residual_signal(function, e)
    return _call(function, [("e", e2, None)], nan_policy, backend, segments), one_d


def _out(value: float | FloatArray) -> float | FloatArray:
    """Aggregates as Python float, per-joint values as float64 (m,) arrays."""
    if np.ndim(value) == 0:
        return float(value)
    return np.asarray(value, dtype=np.float64)


def _vec(value: ArrayLike) -> FloatArray:
    """Per-joint values as a float64 (m,) array."""
    return np.asarray(value, dtype=np.float64).reshape(-1)


# --------------------------------------------------------------------------- point metrics


def residuals(tau_meas: ArrayLike, tau_pred: ArrayLike, *, nan_policy: NanPolicy = "raise",
              backend: BackendName | None = None) -> FloatArray:
    """Residuals ``e = tau_meas − tau_pred``.

    Parameters
    ----------
    tau_meas, tau_pred : array_like, (N,) or (N, m)
        Measured and predicted joint torques.
    nan_policy : {"raise", "omit"}
        ``omit`` deletes rows holding a non-finite value.
    backend : {None, "python", "cpp"}

    Returns
    -------
    numpy.ndarray
        ``(N, m)``, or ``(N,)`` when both inputs are 1-D.

    Examples
    --------
    >>> import dynval
    >>> dynval.residuals([1.0, 2.0], [0.5, 2.5])
    array([ 0.5, -0.5])

    A perfect prediction gives zeros; 2-D input keeps its shape:

    >>> dynval.residuals([[1.0], [2.0]], [[1.0], [2.0]])
    array([[0.],
           [0.]])
    """
    call, one_d = _pair_call("residuals", tau_meas, tau_pred, nan_policy, backend)
    e = np.asarray(call.kernel.residuals(*call.pair), dtype=np.float64)
    return e[:, 0].copy() if one_d else e


def _point(function: str, allowed: tuple[str, ...], tau_meas: ArrayLike, tau_pred: ArrayLike, multioutput: object,
           nan_policy: object, backend: object) -> tuple[CheckedCall, str]:
    call, _ = _pair_call(function, tau_meas, tau_pred, nan_policy, backend)
    multioutput = call.check(check_multioutput, multioutput, allowed, function)
    return call, multioutput


def sse(tau_meas: ArrayLike, tau_pred: ArrayLike, *, multioutput: Literal["pooled", "raw_values"] = "pooled",
        nan_policy: NanPolicy = "raise", backend: BackendName | None = None) -> float | FloatArray:
    """Sum of squared errors Σ e².

    Parameters
    ----------
    tau_meas, tau_pred : array_like, (N,) or (N, m)
        Measured and predicted joint torques.
    multioutput : {"pooled", "raw_values"}
        ``pooled`` sums over all joints (float); ``raw_values`` gives SSE_j per joint (m,).
    nan_policy : {"raise", "omit"}
        ``omit`` deletes rows holding a non-finite value.
    backend : {None, "python", "cpp"}
        Computation backend; ``None`` uses the default.

    Returns
    -------
    float or numpy.ndarray
        A float for ``pooled``; ``(m,)`` for ``raw_values``.

    Examples
    --------
    >>> import dynval
    >>> dynval.sse([[1.0, 2.0], [3.0, 4.0]], [[1.0, 1.0], [3.0, 2.0]])
    5.0
    >>> dynval.sse([[1.0, 2.0], [3.0, 4.0]], [[1.0, 1.0], [3.0, 2.0]], multioutput="raw_values")
    array([0., 5.])

    A perfect prediction gives 0:

    >>> dynval.sse([1.0, 2.0], [1.0, 2.0])
    0.0
    """
    call, mo = _point("sse", ("pooled", "raw_values"), tau_meas, tau_pred, multioutput, nan_policy, backend)
    return _out(call.kernel.sse(*call.pair, mo))


def max_abs_error(tau_meas: ArrayLike, tau_pred: ArrayLike, *,
                  multioutput: Literal["pooled", "raw_values"] = "pooled", nan_policy: NanPolicy = "raise",
                  backend: BackendName | None = None) -> float | FloatArray:
    """Largest absolute residual, pooled or per joint.

    Parameters
    ----------
    tau_meas, tau_pred : array_like, (N,) or (N, m)
        Measured and predicted joint torques.
    multioutput : {"pooled", "raw_values"}
        ``pooled`` max over all joints (float); ``raw_values`` the max per joint (m,).
    nan_policy : {"raise", "omit"}
        ``omit`` deletes rows holding a non-finite value.
    backend : {None, "python", "cpp"}
        Computation backend; ``None`` uses the default.

    Returns
    -------
    float or numpy.ndarray
        A float for ``pooled``; ``(m,)`` for ``raw_values``.

    Examples
    --------
    >>> import dynval
    >>> dynval.max_abs_error([1.0, 2.0, 3.0], [1.5, 2.0, 1.0])
    2.0

    A perfect prediction gives 0:

    >>> dynval.max_abs_error([1.0, 2.0], [1.0, 2.0])
    0.0
    """
    call, mo = _point("max_abs_error", ("pooled", "raw_values"), tau_meas, tau_pred, multioutput, nan_policy, backend)
    return _out(call.kernel.max_abs_error(*call.pair, mo))


def rmse(tau_meas: ArrayLike, tau_pred: ArrayLike, *,
         multioutput: Literal["pooled", "raw_values", "uniform_average"] = "pooled",
         convention: Convention | None = None, nan_policy: NanPolicy = "raise",
         backend: BackendName | None = None) -> float | FloatArray:
    """Root mean squared error.

    Parameters
    ----------
    tau_meas, tau_pred : array_like, (N,) or (N, m)
    multioutput : {"pooled", "raw_values", "uniform_average"}
        ``raw_values`` √(SSE_j/N) per joint; ``uniform_average`` their mean (scikit-learn).
    convention : {None, "per_element", "per_sample"}
        Only with ``pooled``: ``per_element`` (default) √(SSE/(N·m)), the lesson's formula;
        ``per_sample`` √(SSE/N), the lesson's code. The two agree for one joint.
    nan_policy : {"raise", "omit"}
        ``omit`` deletes rows holding a non-finite value.
    backend : {None, "python", "cpp"}
        Computation backend; ``None`` uses the default.

    Returns
    -------
    float or numpy.ndarray
        A float for ``pooled`` and ``uniform_average``; ``(m,)`` for ``raw_values``.

    Examples
    --------
    >>> import dynval
    >>> dynval.rmse([[1.0, 1.0], [1.0, 1.0]], [[0.0, 0.0], [0.0, 0.0]], convention="per_sample")
    1.4142135623730951
    >>> dynval.rmse([[1.0, 1.0], [1.0, 1.0]], [[0.0, 0.0], [0.0, 0.0]])
    1.0

    An exact fit (SSE = 0) gives 0 (contract §3.2):

    >>> dynval.rmse([1.0, 2.0, 3.0], [1.0, 2.0, 3.0])
    0.0
    """
    call, mo = _point("rmse", ("pooled", "raw_values", "uniform_average"), tau_meas, tau_pred, multioutput, nan_policy,
                      backend)
    conv = call.check(check_convention, convention, mo)
    return _out(call.kernel.rmse(*call.pair, mo, conv))


def vaf(tau_meas: ArrayLike, tau_pred: ArrayLike, *, multioutput: MultiOutput = "pooled",
        nan_policy: NanPolicy = "raise", backend: BackendName | None = None) -> float | FloatArray:
    """Variance accounted for, in percent: 100(1 − var(e)/var(τ)).

    Parameters
    ----------
    tau_meas, tau_pred : array_like, (N,) or (N, m)
        Measured and predicted joint torques.
    multioutput : {"pooled", "raw_values", "uniform_average", "variance_weighted"}
        ``pooled`` all N·m values with one mean; ``raw_values`` per joint (m,); the averages as
        scikit-learn's ``explained_variance_score``.
    nan_policy : {"raise", "omit"}
        ``omit`` deletes rows holding a non-finite value.
    backend : {None, "python", "cpp"}
        Computation backend; ``None`` uses the default.

    Returns
    -------
    float or numpy.ndarray
        VAF in percent: a float, or ``(m,)`` for ``raw_values``.

    Notes
    -----
    A constant target gives ``-inf``, or ``nan`` when the residual is constant too (§3.2).

    Examples
    --------
    >>> import dynval
    >>> round(dynval.vaf([1.0, 2.0, 3.0, 4.0], [1.1, 1.9, 3.1, 3.9]), 6)
    99.2

    A constant target gives ``-inf``, or ``nan`` when the residual is constant too:

    >>> dynval.vaf([2.0, 2.0, 2.0], [1.0, 2.0, 3.0])
    -inf
    >>> dynval.vaf([2.0, 2.0, 2.0], [1.5, 1.5, 1.5])
    nan
    """
    call, mo = _point("vaf", MULTIOUTPUT_OPTIONS, tau_meas, tau_pred, multioutput, nan_policy, backend)
    return _out(call.kernel.vaf(*call.pair, mo))


def fit_percent(tau_meas: ArrayLike, tau_pred: ArrayLike, *, multioutput: MultiOutput = "pooled",
                nan_policy: NanPolicy = "raise", backend: BackendName | None = None) -> float | FloatArray:
    """Normalised fit, in percent: 100(1 − √(SSE/TSS)) (= 100(1 − √(1 − R²))).

    Parameters
    ----------
    tau_meas, tau_pred : array_like, (N,) or (N, m)
        Measured and predicted joint torques.
    multioutput : {"pooled", "raw_values", "uniform_average", "variance_weighted"}
        ``pooled`` all N·m values with one mean; ``raw_values`` per joint (m,); the averages as
        for :func:`r2`.
    nan_policy : {"raise", "omit"}
        ``omit`` deletes rows holding a non-finite value.
    backend : {None, "python", "cpp"}
        Computation backend; ``None`` uses the default.

    Returns
    -------
    float or numpy.ndarray
        Fit in percent: a float, or ``(m,)`` for ``raw_values``.

    Examples
    --------
    >>> import dynval
    >>> dynval.fit_percent([0.0, 2.0], [0.0, 2.0])
    100.0

    A constant target gives ``-inf``, or ``nan`` for an exact prediction (contract §3.2):

    >>> dynval.fit_percent([2.0, 2.0, 2.0], [1.0, 2.0, 3.0])
    -inf
    >>> dynval.fit_percent([2.0, 2.0, 2.0], [2.0, 2.0, 2.0])
    nan
    """
    call, mo = _point("fit_percent", MULTIOUTPUT_OPTIONS, tau_meas, tau_pred, multioutput, nan_policy, backend)
    return _out(call.kernel.fit_percent(*call.pair, mo))


def r2(tau_meas: ArrayLike, tau_pred: ArrayLike, *, multioutput: MultiOutput = "pooled",
       nan_policy: NanPolicy = "raise", backend: BackendName | None = None) -> float | FloatArray:
    """Coefficient of determination 1 − SSE/TSS (a fraction).

    ``pooled`` uses all N·m values with one global mean (the lesson); ``raw_values``,
    ``uniform_average`` and ``variance_weighted`` match scikit-learn's ``r2_score``.

    Parameters
    ----------
    tau_meas, tau_pred : array_like, (N,) or (N, m)
        Measured and predicted joint torques.
    multioutput : {"pooled", "raw_values", "uniform_average", "variance_weighted"}
        ``variance_weighted`` gives constant joints weight 0.
    nan_policy : {"raise", "omit"}
        ``omit`` deletes rows holding a non-finite value.
    backend : {None, "python", "cpp"}
        Computation backend; ``None`` uses the default.

    Returns
    -------
    float or numpy.ndarray
        A float, or ``(m,)`` for ``raw_values``.

    Examples
    --------
    >>> import dynval
    >>> dynval.r2([1.0, 2.0, 3.0], [1.0, 2.0, 4.0])
    0.5

    A constant target gives ``-inf``, or ``nan`` for an exact prediction (IEEE values, contract
    §3.2; ``validate(..., profile="sklearn")`` gives 0.0 / 1.0 instead, scikit-learn's
    ``force_finite``):

    >>> dynval.r2([2.0, 2.0, 2.0], [1.0, 2.0, 3.0])
    -inf
    >>> dynval.r2([2.0, 2.0, 2.0], [2.0, 2.0, 2.0])
    nan
    >>> tau = [[1.0, 2.0], [2.0, 2.0], [3.0, 2.0]]          # joint 2 is constant
    >>> pred = [[1.0, 2.0], [2.5, 1.0], [3.0, 2.0]]
    >>> dynval.r2(tau, pred, multioutput="raw_values")
    array([0.875, -inf])
    >>> dynval.r2(tau, pred, multioutput="variance_weighted")
    0.875
    """
    call, mo = _point("r2", MULTIOUTPUT_OPTIONS, tau_meas, tau_pred, multioutput, nan_policy, backend)
    return _out(call.kernel.r2(*call.pair, mo))


# --------------------------------------------------------------------------- residual statistics


def residual_mean(e: ArrayLike, *, nan_policy: NanPolicy = "raise", backend: BackendName | None = None) -> FloatArray:
    """Mean of the residual of each joint, ``(m,)``.

    Parameters
    ----------
    e : array_like, (N,) or (N, m)
        Residuals.
    nan_policy : {"raise", "omit"}
        ``omit`` deletes rows holding a non-finite value.
    backend : {None, "python", "cpp"}
        Computation backend; ``None`` uses the default.

    Returns
    -------
    numpy.ndarray
        ``(m,)``, also for 1-D ``e``.

    Examples
    --------
    >>> import dynval
    >>> dynval.residual_mean([[1.0, 0.0], [3.0, 1.0]])
    array([2. , 0.5])

    One sample (the minimum, N = 1) is its own mean:

    >>> dynval.residual_mean([0.5])
    array([0.5])
    """
    call, _ = _residual_call("residual_mean", e, nan_policy, backend)
    return _vec(call.kernel.residual_mean(call.data[0]))


def residual_variance(e: ArrayLike, *, ddof: Integer = 1, nan_policy: NanPolicy = "raise",
                      backend: BackendName | None = None) -> FloatArray:
    """Variance of the residual of each joint, Σ(e − ē_j)²/(N − ddof), ``(m,)``.

    Parameters
    ----------
    e : array_like, (N,) or (N, m)
        Residuals.
    ddof : int
        Delta degrees of freedom, ``0 <= ddof < N``.
    nan_policy : {"raise", "omit"}
        ``omit`` deletes rows holding a non-finite value.
    backend : {None, "python", "cpp"}
        Computation backend; ``None`` uses the default.

    Returns
    -------
    numpy.ndarray
        ``(m,)``, also for 1-D ``e``.

    Examples
    --------
    >>> import dynval
    >>> dynval.residual_variance([1.0, 2.0, 3.0])
    array([1.])
    >>> dynval.residual_variance([1.0, 2.0, 3.0], ddof=0)
    array([0.66666667])

    A constant residual has zero variance:

    >>> dynval.residual_variance([3.0, 3.0, 3.0])
    array([0.])
    """
    call, _ = _residual_call("residual_variance", e, nan_policy, backend)
    ddof = call.check(check_ddof, ddof, call.n)
    return _vec(call.kernel.residual_variance(call.data[0], ddof))


# Below this largest |e| of a joint, its squares leave float64's normal range (2^-400 squared is
# 2^-800, the kernels' threshold for rescaling a sum of squares).
_TINY_MAGNITUDE = 2.0**-400


def _tiny_exponents(e2: np.ndarray) -> np.ndarray:
    """Per column: k with max|e_j|·2^-k in [0.5, 1) where max|e_j| is below 2^-400, else 0."""
    largest = np.max(np.abs(e2), axis=0)
    k = np.frexp(largest)[1].astype(np.int64)
    return np.where((largest > 0) & (largest < _TINY_MAGNITUDE), k, 0)


def zero_mean_test(e: ArrayLike, *, segments: SegmentsLike = None, nan_policy: NanPolicy = "raise",
                   backend: BackendName | None = None) -> ZeroMeanTest:
    """Test whether each joint's residual has zero mean.

    Gives the i.i.d. Student t-test (as ``scipy.stats.ttest_1samp(e, 0)``) and a test
    corrected for autocorrelation (Newey–West/Bartlett weights, effective sample size N_eff),
    which is the one to read: robot residuals are autocorrelated and the i.i.d. p-value is
    overconfident.

    Parameters
    ----------
    e : array_like, (N,) or (N, m)
        Residuals.
    segments : None or sequence of int
        Lengths or starts of concatenated records (no lagged product joins two).
    nan_policy : {"raise", "omit"}
    backend : {None, "python", "cpp"}

    Returns
    -------
    ZeroMeanTest

    Examples
    --------
    >>> import dynval
    >>> res = dynval.zero_mean_test([0.1, -0.2, 0.15, -0.05, 0.0, 0.02])
    >>> res.df_iid
    5

    Zero residual variance gives a statistic of ``±inf`` (mean ≠ 0, p-value 0), or ``nan``
    (mean = 0, p-value nan) (contract §3.2); ``n_eff`` is then N:

    >>> res = dynval.zero_mean_test([0.5, 0.5, 0.5])
    >>> res.statistic_iid, res.pvalue_iid, res.n_eff
    (array([inf]), array([0.]), array([3.]))
    >>> dynval.zero_mean_test([0.0, 0.0, 0.0]).pvalue_eff
    array([nan])
    """
    call, _ = _residual_call("zero_mean_test", e, nan_policy, backend, segments)
    return checked_zero_mean_test(call.data[0], call.kernel, call.starts, call.limit)


def checked_zero_mean_test(e2: FloatArray, kernel: Kernels, starts: IntArray, longest: int) -> ZeroMeanTest:
    """:func:`zero_mean_test` of a residual already checked: (N, m) finite float64, the backend's
    kernels, the segments' starts and the longest segment's length (``validate`` has checked them
    once for all its sections)."""
    n = int(e2.shape[0])
    # The t statistics are ratios: they are computed on e scaled by a power of two per joint
    # (exact), so a residual near 1e-160, whose variance underflows, keeps them (contract §1.3).
    exps = _tiny_exponents(e2)
    scaled = np.ldexp(e2, -exps) if exps.any() else e2
    mean = _vec(kernel.residual_mean(scaled))
    std = np.sqrt(_vec(kernel.residual_variance(scaled, 1)))
    k = newey_west_bandwidth(n)
    # Lags past the longest segment have no products: their ρ̂ is 0 and adds nothing.
    k_used = min(k, longest - 1)
    rho = np.asarray(kernel.autocorrelation(e2, k_used, False, starts), dtype=np.float64)
    n_eff = newey_west_n_eff(rho, k, n)
    t_iid, p_iid = iid_t_test(mean, std, n)
    t_eff, p_eff = iid_t_test(mean, std, n_eff)
    return ZeroMeanTest(
        mean=np.ldexp(mean, exps),
        std=np.ldexp(std, exps),
        n_samples=n,
        statistic_iid=t_iid,
        pvalue_iid=p_iid,
        df_iid=n - 1,
        statistic_eff=t_eff,
        pvalue_eff=p_eff,
        df_eff=n_eff - 1.0,
        n_eff=n_eff,
        bandwidth=k,
    )


# --------------------------------------------------------------------------- correlation


def autocorrelation(e: ArrayLike, max_lag: Integer, *, adjusted: bool = True, segments: SegmentsLike = None,
                    nan_policy: NanPolicy = "raise", backend: BackendName | None = None) -> FloatArray:
    """Normalised autocorrelation ρ̂(ℓ) = R̂(ℓ)/R̂(0) of the residual, ℓ = 0..max_lag.

    Parameters
    ----------
    e : array_like, (N,) or (N, m)
        Residuals.
    max_lag : int
        Largest lag, below the longest segment.
    adjusted : bool
        ``True`` (the lesson): R̂(ℓ) divides by the number of products n_ℓ; ``False`` (biased:
        NIST StRD, R, statsmodels' default): by N at every lag.
    segments : None or sequence of int
    nan_policy : {"raise", "omit"}
    backend : {None, "python", "cpp"}

    Returns
    -------
    numpy.ndarray
        ``(max_lag+1,)`` for 1-D ``e``, else ``(max_lag+1, m)``. A constant residual gives nan.

    Examples
    --------
    >>> import dynval
    >>> dynval.autocorrelation([1.0, -1.0, 1.0, -1.0], 1, adjusted=False)
    array([ 1.  , -0.75])

    A constant residual gives ``nan`` at every lag, lag 0 included (contract §3.2):

    >>> dynval.autocorrelation([1.0, 1.0, 1.0, 1.0], 2)
    array([nan, nan, nan])
    """
    call, one_d = _residual_call("autocorrelation", e, nan_policy, backend, segments)
    max_lag = call.check(check_max_lag, max_lag, call.limit)
    adjusted = call.check(check_adjusted, adjusted)
    rho = np.asarray(call.kernel.autocorrelation(call.data[0], max_lag, adjusted, call.starts), dtype=np.float64)
    return rho[:, 0].copy() if one_d else rho


def confidence_band(n: Integer, *, level: float = 0.95, backend: BackendName | None = None) -> float:
    """Half-width z/√n of the white-noise band, z = Φ⁻¹((1 + level)/2).

    Parameters
    ----------
    n : int
        Number of samples, ``n >= 1``.
    level : float
        Confidence level, ``0 < level < 1``.
    backend : {None, "python", "cpp"}
        Checked only; the value does not depend on it.

    Returns
    -------
    float
        The band's half-width.

    Examples
    --------
    >>> import dynval
    >>> round(dynval.confidence_band(100), 6)
    0.195996

    With one sample the band is z itself:

    >>> round(dynval.confidence_band(1), 6)
    1.959964
    """
    _backend.resolve(backend)
    n = check_n(n)
    level = check_level(level)
    return z_two_sided(level) / math.sqrt(n)


def _portmanteau(function: str, e: ArrayLike, lags: LagsLike, model_df: Integer, segments: SegmentsLike,
                 nan_policy: NanPolicy, backend: BackendName | None) -> PortmanteauTest:
    call, _ = _residual_call(function, e, nan_policy, backend, segments)
    lag_array = call.check(check_lags, lags, call.limit)
    model_df = call.check(check_model_df, model_df, int(lag_array.min()))
    out = call.kernel.portmanteau(call.data[0], lag_array, model_df, call.starts, function)
    return PortmanteauTest(
        test=function,
        lags=lag_array,
        model_df=model_df,
        statistic=np.asarray(out["statistic"], dtype=np.float64),
        pvalue=np.asarray(out["pvalue"], dtype=np.float64),
        log_pvalue=np.asarray(out["log_pvalue"], dtype=np.float64),
        df=np.asarray(out["df"], dtype=np.int64),
    )


def ljung_box(e: ArrayLike, lags: LagsLike, *, model_df: Integer = 0, segments: SegmentsLike = None,
              nan_policy: NanPolicy = "raise", backend: BackendName | None = None) -> PortmanteauTest:
    """Ljung–Box test Q(h) = N(N+2) Σ_{ℓ≤h} ρ̂_ℓ²/n_ℓ on the biased autocorrelation.

    Parameters
    ----------
    e : array_like, (N,) or (N, m)
    lags : int or sequence of int
        One statistic per entry, in the given order.
    model_df : int
        Degrees of freedom used by the model; df = h − model_df must be >= 1.
    segments, nan_policy, backend : as in :func:`autocorrelation`.

    Returns
    -------
    PortmanteauTest
        ``log_pvalue`` stays accurate where ``pvalue`` underflows (real robot residuals).

    Examples
    --------
    >>> import dynval
    >>> res = dynval.ljung_box([1.0, -1.0, 1.0, -1.0, 1.0, -1.0], 1)
    >>> res.df.tolist()
    [1]

    A constant residual gives a ``nan`` statistic and p-value (contract §3.2):

    >>> res = dynval.ljung_box([1.0, 1.0, 1.0, 1.0], 1)
    >>> res.statistic, res.pvalue
    (array([[nan]]), array([[nan]]))
    """
    return _portmanteau("ljung_box", e, lags, model_df, segments, nan_policy, backend)


def box_pierce(e: ArrayLike, lags: LagsLike, *, model_df: Integer = 0, segments: SegmentsLike = None,
               nan_policy: NanPolicy = "raise", backend: BackendName | None = None) -> PortmanteauTest:
    """Box–Pierce test Q(h) = N Σ_{ℓ≤h} ρ̂_ℓ²; arguments as :func:`ljung_box`.

    Parameters
    ----------
    e : array_like, (N,) or (N, m)
        Residuals.
    lags : int or sequence of int
        One statistic per entry, in the given order.
    model_df : int
        Degrees of freedom used by the model; df = h − model_df must be >= 1.
    segments, nan_policy, backend : as in :func:`autocorrelation`.

    Returns
    -------
    PortmanteauTest
        ``statistic``, ``pvalue``, ``log_pvalue`` ``(n_lags, m)``; ``lags``, ``df`` ``(n_lags,)``.

    Examples
    --------
    >>> import dynval
    >>> float(dynval.box_pierce([1.0, -1.0, 1.0, -1.0], 1).statistic[0, 0])
    2.25

    A constant residual gives a ``nan`` statistic and p-value (contract §3.2):

    >>> dynval.box_pierce([1.0, 1.0, 1.0, 1.0], 1).pvalue
    array([[nan]])
    """
    return _portmanteau("box_pierce", e, lags, model_df, segments, nan_policy, backend)


def cross_correlation(
    e: ArrayLike,
    Y: ArrayLike,
    max_lag: Integer,
    *,
    n_joints: Integer | None = None,
    adjusted: bool = True,
    level: float = 0.95,
    segments: SegmentsLike = None,
    nan_policy: NanPolicy = "raise",
    backend: BackendName | None = None,
) -> CrossCorrelation:
    """Cross-correlation of each joint's residual with that joint's regressor columns.

    Parameters
    ----------
    e : array_like, (N,) or (N, m)
        Residuals.
    Y : array_like, (N, m, p), or (N*m, p) stacked sample-major with ``n_joints=m``
        Regressor (row k·m + j of the stacked form is sample k, joint j).
    max_lag : int
        Lags 0..max_lag; ℓ pairs e at sample k with Y at sample k − ℓ.
    n_joints : int, optional
        Required for the stacked form.
    adjusted : bool
        Denominator n_ℓ (True) or N (False) of the lagged sums.
    level : float
        Confidence level of the band z/√N.
    segments, nan_policy, backend : as in :func:`autocorrelation`.

    Returns
    -------
    CrossCorrelation

    Examples
    --------
    >>> import numpy as np, dynval
    >>> e = np.array([1.0, -1.0, 2.0, 0.0])
    >>> Y = np.array([[1.0], [-1.0], [2.0], [0.0]])[:, None, :]
    >>> round(float(dynval.cross_correlation(e, Y, 0).rho[0, 0, 0]), 12)  # e against itself
    1.0

    A regressor column constant on a joint gives ``nan`` and is marked in ``constant_mask``
    (contract §3.2):

    >>> Y2 = np.concatenate([Y, np.full((4, 1, 1), 5.0)], axis=2)
    >>> res = dynval.cross_correlation(e, Y2, 0)
    >>> res.rho[0, :, 0], res.constant_mask
    (array([ 1., nan]), array([[False,  True]]))
    """
    e_arr = to_float_array(e, "e")
    y_arr = to_float_array(Y, "regressor")
    e2 = promote_signal(e_arr, "e")
    n, m = e2.shape
    p = regressor_shape(y_arr, "e", n, m, n_joints)
    check_min_samples("cross_correlation", n)
    y2 = regressor_to_2d(y_arr, n, m, p)
    call = _call("cross_correlation", [("e", e2, None), ("regressor", y2, p)], nan_policy, backend, segments)
    max_lag = call.check(check_max_lag, max_lag, call.limit)
    call.check(check_n_joints, n_joints, y_arr.shape[0], m, y_arr.ndim == 3)
    adjusted = call.check(check_adjusted, adjusted)
    level = call.check(check_level, level)
    out = call.kernel.cross_correlation(call.data[0], call.data[1], p, max_lag, adjusted, call.starts)
    rho = np.asarray(out["rho"], dtype=np.float64).reshape(m, p, max_lag + 1)
    mask = np.asarray(out["constant_mask"], dtype=bool).reshape(m, p)
    band = z_two_sided(level) / math.sqrt(call.n)
    with np.errstate(invalid="ignore"):
        hits = np.argwhere(np.abs(rho) > band)
    outside = [
        (int(j), int(c), int(lag), float(rho[j, c, lag]), float(abs(rho[j, c, lag]) / band)) for j, c, lag in hits
    ]
    outside.sort(key=lambda t: (-t[4], t[0], t[1], t[2]))
    return CrossCorrelation(rho=rho, constant_mask=mask, band=band, level=level, outside=outside)


# --------------------------------------------------------------------------- information criteria


def information_criteria(rss: float, n_obs: Integer, n_params: Integer, *,
                         backend: BackendName | None = None) -> InformationCriteria:
    """AIC, BIC, AICc, FPE and nAIC from a residual sum of squares (constants dropped).

    σ̂² = rss/n; aic = 2p + n·ln σ̂²; bic = p·ln n + n·ln σ̂²; aicc = aic + 2p(p+1)/(n − p − 1);
    fpe = σ̂²(1 + p/n)/(1 − p/n); naic = ln σ̂² + 2p/n. Requires p < n − 1.

    Parameters
    ----------
    rss : float
        Residual sum of squares, finite and ``>= 0``.
    n_obs : int
        Number of observations n, ``>= 1``.
    n_params : int
        Number of parameters p, ``0 <= p < n − 1``.
    backend : {None, "python", "cpp"}
        Computation backend; ``None`` uses the default.

    Returns
    -------
    InformationCriteria
        ``aic``, ``bic``, ``aicc``, ``fpe``, ``naic`` (floats), ``noise_model="pooled"``.

    Raises
    ------
    InvalidParameter
        If p >= n − 1 (aicc and fpe are undefined there), or another argument is out of range.

    Examples
    --------
    >>> import dynval
    >>> round(dynval.information_criteria(10.0, 1000, 6).aic, 6)
    -4593.170186

    A zero residual gives ``-inf`` for aic, bic and aicc, and fpe = 0 (contract §3.2):

    >>> ic = dynval.information_criteria(0.0, 10, 2)
    >>> ic.aic, ic.bic, ic.aicc, ic.fpe
    (-inf, -inf, -inf, 0.0)
    """
    _, kernel = _backend.resolve(backend)
    rss = check_rss(rss)
    n_obs = check_n_obs(n_obs)
    n_params = check_n_params(n_params, n_obs)
    out = kernel.information_criteria(rss, n_obs, n_params)
    return InformationCriteria(
        aic=float(out["aic"]),
        bic=float(out["bic"]),
        aicc=float(out["aicc"]),
        fpe=float(out["fpe"]),
        naic=float(out["naic"]),
        n_obs=n_obs,
        n_params=n_params,
        noise_model="pooled",
    )


def criteria(tau_meas: ArrayLike, tau_pred: ArrayLike, *, n_params: Integer, noise_model: NoiseModel = "pooled",
             nan_policy: NanPolicy = "raise", backend: BackendName | None = None) -> InformationCriteria:
    """Information criteria of a model's residuals under an explicit noise model.

    Parameters
    ----------
    tau_meas, tau_pred : array_like, (N,) or (N, m)
    n_params : int
        Number of identified parameters p (always given; there is no default).
    noise_model : {"pooled", "per_joint", "full"}
        ``pooled`` one σ² for all N·m values (the lesson); ``per_joint`` one σ² per joint;
        ``full`` a full m×m covariance (MATLAB's multi-output AIC).
    nan_policy : {"raise", "omit"}
    backend : {None, "python", "cpp"}

    Returns
    -------
    InformationCriteria
        aicc and fpe are nan when p >= n − 1.

    Examples
    --------
    >>> import dynval
    >>> ic = dynval.criteria([1.0, 2.0, 3.0, 4.0], [1.1, 1.9, 3.1, 3.9], n_params=1)
    >>> ic.n_obs
    4

    SSE = 0 gives ``-inf`` and fpe = 0; p >= n − 1 gives ``nan`` for aicc and fpe, also when
    the residual is zero (contract §3.2, §3.7):

    >>> ic = dynval.criteria([1.0, 2.0, 3.0], [1.0, 2.0, 3.0], n_params=1)
    >>> ic.aic, ic.aicc, ic.fpe
    (-inf, -inf, 0.0)
    >>> ic = dynval.criteria([1.0, 2.0, 3.0], [1.0, 2.0, 3.0], n_params=2)
    >>> ic.aic, ic.aicc, ic.fpe
    (-inf, nan, nan)
    """
    call, _ = _pair_call("criteria", tau_meas, tau_pred, nan_policy, backend)
    n_params = call.check(check_n_params, n_params)
    nm = call.check(check_noise_model, noise_model)
    out = call.kernel.criteria(*call.pair, n_params, nm)
    return InformationCriteria(
        aic=float(out["aic"]),
        bic=float(out["bic"]),
        aicc=float(out["aicc"]),
        fpe=float(out["fpe"]),
        naic=float(out["naic"]),
        n_obs=int(out["n_obs"]),
        n_params=n_params,
        noise_model=nm,
    )


def _criterion(function: str, field: str, tau_meas: ArrayLike, tau_pred: ArrayLike, n_params: Integer,
               noise_model: object, nan_policy: object, backend: object) -> float:
    call, _ = _pair_call(function, tau_meas, tau_pred, nan_policy, backend)
    n_params = call.check(check_n_params, n_params)
    noise_model = call.check(check_noise_model, noise_model)
    return float(call.kernel.criteria(*call.pair, n_params, noise_model)[field])


def aic(tau_meas: ArrayLike, tau_pred: ArrayLike, *, n_params: Integer, noise_model: NoiseModel = "pooled",
        nan_policy: NanPolicy = "raise", backend: BackendName | None = None) -> float:
    """Akaike information criterion (constant dropped); see :func:`criteria`.

    Parameters
    ----------
    tau_meas, tau_pred : array_like, (N,) or (N, m)
        Measured and predicted joint torques.
    n_params : int
        Number of identified parameters p (always given; there is no default).
    noise_model : {"pooled", "per_joint", "full"}
        As in :func:`criteria`.
    nan_policy : {"raise", "omit"}
        ``omit`` deletes rows holding a non-finite value.
    backend : {None, "python", "cpp"}
        Computation backend; ``None`` uses the default.

    Returns
    -------
    float
        F + 2p, F the noise model's fit term.

    Examples
    --------
    >>> import dynval
    >>> round(dynval.aic([1.0, 2.5, 3.2, 4.1, 4.8, 6.1], [1.1, 2.4, 3.0, 4.3, 4.7, 6.0], n_params=2), 9)
    -19.472138033

    SSE = 0 (pooled), or any joint's SSE_j = 0 (per_joint), gives ``-inf`` (contract §3.2):

    >>> dynval.aic([1.0, 2.0, 3.0], [1.0, 2.0, 3.0], n_params=1)
    -inf
    >>> dynval.aic([[1.0, 2.0], [2.0, 3.0], [3.0, 5.0]], [[1.0, 2.1], [2.0, 3.0], [3.0, 5.0]],
    ...            n_params=1, noise_model="per_joint")
    -inf
    """
    return _criterion("aic", "aic", tau_meas, tau_pred, n_params, noise_model, nan_policy, backend)


def bic(tau_meas: ArrayLike, tau_pred: ArrayLike, *, n_params: Integer, noise_model: NoiseModel = "pooled",
        nan_policy: NanPolicy = "raise", backend: BackendName | None = None) -> float:
    """Bayesian information criterion (constant dropped); see :func:`criteria`.

    Parameters
    ----------
    tau_meas, tau_pred : array_like, (N,) or (N, m)
        Measured and predicted joint torques.
    n_params : int
        Number of identified parameters p (always given; there is no default).
    noise_model : {"pooled", "per_joint", "full"}
        As in :func:`criteria`.
    nan_policy : {"raise", "omit"}
        ``omit`` deletes rows holding a non-finite value.
    backend : {None, "python", "cpp"}
        Computation backend; ``None`` uses the default.

    Returns
    -------
    float
        F + p·ln n, F the noise model's fit term.

    Examples
    --------
    >>> import dynval
    >>> round(dynval.bic([1.0, 2.5, 3.2, 4.1, 4.8, 6.1], [1.1, 2.4, 3.0, 4.3, 4.7, 6.0], n_params=2), 9)
    -19.888619094

    SSE = 0, or a numerically singular Σ̂ (full), gives ``-inf`` (contract §3.2):

    >>> dynval.bic([1.0, 2.0, 3.0], [1.0, 2.0, 3.0], n_params=1)
    -inf
    >>> dynval.bic([[1.0, 2.0], [2.0, 4.0], [3.0, 6.5]], [[1.0, 2.0], [2.1, 4.2], [3.0, 6.5]],
    ...            n_params=1, noise_model="full")
    -inf
    """
    return _criterion("bic", "bic", tau_meas, tau_pred, n_params, noise_model, nan_policy, backend)
