"""Deterministic inputs: pseudo-random streams built on random.Random(seed).random() only,
the (tau_meas, tau_pred) datasets shared by norms and normalized_fit, and the NIST StRD data."""

from __future__ import annotations

import json
import random
from collections.abc import Sequence
from typing import Any

from mpmath import mpf

from ._config import GOLDEN
from ._exact import columns, rows_of
from ._json import arr, mat


def q(x: float, digits: int = 9) -> float:
    """Round to `digits` significant decimal digits (correctly rounded, platform independent)."""
    return float(format(x, f".{digits}g"))


class Stream:
    """Deterministic pseudo-random numbers built only on ``random.Random(seed).random()``."""

    def __init__(self, seed: int):
        self._rng = random.Random(seed)

    def uniform(self, lo: float = 0.0, hi: float = 1.0) -> float:
        return lo + (hi - lo) * self._rng.random()

    def normal(self) -> float:
        # Irwin-Hall: sum of 12 uniforms minus 6 (mean 0, variance 1); only + and - involved.
        s = 0.0
        for _ in range(12):
            s += self._rng.random()
        return s - 6.0

    def noise(self, n: int, scale: float = 1.0, digits: int = 9) -> list[float]:
        return [q(scale * self.normal(), digits) for _ in range(n)]

    def ar1(self, n: int, a: float, scale: float = 1.0) -> list[float]:
        out, prev = [], 0.0
        for _ in range(n):
            prev = a * prev + self.normal()
            out.append(q(scale * prev))
        return out

    def ar2(self, n: int, a1: float, a2: float, scale: float = 1.0) -> list[float]:
        out, p1, p2 = [], 0.0, 0.0
        for _ in range(n):
            x = a1 * p1 + a2 * p2 + self.normal()
            p2, p1 = p1, x
            out.append(q(scale * x))
        return out


def trajectory(s: Stream, n: int, m: int, means: Sequence[float], scales: Sequence[float]) -> list[list[float]]:
    """Smooth joint torques: mean + scale * (random-phase polynomial-free AR(2) motion)."""
    cols = []
    for j in range(m):
        base = s.ar2(n, 1.6, -0.7, 1.0)
        cols.append([q(means[j] + scales[j] * 0.2 * b) for b in base])
    return rows_of(cols)


def predict(s: Stream, meas: Sequence[Sequence[float]], rel: Sequence[float], ar: float = 0.0) -> list[list[float]]:
    """A prediction = measurement - residual, residual of size rel[j] (optionally AR(1) coloured)."""
    cols = columns(meas)
    out = []
    for j, col in enumerate(cols):
        res = s.ar1(len(col), ar, rel[j]) if ar else s.noise(len(col), rel[j])
        out.append([q(v - r, 12) for v, r in zip(col, res)])
    return rows_of(out)


