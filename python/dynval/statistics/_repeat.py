"""Does the validation run retrace the estimation run? The share of its states near the estimation
trajectory at any time (docs/conventions.md §5.6).

A run that repeats the estimation trajectory, with a time shift or on a later period of a periodic
excitation, measures the fit rather than the prediction of new motion. Comparing rows at equal times
misses both cases, so each validation state is compared with the whole estimation trajectory:

* both runs are averaged over blocks of 0.1 s (at least 7 samples; longer blocks for runs beyond
  20,000 of them): a low-pass that also bounds the work;
* the state is (q, q̇, q̈), what a regressor row is a function of: the block means of q and their
  Savitzky–Golay derivatives (degree 4 over 7 blocks, the same filter on both runs; the estimation
  run has no q̇ of its own, and a given q̇ filtered otherwise would differ by the filters alone).
  Without ``q`` in both runs it is the 3m leading principal components of the regressor's block
  means, smoothed (Savitzky–Golay, degree 2 over 7 blocks) and standardised: the noise of its
  differentiated columns averages out and spreads over the trailing components;
* every coordinate is scaled by the estimation run's standard deviation (floored at 1 % of the
  validation run's, so that a coordinate the estimation run holds still and the validation run
  moves is far, not undefined); a validation block is *near* when its distance to the polyline
  through the estimation blocks, as a root mean square over the coordinates, is at most
  ``tolerance``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["repeat_share", "near_distances", "block_length"]

_MAX_BLOCKS = 20_000  # rows per run after block averaging: the KD-tree's size and the queries
_PCA_ROWS = 4_000  # rows of the union of both runs that fit the principal components
_SG_BLOCKS = 7  # the derivatives' window, in blocks
_FLOOR = 0.01  # a coordinate's scale is at least this share of the validation run's spread


def block_length(sample_rate: float | None) -> int:
    """Samples of a 0.1 s block (at least 7, odd; 7 without a sample rate), the window the report
    differentiates q with."""
    fs = 1.0 if sample_rate is None else float(sample_rate)
    w = int(round(max(0.1, 7.0 / fs) * fs))
    return w + 1 - w % 2


def _block(n_e: int, n_v: int, window: int) -> int:
    """Samples per block: 0.1 s, longer for long runs, shorter for runs of fewer than 4 blocks."""
    w = max(window, math.ceil(max(n_e, n_v) / _MAX_BLOCKS))
    return max(1, min(w, min(n_e, n_v) // 4))


def _block_means(x: np.ndarray, w: int) -> np.ndarray:
    n = (x.shape[0] // w) * w
    if w == 1:
        return np.asarray(x[:n], dtype=float)
    return np.asarray(x[:n].reshape(n // w, w, -1).mean(axis=1), dtype=float)


def _motion_state(q: np.ndarray) -> np.ndarray:
    """(q, q̇, q̈) of a block-averaged q, time in blocks (the scale drops out): Savitzky–Golay of
    degree 4 over 7 blocks, or central differences on series shorter than that."""
    if q.shape[0] < _SG_BLOCKS + 2:
        d1 = np.gradient(q, axis=0) if q.shape[0] > 1 else np.zeros_like(q)
        d2 = np.gradient(d1, axis=0) if q.shape[0] > 1 else np.zeros_like(q)
        return np.hstack([q, d1, d2])
    import scipy.signal

    d = [np.asarray(scipy.signal.savgol_filter(q, _SG_BLOCKS, 4, deriv=k, axis=0), dtype=float) for k in (1, 2)]
    return np.hstack([q, *d])


def _state_noise(q: np.ndarray, w: int) -> np.ndarray:
    """Per coordinate of :func:`_motion_state` on blocks of ``w`` samples, the standard deviation
    white sensor noise on q gives it: the noise of the logged q from its third differences at the
    logged rate (robustly: 1.4826 MAD / √20; there the motion adds almost nothing, where on the
    blocks it would pass for noise), over √w for a block mean, carried through the state's filters
    (the identity for q, the Savitzky–Golay coefficients' norm for q̇ and q̈). Coloured noise shows
    less at the logged rate: the estimate errs towards no correction."""
    m = q.shape[1]
    if q.shape[0] < 4 or q.shape[0] // max(w, 1) < _SG_BLOCKS + 2:
        return np.zeros(3 * m)
    import scipy.signal

    d3 = np.diff(np.asarray(q, dtype=float), n=3, axis=0)
    sd = 1.4826 * np.median(np.abs(d3 - np.median(d3, axis=0)), axis=0) / math.sqrt(20.0 * w)
    gains = [1.0] + [float(np.linalg.norm(scipy.signal.savgol_coeffs(_SG_BLOCKS, 4, deriv=k))) for k in (1, 2)]
    return np.concatenate([g * sd for g in gains])


def _smooth(x: np.ndarray) -> np.ndarray:
    """Savitzky–Golay smoothing of degree 2 over 7 blocks (the regressor's noisy differentiated
    columns); series shorter than that as they are."""
    if x.shape[0] < _SG_BLOCKS + 2:
        return x
    import scipy.signal

    return np.asarray(scipy.signal.savgol_filter(x, _SG_BLOCKS, 2, axis=0), dtype=float)


def _standardise(est: np.ndarray, val: np.ndarray, noise: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray, float]:
    """Both runs' coordinates about the estimation run's mean, over its standard deviation floored
    at 1 % of the validation run's; coordinates constant in both runs are left out. The third value:
    the mean square per coordinate, in these units, that ``noise`` (each coordinate's noise SD, the
    same sensor in both runs) adds to the squared distance between two noisy states (0 without)."""
    mean = est.mean(axis=0)
    sd_e, sd_v = est.std(axis=0), val.std(axis=0)
    scale = np.maximum(sd_e, _FLOOR * sd_v)
    live = scale > 1e-9 * max(float(scale.max(initial=0.0)), np.finfo(float).tiny)
    floor = 0.0
    if noise is not None and np.any(live):
        floor = float(np.mean(2.0 * (noise[live] / scale[live]) ** 2))
    return (est[:, live] - mean[live]) / scale[live], (val[:, live] - mean[live]) / scale[live], floor


def _principal_state(fe: np.ndarray, fv: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The k leading principal components of both runs' standardised features, scaled so that the
    estimation run's mean square per coordinate is 1 (as the standardised q-state's)."""
    both = np.vstack([fe, fv])
    stride = max(1, both.shape[0] // _PCA_ROWS)
    sub = both[::stride]
    _, s, vt = np.linalg.svd(sub, full_matrices=False)
    k = max(1, min(k, int(np.sum(s > 1e-9 * s[0])) if s.size and s[0] > 0 else 1))
    basis = vt[:k].T
    ze, zv = fe @ basis, fv @ basis
    spread = math.sqrt(float(np.mean(ze * ze)))
    spread = spread if spread > 0 else 1.0
    return ze / spread, zv / spread


def near_distances(ze: np.ndarray, zv: np.ndarray, tolerance: float) -> np.ndarray:
    """Each validation row's distance to the polyline through the estimation rows, as an RMS over
    the coordinates; ``inf`` beyond reach of the search (farther than the tolerance for sure).

    The nearest estimation vertex comes from a KD-tree (``scipy.spatial.cKDTree``) searched within
    the tolerance plus half the estimation run's largest step (99th percentile), then the distance
    is refined on the two segments that meet at that vertex.
    """
    from scipy.spatial import cKDTree

    d = ze.shape[1]
    root = math.sqrt(d)
    radius = tolerance * root
    n_e = ze.shape[0]
    steps = np.sqrt(np.sum(np.diff(ze, axis=0) ** 2, axis=1)) if n_e > 1 else np.zeros(1)
    reach = radius + 0.5 * float(np.quantile(steps, 0.99)) + 1e-12
    dist, idx = cKDTree(ze).query(zv, k=1, distance_upper_bound=reach)
    found = np.isfinite(dist)
    best = np.asarray(dist, dtype=float).copy()
    if n_e > 1 and np.any(found):
        i = idx[found]
        x = zv[found]
        for side in (-1, 0):
            a = np.clip(i + side, 0, n_e - 2)
            p0 = ze[a]
            seg = ze[a + 1] - p0
            rel = x - p0
            length2 = np.einsum("ij,ij->i", seg, seg)
            t = np.clip(np.einsum("ij,ij->i", rel, seg) / np.where(length2 > 0, length2, 1.0), 0.0, 1.0)
            gap = rel - t[:, None] * seg
            best[found] = np.minimum(best[found], np.sqrt(np.einsum("ij,ij->i", gap, gap)))
    return np.asarray(best / root, dtype=float)


def repeat_share(q_val: np.ndarray | None, q_est: np.ndarray | None, reg_val: np.ndarray | None,
                 reg_est: np.ndarray | None, sample_rate: float | None, tolerance: float) -> dict[str, Any] | None:
    """The share of the validation run whose state lies within ``tolerance`` of the estimation
    trajectory (module notes): from q when both runs have it, else from the regressor; None when
    neither is in both runs."""
    window = block_length(sample_rate)
    if q_val is not None and q_est is not None and q_val.shape[1] == q_est.shape[1]:
        w = _block(q_est.shape[0], q_val.shape[0], window)
        qe, qv = _block_means(q_est, w), _block_means(q_val, w)
        # the same sensor in both runs: the smaller of the two runs' estimates, so a fast
        # trajectory's own third differences cannot pass for noise and make runs look alike
        noise = np.minimum(_state_noise(q_est, w), _state_noise(q_val, w)) if qe.shape[0] and qv.shape[0] else None
        ze, zv, floor = _standardise(_motion_state(qe), _motion_state(qv), noise)
        state = "q"
    elif reg_val is not None and reg_est is not None and reg_val.shape[1:] == reg_est.shape[1:]:
        m = reg_val.shape[1]
        w = _block(reg_est.shape[0], reg_val.shape[0], window)
        fe = _smooth(_block_means(reg_est.reshape(reg_est.shape[0], -1), w))
        fv = _smooth(_block_means(reg_val.reshape(reg_val.shape[0], -1), w))
        ze, zv, floor = _standardise(fe, fv)
        if ze.shape[1]:
            ze, zv = _principal_state(ze, zv, 3 * m)
        state = "regressor"
    else:
        return None
    if ze.shape[0] == 0 or zv.shape[0] == 0:
        return None
    if ze.shape[1] == 0:  # nothing moves in either run: the same (still) state
        dist = np.zeros(zv.shape[0])
    else:
        # the noise's part of each squared distance taken out (the near test is on the states,
        # not on their sensor noise), searched within the tolerance widened by it
        raw = near_distances(ze, zv, math.sqrt(tolerance ** 2 + floor))
        dist = np.sqrt(np.maximum(raw ** 2 - floor, 0.0))
    return {"share": float(np.mean(dist <= tolerance)), "tolerance": float(tolerance), "state": state,
            "noise_floor": math.sqrt(floor),
            "dimension": int(ze.shape[1]), "block": int(w), "n_compared": int(zv.shape[0]),
            "median_distance": float(np.median(dist)),
            "method": "nearest neighbour at any time (KD-tree), distance to the estimation trajectory as an "
                      "RMS over coordinates scaled by the estimation run's standard deviation"}
