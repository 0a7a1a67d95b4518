"""Missing physics named without its column: the residual against a library of physical terms.

A user validates a model because they do not know what it lacks, so the column of the missing
term is usually not in the regressor they hand over. The joint positions are: from q (and q̇, q̈,
given or derived with a stated bandwidth) this module builds, for each joint j, the terms that
robot dynamics is made of (docs/conventions.md §5.2):

* ``coulomb``: sign(q̇_j), tanh(q̇_j/v) at three velocity scales and a Stribeck term
  sign(q̇_j)·exp(−(q̇_j/v_s)²) (an asymmetric friction is Coulomb plus ``offset``);
* ``viscous``: q̇_j; ``velocity_squared``: q̇_j|q̇_j|;
* ``gravity``: sin and cos of q_i + … + q_k for every chain i ≤ j ≤ k (a planar sub-chain's link
  angle; coupled links show on every joint before them); ``position_harmonic``: sin/cos of 2q_j and
  3q_j (cogging, a gravity term of a link with two CoMs);
* ``inertia``: q̈_k of every joint (a payload, a wrong link inertia);
* ``offset``: 1; ``drift``: t and t² (a sensor that drifts over the run);

A delay of the measured torque behind the encoders is not a missing term: :func:`delay_test`
shifts the prediction (one shift for every joint, sub-sample, linear interpolation) to the lag that
best aligns it and reports the share of each joint's mean square the realignment removes, with the
joint's prewhitened test of the residual against −τ̂' (τ(t − d) ≈ τ(t) − d τ'(t)).

The model's own columns (its regressor when given, else its prediction) are nuisance terms: what
they can represent is not missing. The test is one Wald test per joint of every library term
together, after prewhitening by an AR(p) model of the residual (feasible GLS, p by BIC) and with a
heteroscedasticity-robust covariance (HC1), so coloured and heteroscedastic noise keep the size.
Terms that interact are refitted together: groups enter by forward selection on the whitened
problem, and the term named is the selected group with the largest share of the joint's mean square
once the others are in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..kernels._threads import thread_map

if TYPE_CHECKING:
    import scipy.linalg
    import scipy.signal
    import scipy.special
    import scipy.stats
else:
    from .._lazy import scipy

__all__ = ["GROUPS", "LABELS", "PhysicsTest", "derivatives", "library", "physics_test", "delay_test",
           "name_group"]

GROUPS = ("coulomb", "viscous", "velocity_squared", "gravity", "position_harmonic", "inertia", "offset",
          "drift")
LABELS = {
    "coulomb": "Coulomb friction",
    "viscous": "viscous friction",
    "velocity_squared": "a velocity-squared (q̇|q̇|) drag term",
    "gravity": "a position-dependent term of the link angles (gravity, or a torque that depends on the posture)",
    "position_harmonic": "a position harmonic (cogging, or gravity of an unmodelled link)",
    "inertia": "an inertial term (a payload or a wrong link inertia)",
    "offset": "a torque offset (sensor bias, or asymmetric friction)",
    "drift": "a drift over the run (sensor drift, temperature)",
    "delay": "a delay of the measured torque behind the prediction",
}
# AR(≤ 2) prewhitening, fitted on the residual as given. A model of what the library leaves would be
# too white (twenty smooth columns absorb the slow part of AR(1) 0.9 noise: 10–25 % false alarms at
# p < 0.01, measured); a higher order would take a missing term's own shape for colour.
_MAX_AR = 2
_OUTSIDE = 0.01
_PARSIMONY = 0.8
_LEFT_RATIO, _LEFT_SLACK = 1.5, 0.01
_MAX_ROWS = 40_000  # longer runs are decimated by a whole factor (anti-aliased) before the test
# Decimation to the information band (conventions §5.2): the band's edge at most 1/_MARGIN of the new
# Nyquist frequency (a Coulomb step's content above the band is what is lost), at least _MIN_ROWS
# rows kept; _EDGE rows at each end of the decimated log dropped (the filter's half length, 10 rows).
_MARGIN = 4.0
_MIN_ROWS = 4_000
_EDGE = 10


@dataclass(frozen=True)
class Derivatives:
    dq: np.ndarray
    ddq: np.ndarray
    method: str
    bandwidth_hz: float | None


def derivatives(q, sample_rate, dq=None, ddq=None) -> Derivatives:
    """q̇ and q̈ as given, or by zero-phase Savitzky–Golay differentiation of q (0.1 s window).
    A joint at rest (q constant) has derived q̇ and q̈ of exactly zero: the filter's rounding
    noise would otherwise be scaled to unit RMS by the library and tested as motion."""
    if dq is not None and ddq is not None:
        return Derivatives(np.asarray(dq, float), np.asarray(ddq, float), "given", None)
    d = _derived(q, sample_rate, dq, ddq)
    rest = [j for j in range(q.shape[1]) if np.ptp(q[:, j]) == 0]
    if not rest:
        return d
    for x, given in ((d.dq, dq), (d.ddq, ddq)):
        if given is None:
            x[:, rest] = 0.0
    joints = ", ".join(str(j + 1) for j in rest)
    return Derivatives(d.dq, d.ddq, f"{d.method}; joint{'s' if len(rest) > 1 else ''} {joints} at rest (q constant): "
                       "no velocity or acceleration of theirs tested", d.bandwidth_hz)


def _derived(q, sample_rate, dq, ddq) -> Derivatives:
    """q̇ and q̈ derived where not given (the filter, or central differences on short runs)."""
    from ._derivatives import checked_differentiate

    fs = 1.0 if sample_rate is None else float(sample_rate)
    n = q.shape[0]
    window = max(0.1, 7.0 / fs)
    if n < int(round(window * fs)) + 2:
        d1 = np.gradient(q, 1.0 / fs, axis=0)
        return Derivatives(d1 if dq is None else np.asarray(dq, float),
                           np.gradient(d1, 1.0 / fs, axis=0) if ddq is None else np.asarray(ddq, float),
                           "central differences", None)
    # q checked by the caller (validate, the stream); its smoothed positions are not read here, and
    # the derivatives' interior is convolved by FFT (the same filter to rounding)
    d = checked_differentiate(q, fs, window=window, positions=False, by_fft=True)
    return Derivatives(d.dq if dq is None else np.asarray(dq, float),
                       d.ddq if ddq is None else np.asarray(ddq, float),
                       f"Savitzky–Golay, {window:g} s window, degree 4", float(d.bandwidth_hz))


def _scale(x):
    s = float(np.sqrt(np.mean(x * x))) if x.size else 0.0
    return s if s > 0 and math.isfinite(s) else 1.0


def library(j: int, q, dq, ddq, pred_j, sample_rate, *, velocity_scale=None,
            row_index=None, chains=None, only=None, column_major=False) -> dict[str, np.ndarray]:
    """The library's columns for joint j, by group (each (N, k), unit RMS); q may be None.

    A stream's chunk (:mod:`._physics_stream`) gives ``velocity_scale`` (the Coulomb shapes' scale,
    fixed on its first block) and ``row_index`` (the rows' place in the log, scaled): the columns are
    then left unscaled and the drift is (u, u²) of that index, which the stream maps linearly to
    the in-memory columns once the log's length and each column's RMS are known. ``chains``: a dict
    shared by the joints' calls on the same rows, which keeps each chain's sin and cos (a chain
    i ≤ j ≤ k is in every joint j between: 28 chains of 7 joints computed once, not 84 times).
    ``only``: the groups to build (each the same columns as in the whole library), else all.
    ``column_major``: each group's columns contiguous (the same values; the test's stack copies
    them so at the cost of a plain copy, not a transposition)."""
    n = pred_j.shape[0]
    wanted = set(GROUPS) if only is None else set(only)
    if "drift" not in wanted:
        drift = []
    elif row_index is None:
        t = (np.arange(n) - 0.5 * (n - 1)) / max(n - 1, 1)
        drift = [t, t * t - np.mean(t * t)]
    else:
        u = np.asarray(row_index, float)
        drift = [u, u * u]
    groups: dict[str, list[np.ndarray]] = {"offset": [np.ones(n)], "drift": drift}
    if q is not None:
        m = q.shape[1]
        v = dq[:, j]
        if "coulomb" in wanted:
            vs = _scale(v) if velocity_scale is None else float(velocity_scale)
            groups["coulomb"] = [np.sign(v)] + [np.tanh(v / (c * vs)) for c in (0.02, 0.1, 0.3)] + \
                [np.sign(v) * np.exp(-(v / (0.1 * vs)) ** 2)]
        groups["viscous"] = [v]
        if "velocity_squared" in wanted:
            groups["velocity_squared"] = [v * np.abs(v)]
        if "gravity" in wanted:
            groups["gravity"] = _chains(j, q, chains)
        if "position_harmonic" in wanted:
            groups["position_harmonic"] = [f(h * q[:, j]) for h in (2.0, 3.0) for f in (np.sin, np.cos)]
        groups["inertia"] = [ddq[:, k] for k in range(m)]
    out = {}
    for g in GROUPS:
        if g in groups and g in wanted:
            if column_major:
                cols = np.array(groups[g], dtype=float).T
                out[g] = cols if row_index is not None else cols / _scales(cols)
            else:
                cols = np.column_stack(groups[g])
                out[g] = cols if row_index is not None else cols / np.array([_scale(c) for c in cols.T])
    return out


def _scales(cols):
    """:func:`_scale` of each column of a column-major (N, k) array in one reduction: each column's
    sum runs over its contiguous rows as the one-column call's does, so the same bits."""
    if cols.shape[0] == 0:
        return np.ones(cols.shape[1])
    with np.errstate(over="ignore", invalid="ignore"):
        s = np.sqrt(np.mean(cols * cols, axis=0))
    return np.where((s > 0) & np.isfinite(s), s, 1.0)


