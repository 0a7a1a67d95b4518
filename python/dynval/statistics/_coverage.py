"""Whether a prediction band's misses depend on the state: a coverage test a missing term cannot pass.

The share of measurements inside a band cannot show a missing term: the term inflates the noise
level estimated on the estimation run too, so the band widens with the error and the overall share
stays near, or above, its level. What a missing term cannot hide is *where* the band misses: its
torque is a function of the state (the velocity's sign for Coulomb friction, the posture for
gravity), so the measurements leave the band's centre on one side in one state and on the other in
another. Noise, white or coloured, does not depend on the state. Per joint (docs/conventions.md §5.8):

* **state**: the standardised residual ``z = (τ − τ̂)/std`` less its least-squares refit on the
  model's own columns on this run (an error of the estimated parameters moves the residual only along
  them: what is left no parameter value can produce) is put in bins by each state variable (the
  joint's velocity sign, its position's quantiles, the prediction's quantiles). With the band's
  model the sum ``S_b`` of each bin has mean zero and the variance ``n_b · LRV_b`` of the bin's own
  stretches (:func:`~dynval.statistics._stats.long_run_variance`, colour-aware, no lag across two
  stretches); ``W = Σ_b S_b² / (n_b · LRV_b)`` over the B bins is referred to F(B, ν)·B with ν the
  smallest bin's effective sample size less one.
* **time**: the exceedance indicator (outside the band) taken every ⌈N/N_eff⌉-th sample, N_eff the
  residual's colour-aware effective sample size, so that the kept samples are about independent
  under its own colour, and the exact Wald–Wolfowitz runs test, one-sided (fewer runs than
  independent exceedances give: they cluster). A time-only test cannot tell a slow noise from a
  slow missing term; it adds what a state the caller did not give may hide.

A joint's p-value is the smallest of its components' times their number (Bonferroni); Holm's
correction runs over the joints.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import scipy.special
    import scipy.stats
else:
    from .._lazy import scipy

from ._stats import holm, long_run_variance

__all__ = ["CoverageTest", "coverage_test", "COMPONENTS", "MIN_BIN"]

COMPONENTS = ("velocity_sign", "posture", "prediction", "runs")
"""The components, in the order of :attr:`CoverageTest.component_pvalues`' columns."""

MIN_BIN = 20
"""A state bin with fewer samples is merged into its neighbour (a side of the velocity sign with fewer
samples leaves the component untested)."""

_WORDS = {
    "velocity_sign": "the residual's mean differs between the joint's two directions of motion (friction?)",
    "posture": "the residual's mean depends on the joint's position (gravity, a posture-dependent term?)",
    "prediction": "the residual's mean depends on the size of the predicted torque (a missing or wrong term)",
    "runs": "the exceedances come in clusters in time",
}


