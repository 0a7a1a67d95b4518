"""Calibration scenarios built from the physics: serial arms in pinocchio, independent of dynval.simulate.

The findings of :func:`dynval.validate` are statistical detectors; their size (false deficiencies
on a right model, at most 5 %) and power (the right cause named in at least 90 % of deficient
replicates) must hold on robots other than the package's own 2-DOF simulator, or the thresholds are
tuned to one simulator. This module is a library of such scenarios (docs/conventions.md §5):

* **Arms** (:data:`ARMS`) built with ``pinocchio.Model`` (revolute joints, one body per joint):
  ``planar2`` (a 2-joint vertical planar arm, axes y, y), ``anthro3`` (3 joints, axes z, y, y:
  gravity acts on joints 2 and 3) and ``arm4`` (4 joints, axes z, y, y, x: a wrist roll whose link
  has its centre of mass off the roll axis). Links of 1–4.5 kg, 0.3–0.45 m. Torques come from
  ``pinocchio.rnea`` plus viscous and Coulomb friction on every joint; the regressor from
  ``pinocchio.computeJointTorqueRegressor`` (10 columns per body, pinocchio's order
  ``m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz``, named ``L2:mx``) reduced to its base columns (the
  independent subset, proximal links first: :func:`base_structure`), then per joint ``Fc<j>``
  (sign q̇_j) and ``Fv<j>`` (q̇_j), non-zero on joint j only. The unreduced regressor is rank
  deficient: the report's excitation check would call every validation run ill-conditioned.
* **Trajectories**: a finite Fourier series per joint (5 harmonics of a fundamental of 0.05–0.2 Hz,
  random amplitudes and phases per replicate, analytic q, q̇, q̈); the estimation and the
  validation runs are drawn independently.
* **Noise** on the measured torque, of standard deviation σ_j = a stated fraction of joint j's
  torque RMS on a reference trajectory: ``white``, ``t3`` (Student t, 3 dof), ``ar0.9``,
  ``ar0.99``, ``ar0.999`` (AR(1), marginal sd σ), ``lowpass`` (white noise through a 2nd-order
  Butterworth low-pass at 30 Hz, run at 1 kHz and sampled at the run's rate), ``heteroscedastic``
  (sd ∝ ``0.3 + |q̇_j|/max|q̇_j|``, RMS σ) and ``jitter`` (white noise, and every row — positions
  and torques alike — taken at t_k + U(−0.3, 0.3)/f_s while the run is analysed as uniformly
  sampled: a logger whose rows are consistent but whose stamps are irregular).
* **Scenarios** (:func:`library`): a right model under every noise (size), and deficient models
  (power): ``no_coulomb``, ``no_viscous``, ``no_gravity``, ``coupled_gravity``, ``offset``,
  ``payload``, ``mode``, ``delay`` (1–5 samples), ``unexcited_joint``, ``low_information``,
  ``chatter`` (the prediction's own line: the model's sign(q̇) flips at a limit cycle's rate where the
  joint is slow), ``stribeck`` (a Stribeck peak beyond the Coulomb and viscous friction the model
  has), ``rotor_inertia`` (a motor's reflected inertia J_a q̈_j the rigid-body model lacks),
  ``repeat`` (a validation run that retraces the estimation trajectory, its positions logged with
  sensor noise), each with its :class:`Expected` cause. Rate (100 Hz, 500 Hz, 1 kHz), length
  (20–40 s), arm and noise level differ between scenarios.
* **Offered or not**: every replicate is validated twice. ``offered=True``: the regressor handed
  to ``validate`` holds every column of the robot's structure and a constant ``off<j>`` per joint
  (zero in the robot unless the scenario is ``offset``), ``model_columns=`` the model's.
  ``offered=False``: the regressor is the model's own columns and ``model_columns=None``: a missing
  term must then be found from the motion itself.

``benchmarks/calibrate_findings.py`` runs the library and prints the table; :func:`run_replicate`
is one replicate of one scenario.
"""

from __future__ import annotations

import functools
import inspect
import math
import time
import zlib
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np

from .checks._typing import FloatArray
from .kernels._blas import one_blas_thread

__all__ = [
    "PARAM_NAMES", "GRAVITY", "Link", "ArmDesign", "ARMS", "Arm", "arm", "base_structure", "payload_columns",
    "Trajectory", "random_trajectory", "NOISES", "noise", "mode_signal",
    "Expected", "Scenario", "CLASSES", "library", "Run", "Replicate", "simulate", "fit",
    "validate_replicate", "named_right", "advice_right", "adds_what_it_has", "run_replicate",
]

PARAM_NAMES = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
"""pinocchio's order of the ten dynamic parameters of a body."""

GRAVITY = 9.81
CHATTER_DITHER = 0.3
STRIBECK_SPEED = 0.15
"""``stribeck``: the Stribeck velocity, in units of the joint's RMS velocity on the reference trajectory."""
REPEAT_NOISE = 0.005
"""``repeat``: the sd (rad) of the white noise on the validation run's logged positions."""
"""``chatter``: the limit cycle's velocity amplitude, in units of the joint's RMS velocity."""
N_HARMONICS = 5
REFERENCE_SEED = 20261127
"""Seed of the reference trajectory on which σ and the effects' sizes are set."""


# --------------------------------------------------------------------------- arms


@dataclass(frozen=True)
class Link:
    """One revolute joint and the body it moves (SI units, the joint's frame).

    ``origin``: the joint frame's origin in the parent joint's frame; ``com``: the centre of mass
    and ``inertia`` the principal moments about it (axes of the joint frame); ``viscous``,
    ``coulomb``: the joint's friction; ``amplitude``, ``centre``: the trajectory's excursion bound
    and centre (rad).
    """

    axis: str
    origin: tuple[float, float, float]
    mass: float
    com: tuple[float, float, float]
    inertia: tuple[float, float, float]
    viscous: float
    coulomb: float
    amplitude: float
    centre: float


@dataclass(frozen=True)
class ArmDesign:
    """A serial arm: its links from the base, the tool point in the last joint's frame."""

    name: str
    links: tuple[Link, ...]
    tool: tuple[float, float, float]
    joint_names: tuple[str, ...]
    description: str

    @property
    def n_joints(self) -> int:
        return len(self.links)