def metric_datasets() -> list[dict]:
    """Named (tau_meas, tau_pred) pairs used by the norms and normalized_fit families."""
    ds = []

    def add(name, comment, flags, meas, pred, one_d=False, mixed=False):
        ds.append({"name": name, "comment": comment, "flags": flags, "meas": meas, "pred": pred,
                   "one_d": one_d, "mixed": mixed})

    s = Stream(101)
    meas = trajectory(s, 12, 1, [2.0], [3.0])
    add("basic1", "single joint, 12 samples", ["Basic"], meas, predict(s, meas, [0.3]))
    s = Stream(102)
    meas = trajectory(s, 40, 3, [5.0, -2.0, 0.5], [4.0, 2.0, 1.0])
    add("basic3", "three joints, 40 samples", ["Basic"], meas, predict(s, meas, [0.5, 0.4, 0.2]))
    s = Stream(103)
    meas = trajectory(s, 200, 6, [10.0, -25.0, 8.0, 1.5, -0.8, 0.3], [20.0, 30.0, 12.0, 3.0, 2.0, 0.6])
    add("lesson6", "the lesson's layout: (N, m) = (200, 6), coloured residuals", ["LessonShape", "Autocorrelated"],
        meas, predict(s, meas, [1.0, 1.5, 0.8, 0.2, 0.15, 0.05], ar=0.8))
    s = Stream(104)
    meas = trajectory(s, 30, 7, [1.0] * 7, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0])
    add("seven", "seven joints", ["ManyJoints"], meas, predict(s, meas, [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]))
    s = Stream(105)
    meas = trajectory(s, 15, 1, [0.0], [1.0])
    add("oned", "1-D inputs (N,)", ["OneDimensional"], meas, predict(s, meas, [0.2]), one_d=True)
    s = Stream(106)
    meas = trajectory(s, 15, 1, [1.0], [1.0])
    add("mixed", "tau_meas (N,) and tau_pred (N, 1)", ["MixedPromotion"], meas, predict(s, meas, [0.2]), mixed=True)
    s = Stream(107)
    meas = trajectory(s, 50, 3, [1000.0, 0.0, -3.0], [500.0, 0.001, 2.0])
    add("scales", "joints with means 1000, 0, -3 and scales 500, 1e-3, 2", ["MixedScales"], meas,
        predict(s, meas, [400.0, 0.0004, 0.1]))
    s = Stream(108)
    meas = [[q(1e7 + 0.1 * s.normal())] for _ in range(100)]
    add("offset", "tau = 1e7 + noise of std 0.1, residual std 0.03", ["LargeOffset"], meas, predict(s, meas, [0.03]))
    s = Stream(109)
    meas = [[q(1e7 + 0.1 * s.normal()), q(-1e7 + 0.5 * s.normal())] for _ in range(60)]
    add("offset2", "two joints at +1e7 and -1e7 with small variance", ["LargeOffset"], meas,
        predict(s, meas, [0.05, 0.2]))
    s = Stream(110)
    meas = trajectory(s, 25, 2, [0.0, 1e-6], [1e-6, 3e-6])
    add("tiny", "values of order 1e-6", ["TinyScale"], meas, predict(s, meas, [1e-7, 5e-7]))
    s = Stream(111)
    meas = trajectory(s, 25, 2, [3e6, -1e6], [1e6, 2e6])
    add("huge", "values of order 1e6", ["HugeScale"], meas, predict(s, meas, [2e5, 1e5]))
    add("n2", "two samples, two joints", ["MinimumSamples"], [[1.0, -2.0], [3.0, 0.5]], [[1.5, -1.0], [2.0, 0.25]])
    add("n3", "three samples", ["SmallN"], [[0.5], [1.5], [-1.0]], [[0.25], [1.0], [-0.5]])
    s = Stream(112)
    meas = trajectory(s, 20, 2, [1.0, 2.0], [1.0, 1.0])
    add("exact", "prediction equals measurement", ["ExactFit"], meas, [list(r) for r in meas])
    add("const", "constant target, imperfect prediction", ["ConstantTarget"],
        [[2.5]] * 6, [[2.5], [2.0], [3.0], [2.5], [2.25], [2.75]])
    add("const_exact", "constant target, exact prediction", ["ConstantTarget", "ExactFit"], [[2.5]] * 6, [[2.5]] * 6)
    add("const_shift", "constant target, prediction off by a constant (residual constant: VAF exact)",
        ["ConstantTarget", "ConstantResidual"], [[4.0]] * 5, [[3.5]] * 5)
    s = Stream(113)
    base = trajectory(s, 20, 2, [1.0, -1.0], [2.0, 1.0])
    meas = [[r[0], 7.0, r[1]] for r in base]
    pred0 = predict(s, base, [0.2, 0.1])
    pred = [[p[0], 7.0 + (0.5 if k % 3 == 0 else -0.25), p[1]] for k, p in enumerate(pred0)]
    add("constjoint", "joint 1 constant (7.0) among two normal joints", ["ConstantJoint"], meas, pred)
    add("allconst", "every joint constant, one predicted exactly", ["AllJointsConstant", "ConstantTarget"],
        [[1.0, 2.0]] * 4, [[1.0, 2.5], [1.0, 1.5], [1.0, 2.0], [1.0, 2.25]])
    return ds


def enc_signal(d: dict, which: str) -> dict:
    rows = d["meas"] if which == "meas" else d["pred"]
    if d["one_d"] or (d["mixed"] and which == "meas"):
        return arr([r[0] for r in rows], [len(rows)])
    return mat(rows)


NIST_UNIVARIATE = ("Lew", "Lottery", "Mavro", "Michelso", "NumAcc1", "NumAcc2", "NumAcc3", "NumAcc4")


def nist_univariate(name: str) -> list[float]:
    text = (GOLDEN / "data" / "nist_strd" / f"{name}.dat").read_text(encoding="ascii")
    # NIST header lines are prefixed with '#'; one decimal value per data line, parsed correctly rounded.
    return [float(ln.split()[0]) for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]


def nist_certified() -> dict:
    return json.loads((GOLDEN / "data" / "nist_strd" / "certified.json").read_text(encoding="utf-8"))


def check_certified(name: str, what: str, value: mpf, certified: Any, digits: int) -> None:
    ref = mpf(certified if isinstance(certified, str) else str(certified))
    if ref == 0:
        ok = abs(value) < mpf(10) ** -digits
    else:
        ok = abs(value - ref) <= abs(ref) * mpf(10) ** (-digits)
    if not ok:
        raise AssertionError(f"NIST {name} {what}: computed {value}, certified {certified}")


# Data scales of the ExtremeScale vectors (contract §1.3): products of two sums of squares overflow
# (1e80) or underflow (1e-80); the largest accepted decade (1e140; 1e150 is beyond the 1e144 bound);
# squares that underflow (1e-150 centred sums of a 1e-3 spread, 1e-162); subnormal data (1e-310).
EXTREME_SCALES = (1e80, 1e-80, 1e140, 1e-150, 1e-162, 1e-310)


def scaled(rows, factor: float) -> list:
    """Every value times `factor`, rounded once to float64 (the vector's input is that float64)."""
    if isinstance(rows, (list, tuple)):
        return [scaled(r, factor) for r in rows]
    return rows * factor


def scale_comment(factor: float) -> str:
    return f"data scaled by {factor:g}"
