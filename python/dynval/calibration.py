"""Size and power of the report's findings, measured by simulation (docs/conventions.md §5.5).

A finding is a statistical detector: this module measures how often it fires when the model is
right (size: the share of replicates with any ``deficiency`` finding, to be at most 1 − level)
and how often the right finding fires when the model lacks a term (power, and whether the cause is
named). The robot is the 2-DOF vertical arm of :mod:`dynval.simulate`, sampled at 100 Hz, with an
estimation and a validation trajectory drawn independently (finite Fourier series).

Noise (σ = 0.2 N·m marginal standard deviation on each joint):
``white`` Gaussian; ``t3`` Student t with 3 degrees of freedom (heavy tails); ``ar0.9`` and
``ar0.99`` AR(1) Gaussian with coefficient 0.9 and 0.99 (filtered sensor noise).

Models (the candidate validated; the regressor handed to ``validate`` always holds every column of
the true structure, so a missing column can be named):
``exact``: the true structure with the true parameters (the residual is the noise itself: the exact
null hypothesis); ``estimated``: the true structure estimated by least squares on the estimation
run (the null with estimation error); ``zero_coulomb``: a robot without Coulomb friction and a
model without its columns (right, and the null of the missing-term test, which tests them);
``no_coulomb``: Coulomb friction (F_c = σ on both joints) left out; ``no_gravity``: the gravity term
MY1 (m₁c_y1·g = 2.2σ: an RMS of about σ) left out; ``mode``: an unmodelled, lightly damped mode
(7 Hz, ζ = 0.02, standard deviation σ on the elbow) in the measured torque.

Run ``python benchmarks/calibrate_findings.py`` for the table.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

__all__ = ["NOISES", "MODELS", "SIZE_MODELS", "CauseCheck", "simulate_replicate", "run_case", "SAMPLE_RATE", "SIGMA"]

SAMPLE_RATE = 100.0
SIGMA = 0.2
N_SAMPLES = 2000
MODE_FREQUENCY = 7.0
MODE_DAMPING = 0.02
NOISES = ("white", "t3", "ar0.9", "ar0.99")
MODELS = ("exact", "estimated", "zero_coulomb", "no_coulomb", "no_gravity", "mode")
SIZE_MODELS = ("exact", "estimated", "zero_coulomb")  # the model is right: any deficiency is a false alarm


def _noise(kind: str, rng, shape):
    n, m = shape
    if kind == "white":
        return rng.normal(0.0, SIGMA, size=shape)
    if kind == "t3":
        return rng.standard_t(3, size=shape) * SIGMA / math.sqrt(3.0)
    if kind.startswith("ar"):
        rho = float(kind[2:])
        w = rng.normal(0.0, SIGMA * math.sqrt(1.0 - rho * rho), size=shape)
        x = np.empty(shape)
        x[0] = rng.normal(0.0, SIGMA, size=m)
        for k in range(1, n):
            x[k] = rho * x[k - 1] + w[k]
        return x
    raise ValueError(f"unknown noise {kind!r}")


def _mode(rng, n):
    """A lightly damped mode: AR(2) with poles r·e^{±iω₀}, scaled to standard deviation σ."""
    w0 = 2.0 * math.pi * MODE_FREQUENCY / SAMPLE_RATE
    r = math.exp(-MODE_DAMPING * w0)
    a1, a2 = 2.0 * r * math.cos(w0), -r * r
    burn = 2000
    w = rng.normal(size=n + burn)
    x = np.zeros(n + burn)
    for k in range(2, n + burn):
        x[k] = a1 * x[k - 1] + a2 * x[k - 2] + w[k]
    x = x[burn:]
    return x * SIGMA / x.std()


def _trajectory(rng, t):
    from .simulate import fourier_trajectory

    n_h = 5
    k = np.arange(1, n_h + 1)
    amplitudes = rng.uniform(0.2, 0.6, size=(2, n_h)) / k
    phases = rng.uniform(0.0, 2.0 * math.pi, size=(2, n_h))
    offsets = np.array([rng.uniform(-0.5, 0.5), rng.uniform(0.3, 1.2)])
    return fourier_trajectory(t, offsets, amplitudes, phases, 0.1)


@dataclass(frozen=True)
class CauseCheck:
    """What a finding must say for the detection to name the right cause: one of ``kinds``, on
    ``joint``, naming first a column whose name starts with ``column`` (a missing term appears as a
    correlation with the column or as a bias the column accounts for), near ``frequency``."""

    kinds: tuple
    joint: int | None = None
    column: str | None = None
    frequency: float | None = None


def _setup(model: str):
    from . import simulate as sim

    arm = sim.DEFAULT_ARM
    names = list(sim.PARAMETER_NAMES)
    drop: list[str] = []
    cause = None
    if model == "zero_coulomb":
        # The robot has no Coulomb friction and the model leaves the columns out: right, and a null
        # case for the missing-term test (the columns are tested and must not be called missing).
        arm = replace(arm, fc1=0.0, fc2=0.0)
        drop = ["Fc1", "Fc2"]
    elif model == "no_coulomb":
        arm = replace(arm, fc1=SIGMA, fc2=SIGMA)
        drop = ["Fc1", "Fc2"]
        cause = CauseCheck(("regressor_correlation", "bias"), column="Fc")
    elif model == "no_gravity":
        # sin q1 has an RMS of about 0.45 on these trajectories: MY1·g = 2.2σ gives a term whose
        # RMS is about σ (benchmarks/calibrate_findings.py prints the measured value).
        arm = replace(arm, cy1=2.2 * SIGMA / (arm.m1 * sim.GRAVITY))
        drop = ["MY1"]
        cause = CauseCheck(("regressor_correlation", "bias"), joint=0, column="MY1")
    elif model == "mode":
        cause = CauseCheck(("oscillation",), joint=1, frequency=MODE_FREQUENCY)
    return arm, names, drop, cause


def simulate_replicate(noise: str, model: str, seed: int, *, backend=None, n_samples: int = N_SAMPLES,
                       with_estimation: bool = True):
    """One replicate: simulate, estimate (unless ``exact``), validate; returns the report and the check.

    ``with_estimation`` hands the estimation run (regressor and torques) to ``validate``, which then
    allows for the parameters' uncertainty and names a missing term by refitting (the default, as a
    user who identified the model has that run); without it the findings see the validation run only.
    """
    from . import simulate as sim
    from .report._report import validate

    rng = np.random.default_rng(seed)
    arm, names, drop, cause = _setup(model)
    pi = sim.base_parameters(arm)
    t = np.arange(n_samples) / SAMPLE_RATE
    runs = []
    for _ in range(2):
        q, dq, ddq = _trajectory(rng, t)
        Y = sim.regressor(q, dq, ddq)
        tau = Y @ pi + _noise(noise, rng, (n_samples, 2))
        if model == "mode":
            tau[:, 1] += _mode(rng, n_samples)
        runs.append((Y, tau))
    (y_est, tau_est), (y_val, tau_val) = runs
    keep = [i for i, nm in enumerate(names) if nm not in drop]
    if model == "exact":
        pi_hat = pi
    else:
        stacked = y_est[:, :, keep].reshape(-1, len(keep))
        pi_hat, *_ = np.linalg.lstsq(stacked, tau_est.reshape(-1), rcond=None)
    pred = y_val[:, :, keep] @ pi_hat
    report = validate(tau_val, pred, n_params=len(keep), regressor=y_val, column_names=names,
                      sample_rate=SAMPLE_RATE, max_lag=50, backend=backend, model_columns=keep,
                      estimation={"regressor": y_est, "tau": tau_est} if with_estimation else None)
    return report, cause


def named_right_cause(report, cause: CauseCheck | None) -> bool:
    """True when a deficiency finding of the expected kind names the expected cause first."""
    if cause is None:
        return False
    names = report.provenance["column_names"]
    for f in report.deficiencies:
        if f.kind not in cause.kinds:
            continue
        if cause.joint is not None and f.joints[0] != cause.joint:
            continue
        if cause.column is not None and not (f.columns and names[f.columns[0]].startswith(cause.column)):
            continue
        if cause.frequency is not None and abs(f.details["frequency"] - cause.frequency) > 0.1 * cause.frequency:
            continue
        return True
    return False


def run_case(noise: str, model: str, replicates: int, *, first_seed: int = 0, backend=None, progress=None,
             with_estimation: bool = True):
    """Replicates of one case; returns a dict of counts (any deficiency, right cause, kinds)."""
    anyd = right = 0
    kinds: dict[str, int] = {}
    for i in range(replicates):
        report, cause = simulate_replicate(noise, model, first_seed + i, backend=backend,
                                           with_estimation=with_estimation)
        found = report.deficiencies
        anyd += bool(found)
        right += named_right_cause(report, cause)
        for k in {f.kind for f in found}:
            kinds[k] = kinds.get(k, 0) + 1
        if progress is not None:
            progress(i + 1, replicates)
    return {"noise": noise, "model": model, "replicates": replicates, "any_deficiency": anyd,
            "right_cause": right, "kinds": kinds}
