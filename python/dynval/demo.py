"""The embedded demonstration: identify a simulated 2-DOF arm, then validate it.

``dynval demo`` needs no input. It simulates a two-link planar arm moving in a
vertical plane, with gravity, viscous and Coulomb friction and torque sensor
noise; identifies the base parameters by least squares on one exciting
trajectory (a sum of sinusoids); predicts the torques of a *different*
trajectory with the identified model and validates the prediction with
:func:`dynval.validate`. A deliberately reduced model (no Coulomb friction) is
identified and validated the same way, so the report shows what an
under-modelled phenomenon looks like: a worse AIC/BIC, non-white residuals and
a strong cross-correlation between the residual and the missing regressor
column.

The model
---------
Joint angles ``q1`` (link 1 from the horizontal) and ``q2`` (link 2 relative to
link 1); gravity ``g`` acts along the downward vertical. Per link ``i``: mass
``m_i``, centre of mass ``(cx_i, cy_i)`` in the link frame (x along the link),
inertia ``I_i`` about the centre of mass; link 1 has length ``l1``. The joint
torques are linear in the ten base parameters

============  ==================================================
``ZZ1R``      ``I1 + m1 (cx1² + cy1²) + m2 l1²``
``MX1R``      ``m1 cx1 + m2 l1``
``MY1``       ``m1 cy1``
``ZZ2``       ``I2 + m2 (cx2² + cy2²)``
``MX2``       ``m2 cx2``
``MY2``       ``m2 cy2``
``Fv1, Fv2``  viscous friction, ``Fv_j q̇_j``
``Fc1, Fc2``  Coulomb friction, ``Fc_j sign(q̇_j)``
============  ==================================================

with (``c2 = cos q2``, ``s2 = sin q2``, ``c1 = cos q1``, ``c12 = cos(q1 + q2)``, ...)::

    τ1 = ZZ1R q̈1 + ZZ2 (q̈1 + q̈2)
         + MX2 l1 [(2q̈1 + q̈2) c2 − (2q̇1q̇2 + q̇2²) s2]
         − MY2 l1 [(2q̈1 + q̈2) s2 + (2q̇1q̇2 + q̇2²) c2]
         + g (MX1R c1 − MY1 s1) + g (MX2 c12 − MY2 s12) + Fv1 q̇1 + Fc1 sign(q̇1)
    τ2 = ZZ2 (q̈1 + q̈2) + MX2 l1 (q̈1 c2 + q̇1² s2) + MY2 l1 (q̇1² c2 − q̈1 s2)
         + g (MX2 c12 − MY2 s12) + Fv2 q̇2 + Fc2 sign(q̇2)

The test suite checks this regressor against a Newton–Euler recursion written
independently from the physical parameters.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "ArmParameters",
    "DEFAULT_ARM",
    "PARAMETER_NAMES",
    "REDUCED_PARAMETER_NAMES",
    "base_parameters",
    "regressor",
    "fourier_trajectory",
    "identify",
    "run_demo",
    "main",
]

GRAVITY = 9.81
"""Gravitational acceleration in m/s² (acting along the downward vertical)."""

PARAMETER_NAMES = ("ZZ1R", "MX1R", "MY1", "ZZ2", "MX2", "MY2", "Fv1", "Fc1", "Fv2", "Fc2")
"""Names of the columns of :func:`regressor` (the full model)."""

REDUCED_PARAMETER_NAMES = tuple(n for n in PARAMETER_NAMES if not n.startswith("Fc"))
"""The reduced model: the full model without Coulomb friction."""

_REDUCED_COLUMNS = np.array([PARAMETER_NAMES.index(n) for n in REDUCED_PARAMETER_NAMES])


@dataclass(frozen=True)
class ArmParameters:
    """Physical parameters of the two-link planar arm (SI units)."""

    l1: float = 0.5
    m1: float = 8.0
    cx1: float = 0.22
    cy1: float = 0.01
    I1: float = 0.18
    m2: float = 4.0
    cx2: float = 0.2
    cy2: float = -0.015
    I2: float = 0.07
    fv1: float = 1.5
    fc1: float = 2.0
    fv2: float = 0.8
    fc2: float = 1.2


DEFAULT_ARM = ArmParameters()


def base_parameters(arm: ArmParameters = DEFAULT_ARM) -> np.ndarray:
    """Return the ten base parameters of `arm`, in the order of :data:`PARAMETER_NAMES`.

    Examples
    --------
    >>> from dynval.demo import base_parameters, ArmParameters
    >>> float(base_parameters(ArmParameters())[1])  # MX1R = m1 cx1 + m2 l1
    3.76
    """
    a = arm
    return np.array(
        [
            a.I1 + a.m1 * (a.cx1**2 + a.cy1**2) + a.m2 * a.l1**2,
            a.m1 * a.cx1 + a.m2 * a.l1,
            a.m1 * a.cy1,
            a.I2 + a.m2 * (a.cx2**2 + a.cy2**2),
            a.m2 * a.cx2,
            a.m2 * a.cy2,
            a.fv1,
            a.fc1,
            a.fv2,
            a.fc2,
        ]
    )


def regressor(q, qd, qdd, *, l1: float = DEFAULT_ARM.l1, g: float = GRAVITY) -> np.ndarray:
    """Joint-torque regressor ``Y`` of the arm, so that ``τ_k = Y[k] @ π``.

    Parameters
    ----------
    q, qd, qdd : array_like, shape (N, 2)
        Joint positions (rad), velocities (rad/s) and accelerations (rad/s²).
    l1 : float
        Length of link 1 (m).
    g : float
        Gravitational acceleration (m/s²).

    Returns
    -------
    ndarray, shape (N, 2, 10)
        Sample, joint, parameter column (order of :data:`PARAMETER_NAMES`) — the
        layout :func:`dynval.validate` takes as ``regressor``.

    Examples
    --------
    >>> import numpy as np
    >>> from dynval.demo import regressor, base_parameters
    >>> z = np.zeros((1, 2))
    >>> tau = regressor(z, z, z) @ base_parameters()   # arm horizontal, at rest
    >>> tau.shape
    (1, 2)
    """
    q, qd, qdd = (np.asarray(x, dtype=float).reshape(-1, 2) for x in (q, qd, qdd))
    q1, q2 = q[:, 0], q[:, 1]
    d1, d2 = qd[:, 0], qd[:, 1]
    a1, a2 = qdd[:, 0], qdd[:, 1]
    c1, s1 = np.cos(q1), np.sin(q1)
    c2, s2 = np.cos(q2), np.sin(q2)
    c12, s12 = np.cos(q1 + q2), np.sin(q1 + q2)
    centripetal = 2.0 * d1 * d2 + d2**2

    Y = np.zeros((q.shape[0], 2, len(PARAMETER_NAMES)))
    # joint 1
    Y[:, 0, 0] = a1
    Y[:, 0, 1] = g * c1
    Y[:, 0, 2] = -g * s1
    Y[:, 0, 3] = a1 + a2
    Y[:, 0, 4] = l1 * ((2.0 * a1 + a2) * c2 - centripetal * s2) + g * c12
    Y[:, 0, 5] = -l1 * ((2.0 * a1 + a2) * s2 + centripetal * c2) - g * s12
    Y[:, 0, 6] = d1
    Y[:, 0, 7] = np.sign(d1)
    # joint 2
    Y[:, 1, 3] = a1 + a2
    Y[:, 1, 4] = l1 * (a1 * c2 + d1**2 * s2) + g * c12
    Y[:, 1, 5] = l1 * (d1**2 * c2 - a1 * s2) - g * s12
    Y[:, 1, 8] = d2
    Y[:, 1, 9] = np.sign(d2)
    return Y


def fourier_trajectory(t, offsets, amplitudes, phases, base_frequency: float):
    """Sum-of-sinusoids joint trajectory and its exact derivatives.

    ``q_j(t) = offsets[j] + Σ_k amplitudes[j, k] sin(2π f (k+1) t + phases[j, k])``.

    Returns
    -------
    q, qd, qdd : ndarray, shape (N, n_joints)
    """
    t = np.asarray(t, dtype=float)[:, None, None]
    w = 2.0 * np.pi * base_frequency * np.arange(1, amplitudes.shape[1] + 1)
    arg = w * t + phases  # (N, n_joints, n_harmonics)
    q = offsets + np.sum(amplitudes * np.sin(arg), axis=2)
    qd = np.sum(amplitudes * w * np.cos(arg), axis=2)
    qdd = -np.sum(amplitudes * w**2 * np.sin(arg), axis=2)
    return q, qd, qdd


def _random_trajectory(rng, t, base_frequency=0.1, n_harmonics=5):
    # Amplitudes fall as 1/k so the accelerations stay moderate; the offsets put
    # the arm through configurations where gravity varies strongly.
    k = np.arange(1, n_harmonics + 1)
    amplitudes = rng.uniform(0.3, 0.8, size=(2, n_harmonics)) / k
    phases = rng.uniform(0.0, 2.0 * np.pi, size=(2, n_harmonics))
    offsets = rng.uniform(-0.5, 0.5, size=2)
    return fourier_trajectory(t, offsets, amplitudes, phases, base_frequency)


def identify(Y, tau) -> np.ndarray:
    """Least-squares parameter estimate ``π̂ = argmin ‖τ − Y π‖`` on the stacked system.

    Parameters
    ----------
    Y : array_like, shape (N, m, p)
    tau : array_like, shape (N, m)
    """
    Y = np.asarray(Y, dtype=float)
    stacked = Y.reshape(-1, Y.shape[2])  # sample-major: row k*m + j
    pi_hat, *_ = np.linalg.lstsq(stacked, np.asarray(tau, dtype=float).reshape(-1), rcond=None)
    return pi_hat


@dataclass
class DemoModel:
    """One candidate model of the demo: its parameters and its validation report."""

    name: str
    parameter_names: tuple
    parameters: np.ndarray
    report: object  # dynval.ValidationReport


@dataclass
class DemoResult:
    """Everything :func:`run_demo` computed."""

    seed: int
    n_samples: int
    noise: float
    sample_rate: float
    true_parameters: np.ndarray
    models: list = field(default_factory=list)
    condition_number: float = float("nan")

    def to_dict(self) -> dict:
        """JSON-ready dictionary (reports included)."""
        return {
            "demo": "2-DOF planar arm in a vertical plane",
            "seed": self.seed,
            "n_samples": self.n_samples,
            "sample_rate_hz": self.sample_rate,
            "torque_noise_std": self.noise,
            "estimation_regressor_condition_number": self.condition_number,
            "true_parameters": dict(zip(PARAMETER_NAMES, self.true_parameters.tolist())),
            "models": {
                m.name: {
                    "parameters": dict(zip(m.parameter_names, m.parameters.tolist())),
                    "report": m.report.to_dict(),
                }
                for m in self.models
            },
        }

    def summary(self) -> str:
        """Readable text: identified parameters, both reports, and the comparison."""
        return _format_result(self)


def run_demo(*, seed: int = 0, n_samples: int = 2000, noise: float = 0.2,
             sample_rate: float = 100.0, profile: str = "lesson", backend=None,
             progress=None) -> DemoResult:
    """Simulate, identify and validate the 2-DOF arm (full and reduced models).

    Parameters
    ----------
    seed : int
        Seed of the trajectories and the sensor noise.
    n_samples : int
        Samples per trajectory (estimation and validation each).
    noise : float
        Standard deviation of the torque sensor noise (N·m), on each joint.
    sample_rate : float
        Sampling rate (Hz).
    profile : str
        Convention profile passed to :func:`dynval.validate`.
    backend : str or None
        Backend passed to :func:`dynval.validate`.
    progress : callable or None
        Called with a short message before each step.

    Examples
    --------
    >>> from dynval.demo import run_demo
    >>> result = run_demo(n_samples=500)
    >>> [m.name for m in result.models]
    ['full', 'reduced']
    """
    from . import validate

    say = progress or (lambda msg: None)
    rng = np.random.default_rng(seed)
    t = np.arange(n_samples) / sample_rate
    pi_true = base_parameters(DEFAULT_ARM)

    say("simulating the estimation and validation trajectories")
    trajectories = []
    for _ in range(2):
        q, qd, qdd = _random_trajectory(rng, t)
        Y = regressor(q, qd, qdd)
        tau = Y @ pi_true + rng.normal(0.0, noise, size=(n_samples, 2))
        trajectories.append((Y, tau))
    (Y_est, tau_est), (Y_val, tau_val) = trajectories

    result = DemoResult(seed=seed, n_samples=n_samples, noise=noise, sample_rate=sample_rate,
                        true_parameters=pi_true,
                        condition_number=float(np.linalg.cond(Y_est.reshape(-1, Y_est.shape[2]))))
    for name, columns, names in (("full", slice(None), PARAMETER_NAMES),
                                 ("reduced", _REDUCED_COLUMNS, REDUCED_PARAMETER_NAMES)):
        say(f"identifying the {name} model ({len(names)} parameters) by least squares")
        pi_hat = identify(Y_est[:, :, columns], tau_est)
        tau_pred = Y_val[:, :, columns] @ pi_hat
        say(f"validating the {name} model on the validation trajectory")
        # Cross-correlate with the *full* candidate regressor: a residual that
        # correlates with a column the model lacks points at the missing term.
        report = validate(tau_val, tau_pred, n_params=len(names), regressor=Y_val,
                          profile=profile, backend=backend)
        result.models.append(DemoModel(name, names, pi_hat, report))
    return result


def _format_result(result: DemoResult) -> str:
    full, reduced = result.models
    lines = [
        "dynval demo: 2-DOF planar arm in a vertical plane",
        f"  gravity, viscous + Coulomb friction, torque noise σ = {result.noise:g} N·m; "
        f"{result.n_samples} samples at {result.sample_rate:g} Hz per trajectory (seed {result.seed})",
        "  identified by least squares on one trajectory, validated on a different one",
        f"  condition number of the estimation regressor: {result.condition_number:.1f}",
        "",
        "Identified parameters",
        f"  {'name':<6}{'true':>11}{'full':>11}{'rel.err':>10}{'reduced':>11}",
    ]
    for i, name in enumerate(PARAMETER_NAMES):
        true = result.true_parameters[i]
        est = full.parameters[i]
        rel = abs(est - true) / abs(true)
        red = (f"{reduced.parameters[reduced.parameter_names.index(name)]:>11.4f}"
               if name in reduced.parameter_names else f"{'—':>11}")
        lines.append(f"  {name:<6}{true:>11.4f}{est:>11.4f}{rel:>10.2e}{red}")
    for model in result.models:
        lines += ["", "=" * 78,
                  f"Model '{model.name}' ({len(model.parameter_names)} parameters: "
                  f"{', '.join(model.parameter_names)})",
                  "=" * 78, model.report.summary()]
    fi, ri = full.report.information_criteria, reduced.report.information_criteria
    lines += ["", "=" * 78, "Comparison on the validation trajectory", "=" * 78,
              f"  {'':<28}{'full':>14}{'reduced':>14}"]

    def row(label, a, b, fmt):
        lines.append(f"  {label:<28}{format(a, fmt):>14}{format(b, fmt):>14}")

    row("parameters", len(full.parameter_names), len(reduced.parameter_names), "d")
    row("RMSE per element (N·m)", full.report.pooled["rmse_per_element"],
        reduced.report.pooled["rmse_per_element"], ".4f")
    row("AIC", fi["aic"], ri["aic"], ".1f")
    row("BIC", fi["bic"], ri["bic"], ".1f")
    lb_f, lb_r = full.report.ljung_box, reduced.report.ljung_box
    if lb_f is not None and lb_r is not None:
        for j in range(np.shape(lb_f["pvalue"])[1]):
            row(f"Ljung–Box log10 p, joint {j + 1}", lb_f["log_pvalue"][0][j] / np.log(10),
                lb_r["log_pvalue"][0][j] / np.log(10), ".1f")
    better = "full" if fi["aic"] < ri["aic"] else "reduced"
    better_bic = "full" if fi["bic"] < ri["bic"] else "reduced"
    lines.append(f"  AIC prefers the {better} model; BIC prefers the {better_bic} model.")
    xc = reduced.report.cross_correlation
    if xc is not None and xc["outside"]:
        joint, col, lag, rho, _ = xc["outside"][0]
        lines.append(
            f"  Strongest residual/regressor correlation of the reduced model: joint {joint + 1} with "
            f"column {PARAMETER_NAMES[col]} at lag {lag} (ρ = {rho:+.3f}) — the missing term.")
    return "\n".join(lines)


def build_parser(parser: argparse.ArgumentParser | None = None) -> argparse.ArgumentParser:
    """Arguments of ``dynval demo``."""
    if parser is None:
        parser = argparse.ArgumentParser(prog="dynval demo")
    parser.description = (
        "Simulate a 2-DOF planar arm (gravity, viscous and Coulomb friction, torque sensor noise), "
        "identify its base parameters by least squares on one trajectory, validate the model on a "
        "different trajectory and print the report; a reduced model without Coulomb friction is "
        "validated beside it.")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--n-samples", type=int, default=2000,
                        help="samples per trajectory at 100 Hz (default 2000)")
    parser.add_argument("--noise", type=float, default=0.2,
                        help="torque sensor noise standard deviation in N·m (default 0.2)")
    parser.add_argument("--profile", default="lesson",
                        help="convention profile: lesson, matlab, statsmodels, sklearn (default lesson)")
    parser.add_argument("--backend", default=None, help="computation backend (python or cpp)")
    parser.add_argument("--json", action="store_true", help="print JSON instead of the text report")
    return parser


def main(argv=None) -> int:
    """Entry point of ``dynval demo``; returns the process exit code."""
    args = build_parser().parse_args(argv)
    return run_from_args(args)


def run_from_args(args) -> int:
    """Run the demo for parsed arguments (shared with :mod:`dynval.cli`)."""
    if args.n_samples < 200:
        print(f"dynval demo: error: --n-samples must be at least 200, got {args.n_samples}",
              file=sys.stderr)
        return 2
    if not (args.noise >= 0.0 and np.isfinite(args.noise)):
        print(f"dynval demo: error: --noise must be a finite number >= 0, got {args.noise}",
              file=sys.stderr)
        return 2

    def progress(msg):
        print(f"[dynval demo] {msg} ...", file=sys.stderr, flush=True)

    result = run_demo(seed=args.seed, n_samples=args.n_samples, noise=args.noise,
                      profile=args.profile, backend=args.backend, progress=progress)
    if args.json:
        print(json.dumps(result.to_dict(), indent=2, allow_nan=False))
    else:
        print(result.summary())
    return 0