ARMS: dict[str, ArmDesign] = {
    "planar2": ArmDesign(
        "planar2",
        (Link("y", (0.0, 0.0, 0.0), 3.0, (0.22, 0.0, 0.0), (0.005, 0.05, 0.05), 0.8, 1.2, 1.2, -0.3),
         Link("y", (0.45, 0.0, 0.0), 2.0, (0.18, 0.0, 0.0), (0.003, 0.027, 0.027), 0.5, 0.8, 1.5, 0.6)),
        (0.4, 0.0, 0.0), ("shoulder", "elbow"),
        "2-joint vertical planar arm (axes y, y; links 0.45 and 0.40 m, 3.0 and 2.0 kg)"),
    "anthro3": ArmDesign(
        "anthro3",
        (Link("z", (0.0, 0.0, 0.0), 4.0, (0.0, 0.0, 0.15), (0.03, 0.03, 0.01), 1.0, 1.5, 1.5, 0.0),
         Link("y", (0.0, 0.0, 0.3), 3.0, (0.2, 0.0, 0.0), (0.005, 0.04, 0.04), 0.8, 1.2, 1.0, -0.3),
         Link("y", (0.4, 0.0, 0.0), 2.0, (0.17, 0.0, 0.0), (0.003, 0.02, 0.02), 0.5, 0.8, 1.2, 0.8)),
        (0.35, 0.0, 0.0), ("base", "shoulder", "elbow"),
        "3-joint anthropomorphic arm (axes z, y, y; column 0.30 m, links 0.40 and 0.35 m; 4, 3, 2 kg)"),
    "arm4": ArmDesign(
        "arm4",
        (Link("z", (0.0, 0.0, 0.0), 4.5, (0.0, 0.0, 0.16), (0.035, 0.035, 0.012), 1.2, 1.8, 1.5, 0.0),
         Link("y", (0.0, 0.0, 0.32), 3.5, (0.22, 0.0, 0.01), (0.006, 0.05, 0.05), 1.0, 1.4, 0.8, -0.4),
         Link("y", (0.45, 0.0, 0.0), 2.5, (0.15, 0.0, 0.0), (0.004, 0.03, 0.03), 0.6, 1.0, 1.2, 0.9),
         Link("x", (0.35, 0.0, 0.0), 1.2, (0.05, 0.0, 0.03), (0.002, 0.002, 0.002), 0.2, 0.3, 2.0, 0.0)),
        (0.12, 0.0, 0.0), ("base", "shoulder", "elbow", "wrist"),
        "4-joint arm (axes z, y, y, x; column 0.32 m, links 0.45, 0.35, 0.12 m; 4.5, 3.5, 2.5, 1.2 kg; "
        "the wrist's centre of mass 3 cm off the roll axis)"),
    "arm6": ArmDesign(
        "arm6",
        (Link("z", (0.0, 0.0, 0.0), 8.0, (0.0, 0.0, 0.15), (0.08, 0.08, 0.04), 1.5, 2.0, 1.5, 0.0),
         Link("y", (0.0, 0.0, 0.35), 6.0, (0.25, 0.0, 0.01), (0.01, 0.12, 0.12), 1.2, 1.8, 0.8, -0.4),
         Link("y", (0.5, 0.0, 0.0), 4.0, (0.2, 0.0, 0.0), (0.006, 0.06, 0.06), 0.9, 1.2, 1.0, 0.8),
         Link("x", (0.4, 0.0, 0.0), 1.5, (0.05, 0.0, 0.01), (0.003, 0.004, 0.004), 0.3, 0.4, 1.8, 0.0),
         Link("y", (0.1, 0.0, 0.0), 1.0, (0.04, 0.0, 0.0), (0.002, 0.002, 0.002), 0.2, 0.3, 1.2, 0.3),
         Link("x", (0.08, 0.0, 0.0), 0.5, (0.03, 0.01, 0.0), (0.001, 0.001, 0.001), 0.1, 0.15, 2.0, 0.0)),
        (0.05, 0.0, 0.0), ("base", "shoulder", "elbow", "wrist1", "wrist2", "wrist3"),
        "6-joint industrial arm (axes z, y, y, x, y, x; column 0.35 m, links 0.50, 0.40 m and a 0.23 m wrist; "
        "8, 6, 4, 1.5, 1.0, 0.5 kg; the last wrist's centre of mass off its roll axis)"),
    "arm7": ArmDesign(
        "arm7",
        (Link("z", (0.0, 0.0, 0.0), 4.0, (0.0, -0.03, 0.12), (0.03, 0.03, 0.01), 1.2, 1.5, 1.5, 0.0),
         Link("y", (0.0, 0.0, 0.11), 4.0, (0.0, 0.03, 0.15), (0.04, 0.04, 0.01), 1.0, 1.4, 1.0, 0.6),
         Link("z", (0.0, 0.0, 0.2), 3.0, (0.0, 0.02, 0.1), (0.03, 0.03, 0.008), 0.8, 1.0, 1.5, 0.0),
         Link("y", (0.0, 0.0, 0.2), 2.7, (0.0, -0.02, 0.12), (0.02, 0.02, 0.005), 0.8, 1.0, 1.0, -0.8),
         Link("z", (0.0, 0.0, 0.19), 1.7, (0.0, 0.01, 0.08), (0.01, 0.01, 0.003), 0.3, 0.5, 1.5, 0.0),
         Link("y", (0.0, 0.0, 0.2), 1.6, (0.0, 0.0, 0.03), (0.005, 0.005, 0.003), 0.3, 0.4, 1.0, 0.4),
         Link("z", (0.0, 0.0, 0.08), 0.3, (0.01, 0.0, 0.02), (0.001, 0.001, 0.001), 0.1, 0.15, 2.0, 0.0)),
        (0.0, 0.0, 0.05), tuple(f"a{j + 1}" for j in range(7)),
        "7-joint arm of the LWR kind (axes z, y, z, y, z, y, z; links 0.31, 0.40, 0.39, 0.08 m along the "
        "arm; 4.0, 4.0, 3.0, 2.7, 1.7, 1.6, 0.3 kg)"),
}
"""The arm designs, by name."""


def _pin() -> Any:
    import pinocchio

    return pinocchio


class Arm:
    """A pinocchio model of an :class:`ArmDesign`, possibly changed (centres of mass, a payload).

    Parameters
    ----------
    design : ArmDesign
    com : mapping of link index to (3,), optional
        Centres of mass replacing the design's (the inertia about the centre is kept).
    payload : float
        Mass (kg) of a point-like payload (a 5 cm sphere) at the tool point.
    """

    def __init__(self, design: ArmDesign, *, com: dict[int, tuple[float, float, float]] | None = None,
                 payload: float = 0.0) -> None:
        pin = _pin()
        axes = {"x": pin.JointModelRX, "y": pin.JointModelRY, "z": pin.JointModelRZ}
        self.design = design
        model = pin.Model()
        model.gravity.linear = np.array([0.0, 0.0, -GRAVITY])
        parent = 0
        for i, link in enumerate(design.links):
            c = (com or {}).get(i, link.com)
            jid = model.addJoint(parent, axes[link.axis](), pin.SE3(np.eye(3), np.array(link.origin, dtype=float)),
                                 design.joint_names[i])
            model.appendBodyToJoint(jid, pin.Inertia(link.mass, np.array(c, dtype=float), np.diag(link.inertia)),
                                    pin.SE3.Identity())
            parent = jid
        if payload > 0.0:
            i_ball = 0.4 * payload * 0.05**2
            model.appendBodyToJoint(parent, pin.Inertia(payload, np.array(design.tool, dtype=float),
                                                        np.eye(3) * i_ball), pin.SE3.Identity())
        self.model = model
        self.data = model.createData()
        self.n = int(model.nv)
        self.viscous = np.array([link.viscous for link in design.links])
        self.coulomb = np.array([link.coulomb for link in design.links])

    def inertial_parameters(self) -> FloatArray:
        """The bodies' dynamic parameters ``(10 n,)`` (pinocchio's order; a payload is in the last)."""
        return np.concatenate([np.asarray(self.model.inertias[j].toDynamicParameters(), dtype=float)
                               for j in range(1, self.model.njoints)])

    def inertial_regressor(self, q: FloatArray, dq: FloatArray, ddq: FloatArray) -> FloatArray:
        """``computeJointTorqueRegressor`` per sample: ``(N, n, 10 n)``, ``rnea = Y π``."""
        pin = _pin()
        out = np.empty((q.shape[0], self.n, 10 * self.n))
        for k in range(q.shape[0]):
            out[k] = pin.computeJointTorqueRegressor(self.model, self.data, q[k], dq[k], ddq[k])
        return out

    def rnea(self, q: FloatArray, dq: FloatArray, ddq: FloatArray) -> FloatArray:
        """Rigid-body joint torques ``(N, n)`` from pinocchio's recursive Newton–Euler algorithm."""
        pin = _pin()
        out = np.empty((q.shape[0], self.n))
        for k in range(q.shape[0]):
            out[k] = pin.rnea(self.model, self.data, q[k], dq[k], ddq[k])
        return out


@functools.lru_cache(maxsize=64)
def arm(name: str, com: tuple[tuple[int, tuple[float, float, float]], ...] = (), payload: float = 0.0) -> Arm:
    """The :class:`Arm` of design ``name`` (cached per process; ``com`` as ``((link, (x, y, z)), ...)``)."""
    return Arm(ARMS[name], com=dict(com), payload=payload)


@functools.lru_cache(maxsize=16)
def payload_columns(name: str, payload: float) -> tuple[str, ...]:
    """The base columns of design ``name`` whose parameter a point payload of ``payload`` kg at the
    tool changes by more than 1 % of the largest change."""
    keep, regroup = base_structure(name)
    names = _structure_names(ARMS[name], keep)
    change = regroup @ (arm(name, payload=payload).inertial_parameters() - arm(name).inertial_parameters())
    big = np.abs(change) > 0.01 * np.max(np.abs(change))
    return tuple(names[i] for i in np.flatnonzero(big))


@functools.lru_cache(maxsize=8)
def base_structure(name: str) -> tuple[tuple[int, ...], FloatArray]:
    """The base columns of design ``name``'s inertial regressor and the regrouping matrix.

    Returns ``(keep, B)``: ``keep`` the independent columns (greedy in the order L1:m ... Ln:Izz, so
    distal parameters regroup into proximal ones), ``B`` (len(keep), 10 n) with ``Y = Y[:, keep] B``
    for every motion; the base parameters are ``B π``. Found on 60 random states; the relations are
    kinematic (independent of the masses), and ``Y[:, keep] B`` reproduces ``Y`` to 1e-12.
    """
    a = arm(name)
    rng = np.random.default_rng(0)
    n = a.n
    samples = 60
    q = rng.uniform(-math.pi, math.pi, (samples, n))
    y = a.inertial_regressor(q, rng.normal(size=(samples, n)), rng.normal(size=(samples, n))).reshape(-1, 10 * n)
    norms = np.linalg.norm(y, axis=0)
    keep: list[int] = []
    basis = np.zeros((y.shape[0], 0))
    for c in range(y.shape[1]):
        if norms[c] <= 1e-10 * norms.max():
            continue
        v = y[:, c] / norms[c]
        r = v - basis @ (basis.T @ v)
        if np.linalg.norm(r) > 1e-8:
            keep.append(c)
            basis = np.column_stack([basis, r / np.linalg.norm(r)])
    b = np.asarray(np.linalg.lstsq(y[:, keep], y, rcond=None)[0], dtype=np.float64)
    b[np.abs(b) < 1e-10] = 0.0
    if np.max(np.abs(y[:, keep] @ b - y)) > 1e-9 * norms.max():
        raise RuntimeError(f"base_structure({name!r}): the regrouping does not reproduce the regressor")
    return tuple(keep), b