@dataclass(frozen=True)
class CoverageTest:
    """The result of :meth:`dynval.identify.PredictionInterval.coverage_test` (contract §9).

    Attributes
    ----------
    pvalue : ndarray (m,)
        Each joint's p-value: the smallest component p-value times the number of components tested.
    adjusted : ndarray (m,)
        ``pvalue`` after Holm's correction over the joints.
    rejected : ndarray of bool (m,)
        ``adjusted <= alpha``: the band fails its coverage test on that joint.
    statistic : ndarray (m,)
        The statistic of the component with the smallest p-value (a Wald statistic W, or the runs
        test's standardised number of runs); nan when no component was tested.
    component : tuple of str
        Per joint, the name of that component (one of :data:`COMPONENTS`; ``""`` when none).
    component_pvalues, component_statistics : ndarray (m, 4)
        Every component's p-value and statistic, columns in the order of :data:`COMPONENTS`; nan
        where a component was not tested (no q or dq given, too few samples on one side, no exceedance).
    n_eff : ndarray (m,)
        The colour-aware effective sample size of each joint's standardised residual.
    share_inside : ndarray (m,)
        :meth:`~dynval.identify.PredictionInterval.share_inside`, for reference.
    level, alpha : float
        The band's probability and the test's significance level.
    n_samples : int
    """

    pvalue: np.ndarray
    adjusted: np.ndarray
    rejected: np.ndarray
    statistic: np.ndarray
    component: tuple[str, ...]
    component_pvalues: np.ndarray
    component_statistics: np.ndarray
    n_eff: np.ndarray
    share_inside: np.ndarray
    level: float
    alpha: float
    n_samples: int

    @property
    def passed(self) -> bool:
        """True when no joint's band fails."""
        return not bool(np.any(self.rejected))

    @property
    def decision(self) -> str:
        """``"pass"`` or ``"fail"``."""
        return "pass" if self.passed else "fail"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (arrays as lists; nan as a string as in reports)."""
        from ..checks._json import to_jsonable

        out: dict[str, Any] = to_jsonable({
            "decision": self.decision,
            "level": self.level,
            "alpha": self.alpha,
            "n_samples": self.n_samples,
            "components": list(COMPONENTS),
            "pvalue": self.pvalue,
            "adjusted": self.adjusted,
            "rejected": self.rejected,
            "statistic": self.statistic,
            "component": list(self.component),
            "component_pvalues": self.component_pvalues,
            "component_statistics": self.component_statistics,
            "n_eff": self.n_eff,
            "share_inside": self.share_inside,
            "summary": str(self),
        })
        return out

    def __str__(self) -> str:
        lvl = f"{100 * self.level:g} %"
        m = int(np.count_nonzero(~np.isnan(self.pvalue)))  # Holm's family: the joints tested
        failed = [j for j in range(self.pvalue.size) if self.rejected[j]]
        untested = [j for j in range(self.pvalue.size) if not self.component[j]]
        note = ("" if not untested else " Not tested (no component could be formed, or a band of zero width): "
                + "joint " + ", ".join(str(j) for j in untested) + ".")
        if not failed:
            return (f"The {lvl} band passes its coverage test (Holm over {m} joint(s) at alpha = {self.alpha:g}): "
                    "its misses do not depend on the state or cluster in time." + note)
        parts = [f"joint {j} (p = {self.adjusted[j]:.2g}, {100 * self.share_inside[j]:.1f} % inside): "
                 f"{_WORDS[self.component[j]]}" for j in failed]
        return (f"The {lvl} band fails its coverage test (Holm over {m} joint(s) at alpha = {self.alpha:g}) on "
                + "; ".join(parts) + ". Where the band misses depends on the state or the time: a term is "
                "missing or wrong, which the share inside cannot show (the term widened the band too)." + note)


def _bins_by_quantile(x: np.ndarray, n_bins: int) -> np.ndarray:
    """Bin labels 0..B−1 by the quantiles of ``x`` (ties kept together, so fewer bins may come out)."""
    edges = np.quantile(x, np.linspace(0.0, 1.0, n_bins + 1)[1:-1])
    return np.searchsorted(np.unique(edges), x, side="right")


def _merge_small(labels: np.ndarray) -> np.ndarray:
    """Merge every bin with fewer than MIN_BIN samples into the next (or the last into the previous)."""
    ids = list(np.unique(labels))
    counts = {b: int(np.count_nonzero(labels == b)) for b in ids}
    merged = labels.copy()
    i = 0
    while i < len(ids) and len(ids) > 1:
        b = ids[i]
        if counts[b] >= MIN_BIN:
            i += 1
            continue
        into = ids[i + 1] if i + 1 < len(ids) else ids[i - 1]
        merged[merged == b] = into
        counts[into] += counts.pop(b)
        ids.pop(i)
    out: np.ndarray = np.searchsorted(np.array(ids), merged)
    return out


def _stretch_starts(idx: np.ndarray) -> np.ndarray:
    """Starts, in the bin's own indexing, of its runs of consecutive samples (no lag joins two of them)."""
    return np.flatnonzero(np.diff(idx, prepend=-2) != 1)


def _state_wald(z: np.ndarray, labels: np.ndarray) -> tuple[float, float]:
    """W = Sᵀ Cov⁻¹ S over the bins (module docstring) and its p-value; (nan, nan) with one bin."""
    bins = np.unique(labels)
    if bins.size < 2:
        return float("nan"), float("nan")
    s = np.empty(bins.size)
    noise = np.empty(bins.size)
    n_eff = np.empty(bins.size)
    for i, b in enumerate(bins):
        idx = np.flatnonzero(labels == b)
        lrv = long_run_variance(z[idx], _stretch_starts(idx))
        s[i] = z[idx].sum()
        noise[i] = idx.size * float(lrv.long_run_variance[0]) if np.isfinite(lrv.long_run_variance[0]) else 0.0
        n_eff[i] = float(lrv.n_eff[0])
    with np.errstate(divide="ignore", invalid="ignore"):
        w = float(np.sum(np.where(noise > 0, s**2 / noise, np.where(s == 0, 0.0, np.inf))))
    dof = max(float(n_eff.min()) - 1.0, 1.0)
    return w, float(scipy.stats.f.sf(w / bins.size, bins.size, dof))


def _runs_lower_tail(hits: np.ndarray) -> tuple[float, float]:
    """Exact one-sided Wald–Wolfowitz test: P(R ≤ r) given the counts; returns (standardised R, p).

    (nan, nan) when the series holds only one kind (no exceedance, or nothing inside)."""
    n1 = int(np.count_nonzero(hits))
    n0 = hits.size - n1
    if n1 == 0 or n0 == 0:
        return float("nan"), float("nan")
    r = 1 + int(np.count_nonzero(hits[1:] != hits[:-1]))
    n = n1 + n0
    mean = 1.0 + 2.0 * n1 * n0 / n
    var = 2.0 * n1 * n0 * (2.0 * n1 * n0 - n) / (n**2 * (n - 1.0)) if n > 1 else 0.0
    zstat = (r - mean) / math.sqrt(var) if var > 0 else 0.0
    lnc = scipy.special.gammaln

    def log_comb(a: int, b: int) -> float:
        return float(lnc(a + 1) - lnc(b + 1) - lnc(a - b + 1)) if 0 <= b <= a else -math.inf

    total = log_comb(n, n1)
    terms = []
    for runs in range(2, r + 1):
        k = runs // 2
        if runs % 2 == 0:
            terms.append(math.log(2.0) + log_comb(n1 - 1, k - 1) + log_comb(n0 - 1, k - 1))
        else:
            terms.append(np.logaddexp(log_comb(n1 - 1, k - 1) + log_comb(n0 - 1, k),
                                      log_comb(n1 - 1, k) + log_comb(n0 - 1, k - 1)))
    logs = np.array(terms) - total
    p = float(np.exp(scipy.special.logsumexp(logs))) if logs.size else 0.0
    return zstat, min(p, 1.0)