def _chains(j, q, chains):
    """sin and cos of q_i + … + q_k for every chain i ≤ j ≤ k (``chains``: the pairs already made)."""
    m = q.shape[1]
    grav: list[np.ndarray] = []
    for i in range(j + 1):
        for k in range(j, m):
            pair = None if chains is None else chains.get((i, k))
            if pair is None:
                s = q[:, i:k + 1].sum(axis=1)
                pair = [np.sin(s), np.cos(s)]
                if chains is not None:
                    chains[(i, k)] = pair
            grav += pair
    return grav


def _ar_prewhitener(u, max_order):
    """AR coefficients a (x_k − Σ a_i x_{k−i} white) by Yule–Walker, order by BIC; and N_eff."""
    n = u.shape[0]
    uc = u - u.mean()
    var = float(uc @ uc) / n
    if var <= 0:
        return np.zeros(0), float(n)
    # the few lags the model needs as direct sums (an FFT of 2n points computes all n of them)
    acov = np.array([var] + [float(uc[:n - k] @ uc[k:]) / n for k in range(1, max_order + 1)])
    best = (math.log(var), np.zeros(0))
    best_bic = math.log(var)
    for p in range(1, max_order + 1):
        try:
            a = scipy.linalg.solve_toeplitz(acov[:p], acov[1:p + 1])
        except (np.linalg.LinAlgError, ValueError):
            break
        s2 = acov[0] - a @ acov[1:p + 1]
        if not s2 > 0:
            break
        bic = math.log(s2) + p * math.log(n) / n
        if bic < best_bic:
            best_bic, best = bic, (math.log(s2), a)
    a = best[1]
    s2 = math.exp(best[0])
    denom = (1.0 - float(a.sum())) ** 2
    lrv = s2 / max(denom, 1e-12)
    n_eff = float(np.clip(n * var / lrv, 2.0, n))
    return a, n_eff


def _whiten(x, a):
    """x_k − Σ a_i x_{k−i} for k ≥ p (p = a.size), along axis 0.

    The sums of ``scipy.signal.lfilter(np.r_[1, -a], 1, x)[p:]`` (an FIR filter: one
    ``numpy.convolve`` per column, oldest product first) in the same order and, as it returns them,
    column-major (the later products' bits depend on the layout), so the same result
    (``tests/test_physics_fast_paths.py``) from a few whole-array operations instead of a Python
    call per column."""
    p = a.size
    if p == 0 or x.size == 0:
        return x[p:]
    n = x.shape[0]
    if x.ndim == 1:
        return _whiten_into(x, a, np.empty(n - p))
    out = np.empty((n - p, x.shape[1]), order="F")
    # by pieces of _WHITEN_COLUMNS columns, each piece's three operands in cache: the same sums,
    # three times as fast on a decimated log's 4,000 × 46 stack as whole-array passes
    for lo in range(0, x.shape[1], _WHITEN_COLUMNS):
        _whiten_into(x[:, lo:lo + _WHITEN_COLUMNS], a, out[:, lo:lo + _WHITEN_COLUMNS])
    return out


_WHITEN_COLUMNS = 16


def _whiten_into(x, a, out):
    """:func:`_whiten` of x written into ``out`` (its rows but the first a.size)."""
    p, n = a.size, x.shape[0]
    np.multiply(x[:n - p], -a[p - 1], out=out)
    for i in range(p - 2, -1, -1):
        out += x[p - 1 - i:n - 1 - i] * -a[i]
    out += x[p:]
    return out


