"""Residual mean and variance per joint."""

from __future__ import annotations

import numpy as np

from ...checks._validation import check_ddof
from ._common import finite_residual
from .norms import joint_major, moments, moments_scaled


def residual_mean(e) -> np.ndarray:
    """Mean of each joint's residual, ``(m,)``."""
    e = finite_residual(e)
    return moments(joint_major(e))[0]


def residual_variance(e, ddof) -> np.ndarray:
    """Σ(e − ē_j)²/(N − ddof) per joint, ``(m,)`` (exactly 0 for a constant residual)."""
    e = finite_residual(e)
    ddof = check_ddof(ddof, e.shape[0])
    # Divided in scaled units, then scaled back: the variance underflows only if it is itself
    # below float64's range.
    _, ss, _, k = moments_scaled(joint_major(e))
    return np.ldexp(ss / (e.shape[0] - ddof), 2 * k)
