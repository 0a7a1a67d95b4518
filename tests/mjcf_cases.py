"""The simulated KUKA case of the MJCF tests: the packaged model's torque on runs 1 (estimation) and
3 (validation) plus 0.3 N·m white noise."""

from __future__ import annotations

import numpy as np

from dynval.datasets import load_kuka_lwr4
from dynval.mjcf import MJCFModel


def simulated_kuka():
    """(estimation run, validation run, the model's MJCF text, [τ estimation, τ validation])."""
    est, val = load_kuka_lwr4(1), load_kuka_lwr4(3)
    right = MJCFModel(est.mjcf)
    rng = np.random.default_rng(20261207)
    taus = [right.predict(r.q, r.dq, r.ddq) + 0.3 * rng.standard_normal(r.q.shape) for r in (est, val)]
    return est, val, est.mjcf.read_text(encoding="utf-8"), taus