def _wald(xw, yw, cols=None, gw=None, cov_p=None, gram=None, xg=None):
    """OLS of yw on xw with HC1 covariance; Wald statistic of ``cols`` (all by default), its df.

    ``gw`` (N, k_p) and ``cov_p`` (k_p, k_p): the model's own columns (whitened) and Cov(π̂) of its
    estimated parameters; their error Y δ is part of the residual and adds
    (XᵀX)⁻¹ Xᵀ G Cov(π̂) Gᵀ X (XᵀX)⁻¹ to the coefficients' covariance. ``gram`` (XᵀX) and ``xg``
    (XᵀG): given when the caller assembled them from products it computed once.
    """
    n, k = xw.shape
    b, *_ = np.linalg.lstsq(xw, yw, rcond=None)
    r = yw - xw @ b
    g = xw.T @ xw if gram is None else gram
    ginv = np.linalg.pinv(g)
    scores = xw * r[:, None]
    meat = scores.T @ scores * (n / max(n - k, 1))
    if gw is not None and cov_p is not None:
        xg = xw.T @ gw if xg is None else xg
        meat = meat + xg @ cov_p @ xg.T
    cov = ginv @ meat @ ginv
    idx = np.arange(k) if cols is None else np.asarray(cols)
    bs, cs = b[idx], cov[np.ix_(idx, idx)]
    w = float(bs @ np.linalg.pinv(cs) @ bs) if idx.size else 0.0
    return w, int(idx.size), b, r


def _wald_one(x, y):
    """:func:`_wald`'s statistic for one column x (1-D): its least squares, HC1 variance and Wald
    statistic in closed form (lstsq's and pinv's cut-offs are relative to the one singular value, so
    only an exact zero column or variance is dropped), without an SVD of the N rows: the delay test's
    one column per joint at the logged rate."""
    n = x.shape[0]
    size = float(x @ x)
    if not size > 0:
        return 0.0
    b = float(x @ y) / size
    h = x * (y - x * b)
    var = float(h @ h) * (n / max(n - 1, 1)) / (size * size)
    return b * b / var if var > 0 else 0.0


@dataclass
class PhysicsTest:
    """One joint's library test."""

    joint: int
    statistic: float  # F = Wald/k of every library term together (prewhitened, HC1)
    df: tuple[int, int]
    pvalue: float
    share: float  # share of the joint's validation mean square the library removes
    term: str | None  # the group named
    term_share: float  # the share it removes alone
    selected: list[str] = field(default_factory=list)
    shares: dict[str, float] = field(default_factory=dict)
    selected_share: float = 0.0  # share the selected groups remove together
    n_eff: float = float("nan")  # effective samples of the residual left by the library (the noise's)
    ar_order: int = 0
    refit_shares: dict[str, float] = field(default_factory=dict)  # the refits' shares, when named so
    refit_run: str | None = None  # "estimation" or "validation": the run the naming refits used
    heldout_share: float = float("nan")  # the named group alone, cross-fitted on the validation run
    carried_share: float = float("nan")  # the named group beyond the model's columns, cross-fitted there
    relation: dict[str, Any] | None = None  # the named group relative to the model's columns (_model_terms)

    def to_dict(self) -> dict[str, Any]:
        return {"joint": self.joint, "statistic": self.statistic, "df": list(self.df), "pvalue": self.pvalue,
                "share": self.share, "term": self.term, "term_share": self.term_share,
                "selected": list(self.selected), "shares": dict(self.shares),
                "selected_share": self.selected_share, "refit_shares": dict(self.refit_shares),
                "refit_run": self.refit_run, "heldout_share": self.heldout_share,
                "carried_share": self.carried_share, "relation": None if self.relation is None else dict(self.relation),
                "n_eff": self.n_eff,
                "ar_order": self.ar_order}


@dataclass(frozen=True)
class Decimation:
    """The whole factor by which :func:`physics_test` decimates a log before its library is built
    (docs/conventions.md §5.2, "Decimated to the information band"), and why."""

    factor: int
    band_hz: float | None  # the report's information band f_I (None: not known, no rate)
    rows: int  # the rows tested
    rule: str

    def to_dict(self) -> dict[str, Any]:
        return {"factor": self.factor, "information_band_hz": self.band_hz, "rows": self.rows,
                "margin": _MARGIN, "min_rows": _MIN_ROWS, "rule": self.rule}