# --------------------------------------------------------------------------- trajectories


@dataclass(frozen=True)
class Trajectory:
    """``q_j(t) = c_j + Σ_k a_jk sin(2π f₀ k t + φ_jk)``, k = 1..H, with analytic derivatives."""

    centres: FloatArray
    amplitudes: FloatArray
    phases: FloatArray
    base_frequency: float

    def __call__(self, t: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        tt = np.asarray(t, dtype=float)[:, None, None]
        w = 2.0 * math.pi * self.base_frequency * np.arange(1, self.amplitudes.shape[1] + 1)
        arg = w * tt + self.phases
        s, c = np.sin(arg), np.cos(arg)
        q = self.centres + np.sum(self.amplitudes * s, axis=2)
        dq = np.sum(self.amplitudes * w * c, axis=2)
        ddq = -np.sum(self.amplitudes * w**2 * s, axis=2)
        return q, dq, ddq


def random_trajectory(rng: np.random.Generator, design: ArmDesign, base_frequency: float,
                      scale: Sequence[float] | None = None) -> Trajectory:
    """Random amplitudes (∝ u/k, u ~ U(0.5, 1), summing to the link's amplitude bound, times
    ``scale[j]``), phases U(0, 2π) and centres (the link's centre ± 0.2 rad)."""
    n = design.n_joints
    k = np.arange(1, N_HARMONICS + 1)
    u = rng.uniform(0.5, 1.0, (n, N_HARMONICS)) / k
    bound = np.array([link.amplitude for link in design.links])
    if scale is not None:
        bound = bound * np.asarray(scale, dtype=float)
    amplitudes = u / u.sum(axis=1, keepdims=True) * bound[:, None]
    phases = rng.uniform(0.0, 2.0 * math.pi, (n, N_HARMONICS))
    centres = np.array([link.centre for link in design.links]) + rng.uniform(-0.2, 0.2, n)
    return Trajectory(centres, amplitudes, phases, base_frequency)


# --------------------------------------------------------------------------- noise

NOISES = ("white", "t3", "ar0.9", "ar0.99", "ar0.999", "lowpass", "heteroscedastic", "jitter")
"""Noise kinds of the measured torque (``jitter`` is white noise plus jittered sampling)."""

LOWPASS_RATE = 1000.0
LOWPASS_CUTOFF = 30.0


def _filtered(b: Any, a: Any, rng: np.random.Generator, n: int, m: int) -> FloatArray:
    """Unit-variance stationary output of the filter b/a driven by white noise (burn-in from the
    impulse response's length; scaled by the impulse response's energy)."""
    import scipy.signal

    impulse = np.zeros(20000)
    impulse[0] = 1.0
    h = scipy.signal.lfilter(b, a, impulse)
    energy = np.cumsum(h**2)
    burn = int(np.searchsorted(energy, (1.0 - 1e-9) * energy[-1])) + 1
    w = rng.normal(size=(n + burn, m))
    x = scipy.signal.lfilter(b, a, w, axis=0)[burn:]
    return np.asarray(x / math.sqrt(energy[-1]))


def noise(kind: str, rng: np.random.Generator, n: int, sigma: FloatArray, sample_rate: float,
          dq: FloatArray | None = None) -> FloatArray:
    """Noise ``(n, m)`` of kind ``kind`` with marginal standard deviation ``sigma`` (m,) per joint.

    ``heteroscedastic`` needs ``dq`` (its sd is ∝ ``0.3 + |q̇_j|/max|q̇_j|``, scaled to RMS σ_j on
    the run); ``lowpass`` is generated at 1 kHz and taken every 1000/f_s-th sample.
    """
    import scipy.signal

    sigma = np.asarray(sigma, dtype=float)
    m = sigma.size
    if kind in ("white", "jitter"):
        return rng.normal(size=(n, m)) * sigma
    if kind == "t3":
        return rng.standard_t(3, size=(n, m)) / math.sqrt(3.0) * sigma
    if kind.startswith("ar"):
        rho = float(kind[2:])
        w = rng.normal(size=(n, m)) * math.sqrt(1.0 - rho * rho)
        w[0] = rng.normal(size=m)  # the stationary start: x_0 ~ N(0, 1)
        return np.asarray(scipy.signal.lfilter([1.0], [1.0, -rho], w, axis=0)) * sigma
    if kind == "lowpass":
        step = LOWPASS_RATE / sample_rate
        if abs(step - round(step)) > 1e-9 or step < 1:
            raise ValueError(f"lowpass noise needs a rate dividing {LOWPASS_RATE:g} Hz, got {sample_rate:g}")
        b, a = scipy.signal.butter(2, LOWPASS_CUTOFF, fs=LOWPASS_RATE)
        x = _filtered(b, a, rng, n * int(round(step)), m)[::int(round(step))]
        return x * sigma
    if kind == "heteroscedastic":
        if dq is None:
            raise ValueError("heteroscedastic noise needs dq")
        s = 0.3 + np.abs(dq) / np.max(np.abs(dq), axis=0)
        s = s / np.sqrt(np.mean(s**2, axis=0))
        return np.asarray(rng.normal(size=(n, m)) * s * sigma, dtype=np.float64)
    raise ValueError(f"unknown noise {kind!r}; expected one of {NOISES}")


def mode_signal(rng: np.random.Generator, n: int, frequency: float, sample_rate: float, sd: float,
                damping: float = 0.02) -> FloatArray:
    """A lightly damped mode (AR(2) with poles r·e^{±iω₀}, r = e^{−ζω₀}) of stationary sd ``sd``."""
    w0 = 2.0 * math.pi * frequency / sample_rate
    r = math.exp(-damping * w0)
    return _filtered([1.0], [1.0, -2.0 * r * math.cos(w0), r * r], rng, n, 1)[:, 0] * sd


# --------------------------------------------------------------------------- scenarios


@dataclass(frozen=True)
class Expected:
    """The cause a deficient scenario's findings should name.

    A finding names it when its severity is ``severity``, its kind one of ``kinds``, it names
    ``joint`` (when given) and: for ``missing_physics``, ``details["term"]`` in ``term`` (when
    given) and ``details["relation"]`` in ``relation`` (when given); for ``regressor_correlation``
    and ``bias``, the name of ``columns[0]`` starts with ``column_prefix`` (one of them, for a
    tuple; only when the column was offered; a bias names an ``offset`` by itself); for
    ``oscillation``, ``details["frequency"]`` within 10 % of ``frequency``; for ``delay``,
    ``details["delay_s"]`` (when present) within a factor 2 of ``delay_s``; ``reported``: a note
    counts too (a significant delay is always reported, at least as a note).
    """

    kinds: tuple[str, ...]
    joint: int | None = None
    term: tuple[str, ...] | None = None
    column_prefix: str | tuple[str, ...] | None = None
    frequency: float | None = None
    delay_s: float | None = None
    severity: str = "deficiency"
    model_column: bool = False  # the column is one of the model's: named right offered or hidden
    relation: tuple[str, ...] | None = None  # a missing_physics finding's relation to the model, when given
    reported: bool = False  # any severity counts: the finding must be reported, at least as a note


CLASSES = ("right", "no_coulomb", "no_viscous", "no_gravity", "coupled_gravity", "offset", "payload", "mode",
           "delay", "unexcited_joint", "low_information", "changed_friction", "decoupled", "chatter", "stribeck",
           "rotor_inertia", "repeat", "gravity_only")
"""Scenario classes: ``right`` (size) and the deficient ones (power)."""


@dataclass(frozen=True)
class Scenario:
    """One row of the calibration: a class on an arm, at a rate and noise.

    ``sigma``: the noise sd as a fraction of each joint's torque RMS on the reference trajectory;
    ``size``: the effect's RMS in units of σ on the joint(s) it acts on (friction, gravity, offset,
    mode; the missing columns of ``low_information``); ``joint``: the joint it acts on;
    ``column``: the inertial column a gravity model lacks; ``missing``: the columns a
    ``low_information`` model lacks; ``delay``: samples; ``payload``: kg; ``mode_frequency``: Hz;
    ``unexcited_scale``: the validation amplitude of ``joint`` relative to the estimation one.
    """

    name: str
    noise: str
    arm: str
    sample_rate: float
    duration: float
    base_frequency: float
    sigma: float
    expected: Expected | None = None
    size: float = 1.5
    joint: int | None = None
    column: str | None = None
    missing: tuple[str, ...] = ()
    delay: int = 0
    payload: float = 0.0
    mode_frequency: float | None = None
    unexcited_scale: float = 0.02
    filtered: bool = False
    tag: str = ""  # tells apart rows of one class, noise, arm and rate (``delay``'s samples)

    @property
    def model_has(self) -> frozenset[str]:
        """The library groups the model holds (its own columns, on every joint): a finding must never
        tell it to add one of these."""
        if self.name == "decoupled":
            return frozenset({"coulomb", "viscous", "offset"})
        if self.name == "gravity_only":
            return frozenset({"coulomb", "viscous", "gravity"})
        has = {"gravity", "inertia", "coulomb", "viscous"}
        if self.name == "no_coulomb":
            has.discard("coulomb")
        if self.name in ("no_viscous", "low_information"):
            has.discard("viscous")
        return frozenset(has)

    @property
    def key(self) -> str:
        return (f"{self.name}{'+filtered' if self.filtered else ''}:{self.noise}:{self.arm}@{self.sample_rate:g}"
                + (f"/{self.tag}" if self.tag else ""))

    @property
    def n_samples(self) -> int:
        return int(round(self.duration * self.sample_rate))

    def describe(self) -> str:
        s = _setup(self)
        extra = {"no_coulomb": lambda: f"Fc = {self.size}σ per joint",
                 "no_viscous": lambda: f"Fv: RMS {self.size}σ per joint",
                 "no_gravity": lambda: f"{self.column}, RMS {self.size}σ on {_joint(self)}",
                 "coupled_gravity": lambda: f"{self.column}, RMS {self.size}σ (largest joint)",
                 "offset": lambda: f"{self.size}σ on {_joint(self)}",
                 "payload": lambda: f"{self.payload:g} kg at the tool",
                 "mode": lambda: f"{self.mode_frequency} Hz, ζ 0.02, sd {self.size}σ on {_joint(self)}",
                 "delay": lambda: f"{self.delay} sample(s) = {1e3 * self.delay / self.sample_rate:g} ms",
                 "chatter": lambda: (f"the model's sign(q̇) on {_joint(self)} evaluated on a velocity with a "
                                     f"{self.mode_frequency} Hz limit cycle of {CHATTER_DITHER:g} × its RMS"),
                 "unexcited_joint": lambda: f"{_joint(self)} at {100 * self.unexcited_scale:g} % amplitude",
                 "low_information": lambda: f"missing {', '.join(self.missing)} ({self.size}σ each)",
                 "changed_friction": lambda: f"Fc of {_joint(self)} larger by {self.size}σ on the validation run",
                 "decoupled": lambda: "per joint q̈_j, q̇_j, sign q̇_j, sin q_j, cos q_j, 1 (no coupling)",
                 "stribeck": lambda: (f"a Stribeck peak sign(q̇)·exp(−(q̇/v_s)²) of RMS {self.size}σ on {_joint(self)}, "
                                      f"v_s {STRIBECK_SPEED:g} × its RMS velocity"),
                 "rotor_inertia": lambda: f"a rotor inertia J_a q̈ of RMS {self.size}σ on {_joint(self)}",
                 "gravity_only": lambda: "a gravity and friction model (the base columns at q̇ = q̈ = 0, Fc, Fv)",
                 "repeat": lambda: f"the validation run retraces the estimation run; q logged with "
                                   f"{1e3 * REPEAT_NOISE:g} mrad of white noise",
                 }.get(self.name, lambda: "")()
        return (f"{self.key:40} {self.arm} {self.sample_rate:g} Hz × {self.duration:g} s (N {self.n_samples}), "
                f"f0 {self.base_frequency:g} Hz, σ {100 * self.sigma:g} % of RMS = "
                f"[{', '.join(f'{x:.3g}' for x in s.sigma)}] N·m"
                + (f"; {extra}" if extra else ""))


def _joint(s: Scenario) -> str:
    return ARMS[s.arm].joint_names[s.joint] if s.joint is not None else "—"


_MISSING_PHYSICS = ("missing_physics", "regressor_correlation", "bias")
_GRAVITY_TERMS = ("gravity", "position_harmonic")


def library() -> tuple[Scenario, ...]:
    """The scenario library: right models under every noise, then the deficient classes.

    Arms, rates (100 Hz, 500 Hz, 1 kHz), lengths (20–40 s), fundamentals and noise levels
    (1–5 % of each joint's torque RMS) are spread over the rows so that no single setting decides.
    """
    r = Scenario
    p2, a3, a4 = "planar2", "anthro3", "arm4"
    rows = [
        r("right", "white", p2, 100.0, 40.0, 0.1, 0.02),
        r("right", "white", a3, 500.0, 30.0, 0.1, 0.01),
        r("right", "white", a4, 1000.0, 20.0, 0.2, 0.03),
        r("right", "t3", a4, 100.0, 40.0, 0.05, 0.02),
        r("right", "ar0.9", a3, 100.0, 40.0, 0.1, 0.03),
        r("right", "ar0.99", p2, 1000.0, 20.0, 0.15, 0.02),
        r("right", "ar0.999", a4, 500.0, 30.0, 0.1, 0.02),
        r("right", "lowpass", a3, 1000.0, 20.0, 0.2, 0.01),
        r("right", "heteroscedastic", p2, 500.0, 30.0, 0.1, 0.05),
        r("right", "jitter", a4, 500.0, 30.0, 0.1, 0.01),
    ]
    coulomb = Expected(_MISSING_PHYSICS, term=("coulomb",), column_prefix="Fc")
    viscous = Expected(_MISSING_PHYSICS, term=("viscous",), column_prefix="Fv")
    rows += [
        r("no_coulomb", "white", a3, 500.0, 30.0, 0.1, 0.02, coulomb),
        r("no_coulomb", "ar0.9", p2, 100.0, 40.0, 0.1, 0.02, coulomb),
        r("no_viscous", "white", a4, 100.0, 40.0, 0.05, 0.02, viscous),
        r("no_viscous", "t3", p2, 500.0, 30.0, 0.15, 0.03, viscous),
        r("no_gravity", "white", p2, 100.0, 40.0, 0.1, 0.02,
          Expected(_MISSING_PHYSICS, joint=0, term=_GRAVITY_TERMS, column_prefix="L1:mz"),
          size=2.0, joint=0, column="L1:mz"),
        r("no_gravity", "lowpass", a3, 1000.0, 20.0, 0.15, 0.02,
          Expected(_MISSING_PHYSICS, joint=1, term=_GRAVITY_TERMS, column_prefix="L2:mz"),
          size=2.0, joint=1, column="L2:mz"),
        r("coupled_gravity", "white", a3, 500.0, 30.0, 0.1, 0.02,
          Expected(_MISSING_PHYSICS, term=_GRAVITY_TERMS, column_prefix="L3:mz"), size=2.0, column="L3:mz"),
        r("coupled_gravity", "heteroscedastic", a4, 500.0, 30.0, 0.1, 0.02,
          Expected(_MISSING_PHYSICS, term=_GRAVITY_TERMS, column_prefix="L4:mz"), size=2.0, column="L4:mz"),
        # On a joint that carries gravity an offset is nearly a combination of the gravity columns
        # (cos q, sin q over a swing of ±1 rad: 95 % of it is absorbed by the fit): the offsets sit
        # on the base joint (no gravity) and on the wrist roll (swings of ±2 rad).
        r("offset", "white", a4, 100.0, 40.0, 0.05, 0.02,
          Expected(("missing_physics", "bias", "regressor_correlation"), joint=3, term=("offset",),
                   column_prefix="off4"), joint=3),
        r("offset", "ar0.9", a3, 500.0, 30.0, 0.1, 0.02,
          Expected(("missing_physics", "bias", "regressor_correlation"), joint=0, term=("offset",),
                   column_prefix="off1"), joint=0),
        # A payload changes base parameters the model has: a correlation with one of them ("re-identify
        # the term of L3:mx: the model has it") names it as well as the physics library's gravity or
        # inertia. Which ones it changes follows from the regrouping (on arm4 the tool lies on the last
        # axis, so the payload moves L3's regrouped parameters and none of L4's).
        r("payload", "white", a3, 100.0, 40.0, 0.1, 0.02,
          Expected(("missing_physics", "predictive_failure", "regressor_correlation"), term=("gravity", "inertia"),
                   column_prefix=payload_columns("anthro3", 1.0), model_column=True), payload=1.0),
        r("payload", "jitter", a4, 500.0, 30.0, 0.1, 0.01,
          Expected(("missing_physics", "predictive_failure", "regressor_correlation"), term=("gravity", "inertia"),
                   column_prefix=payload_columns("arm4", 1.0), model_column=True), payload=1.0),
        r("mode", "white", p2, 100.0, 40.0, 0.1, 0.02, Expected(("oscillation",), joint=1, frequency=7.0),
          size=1.0, joint=1, mode_frequency=7.0),
        r("mode", "white", a4, 1000.0, 20.0, 0.2, 0.02, Expected(("oscillation",), joint=3, frequency=25.0),
          size=1.0, joint=3, mode_frequency=25.0),
        r("mode", "lowpass", a3, 1000.0, 20.0, 0.15, 0.02, Expected(("oscillation",), joint=2, frequency=25.0),
          size=1.0, joint=2, mode_frequency=25.0),
        r("delay", "white", p2, 100.0, 40.0, 0.1, 0.02,
          Expected(("delay", "missing_physics"), term=("delay",), delay_s=0.01), delay=1),
        r("delay", "white", a4, 1000.0, 20.0, 0.2, 0.02,
          Expected(("delay", "missing_physics"), term=("delay",), delay_s=0.003), delay=3),
        # Delays of 1–5 samples on a slow, noisier run: a significant delay is always reported (a
        # note below 10° at the information band's edge and 5 % of the mean square).
        *(r("delay", "white", a3, 100.0, 40.0, 0.05, 0.03,
            Expected(("delay",), delay_s=k / 100.0, reported=True), delay=k, tag=f"{k}samples") for k in range(1, 6)),
        # The prediction's own line: the model's friction chatters at 6.9 Hz where the joint is slow.
        # Smoothing the sign is the fix, so "add the friction shape it lacks (a smooth sign or a
        # Stribeck term)" on the joint (a partial Coulomb term) names it as well as the line.
        r("chatter", "white", p2, 100.0, 40.0, 0.1, 0.02,
          Expected(("prediction_artefact", "missing_physics"), joint=1, term=("coulomb",), frequency=6.9,
                   relation=("partial",)), joint=1, mode_frequency=6.9),
        r("chatter", "white", a3, 500.0, 30.0, 0.1, 0.02,
          Expected(("prediction_artefact", "missing_physics"), joint=2, term=("coulomb",), frequency=6.9,
                   relation=("partial",)), joint=2, mode_frequency=6.9),
        r("unexcited_joint", "white", a3, 500.0, 30.0, 0.1, 0.02,
          Expected(("excitation",), joint=2, severity="design"), joint=2),
        r("unexcited_joint", "ar0.9", a4, 100.0, 40.0, 0.05, 0.02,
          Expected(("excitation",), joint=3, severity="design"), joint=3),
        # A slowly excited run (one to one and a half periods of the fundamental) under AR(1) 0.999:
        # N_eff ≈ 10 for the mean, and few for a motion-dependent term too (prewhitening recovers
        # about T·π·f²/f_c effective samples for a term at frequency f, f_c the noise's corner;
        # with f₀ = 0.15 Hz the detectors do name the three missing terms: that run can decide).
        r("low_information", "ar0.999", p2, 1000.0, 20.0, 0.05, 0.02,
          Expected(("low_information",), severity="design"), size=1.0, missing=("Fv1", "Fv2", "L2:mz")),
        r("low_information", "ar0.999", a4, 500.0, 30.0, 0.05, 0.02,
          Expected(("low_information",), severity="design"), size=1.0, missing=("Fv1", "Fv2", "Fv3")),
    ]
    return tuple(rows) + _rows_like_real_logs(coulomb, viscous)


# --------------------------------------------------------------------------- setup of a scenario


@dataclass(frozen=True)
class _Setup:
    """What a scenario's replicates share: the robot, σ, the columns, the model."""

    arm: Arm
    payload_arm: Arm | None
    sigma: FloatArray
    viscous: FloatArray
    coulomb: FloatArray
    offset: FloatArray
    keep: tuple[int, ...]
    regroup: FloatArray
    names: tuple[str, ...]   # offered columns: base inertial, Fc, Fv, off
    truth: FloatArray        # the robot's parameters in those columns
    model: tuple[int, ...]   # the model's columns (indices into names)
    joint_term: FloatArray | None = None  # stribeck, rotor_inertia: the gain of the term per joint
    joint_speed: float = 1.0  # the joint's RMS velocity on the reference trajectory


def _rows_like_real_logs(coulomb: Expected, viscous: Expected) -> tuple[Scenario, ...]:
    """Scenarios built like real logs (issue 34): a friction that changed between the runs (the
    model has every term: re-identify, never add), a decoupled per-joint model of a coupled arm
    (its coupling named), the user's own filtered derivatives on both runs, a 6-joint arm, a
    Stribeck peak beyond the friction the model has, a rotor inertia and a retraced trajectory with noisy q."""
    r = Scenario
    p2, a3, a4, a6 = "planar2", "anthro3", "arm4", "arm6"
    return (
        r("changed_friction", "white", a3, 500.0, 30.0, 0.1, 0.02,
          Expected(_MISSING_PHYSICS, joint=1, term=("coulomb",), column_prefix="Fc2", model_column=True),
          size=2.0, joint=1),
        r("changed_friction", "ar0.9", p2, 100.0, 40.0, 0.1, 0.02,
          Expected(_MISSING_PHYSICS, joint=0, term=("coulomb",), column_prefix="Fc1", model_column=True),
          size=2.0, joint=0),
        r("decoupled", "white", a3, 200.0, 30.0, 0.1, 0.02,
          Expected(("missing_physics", "bias"), term=("gravity", "inertia", "position_harmonic", "velocity_squared"))),
        r("decoupled", "white", a4, 100.0, 40.0, 0.1, 0.02,
          Expected(("missing_physics", "bias"), term=("gravity", "inertia", "position_harmonic", "velocity_squared"))),
        r("right", "white", a3, 500.0, 30.0, 0.1, 0.02, filtered=True),
        r("no_viscous", "white", p2, 500.0, 30.0, 0.15, 0.03, viscous, filtered=True),
        # A 6-joint arm (the wrist's three joints carry little torque): the right model, a missing
        # Coulomb friction, and a friction that changed between runs on the elbow.
        r("right", "white", a6, 200.0, 30.0, 0.1, 0.02),
        r("no_coulomb", "white", a6, 200.0, 30.0, 0.1, 0.02, coulomb),
        r("changed_friction", "white", a6, 200.0, 30.0, 0.1, 0.02,
          Expected(_MISSING_PHYSICS, joint=2, term=("coulomb",), column_prefix="Fc3", model_column=True),
          size=2.0, joint=2),
        # A Stribeck peak beyond the Coulomb and viscous friction the model has: the friction shape it
        # lacks ("complete Coulomb friction"), never "add Coulomb friction".
        r("stribeck", "white", a3, 500.0, 30.0, 0.1, 0.02,
          Expected(("missing_physics",), joint=2, term=("coulomb",), relation=("partial",)), size=2.0, joint=2),
        r("stribeck", "ar0.9", a6, 200.0, 30.0, 0.1, 0.02,
          Expected(("missing_physics",), joint=1, term=("coulomb",), relation=("partial",)), size=2.0, joint=1),
        # A real but negligible Stribeck term on a wrist under strongly coloured noise: nothing to fix
        # (no deficiency: chance fits of the noise must not make it practical).
        r("stribeck", "ar0.99", a6, 200.0, 30.0, 0.1, 0.02, None, size=0.1, joint=4, tag="negligible"),
        # A motor's reflected inertia on one joint, which no rigid-body column holds alone.
        r("rotor_inertia", "white", a3, 500.0, 30.0, 0.1, 0.02,
          Expected(("missing_physics",), joint=2, term=("inertia",)), size=2.0, joint=2),
        r("rotor_inertia", "white", a6, 200.0, 30.0, 0.1, 0.02,
          Expected(("missing_physics",), joint=2, term=("inertia",)), size=2.0, joint=2),
        # The estimation trajectory run again, q logged with an encoder's noise: a repeat, not new data.
        r("repeat", "white", a3, 200.0, 30.0, 0.1, 0.02, Expected(("repeat_trajectory",), severity="design")),
        r("repeat", "ar0.9", p2, 100.0, 40.0, 0.1, 0.02, Expected(("repeat_trajectory",), severity="design")),
        # A gravity and friction model of a 7-joint and a 6-joint arm: the inertial terms it lacks are named.
        r("gravity_only", "white", "arm7", 100.0, 30.0, 0.15, 0.02, Expected(("missing_physics",), term=("inertia",))),
        r("gravity_only", "white", a6, 200.0, 30.0, 0.1, 0.02, Expected(("missing_physics",), term=("inertia",))),
    )


def _structure_names(design: ArmDesign, keep: Sequence[int]) -> list[str]:
    n = design.n_joints
    inertial = [f"L{j + 1}:{p}" for j in range(n) for p in PARAM_NAMES]
    return ([inertial[c] for c in keep] + [f"Fc{j + 1}" for j in range(n)] + [f"Fv{j + 1}" for j in range(n)]
            + [f"off{j + 1}" for j in range(n)])


@functools.lru_cache(maxsize=256)
def _setup(s: Scenario) -> _Setup:
    design = ARMS[s.arm]
    n = design.n_joints
    base = arm(s.arm)
    keep, regroup = base_structure(s.arm)
    names = _structure_names(design, keep)
    # The reference trajectory (a fixed draw at the scenario's rate, length and fundamental): σ and
    # the effects are sized on it, so every replicate of a scenario has the same robot and noise level.
    t = np.arange(s.n_samples) / s.sample_rate
    step = max(1, s.n_samples // 4000)
    t = t[::step]
    q, dq, ddq = random_trajectory(np.random.default_rng(REFERENCE_SEED), design, s.base_frequency)(t)
    tau = base.rnea(q, dq, ddq) + base.viscous * dq + base.coulomb * np.sign(dq)
    sigma = s.sigma * np.sqrt(np.mean(tau**2, axis=0))
    viscous, coulomb, offset = base.viscous.copy(), base.coulomb.copy(), np.zeros(n)
    robot, dropped = base, [f"off{j + 1}" for j in range(n)]
    if s.name == "no_coulomb":
        coulomb = s.size * sigma
        dropped += [f"Fc{j + 1}" for j in range(n)]
    elif s.name == "no_viscous":
        viscous = s.size * sigma / np.sqrt(np.mean(dq**2, axis=0))
        dropped += [f"Fv{j + 1}" for j in range(n)]
    elif s.name in ("no_gravity", "coupled_gravity"):
        column = str(s.column)
        robot = _sized_column_arm(s, t, q, dq, ddq, sigma, [column])
        dropped.append(column)
    elif s.name == "low_information":
        inertial = [c for c in s.missing if c.startswith("L")]
        if inertial:
            robot = _sized_column_arm(s, t, q, dq, ddq, sigma, inertial)
        for c in s.missing:
            if c.startswith("Fv"):
                j = int(c[2:]) - 1
                viscous[j] = s.size * sigma[j] / math.sqrt(float(np.mean(dq[:, j] ** 2)))
        dropped += list(s.missing)
    elif s.name == "offset":
        offset[s.joint] = s.size * sigma[s.joint]  # in the robot (a sensor offset), not in the model
    joint_term = np.zeros(n)  # stribeck, rotor_inertia: the term's gain on ``s.joint``
    if s.name in ("stribeck", "rotor_inertia") and s.joint is not None:
        shape = _joint_term(s, dq, ddq, float(np.sqrt(np.mean(dq[:, s.joint] ** 2))))
        joint_term[s.joint] = s.size * sigma[s.joint] / float(np.sqrt(np.mean(shape**2)))
    payload_arm = arm(s.arm, payload=s.payload) if s.payload > 0 else None
    truth = np.concatenate([regroup @ robot.inertial_parameters(), coulomb, viscous, offset])
    model = tuple(i for i, nm in enumerate(names) if nm not in dropped)
    if s.name == "decoupled":
        # a per-joint model of the joint's own motion: the robot is the right one, the structure is not
        names = _decoupled_names(n)
        truth = np.zeros(len(names))
        model = tuple(range(len(names)))
    elif s.name == "gravity_only":
        # the static model (the base columns that gravity excites, evaluated at rest) with friction;
        # named without the rigid-body parameter syntax: its columns declare no inertia
        gravity = _gravity_columns(s.arm)
        names = [f"g_{n_.replace(':', '_')}" for n_ in (names[c] for c in gravity)] + \
            [f"Fc{j + 1}" for j in range(n)] + [f"Fv{j + 1}" for j in range(n)]
        truth = np.zeros(len(names))
        model = tuple(range(len(names)))
    return _Setup(robot, payload_arm, sigma, viscous, coulomb, offset, keep, regroup, tuple(names), truth, model,
                  joint_term, float(np.sqrt(np.mean(dq[:, s.joint] ** 2))) if s.joint is not None else 1.0)


def _joint_term(s: Scenario, dq: FloatArray, ddq: FloatArray, speed: float) -> FloatArray:
    """The unit-gain shape of a ``stribeck`` or ``rotor_inertia`` term on ``s.joint`` (``speed``:
    the joint's RMS velocity on the reference trajectory)."""
    j = int(s.joint if s.joint is not None else 0)
    if s.name == "stribeck":
        v = dq[:, j]
        return np.sign(v) * np.exp(-((v / (STRIBECK_SPEED * speed)) ** 2))
    return ddq[:, j]


@functools.lru_cache(maxsize=8)
def _gravity_columns(name: str) -> tuple[int, ...]:
    """The base columns of design ``name`` that gravity excites (nonzero at rest on random postures)."""
    keep, _ = base_structure(name)
    design = ARMS[name]
    rng = np.random.default_rng(REFERENCE_SEED)
    q = rng.uniform(-2.0, 2.0, (64, design.n_joints))
    y = arm(name).inertial_regressor(q, np.zeros_like(q), np.zeros_like(q))[:, :, list(keep)]
    size = np.sqrt(np.mean(y**2, axis=(0, 1)))
    return tuple(int(c) for c in np.flatnonzero(size > 1e-9 * size.max()))


def _gravity_regressor(st: _Setup, name: str, q: FloatArray, dq: FloatArray) -> FloatArray:
    """A ``gravity_only`` model's regressor (N, m, P): the gravity columns at rest, Fc, Fv."""
    n = q.shape[1]
    static = st.arm.inertial_regressor(q, np.zeros_like(q), np.zeros_like(q))[:, :, list(st.keep)]
    eye = np.eye(n)
    return np.concatenate([static[:, :, list(_gravity_columns(name))], np.sign(dq)[:, :, None] * eye,
                           dq[:, :, None] * eye], axis=2)


def _decoupled_names(n: int) -> list[str]:
    return [f"{t}{j + 1}" for t in ("ddq", "dq", "sgn", "sin", "cos", "one") for j in range(n)]


def _decoupled_regressor(q: FloatArray, dq: FloatArray, ddq: FloatArray) -> FloatArray:
    """Per joint j: q̈_j, q̇_j, sign q̇_j, sin q_j, cos q_j and 1, non-zero on joint j only (N, m, 6m)."""
    eye = np.eye(q.shape[1])
    terms = [ddq, dq, np.sign(dq), np.sin(q), np.cos(q), np.ones_like(q)]
    return np.concatenate([x[:, :, None] * eye for x in terms], axis=2)


def _filtered_motion(rng: np.random.Generator, traj: Trajectory, stamps: FloatArray,
                     sample_rate: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """What a user logs and derives: encoder positions with 1e-6 rad of noise (a 20-bit encoder), a
    4th-order Butterworth low-pass at 4 % of the rate run forward and backward, and central
    differences (the user's own filtered q, q̇, q̈, not dynval's Savitzky–Golay). The logger runs a
    second before and after the rows kept, as real logs are trimmed of the filter's end effects."""
    import scipy.signal

    pad = int(round(sample_rate))
    step = 1.0 / sample_rate
    ext = np.concatenate([stamps[0] - step * np.arange(pad, 0, -1), stamps, stamps[-1] + step * np.arange(1, pad + 1)])
    logged = traj(ext)[0] + 1e-6 * rng.standard_normal((ext.size, len(traj.amplitudes)))
    b, a = scipy.signal.butter(4, 0.04 * sample_rate, fs=sample_rate)
    qf = scipy.signal.filtfilt(b, a, logged, axis=0)
    dqf = np.gradient(qf, step, axis=0)
    ddqf = np.gradient(dqf, step, axis=0)
    keep = slice(pad, pad + stamps.size)
    return logged[keep], dqf[keep], ddqf[keep]


def _sized_column_arm(s: Scenario, t: FloatArray, q: FloatArray, dq: FloatArray, ddq: FloatArray,
                      sigma: FloatArray, columns: Sequence[str]) -> Arm:
    """The arm with each first-moment column of ``columns`` set so that its part of the torque has
    an RMS of ``s.size`` σ on the joint where it is largest (on the reference trajectory).

    The column must be a base column that nothing regroups into (true of ``L<j>:my``/``mz`` of
    these designs); its base parameter is then m·c of the link, linear in the centre of mass.
    """
    design = ARMS[s.arm]
    keep, regroup = base_structure(s.arm)
    inertial = [f"L{j + 1}:{p}" for j in range(design.n_joints) for p in PARAM_NAMES]
    y = arm(s.arm).inertial_regressor(q, dq, ddq)
    com = {i: link.com for i, link in enumerate(design.links)}
    for column in columns:
        c = inertial.index(column)
        row = keep.index(c)
        if np.count_nonzero(regroup[row]) != 1:
            raise ValueError(f"{column} is regrouped with other parameters: choose a pure base column")
        link, axis = int(column[1:column.index(":")]) - 1, "xyz".index(column[-1])
        rms = np.sqrt(np.mean(y[:, :, c] ** 2, axis=0)) / sigma  # per unit of m·c, in σ
        value = s.size / float(rms.max())
        new = list(com[link])
        new[axis] = value / design.links[link].mass
        com[link] = (new[0], new[1], new[2])
    return arm(s.arm, com=tuple(sorted(com.items())))


# --------------------------------------------------------------------------- replicates


@dataclass(frozen=True)
class Run:
    """One run: motion (N, m), measured torque (N, m), the offered regressor (N, m, P) and the
    measured torque without the sensor noise (``tau_true``: the physics, with any payload, delay,
    jitter, offset or mode)."""

    q: FloatArray
    dq: FloatArray
    ddq: FloatArray
    tau: FloatArray
    regressor: FloatArray
    tau_true: FloatArray
    time: FloatArray | None = None  # the instants the rows were taken at (irregular under ``jitter``)


@dataclass(frozen=True)
class Replicate:
    """An estimation and a validation run of a scenario, with what the model lacks.

    ``effect``: the part of the validation run's measured torque the model's structure cannot
    hold (missing terms, the payload, the mode, the delay's error), noise-free, (N, m);
    ``column_names``: the offered regressor's; ``model_columns``: the model's (indices into them).
    """

    scenario: Scenario
    estimation: Run
    validation: Run
    column_names: tuple[str, ...]
    model_columns: tuple[int, ...]
    truth: FloatArray
    sigma: FloatArray
    effect: FloatArray
    seconds: float
    prediction_extra: FloatArray | None = None  # what the model's own evaluation adds to its prediction


def _seed(s: Scenario, replicate: int) -> np.random.SeedSequence:
    return np.random.SeedSequence([zlib.crc32(s.key.encode()), int(replicate)])


def _regressor(st: _Setup, q: FloatArray, dq: FloatArray, ddq: FloatArray) -> FloatArray:
    """The offered regressor (N, m, P): base inertial columns, Fc, Fv, off."""
    n_s, n = q.shape
    inertial = st.arm.inertial_regressor(q, dq, ddq)
    eye = np.eye(n)
    return np.concatenate([inertial[:, :, list(st.keep)], np.sign(dq)[:, :, None] * eye,
                           dq[:, :, None] * eye, np.broadcast_to(eye, (n_s, n, n))], axis=2)


def _physical_torque(st: _Setup, robot: Arm, q: FloatArray, dq: FloatArray, ddq: FloatArray) -> FloatArray:
    return robot.rnea(q, dq, ddq) + st.viscous * dq + st.coulomb * np.sign(dq) + st.offset


def simulate(s: Scenario, replicate: int) -> Replicate:
    """Replicate number ``replicate`` of scenario ``s`` (deterministic in both)."""
    t0 = time.perf_counter()
    st = _setup(s)
    design = ARMS[s.arm]
    m = design.n_joints
    rng = np.random.default_rng(_seed(s, replicate))
    n = s.n_samples
    t = np.arange(n) / s.sample_rate
    est_traj = random_trajectory(rng, design, s.base_frequency)
    val_traj = random_trajectory(rng, design, s.base_frequency)
    if s.name == "repeat":
        val_traj = est_traj  # the same trajectory run again (a periodic test, or one excitation file)
    if s.name == "unexcited_joint":
        # the validation run moves `joint` by a fraction of the estimation run's amplitudes
        amplitudes = val_traj.amplitudes.copy()
        amplitudes[s.joint] = est_traj.amplitudes[s.joint] * s.unexcited_scale
        val_traj = replace(val_traj, amplitudes=amplitudes)
    outside = [i for i in range(len(st.names)) if i not in st.model]
    runs = []
    effect = np.zeros((n, m))
    for which, traj in (("estimation", est_traj), ("validation", val_traj)):
        # jitter: every row (encoders and torques alike) is taken at t_k + δ_k, the rows stay
        # consistent, and the run is analysed as if sampled on the uniform grid
        stamps = t + rng.uniform(-0.3, 0.3, n) / s.sample_rate if s.noise == "jitter" else t
        q, dq, ddq = traj(stamps)
        robot = st.payload_arm if (which == "validation" and st.payload_arm is not None) else st.arm
        if s.delay:
            tau_true = _physical_torque(st, robot, *traj(t - s.delay / s.sample_rate))
        else:
            tau_true = _physical_torque(st, robot, q, dq, ddq)
        if s.filtered:  # the user's logged positions and filtered derivatives, in the regressor too
            q, dq, ddq = _filtered_motion(rng, traj, stamps, s.sample_rate)
        reg = (_decoupled_regressor(q, dq, ddq) if s.name == "decoupled"
               else _gravity_regressor(st, s.arm, q, dq) if s.name == "gravity_only" else _regressor(st, q, dq, ddq))
        extra = np.zeros((n, m))
        if s.name == "changed_friction" and which == "validation" and s.joint is not None:
            # the joint's Coulomb friction grew between the runs (wear, temperature): the model has the term
            extra[:, s.joint] = s.size * float(st.sigma[s.joint]) * np.sign(dq[:, s.joint])
        if s.name == "mode" and s.joint is not None and s.mode_frequency is not None:
            extra[:, s.joint] = mode_signal(rng, n, s.mode_frequency, s.sample_rate,
                                            s.size * float(st.sigma[s.joint]))
        if s.name in ("stribeck", "rotor_inertia") and st.joint_term is not None:
            extra += st.joint_term * _joint_term(s, dq, ddq, st.joint_speed)[:, None]
        tau_true = tau_true + extra
        tau = tau_true + noise(s.noise, rng, n, st.sigma, s.sample_rate, dq)
        if s.name == "repeat" and which == "validation":
            # the positions as logged: an encoder's noise on the retraced run
            q = q + REPEAT_NOISE * rng.standard_normal(q.shape)
            reg = _regressor(st, q, dq, ddq)
        if which == "validation" and s.name in ("decoupled", "gravity_only"):
            # what the decoupled structure cannot hold of the noise-free torque, joint by joint
            effect = np.column_stack([tau_true[:, j] - reg[:, j] @ np.linalg.lstsq(reg[:, j], tau_true[:, j],
                                                                                     rcond=None)[0] for j in range(m)])
        elif which == "validation":
            effect = reg[:, :, outside] @ st.truth[outside] + extra
            if s.payload > 0:
                effect += _physical_torque(st, robot, q, dq, ddq) - _physical_torque(st, st.arm, q, dq, ddq)
            if s.delay:
                effect += tau_true - extra - _physical_torque(st, robot, q, dq, ddq)
        runs.append(Run(q, dq, ddq, tau, reg, tau_true, stamps))
    extra_pred = _chatter(s, st, runs[1]) if s.name == "chatter" else None
    if extra_pred is not None:
        effect = effect - extra_pred  # the measured torque the prediction misses
    return Replicate(s, runs[0], runs[1], st.names, st.model, st.truth, st.sigma, effect,
                     time.perf_counter() - t0, extra_pred)


def _chatter(s: Scenario, st: _Setup, run: Run) -> FloatArray:
    """What a model whose friction reads sign(q̇ + v) adds to its prediction of joint ``s.joint``,
    v a square limit cycle at ``s.mode_frequency`` of ``CHATTER_DITHER`` × the joint's RMS velocity:
    its sign flips at that rate wherever the joint moves slower (at standstill above all), which
    the robot's friction does not."""
    j = int(s.joint if s.joint is not None else 0)
    n = run.dq.shape[0]
    t = np.arange(n) / s.sample_rate
    dq = run.dq[:, j]
    v = CHATTER_DITHER * math.sqrt(float(np.mean(dq**2))) * np.sign(np.sin(2.0 * math.pi * float(s.mode_frequency) * t))
    out = np.zeros_like(run.dq)
    out[:, j] = st.coulomb[j] * (np.sign(dq + v) - np.sign(dq))
    return out


# --------------------------------------------------------------------------- identification and validation


@one_blas_thread
def fit(rep: Replicate) -> tuple[FloatArray, int]:
    """Least squares of the model's columns on the estimation run (stacked rows): (π̂, rank)."""
    cols = list(rep.model_columns)
    x = rep.estimation.regressor[:, :, cols].reshape(-1, len(cols))
    pi, _, rank, _ = np.linalg.lstsq(x, rep.estimation.tau.reshape(-1), rcond=None)
    return np.asarray(pi, dtype=np.float64), int(rank)


@functools.lru_cache(maxsize=1)
def _validate_keywords() -> frozenset[str]:
    import dynval

    return frozenset(inspect.signature(dynval.validate).parameters)


@functools.lru_cache(maxsize=1)
def _estimation_keys() -> tuple[str, ...]:
    """The keys ``validate(estimation=...)`` accepts beyond q, regressor, tau (dq, ddq when it has them)."""
    import dynval

    x = np.linspace(0.0, 1.0, 40)[:, None]
    accepted = []
    for key in ("dq", "ddq"):
        try:
            dynval.validate(np.sin(7 * x), np.zeros_like(x), n_params=1, max_lag=2, estimation={"q": x, key: x})
        except dynval.InputError:
            continue
        accepted.append(key)
    return tuple(accepted)


def validate_replicate(rep: Replicate, offered: bool, *, prediction: tuple[FloatArray, int] | None = None,
                       backend: Literal["python", "cpp"] | None = None, **keywords: Any) -> Any:
    """``dynval.validate`` of the replicate's validation run, with the estimation run.

    ``offered=True``: the regressor holds every offered column (the robot's structure and the
    offsets) and ``model_columns`` the model's; ``offered=False``: only the model's columns and
    ``model_columns=None``. ``prediction``: (π̂, rank) from :func:`fit` (computed when omitted).
    ``dq``/``ddq`` are passed when ``validate`` has them; extra ``keywords`` go to ``validate``.
    """
    import dynval

    s = rep.scenario
    pi, rank = prediction if prediction is not None else fit(rep)
    cols = list(rep.model_columns)
    est, val = rep.estimation, rep.validation
    pred = val.regressor[:, :, cols] @ pi
    if rep.prediction_extra is not None:
        pred = pred + rep.prediction_extra
    if offered:
        reg_val, reg_est, names, model = val.regressor, est.regressor, list(rep.column_names), cols
    else:
        reg_val, reg_est = val.regressor[:, :, cols], est.regressor[:, :, cols]
        names, model = [rep.column_names[c] for c in cols], None
    estimation: dict[str, Any] = {"q": est.q, "regressor": reg_est, "tau": est.tau}
    for key in _estimation_keys():
        estimation[key] = getattr(est, key)
    accepted = _validate_keywords()
    kw: dict[str, Any] = {}
    for key in ("dq", "ddq"):
        if key in accepted:
            kw[key] = getattr(val, key)
    if s.noise == "jitter" and "time" in accepted:
        kw["time"] = val.time  # a logger with irregular stamps hands them over
    else:
        kw["sample_rate"] = s.sample_rate
    kw.update(keywords)
    # the largest lag is validate's default: the motion's time scale
    return dynval.validate(val.tau, pred, n_params=rank, regressor=reg_val, column_names=names, model_columns=model,
                           q=val.q, estimation=estimation,
                           joint_names=list(ARMS[s.arm].joint_names), backend=backend, **kw)


def _column_joint(name: str) -> int | None:
    """The joint a column belongs to: ``Fc2``/``Fv2``/``off2`` to joint 1, ``L2:*`` (the link joint 1 moves) too."""
    for prefix in ("Fc", "Fv", "off"):
        if name.startswith(prefix) and name[len(prefix):].isdigit():
            return int(name[len(prefix):]) - 1
    if name.startswith("L") and ":" in name and name[1:name.index(":")].isdigit():
        return int(name[1:name.index(":")]) - 1
    return None


def _names_joint(f: Any, joint: int, names: Sequence[str]) -> bool:
    if joint in tuple(f.joints):
        return True
    if f.joints or not f.columns:
        return False
    return all(_column_joint(names[c]) == joint for c in f.columns)


def named_right(report: Any, expected: Expected | None, offered: bool) -> bool:
    """True when a finding of the expected severity and kind names the expected cause (:class:`Expected`)."""
    if expected is None:
        return False
    names = report.provenance["column_names"] or ()
    return any(_names_cause(f, expected, offered, names) for f in report.findings)


def _names_cause(f: Any, expected: Expected, offered: bool, names: Sequence[str]) -> bool:
    """One finding names the expected cause (:func:`named_right`)."""
    for _ in (0,):
        if (f.severity != expected.severity and not expected.reported) or f.kind not in expected.kinds:
            continue
        if expected.joint is not None and not _names_joint(f, expected.joint, names):
            continue
        details = f.details or {}
        if f.kind == "missing_physics":
            if expected.term is not None and details.get("term") not in expected.term:
                continue
            if expected.relation is not None and details.get("relation") not in expected.relation:
                continue
        elif f.kind in ("regressor_correlation", "bias"):
            offset_bias = f.kind == "bias" and expected.term is not None and "offset" in expected.term
            names_column = ((offered or expected.model_column) and expected.column_prefix is not None
                            and bool(f.columns) and str(names[f.columns[0]]).startswith(expected.column_prefix))
            names_term = f.kind == "bias" and expected.term is not None and details.get("term") in expected.term
            if not (offset_bias or names_column or names_term):
                continue
        elif f.kind in ("oscillation", "prediction_artefact"):
            if expected.frequency is not None and not (
                    abs(float(details.get("frequency", math.inf)) - expected.frequency) <= 0.1 * expected.frequency):
                continue
        elif f.kind == "delay":
            d = details.get("delay_s")
            if expected.delay_s is not None and d is not None and not (
                    0.5 * expected.delay_s <= float(d) <= 2.0 * expected.delay_s):
                continue
        return True
    return False


_ADD_WORDS = {"offset": "add a torque offset", "coulomb": "add a friction", "viscous": "add a friction",
              "gravity": "add a gravity term"}


def adds_what_it_has(report: Any, s: Scenario, offered: bool, model_columns: Sequence[int]) -> list[str]:
    """The actions of ``report``'s deficiencies that tell the model to add a term it has (empty when
    none): a named physical term among :attr:`Scenario.model_has` (its cross-joint coupling aside, and
    a term of one joint alone the model's shared parameters only bend to, relation ``local``: a
    rotor inertia beside link inertias is a column outside the model's span over all joints), a
    bias's "add a friction"/"a gravity term"/"a torque offset" for a kind it has, or "add the term C"
    for one of its own columns."""
    names = report.provenance["column_names"] or ()
    own = set(model_columns) if offered else set(range(len(names)))
    bad = []
    for f in report.deficiencies:
        d = f.details or {}
        physics = (f.kind == "missing_physics" and f.action.startswith("add ") and d.get("term") in s.model_has
                   and d.get("relation") not in ("coupling", "local"))
        bias = f.kind == "bias" and any(k in s.model_has and w in f.action for k, w in _ADD_WORDS.items())
        column = f.action.startswith("add the term ") and bool(f.columns) and int(f.columns[0]) in own
        if physics or bias or column:
            bad.append(f.action)
    return bad


def advice_right(report: Any, s: Scenario, offered: bool, model_columns: Sequence[int]) -> bool | None:
    """The first step is right: the first deciding finding (the report's ``first_step``: the
    deficiencies ranked by the share of the torque each explains, docs/conventions.md §5.10) names the
    expected cause, and no deficiency tells the model to add a term it has. None for a scenario
    without an expected deficiency."""
    if s.expected is None or s.expected.severity != "deficiency":
        return None
    ranked = report.deciding
    names = report.provenance["column_names"] or ()
    first = bool(ranked) and _names_cause(ranked[0].finding, s.expected, offered, names)
    return bool(first) and not adds_what_it_has(report, s, offered, model_columns)


def run_replicate(s: Scenario, replicate: int, *, offered: Sequence[bool] = (True, False),
                  backend: Literal["python", "cpp"] | None = None) -> list[dict[str, Any]]:
    """Simulate, identify and validate one replicate once per ``offered``; one outcome record each.

    A record: ``key``, ``offered``, ``replicate``, ``any_deficiency``, ``named_right`` (None for a
    right model), ``kinds`` (the deficiency kinds, and ``kind/design`` for design findings),
    ``seconds_simulate`` (simulation and identification) and ``seconds_validate``.
    """
    t0 = time.perf_counter()
    rep = simulate(s, replicate)
    prediction = fit(rep)
    t_sim = time.perf_counter() - t0
    out = []
    for flag in offered:
        t1 = time.perf_counter()
        report = validate_replicate(rep, flag, prediction=prediction, backend=backend)
        kinds = sorted({f.kind for f in report.findings if f.severity == "deficiency"}
                       | {f"{f.kind}/design" for f in report.findings if f.severity == "design"})
        out.append({"key": s.key, "offered": bool(flag), "replicate": int(replicate),
                    "any_deficiency": bool(report.deficiencies),
                    "named_right": None if s.expected is None else named_right(report, s.expected, flag),
                    "advice_right": advice_right(report, s, flag, rep.model_columns),
                    "adds_what_it_has": len(adds_what_it_has(report, s, flag, rep.model_columns)),
                    "kinds": kinds, "seconds_simulate": t_sim, "seconds_validate": time.perf_counter() - t1})
    return out