def _partitions(j: int, pred: np.ndarray, q: np.ndarray | None, dq: np.ndarray | None,
                n_bins: int) -> dict[str, np.ndarray | None]:
    """Each state component's bin labels for joint j (None when it cannot be formed)."""
    n = pred.shape[0]
    velocity = dq[:, j] if dq is not None else (np.gradient(q[:, j]) if q is not None and n > 1 else None)
    out: dict[str, np.ndarray | None] = {"velocity_sign": None, "posture": None}
    if velocity is not None:
        sides = (velocity > 0).astype(np.int64)
        counts = np.bincount(sides, minlength=2)
        out["velocity_sign"] = sides if counts.min() >= MIN_BIN else None
    if q is not None:
        out["posture"] = _merge_small(_bins_by_quantile(q[:, j], n_bins))
    out["prediction"] = _merge_small(_bins_by_quantile(pred[:, j], n_bins))
    return out


def off_model(z: np.ndarray, g: np.ndarray | None) -> np.ndarray:
    """``z`` less its least-squares fit on the model's own columns ``g`` (N, r) on this run.

    An error of the estimated parameters moves the residual only along the model's columns, by as
    much as the estimation noise allows, and a coloured noise allows far more than the white-noise
    covariance says (and how much more cannot be told from one run whose residual is slow). What is
    left after the refit is what no value of the model's parameters can produce: a missing term.
    """
    if g is None or g.shape[1] == 0:
        return z
    coef = np.linalg.lstsq(g, z, rcond=None)[0]
    out: np.ndarray = z - g @ coef
    return out


def coverage_test(meas: np.ndarray, pred: np.ndarray, std: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                  level: float, *,
                  design: np.ndarray | None, q: np.ndarray | None,
                  dq: np.ndarray | None, n_bins: int, alpha: float) -> CoverageTest:
    """The test on checked arrays: ``meas``, ``pred``, ``std``, the band's edges, ``q``, ``dq`` (N, m); ``design``
    (N, m, r) the base regressor rows (or None)."""
    n, m = meas.shape
    with np.errstate(divide="ignore", invalid="ignore"):
        z = (meas - pred) / std
    # A band of zero width somewhere (an exact fit's noise level) cannot standardise its misses: the
    # joint is not tested, and its share inside says what there is to say.
    testable = np.all(std > 0, axis=0)
    z = np.where(testable, z, 0.0)
    inside = (meas >= lower) & (meas <= upper)  # as share_inside counts
    hits = ~inside
    lrv = long_run_variance(z, np.array([0]))
    n_eff = np.asarray(lrv.n_eff, dtype=np.float64)
    pvals = np.full((m, len(COMPONENTS)), np.nan)
    stats = np.full((m, len(COMPONENTS)), np.nan)
    for j in (int(k) for k in np.flatnonzero(testable)):
        zj = off_model(z[:, j], None if design is None else design[:, j, :] / std[:, j:j + 1])
        for c, labels in _partitions(j, pred, q, dq, n_bins).items():
            if labels is not None:
                col = COMPONENTS.index(c)
                stats[j, col], pvals[j, col] = _state_wald(zj, labels)
        step = max(1, math.ceil(n / n_eff[j] - 1e-9))
        stats[j, -1], pvals[j, -1] = _runs_lower_tail(hits[::step, j])
    tested = np.sum(~np.isnan(pvals), axis=1)
    with np.errstate(invalid="ignore"):
        best = np.where(tested > 0, np.nanmin(np.where(np.isnan(pvals), np.inf, pvals), axis=1), np.nan)
    pvalue = np.minimum(best * tested, 1.0)
    adjusted = holm(pvalue)
    which = tuple(COMPONENTS[int(np.nanargmin(pvals[j]))] if tested[j] else "" for j in range(m))
    statistic = np.array([stats[j, COMPONENTS.index(which[j])] if which[j] else np.nan for j in range(m)])
    return CoverageTest(pvalue=pvalue, adjusted=adjusted, rejected=np.nan_to_num(adjusted, nan=1.0) <= alpha,
                        statistic=statistic, component=which, component_pvalues=pvals,
                        component_statistics=stats, n_eff=n_eff, share_inside=inside.mean(axis=0), level=level,
                        alpha=alpha, n_samples=n)