def decimation(n: int, sample_rate: float | None, band: float | None) -> Decimation:
    """The factor: the largest that keeps the information band ``band`` (Hz) at most 1/_MARGIN of
    the new Nyquist frequency and at least _MIN_ROWS rows; at least the factor that brings the
    log to _MAX_ROWS rows. 1 (no decimation) without a rate or a band, or when neither allows 2."""
    by_rows = max(1, math.ceil(n / _MAX_ROWS))
    by_band = 1
    usable = sample_rate is not None and band is not None and math.isfinite(band) and band > 0
    if usable:
        fs = float(sample_rate)
        by_band = max(1, min(int(math.floor(min(fs / (2.0 * _MARGIN * band), float(n)))), n // _MIN_ROWS))
    factor = max(by_rows, by_band)
    if factor == 1:
        return Decimation(1, band if usable else None, n, "none")
    rows = len(range(0, n, factor)) - 2 * _EDGE
    if by_band >= by_rows:
        rule = (f"decimated by {factor} (zero-phase FIR) to {rows} rows before the library is built: the new "
                f"Nyquist frequency {float(sample_rate) / (2 * factor):.4g} Hz is at least {_MARGIN:g}× the "
                f"information band {band:.4g} Hz and N/{factor} at least {_MIN_ROWS} rows ({_EDGE} rows at each end, "
                f"where the filter reached past the log, dropped)")
    else:
        rule = f"decimated by {factor} (zero-phase FIR) to {rows} rows: longer than {_MAX_ROWS} rows"
    return Decimation(factor, band if usable else None, rows, rule)


def _down(x, factor):
    """x (N, ...) low-passed and kept every ``factor``-th row (scipy.signal.decimate's zero-phase
    FIR), less _EDGE rows at each end, where the filter reached past the log (its zero padding)."""
    if factor == 1:
        return x
    y = scipy.signal.decimate(x, factor, ftype="fir", axis=0, zero_phase=True)
    return y[_EDGE:y.shape[0] - _EDGE]


def physics_test(e, pred, q=None, dq=None, ddq=None, *, sample_rate=None, nuisance=None, alpha=0.05,
                 groups=None, model_regressor=None, parameter_covariance=None,
                 libraries=None, band=None) -> list[PhysicsTest]:
    """Each joint's residual against the physics library (module docstring).

    e, pred : (N, m) residual and prediction; q, dq, ddq : (N, m) or None (then only ``offset``,
    ``drift`` and ``delay`` are tested); nuisance : list of (N, k_j) arrays refitted on the
    validation run (the model's own columns when their estimation error is unknown), or None;
    model_regressor (N, m, k) and parameter_covariance (k, k): the model's columns and Cov(π̂) from
    the estimation run, whose error then widens the test instead of being refitted away;
    libraries: each joint's :func:`library` when the caller built them already (at the logged
    rate: not used when the log is decimated); band: the report's information band (Hz), from
    which :func:`decimation` chooses the factor.
    """
    n, m = e.shape
    dec = decimation(n, sample_rate, band).factor
    full_ms = None
    if dec > 1:
        # Linear columns commute with the filter; the library's are built from the decimated q,
        # q̇, q̈ (conventions §5.2): its nonlinear columns of band-limited motion stay in the band
        full_ms = np.mean(e * e, axis=0)
        # one filter call for the joints' series side by side; not the prediction, of which the
        # library reads only the row count
        parts = [e] + ([] if q is None else [q, dq, ddq])
        e, *motion = np.split(_down(np.hstack(parts), dec), len(parts), axis=1)
        pred = e
        if q is not None:
            q, dq, ddq = motion
        nuisance = None if nuisance is None else [_down(x, dec) for x in nuisance]
        if model_regressor is not None:
            g = np.asarray(model_regressor, float)
            model_regressor = _down(g.reshape(n, -1), dec).reshape(-1, *g.shape[1:])
        libraries, sample_rate = None, None if sample_rate is None else float(sample_rate) / dec
    chains: dict = {}

    def joint(j):
        if libraries is not None:
            lib = libraries[j]
        else:
            lib = library(j, q, dq, ddq, pred[:, j], sample_rate, chains=chains if dec > 1 else None,
                          column_major=True)
        if groups is not None:
            lib = {g: x for g, x in lib.items() if g in groups}
        nz = None if nuisance is None else nuisance[j]
        gj = None if model_regressor is None else model_regressor[:, j, :]
        return _joint_test(j, e[:, j], lib, nz, alpha, gj, parameter_covariance,
                           None if full_ms is None else (float(full_ms[j]), n))

    # the joints' tests are independent: on threads where the whitened stacks are large enough
    return thread_map(joint, m, values=e.shape[0] * m * _TYPICAL_WIDTH)


_TYPICAL_WIDTH = 64
"""A joint's stack of library and nuisance columns, about (20 to 100 on 3- to 7-joint arms): the
physics test's joints go on threads (:func:`dynval.kernels._threads.thread_map`) when rows × joints ×
this reaches the threads' minimum, 4,096 rows × joints (below it a joint's test takes a few ms)."""


def name_group(shares: dict[str, float], widths: dict[str, int]) -> str:
    """The group to name from each group's share of the joint's mean square (``widths``: its
    columns): of the groups near the best, the one with the fewest columns (conventions §5.2). Near:
    within :data:`_PARSIMONY` of the best share, *and* leaving at most :data:`_LEFT_RATIO` times what
    the best leaves plus :data:`_LEFT_SLACK` of the mean square. The first keeps a joint's own
    friction or offset before the many-column posture and inertia groups that can mimic it; the
    second keeps a one-column shape from standing for the term that removes nearly everything (a
    wrist's Coulomb friction: 99.7 % against q̇|q̇|'s 95.7 %, which leaves 14 times as much)."""
    top = max(shares.values())
    left = 1.0 - min(top, 1.0)
    near = [g for g, a in shares.items()
            if a >= _PARSIMONY * top and 1.0 - min(a, 1.0) <= _LEFT_RATIO * left + _LEFT_SLACK]
    return min(near, key=lambda g: (widths[g], -shares[g]))


def _joint_test(j, ej, lib, nz, alpha, g=None, cov_p=None, logged=None):
    """One joint. ``nz``: nuisance columns refitted on the validation run (the model's columns when
    Cov(π̂) is unknown), or None; ``g``, ``cov_p``: the model's columns and Cov(π̂) when known.
    ``logged``: on a decimated log, the residual's mean square at the logged rate and the logged
    rows: the shares are of it (a sum of squares of the decimated rows taken per row, as the band's
    power is kept by the filter) and N_eff is in its units, at most the logged rows (conventions §5.2)."""
    full_ms, full_n = (None, None) if logged is None else logged
    n = ej.shape[0]
    total = float(ej @ ej)
    if not total > 0 or n < 50:
        return _nan_result(j)
    nz = np.zeros((n, 0)) if nz is None else np.asarray(nz, float).reshape(n, -1)
    stack = _Stack(ej, nz, lib, g)
    a, problem, fit = _filtered_fit(stack, alpha, cov_p)
    if fit is None:
        return _nan_result(j)

    def raw_sses(fits):
        # every design's coefficients side by side: one product of the rows for all of them
        coefs = np.zeros((stack.raw.shape[1], len(fits)))
        for i, (cols, coef) in enumerate(fits):
            coefs[cols, i] = coef
        left = ej[:, None] - stack.raw @ coefs
        return [float(x) for x in np.einsum("ij,ij->j", left, left)]

    def n_eff(cols, coef):
        # the noise's N_eff (what the model's columns and the library leave), for the design rule
        left = ej - stack.times(cols, coef)
        got = _ar_prewhitener(left, min(_MAX_AR, n // 50))[1]
        if full_ms is None:
            return got
        # in the logged rate's units: the filter removed the residual's power above the band, which
        # the library leaves; a term in the band sees got · (what is left there)/(what is left here)
        left_ms = float(left @ left) / n
        above = max(full_ms - total / n, 0.0)
        return min(got * (1.0 + above / left_ms), float(full_n)) if left_ms > 0 else got

    return _conclude(j, problem, fit, total, raw_sses, n_eff, {g: x.shape[1] for g, x in lib.items()}, int(a.size),
                     None if full_ms is None else n * full_ms)


def _nan_result(j):
    return PhysicsTest(j, float("nan"), (0, 0), float("nan"), float("nan"), None, float("nan"))


def _filtered_fit(stack, alpha, cov_p=None):
    """The prewhitening filter, the compressed whitened problem and its fit (None: no group keeps
    a direction of its own) of one joint's stacked columns."""
    ej = stack.raw[:, 0]
    n = ej.shape[0]
    # Feasible GLS with the AR(≤ 2) model of the residual as given (see _MAX_AR); when groups enter,
    # the AR model is fitted again to what those few groups leave (a large missing term would
    # otherwise be taken for colour and whitened away), and the test is repeated once.
    a, _ = _ar_prewhitener(ej, min(_MAX_AR, n // 50))
    problem = _Compressed(stack, a)
    # the first pass's test of every group is read only when no second pass replaces it
    fit = _whitened_fit(problem, alpha, cov_p, joint_test=False)
    if fit is not None and fit["selected"]:
        chosen = stack.raw[:, stack.columns(["nz"] + [fit["names"][s] for s in fit["selected"]])]
        c1, *_ = np.linalg.lstsq(chosen, ej, rcond=None)
        a, _ = _ar_prewhitener(ej - chosen @ c1, min(_MAX_AR, n // 50))
        problem = _Compressed(stack, a)
        fit = _whitened_fit(problem, alpha, cov_p) or fit
    return a, problem, None if fit is None else _with_joint_test(fit)


def _conclude(j, problem, fit, total, raw_sses, n_eff_of, widths, ar_order, denominator=None):
    """The shares, N_eff and the term named, from the whitened fit: ``raw_sses(fits)`` are the raw
    residual's sums of squares after each of the GLS fits ``fits`` (pairs of the stacked ``cols``
    and their coefficients), ``n_eff_of(cols, coef)`` the N_eff of what they leave; ``widths`` each
    group's columns; ``denominator``: the sum of squares the shares are of (``total``, the rows',
    unless decimated)."""
    denominator = total if denominator is None else denominator
    names, selected = fit["names"], fit["selected"]
    f_stat, k, df2, pvalue = fit["f"], fit["k"], fit["df2"], fit["pvalue"]
    stack = problem.stack
    every = tuple(range(len(names)))
    # the designs whose sums of squares are read: none, every group, and with a selection the
    # selected groups, each of them left out in turn and each group alone
    designs = [(), every]
    if selected:
        designs += [tuple(selected)] + [tuple(t for t in selected if t != s) for s in selected] + \
            [(i,) for i in every]
    fits = {}
    for groups in dict.fromkeys(designs):
        # the GLS fit of the nuisance columns and the groups from the compressed whitened problem
        cols = stack.columns(["nz"] + [names[i] for i in groups])
        fits[groups] = (cols, problem.lstsq(cols, stack.index["e"]) if cols.size else np.zeros(0))
    # the residual of the raw rows: one pass for every design
    sse = {groups: total if fits[groups][0].size == 0 else got
           for groups, got in zip(fits, raw_sses(list(fits.values())))}
    base, full = sse[()], sse[every]
    n_eff = n_eff_of(*fits[every])
    share = max(0.0, (base - full) / denominator)
    shares: dict[str, float] = {}
    selected_share = 0.0
    if selected:
        fit_all = sse[tuple(selected)]
        selected_share = max(0.0, (base - fit_all) / denominator)
        for s in selected:
            without = sse[tuple(t for t in selected if t != s)]
            shares[names[s]] = max(0.0, (without - fit_all) / denominator)
    # The term named: of the groups that alone remove nearly as much as the best one (within
    # _PARSIMONY of it), the one with the fewest columns. A joint's own friction or offset (one to
    # five columns) is named before the many-column inertia and posture groups, which on a
    # few-harmonic trajectory can mimic it; the first group to enter is the most significant after
    # whitening, which favours sharp terms such as Coulomb's, and is not used for the name.
    alone_by = {i: max(0.0, (base - sse[(i,)]) / denominator) for i in every} if selected else {}
    term = None
    alone = 0.0
    if alone_by:
        named = name_group({names[i]: a for i, a in alone_by.items()}, {names[i]: widths[names[i]] for i in every})
        term, alone = named, alone_by[names.index(named)]
    return PhysicsTest(j, float(f_stat), (k, df2), pvalue, share, term, alone, [names[s] for s in selected], shares,
                       selected_share, n_eff, ar_order)


class _Stack:
    """One joint's raw columns side by side, once: the residual ``e``, the nuisance columns ``nz``
    and the library's groups by name; beside them the model's columns ``g`` (when Cov(π̂) is known)."""

    def __init__(self, ej, nz, lib, g=None):
        parts = [("e", ej[:, None]), ("nz", nz)] + list(lib.items())
        # the model's columns enter through XᵀG alone: a product of the rows, not part of the QR
        self.g = None if g is None else np.asarray(g, float).reshape(ej.shape[0], -1)
        edges = np.cumsum([0] + [x.shape[1] for _, x in parts])
        self.index = {name: np.arange(edges[i], edges[i + 1]) for i, (name, _) in enumerate(parts)}
        self.groups = [name for name, _ in parts if name not in ("e", "nz")]
        # column-major: each column contiguous for the filter, the QR and the fits' gathers
        self.raw = np.empty((ej.shape[0], int(edges[-1])), order="F")
        for (_, x), lo, hi in zip(parts, edges[:-1], edges[1:]):
            self.raw[:, lo:hi] = x

    def times(self, cols, coef):
        """raw[:, cols] @ coef without copying the columns out (one pass over the stack)."""
        full = np.zeros(self.raw.shape[1])
        full[cols] = coef
        return self.raw @ full

    def columns(self, names):
        """The stacked indices of the named parts, in order."""
        got = [self.index[x] for x in names if x in self.index]
        return np.concatenate(got) if got else np.zeros(0, dtype=int)


class _Compressed:
    """The whitened columns' sufficient statistics for least squares: R of a Householder QR of the
    whitened stack Z_w = Q R (:func:`_tall_r`). Every product Z_w[:, c]ᵀ Z_w[:, d] is R[:, c]ᵀ R[:, d], so every fit,
    projection and singular value of the whitened problem is computed on R's few rows, to the
    accuracy of the rows themselves (a Gram matrix squares the library's condition number, up to
    3e7 on the KUKA runs). The whitened rows are kept for the heteroscedasticity-robust covariance,
    which needs each row's residual."""

    def __init__(self, stack, a):
        self.stack = stack
        self.rows = _whiten(stack.raw, a)
        self.g_rows = None if stack.g is None else _whiten(stack.g, a)
        self.n = self.rows.shape[0]
        self.r = _tall_r(self.rows)

    def tests(self, x_r, y_r, row_map, cov_p=None):
        """The Wald tests of the R-space blocks ``x_r`` against ``y_r``, whose rows are the stacked
        rows times ``row_map`` (the blocks' columns, then the residual's)."""
        # the blocks' and the residual's whitened rows, column-major: each group's columns are then one
        # contiguous piece of memory for its residual and meat
        rows = (row_map.T @ self.rows.T).T
        xg = None if self.g_rows is None or cov_p is None else rows[:, :-1].T @ self.g_rows
        return _Tests(x_r, y_r, rows[:, :-1], rows[:, -1], self.n, xg, cov_p)

    def lstsq(self, cols, target):
        """The least squares (:func:`_small_lstsq`) of the whitened column ``target`` on the whitened
        ``cols``, with numpy.linalg.lstsq's default cut-off for the rows' count (the minimum-norm
        solution depends on the normal equations alone, which R holds)."""
        x = self.r[:, cols]
        return _small_lstsq(x, self.r[:, int(target[0])], np.finfo(float).eps * max(self.n, x.shape[1]))


_QR_ROWS = 1024


def _tall_r(x):
    """R of a QR of a tall x, by pieces of about _QR_ROWS rows (the R of their stacked Rs): each
    piece's Householder QR stays in cache, twice as fast on 20,000 rows as one QR of all of them
    and a third faster on a decimated log's 4,000 (pieces of 1,024 rows; of 2,048 it was one piece),
    and as accurate (a product of orthogonal transforms). R is unique up to the signs of its rows,
    which no product RᵀR, fit or singular value depends on."""
    pieces = x.shape[0] // _QR_ROWS
    if pieces < 2:
        return _r_of(x)
    return _r_of(np.vstack([_r_of(p) for p in np.array_split(x, pieces)]))


def _r_of(x):
    """``numpy.linalg.qr(x, mode="r")`` from LAPACK's dgeqrf called directly (the same Householder
    QR, so the same R; without numpy's checks, copies and wrapping: 2.1 against 2.3 ms for a
    3,978 × 45 stack by pieces)."""
    if x.shape[0] == 0 or x.shape[1] == 0:
        return np.linalg.qr(x, mode="r")
    factored, _, _, info = scipy.linalg.lapack.dgeqrf(x)
    if info != 0:
        raise np.linalg.LinAlgError(f"dgeqrf failed on a ({x.shape[0]}, {x.shape[1]}) array (info {info})")
    return np.triu(factored[:min(x.shape)])


def _orthonormal(x, rel=1e-7, floor=0.0):
    """An orthonormal basis u of x's column space (SVD; directions below rel·σ_max or below
    ``floor`` dropped) and its map m: u = x m."""
    if x.shape[1] == 0:
        return x, np.zeros((0, 0))
    u, s, vt = np.linalg.svd(x, full_matrices=False)
    keep = (s > rel * max(s[0], 1e-300)) & (s > floor) if s.size else np.zeros(0, bool)
    return u[:, keep], vt[keep].T / s[keep]


def _whitened_fit(problem, alpha, cov_p=None, joint_test=True):
    """The whitened problem: the library's groups outside the nuisance columns, the Wald test of
    them all and the forward selection; None when no group keeps a direction of its own.
    ``joint_test=False``: the test of them all left to :func:`_with_joint_test` (a first pass
    whose selection is refitted under a new filter does not need it).

    Computed on the compressed problem (:class:`_Compressed`): each group's orthonormal block and
    the residual outside the nuisance columns are maps of the stacked columns, so their rows are
    one product of the whitened rows and every fit is solved on R's rows."""
    stack_index, r = problem.stack.index, problem.r
    e_i, nz_i = stack_index["e"], stack_index["nz"]
    basis, basis_map = _orthonormal(r[:, nz_i]) if nz_i.size else (r[:, nz_i], np.zeros((0, 0)))
    t = r.shape[1]

    def perp(cols):
        """(R-space columns outside the nuisance span, their map on the stacked columns)."""
        x = r[:, cols]
        m = np.zeros((t, cols.size))
        m[cols, np.arange(cols.size)] = 1.0
        if basis.shape[1]:
            c = basis.T @ x
            x = x - basis @ c
            m[nz_i] -= basis_map @ c
        return x, m

    yw, y_map = perp(e_i)
    names, blocks, maps = [], [], []
    for name in problem.stack.groups:
        cols = stack_index[name]
        xw = r[:, cols]
        # a direction that keeps less than 1 % of its size outside the model's columns is the
        # model's own term (or numerical dust): not a candidate
        floor = _OUTSIDE * float(np.sqrt(np.max(np.sum(xw * xw, axis=0))))
        xp, m = perp(cols)
        b, bm = _orthonormal(xp, rel=1e-6, floor=floor)
        if b.shape[1]:
            names.append(name)
            blocks.append(b)
            maps.append(m @ bm)
    if not blocks:
        return None
    sizes = [b.shape[1] for b in blocks]
    edges = np.cumsum([0] + sizes)
    x_r = np.hstack(blocks)
    # the blocks' and the residual's whitened rows, column-major: each group's columns are then one
    # contiguous piece of memory for its residual and meat
    tests = problem.tests(x_r, yw[:, 0], np.hstack(maps + [y_map]), cov_p)
    k = int(edges[-1])
    df2 = max(problem.n - k - basis.shape[1], 1)
    columns = [np.arange(edges[i], edges[i + 1]) for i in range(len(blocks))]
    fit = {"names": names, "k": k, "df2": df2, "selected": _forward_selection(columns, tests, alpha), "tests": tests}
    return _with_joint_test(fit) if joint_test else fit


def _with_joint_test(fit):
    """The fit with the Wald test of every group together (its F and p-value); each step's tests are
    computed from the same stored products whatever was tested before."""
    if "f" not in fit:
        k, df2 = fit["k"], fit["df2"]
        w = fit["tests"].step(np.zeros(0, dtype=int), [np.arange(k)])[0]
        fit.update(f=w / k, pvalue=float(scipy.stats.f.sf(w / k, k, df2)))
    fit.pop("tests", None)  # the whitened rows it holds are not needed past the tests
    return fit


class _Tests:
    """Wald tests of the blocks' columns (HC1, as :func:`_wald`): coefficients from the compressed
    rows (``x_r``, ``y_r``: R-space), the HC1 meat from the whitened rows (``x_rows``, ``y_rows``),
    and the model's parameter error through XᵀG (``xg``) and Cov(π̂)."""

    def __init__(self, x_r, y_r, x_rows, y_rows, n, xg=None, cov_p=None):
        self.x_r, self.y_r, self.x_rows, self.y_rows, self.n = x_r, y_r, x_rows, y_rows, n
        self.xg, self.cov_p = xg, cov_p

    def step(self, base, candidates):
        """Each candidate's Wald statistic in the fit of the ``base`` columns and its own.

        By Frisch–Waugh–Lovell, with X̃ the candidate's columns outside the base's span and ỹ the
        residual of the base alone: the fit's residual is ỹ − X̃β, the tested coefficients are
        (X̃ᵀX̃)⁻¹X̃ᵀy with covariance (X̃ᵀX̃)⁻¹ M (X̃ᵀX̃)⁻¹, M = X̃ᵀΩX̃ (+ X̃ᵀG Cov(π̂) GᵀX̃), so
        W = (X̃ᵀy)ᵀ M⁻¹ (X̃ᵀy): one inverse of a matrix conditioned as X̃ᵀX̃ (the product
        (XᵀX)⁻¹ M (XᵀX)⁻¹ squares it again: the statistic then moved by percents under a 1e-13 change
        of y). Every candidate's columns are projected off the base together (one least-squares
        solve on R's rows, one product of the rows: conventions §5.2), then the rows are read once
        per candidate for its residual and its meat."""
        eps = np.finfo(float).eps
        if not candidates:
            return []
        every = np.concatenate(candidates)
        x_all = self.x_r[:, every]
        xg_all = None if self.xg is None or self.cov_p is None else self.xg[every]
        y_r = self.y_r
        c_y = c_all = None
        if base.size:
            x_base = self.x_r[:, base]
            coef = _small_lstsq(x_base, np.column_stack([y_r, x_all]), eps * max(self.n, base.size))
            c_y, c_all = coef[:, 0], coef[:, 1:]
            y_r = y_r - x_base @ c_y
            x_all = x_all - x_base @ c_all
            if xg_all is not None:
                xg_all = xg_all - c_all.T @ self.xg[base]
        self._project(base, every, c_y, c_all)
        out = []
        lo = 0
        for cand in candidates:
            ki = cand.size
            piece = slice(lo, lo + ki)
            lo += ki
            if not ki:
                out.append(0.0)
                continue
            x_r = x_all[:, piece]
            score = x_r.T @ y_r
            if ki == 1:
                # one column: its least squares and pseudo-inverse in closed form (lstsq's and pinv's
                # cut-offs are relative to the one singular value, so only an exact zero is dropped)
                size = float(x_r[:, 0] @ x_r[:, 0])
                beta = score / size if size > 0 else np.zeros(1)
            else:
                beta = _small_lstsq(x_r, y_r, eps * max(self.n, ki))
            meat = self._meat(piece, beta) * (self.n / max(self.n - base.size - ki, 1))
            if xg_all is not None:
                meat = meat + xg_all[piece] @ self.cov_p @ xg_all[piece].T
            if ki == 1:
                out.append(float(score[0] * score[0] / meat[0, 0]) if meat[0, 0] != 0 else 0.0)
            else:
                out.append(_score_quadratic(score, meat))
        return out

    def _project(self, base, every, c_y, c_all):
        """The rows of the residual and of the candidates' columns ``every`` outside the ``base``
        columns (``c_y``, ``c_all``: their coefficients on them; None: no base), for :meth:`_meat`."""
        if c_y is None:
            contiguous = every.size and every[-1] - every[0] == every.size - 1 and np.all(np.diff(every) == 1)
            self._y_rows = self.y_rows
            self._rows_all = self.x_rows[:, int(every[0]):int(every[-1]) + 1] if contiguous else self.x_rows[:, every]
            return
        rows_base_t = self.x_rows[:, base].T
        self._y_rows = self.y_rows - c_y @ rows_base_t
        # column-major, as the rows: each candidate's columns are one contiguous piece; by pieces of
        # _WHITEN_COLUMNS columns (gathered, their fit on the base and the difference in cache), each
        # difference written over its product (into a fresh array it took eight times as long)
        out = np.empty((self.x_rows.shape[0], every.size), order="F")
        for lo in range(0, every.size, _WHITEN_COLUMNS):
            piece = out[:, lo:lo + _WHITEN_COLUMNS]
            np.matmul(c_all[:, lo:lo + _WHITEN_COLUMNS].T, rows_base_t, out=piece.T)
            np.subtract(self.x_rows[:, every[lo:lo + _WHITEN_COLUMNS]], piece, out=piece)
        self._rows_all = out

    def _meat(self, piece, beta):
        """Σ h hᵀ of the rows' scores h = x̃ r: the candidate's columns (``piece`` of the projected
        ones) and the residual after its coefficients ``beta``."""
        x_rows = self._rows_all[:, piece]
        h = x_rows * (self._y_rows - x_rows @ beta)[:, None]
        return h.T @ h


def _small_lstsq(x, y, rcond):
    """The minimum-norm least-squares solution of x b = y (y: one column or several) for a few
    columns, the directions of rank below ``rcond`` (relative) dropped: LAPACK's dgelsy, a QR with
    column pivoting, where ``numpy.linalg.lstsq``'s dgelsd takes an SVD; the two agree to rounding
    wherever the rank is not within rounding of the cut-off (conventions §5.2, "Fewer passes"), at a
    quarter of the cost on R's few dozen rows, the selection steps' count of small fits."""
    m, k = x.shape
    rhs = np.zeros((max(m, k), 1 if y.ndim == 1 else y.shape[1]), order="F")
    rhs[:m] = y.reshape(m, -1)
    lwork, info = scipy.linalg.lapack.dgelsy_lwork(m, k, rhs.shape[1], rcond)
    if info == 0 and m and k:
        _, got, _, _, info = scipy.linalg.lapack.dgelsy(x, rhs, np.zeros(k, dtype=np.int32), rcond, int(lwork))
        if info == 0:
            return got[:k, 0] if y.ndim == 1 else got[:k]
    return np.linalg.lstsq(x, y, rcond=rcond)[0]


# the meat's reciprocal condition number above which its Cholesky factor stands for its
# pseudo-inverse: the two then agree to about 1e-8 relative (numpy's pinv cuts at 1e-15)
_CHOLESKY_RCOND = 1e-7


def _score_quadratic(score, meat):
    """scoreᵀ pinv(meat) score for a symmetric positive semi-definite ``meat``: ‖L⁻¹ score‖² from its
    Cholesky factor L where it is well conditioned (LAPACK's estimate), else ``numpy.linalg.pinv``'s
    (an SVD per call: 143 against 23 µs on a 21-column meat)."""
    lapack = scipy.linalg.lapack
    chol, info = lapack.dpotrf(meat, lower=1, clean=1)
    if info == 0:
        rcond, info = lapack.dpocon(chol, float(np.max(np.sum(np.abs(meat), axis=0))), uplo="L")
        if info == 0 and rcond > _CHOLESKY_RCOND:
            z, info = lapack.dtrtrs(chol, score, lower=1)
            if info == 0:
                return float(z @ z)
    return float(score @ np.linalg.pinv(meat) @ score)


def _forward_selection(columns, tests, alpha):
    """Groups in order of entry while the next one is significant at α / (number of groups)."""
    selected: list[int] = []
    while len(selected) < len(columns):
        candidates = [i for i in range(len(columns)) if i not in selected]
        base = np.concatenate([columns[s] for s in selected]) if selected else np.zeros(0, dtype=int)
        best = None
        for i, wi in zip(candidates, tests.step(base, [columns[i] for i in candidates])):
            ki = columns[i].size
            # scipy.stats.chi2.sf's own function, without its per-call argument handling (355 calls
            # took 0.1 s of a 2 s validate on the simulated 1 kHz log)
            pi = float(scipy.special.chdtrc(ki, wi))
            if best is None or pi < best[1] or (pi == best[1] and wi / ki > best[2]):
                best = (i, pi, wi / ki)
        if best is None or best[1] > alpha / len(columns):
            break
        selected.append(best[0])
    return selected


def _best_whole_shift(meas, pred, inner, big, sse, sse0):
    """The whole shift in −big..big of least Σ_j sse_j(d)/sse0_j (the first on a tie), as a loop of
    ``sse`` over every shift finds it: the costs of all shifts from one product of the prediction's
    windows with the measurement (Σ m² − 2 Σ m p + Σ p² on the inner rows), then the shifts within
    1e-9 of the least cost, relative, scored again by ``sse`` itself (the product's rounding cannot
    change which is chosen)."""
    width = inner.stop - inner.start
    lo = inner.start - big  # the window of shift +big starts here, that of −big at inner.start + big
    m_in = meas[inner]
    cost = np.zeros(2 * big + 1)
    for j in range(meas.shape[1]):
        p = pred[lo:lo + width + 2 * big, j]
        cross = np.correlate(p, m_in[:, j], "valid")  # r: the window starting at lo + r, i.e. shift big − r
        sq = np.cumsum(np.concatenate([[0.0], p * p]))
        power = sq[width:] - sq[:-width]
        cost += ((m_in[:, j] @ m_in[:, j] - 2.0 * cross + power) / sse0[j])[::-1]
    shifts = np.arange(-big, big + 1)
    near = shifts[cost <= cost.min() + 1e-9 * max(abs(cost.min()), 1e-300) + 1e-9]
    exact = [float(np.sum(sse(float(d)) / sse0)) for d in near]
    return float(near[int(np.argmin(exact))])


def _shifted(pred, shift, rows):
    """pred (N, m) at t − shift for t in the slice ``rows`` (each t − shift within 0..N − 1), by linear
    interpolation between samples, computed as ``numpy.interp(t − shift, arange(N), pred[:, j])``
    computes it, (p[i + 1] − p[i])·(x − i) + p[i] with i = ⌊x⌋, so the same bits
    (``tests/test_physics_fast_paths.py``), for every joint at once on those rows."""
    x = np.arange(rows.start, rows.stop, dtype=float) - shift
    lo = np.floor(x)
    i = lo.astype(np.intp)
    if i.size and i[-1] - i[0] == i.size - 1 and np.all(np.diff(i) == 1):
        # consecutive samples (every x on one side of the same grid offset): slices, not a gather
        below, above = pred[i[0]:i[-1] + 1], pred[i[0] + 1:i[-1] + 2]
    else:
        below, above = pred[i], pred[i + 1]
    return (above - below) * (x - lo)[:, None] + below


def _grid_costs(meas, pred, inner, grid, sse, sse0):
    """Σ_j sse_j(d)/sse0_j on the quarter-sample ``grid``, as a loop of ``sse`` over it gives them
    wherever they are read: between whole shifts k < d < k + 1 the interpolated prediction is
    P_{k+1} + g (P_k − P_{k+1}), g = k + 1 − d, so each joint's sum of squares is the quadratic
    S0 − 2g S1 + g² S2 of three sums per interval; the grid points within 1e-9 of the least of these
    and their neighbours (which the parabolic refinement reads) are then scored by ``sse`` itself, so
    the shift chosen and refined is the loop's to the bit."""
    width = inner.stop - inner.start
    m_in = meas[inner]
    sums = {}

    def quadratic(d):
        k = math.floor(d)
        if k not in sums:
            lo = inner.start - k - 1
            after, before = pred[lo:lo + width], pred[lo + 1:lo + 1 + width]  # P_{k+1}, P_k
            left, step = m_in - after, before - after
            sums[k] = (np.sum(left * left, axis=0), np.sum(left * step, axis=0), np.sum(step * step, axis=0))
        s0, s1, s2 = sums[k]
        g = k + 1 - d
        return float(np.sum((s0 - 2.0 * g * s1 + g * g * s2) / sse0))

    exact: dict[int, float] = {}

    def scored(i):
        if i not in exact:
            exact[i] = float(np.sum(sse(float(grid[i])) / sse0))
        return exact[i]

    approx = np.array([scored(i) if grid[i] == int(grid[i]) else quadratic(float(grid[i]))
                       for i in range(grid.size)])
    least = float(approx.min())
    near = np.flatnonzero(approx <= least + 1e-9 * max(abs(least), 1e-300) + 1e-9)
    cost = approx.copy()
    for i in near:
        cost[i] = scored(int(i))
    i = int(np.argmin(cost))
    for k in (i - 1, i, i + 1):
        if 0 <= k < grid.size:
            cost[k] = scored(k)
    return cost


def delay_test(meas, pred, *, sample_rate=None, max_shift=None) -> dict[str, Any]:
    """The common time shift d (samples; > 0: the measurement lags) that best aligns the prediction
    with the measured torque, each joint's share of the mean square realigning removes, and each
    joint's p-value of the residual against −τ̂' (prewhitened AR(≤ 2), HC1)."""
    n, m = meas.shape
    fs = 1.0 if sample_rate is None else float(sample_rate)
    big = int(max_shift if max_shift is not None else min(max(10, round(0.05 * fs)), n // 20))
    inner = slice(big + 1, n - big - 1)  # rows every shift reaches
    e0 = meas - pred
    sse0 = np.sum(e0[inner] ** 2, axis=0)
    if big < 1 or not np.all(sse0 > 0):
        return {"shift_samples": 0.0, "share": np.zeros(m), "pvalue": np.full(m, np.nan), "grid_limit": big}

    def sse(shift):
        if shift == int(shift):
            # a whole shift is a slice: np.interp returns the sample itself at a grid point
            lo = inner.start - int(shift)
            return np.sum((meas[inner] - pred[lo:lo + inner.stop - inner.start]) ** 2, axis=0)
        return np.sum((meas[inner] - _shifted(pred, shift, inner)) ** 2, axis=0)

    # whole samples first, then quarter samples around the best
    best = _best_whole_shift(meas, pred, inner, big, sse, sse0)
    grid = np.clip(best + np.arange(-1.0, 1.001, 0.25), -big, big)
    cost = _grid_costs(meas, pred, inner, grid, sse, sse0)
    i = int(np.argmin(cost))
    d = float(grid[i])
    if 0 < i < grid.size - 1:  # parabolic refinement between grid points
        c0, c1, c2 = cost[i - 1], cost[i], cost[i + 1]
        den = c0 - 2.0 * c1 + c2
        if den > 0:
            d += 0.25 * 0.5 * (c0 - c2) / den
    share = np.clip(1.0 - sse(d) / sse0, 0.0, 1.0)
    p = np.full(m, np.nan)
    # The realignment's own correction, τ̂(t − d) − τ̂(t), is the column tested: −τ̂' d fits a small
    # shift of a smooth prediction, but not the d-sample step a delayed Coulomb jump leaves, whose
    # misfit the HC1 variance turned into lost power (a 4-sample delay removing 85 % of a joint's
    # mean square at p = 0.03). d is chosen from the data among the 2·big + 1 whole shifts: the
    # p-value is multiplied by their number (Bonferroni), so a right model is not called delayed.
    # the realignment's correction on the rows every shift reaches (the only rows tested)
    # (column-major: each joint's column contiguous, as the products below read it)
    correction = np.asfortranarray(_shifted(pred, d, inner) - pred[inner] if d != 0.0 else
                                   np.zeros((inner.stop - inner.start, m)))
    searched = 2 * big + 1
    for j in range(m):
        c, y = correction[:, j], e0[inner, j]
        if not np.any(c):
            continue
        # one column absorbs little of the noise: the AR model of what it leaves is not too white
        b = float(c @ y) / float(c @ c)
        a, _ = _ar_prewhitener(y - b * c, min(_MAX_AR, n // 50))
        w = _wald_one(_whiten(c, a), _whiten(y, a))
        p[j] = min(1.0, searched * float(scipy.stats.chi2.sf(w, 1)))
    return {"shift_samples": d, "delay_s": d / fs if sample_rate else None, "share": share, "pvalue": p,
            "grid_limit": big,
            "method": "common shift of the prediction (linear interpolation; whole samples, then a 1/4-sample grid); "
                      "each joint's residual against the realignment's correction, Bonferroni over the whole shifts"}
