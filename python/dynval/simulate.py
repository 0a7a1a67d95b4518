"""Simulated data sets of a 2-DOF arm for the demo and the tests: one lesson per scenario.

A two-link planar arm moves in a vertical plane under gravity. Each scenario makes one
estimation record and one validation record, both excited by finite Fourier series
trajectories, with torque sensor noise; the data are seeded and deterministic.

==============  ==========================================================================
scenario        what the true system has, and what the validation should show
==============  ==========================================================================
``rigid``       rigid body only: the rigid-body candidate suffices; no deficiency.
``friction``    rigid body + viscous + Coulomb friction: the friction candidate wins.
``flexible``    friction + an elastic joint 2 (lumped spring and damper between motor and
                link, lightly damped, shaken by a small broadband disturbance on the link):
                every rigid candidate leaves an oscillatory residual at the joint's mode
                frequency (:attr:`SimulatedData.mode_frequency`) — the lesson's Problem 5.
``offset``      friction + a constant torque-sensor offset per joint: the offset candidate
                wins.
``repeat``      the ``friction`` system, but the validation record repeats the estimation
                trajectory (a new noise realization): a design flaw, not a model flaw.
==============  ==========================================================================

Every record carries the regressors of the three candidate structures (:data:`CANDIDATES`):
``rigid`` (6 base parameters), ``friction`` (+ ``Fv1, Fc1, Fv2, Fc2``) and ``friction+offset``
(+ ``off1, off2``).

The arm
-------
Joint angles ``q1`` (link 1 from the horizontal) and ``q2`` (link 2 relative to link 1);
gravity ``g`` acts along the downward vertical. Per link ``i``: mass ``m_i``, centre of mass
``(cx_i, cy_i)`` in the link frame (x along the link), inertia ``I_i`` about the centre of mass;
link 1 has length ``l1``. The joint torques are linear in the base parameters

============  ==================================================
``ZZ1R``      ``I1 + m1 (cx1² + cy1²) + m2 l1²``
``MX1R``      ``m1 cx1 + m2 l1``
``MY1``       ``m1 cy1``
``ZZ2``       ``I2 + m2 (cx2² + cy2²)``
``MX2``       ``m2 cx2``
``MY2``       ``m2 cy2``
``Fv1, Fv2``  viscous friction, ``Fv_j q̇_j``
``Fc1, Fc2``  Coulomb friction, ``Fc_j sign(q̇_j)``
``off1/2``    constant torque offset (sensor bias)
============  ==================================================

with (``c2 = cos q2``, ``s2 = sin q2``, ``c1 = cos q1``, ``c12 = cos(q1 + q2)``, ...)::

    τ1 = ZZ1R q̈1 + ZZ2 (q̈1 + q̈2)
         + MX2 l1 [(2q̈1 + q̈2) c2 − (2q̇1q̇2 + q̇2²) s2]
         − MY2 l1 [(2q̈1 + q̈2) s2 + (2q̇1q̇2 + q̇2²) c2]
         + g (MX1R c1 − MY1 s1) + g (MX2 c12 − MY2 s12) + Fv1 q̇1 + Fc1 sign(q̇1)
    τ2 = ZZ2 (q̈1 + q̈2) + MX2 l1 (q̈1 c2 + q̇1² s2) + MY2 l1 (q̇1² c2 − q̈1 s2)
         + g (MX2 c12 − MY2 s12) + Fv2 q̇2 + Fc2 sign(q̇2)

The elastic joint
-----------------
In ``flexible`` the motor of joint 2 follows the commanded trajectory ``θ2(t)`` (a stiff
position loop) and drives link 2 through a spring ``K`` and damper ``D``; joint 1 is rigid.
With ``q1 = θ1`` prescribed, link 2 obeys ``ZZ2 q̈2 = K(θ2 − q2) + D(θ̇2 − q̇2) + w − h2(q, q̇, q̈1)``,
where ``h2`` is the rest of the rigid ``τ2`` and ``w`` a small white disturbance torque on the
link. Its inertia about joint 2 is the constant ``ZZ2``, so the mode frequency is
``f = √(K/ZZ2)/(2π)·√(1−ζ²)`` whatever the configuration (gravity shifts it by well under 1 %).
The encoders are on the motor side: the data record ``q = θ``, the torques of the link's true
motion, and the regressors evaluated at ``θ`` — exactly what a rigid model is fitted to.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

__all__ = [
    "ArmParameters",
    "DEFAULT_ARM",
    "GRAVITY",
    "PARAMETER_NAMES",
    "COLUMN_NAMES",
    "CANDIDATES",
    "SCENARIOS",
    "JOINT_NAMES",
    "base_parameters",
    "regressor",
    "full_regressor",
    "fourier_trajectory",
    "Record",
    "SimulatedData",
    "simulate",
]

GRAVITY = 9.81
"""Gravitational acceleration in m/s² (acting along the downward vertical)."""

PARAMETER_NAMES = ("ZZ1R", "MX1R", "MY1", "ZZ2", "MX2", "MY2", "Fv1", "Fc1", "Fv2", "Fc2")
"""Columns of :func:`regressor`: rigid body and friction."""

COLUMN_NAMES = PARAMETER_NAMES + ("off1", "off2")
"""Columns of :func:`full_regressor`: rigid body, friction and torque offsets."""

JOINT_NAMES = ("shoulder", "elbow")

CANDIDATES = MappingProxyType({
    "rigid": ("ZZ1R", "MX1R", "MY1", "ZZ2", "MX2", "MY2"),
    "friction": PARAMETER_NAMES,
    "friction+offset": COLUMN_NAMES,
})
"""Candidate model structures, by name: the regressor columns each one uses."""

SCENARIOS = ("rigid", "friction", "flexible", "offset", "repeat")

_DESCRIPTIONS = {
    "rigid": "rigid body only (no friction)",
    "friction": "rigid body with viscous and Coulomb friction",
    "flexible": "friction and an elastic joint 2 (spring and damper between motor and link)",
    "offset": "friction and a constant torque-sensor offset on each joint",
    "repeat": "friction; the validation record repeats the estimation trajectory",
}


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
    >>> from dynval.simulate import base_parameters, ArmParameters
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
    >>> from dynval.simulate import regressor, base_parameters
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


def full_regressor(q, qd, qdd, *, l1: float = DEFAULT_ARM.l1, g: float = GRAVITY) -> np.ndarray:
    """:func:`regressor` with one torque-offset column per joint appended: ``(N, 2, 12)``."""
    y = regressor(q, qd, qdd, l1=l1, g=g)
    off = np.zeros((y.shape[0], 2, 2))
    off[:, 0, 0] = 1.0
    off[:, 1, 1] = 1.0
    return np.concatenate([y, off], axis=2)


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


def trajectory_coefficients(rng, n_harmonics=5):
    # Amplitudes fall as 1/k so the accelerations stay moderate (a few rad/s²). Wide swings of
    # joint 1 (about ±2 rad) keep the gravity columns g·cos q1 and g·sin q1 apart from a constant
    # offset column: with ±1 rad the three are nearly collinear and the offset candidate
    # extrapolates badly to a different trajectory.
    k = np.arange(1, n_harmonics + 1)
    amplitudes = rng.uniform(0.6, 1.2, size=(2, n_harmonics)) / k
    phases = rng.uniform(0.0, 2.0 * np.pi, size=(2, n_harmonics))
    offsets = rng.uniform(-1.0, 1.0, size=2)
    return offsets, amplitudes, phases


@dataclass(frozen=True)
class Record:
    """One experiment: time, joint motion, measured torques, and each candidate's regressor.

    ``t`` (N,) s; ``q``, ``dq``, ``ddq`` (N, 2) in rad, rad/s, rad/s²; ``tau_meas`` (N, 2) N·m;
    ``regressors`` maps each candidate name to its ``(N, 2, p)`` regressor; ``full_regressor``
    is the ``(N, 2, 12)`` regressor of every column (:data:`COLUMN_NAMES`).
    """

    t: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    tau_meas: np.ndarray
    regressors: MappingProxyType
    full_regressor: np.ndarray


@dataclass(frozen=True)
class SimulatedData:
    """A scenario's estimation and validation records and what was simulated.

    ``column_names`` maps each candidate to its column names; ``mode_frequency`` is the
    damped natural frequency (Hz) of the elastic joint in ``flexible`` (None otherwise);
    ``true_parameters`` maps each of :data:`COLUMN_NAMES` to its true value (elastic and
    disturbance values in ``elastic``).
    """

    scenario: str
    description: str
    estimation: Record
    validation: Record
    sample_rate: float
    column_names: MappingProxyType
    candidates: tuple
    joint_names: tuple
    true_parameters: MappingProxyType
    noise: float
    seed: int
    mode_frequency: float | None = None
    elastic: MappingProxyType | None = None
    full_column_names: tuple = COLUMN_NAMES

    @property
    def n_samples(self) -> int:
        return int(self.estimation.t.shape[0])


def _elastic_link_motion(theta_fn, t, dt_int, pi, arm, g, stiffness, damping, disturbance, rng, lead_in):
    """Integrate link 2 of the elastic joint (RK4, fixed step); returns q2, dq2, ddq2, w at ``t``."""
    zz2, mx2, my2 = pi[3], pi[4], pi[5]
    l1 = arm.l1
    fs = 1.0 / (t[1] - t[0])
    sub = max(1, int(round(1.0 / (fs * dt_int))))
    h = 1.0 / (fs * sub)
    n_lead = int(round(lead_in * fs))
    n_total = n_lead + t.shape[0]
    t0 = t[0] - n_lead / fs
    # Motor trajectory on the half-step grid (RK4 needs it at t, t + h/2, t + h).
    grid = t0 + 0.5 * h * np.arange(2 * sub * n_total + 1)
    th, dth, ddth = theta_fn(grid)
    # White disturbance held over each sampling interval: band-limited to the data's band,
    # so it rings the mode without adding much broadband torque of its own.
    w_steps = np.repeat(rng.normal(0.0, disturbance, size=n_total), sub)

    # Plain Python floats: scalar indexing of numpy arrays would dominate the loop.
    th1, th2 = th[:, 0].tolist(), th[:, 1].tolist()
    dth1, dth2 = dth[:, 0].tolist(), dth[:, 1].tolist()
    ddth1 = ddth[:, 0].tolist()
    w_steps = w_steps.tolist()
    zz2, mx2l, my2l, gmx2, gmy2 = float(zz2), float(mx2 * l1), float(my2 * l1), float(g * mx2), float(g * my2)
    k_s, d_s = float(stiffness), float(damping)

    def rhs(i, x, v, w):
        q1, d1, a1 = th1[i], dth1[i], ddth1[i]
        c2, s2 = math.cos(x), math.sin(x)
        c12, s12 = math.cos(q1 + x), math.sin(q1 + x)
        rest = (zz2 * a1 + mx2l * (a1 * c2 + d1 * d1 * s2) + my2l * (d1 * d1 * c2 - a1 * s2)
                + gmx2 * c12 - gmy2 * s12)
        spring = k_s * (th2[i] - x) + d_s * (dth2[i] - v)
        return (spring + w - rest) / zz2

    x = th2[0]
    v = dth2[0]
    q2 = np.empty(n_total)
    dq2 = np.empty(n_total)
    ddq2 = np.empty(n_total)
    w_at = np.empty(n_total)
    for k in range(n_total):
        i0 = 2 * sub * k
        w = w_steps[sub * k]
        q2[k], dq2[k], w_at[k] = x, v, w
        ddq2[k] = rhs(i0, x, v, w)
        for s in range(sub):
            i = i0 + 2 * s
            w = w_steps[sub * k + s]
            k1x, k1v = v, rhs(i, x, v, w)
            k2x, k2v = v + 0.5 * h * k1v, rhs(i + 1, x + 0.5 * h * k1x, v + 0.5 * h * k1v, w)
            k3x, k3v = v + 0.5 * h * k2v, rhs(i + 1, x + 0.5 * h * k2x, v + 0.5 * h * k2v, w)
            k4x, k4v = v + h * k3v, rhs(i + 2, x + h * k3x, v + h * k3v, w)
            x += h / 6.0 * (k1x + 2 * k2x + 2 * k3x + k4x)
            v += h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v)
    return q2[n_lead:], dq2[n_lead:], ddq2[n_lead:], w_at[n_lead:]


def _record(t, q, dq, ddq, tau, arm, g):
    full = full_regressor(q, dq, ddq, l1=arm.l1, g=g)
    regs = {name: np.ascontiguousarray(full[:, :, [COLUMN_NAMES.index(c) for c in cols]])
            for name, cols in CANDIDATES.items()}
    return Record(t=t, q=q, dq=dq, ddq=ddq, tau_meas=tau, regressors=MappingProxyType(regs), full_regressor=full)


def simulate(scenario: str = "friction", *, seed: int = 0, n_samples: int = 2000,
             sample_rate: float = 100.0, noise: float = 0.2, arm: ArmParameters = DEFAULT_ARM,
             mode_frequency: float = 7.0, damping_ratio: float = 0.02, disturbance: float = 0.3,
             offsets=(0.8, -0.6), base_frequency: float = 0.1, g: float = GRAVITY) -> SimulatedData:
    """Simulate a scenario's estimation and validation records.

    Parameters
    ----------
    scenario : str
        One of :data:`SCENARIOS`.
    seed : int
        Seed of the trajectories, the noise and the disturbance.
    n_samples : int
        Samples per record (at least 200).
    sample_rate : float
        Sampling rate in Hz.
    noise : float
        Standard deviation (N·m) of the torque sensor noise, on each joint.
    arm : ArmParameters
        Physical parameters.
    mode_frequency : float
        Undamped natural frequency (Hz) of the elastic joint (``flexible``); the spring is
        ``K = ZZ2 (2π f)²``.
    damping_ratio : float
        Damping ratio ζ of the elastic joint.
    disturbance : float
        Standard deviation (N·m) of the white disturbance torque on link 2 in ``flexible``, held
        over each sampling interval (integration is RK4 with a step of about 2 ms).
    offsets : pair of float
        Torque sensor offsets (N·m) in ``offset``.
    base_frequency : float
        Fundamental frequency (Hz) of the Fourier series trajectories (five harmonics).

    Returns
    -------
    SimulatedData

    Examples
    --------
    >>> from dynval.simulate import simulate
    >>> data = simulate("friction", n_samples=300)
    >>> data.estimation.regressors["friction"].shape, data.column_names["rigid"][:2]
    ((300, 2, 10), ('ZZ1R', 'MX1R'))
    """
    from .checks._validation import check_choice, parameter_error

    check_choice("scenario", scenario, SCENARIOS)
    if not isinstance(n_samples, (int, np.integer)) or n_samples < 200:
        raise parameter_error("n_samples", "an integer >= 200", n_samples)
    if not (isinstance(noise, (int, float)) and math.isfinite(noise) and noise >= 0):
        raise parameter_error("noise", "a finite number >= 0", noise)
    if not (isinstance(sample_rate, (int, float)) and math.isfinite(sample_rate) and sample_rate > 0):
        raise parameter_error("sample_rate", "a finite number > 0", sample_rate)

    rng = np.random.default_rng(seed)
    t = np.arange(n_samples) / float(sample_rate)
    pi = base_parameters(arm)
    if scenario == "rigid":
        pi[6:] = 0.0
    bias = np.asarray(offsets, dtype=float) if scenario == "offset" else np.zeros(2)
    coefs_est = trajectory_coefficients(rng)
    coefs_val = coefs_est if scenario == "repeat" else trajectory_coefficients(rng)

    elastic = None
    f_damped = None
    if scenario == "flexible":
        omega = 2.0 * math.pi * mode_frequency
        stiffness = pi[3] * omega**2
        damping_coef = 2.0 * damping_ratio * omega * pi[3]
        f_damped = mode_frequency * math.sqrt(1.0 - damping_ratio**2)
        elastic = MappingProxyType({"stiffness": stiffness, "damping": damping_coef,
                                    "damping_ratio": damping_ratio, "undamped_frequency": mode_frequency,
                                    "disturbance_std": disturbance})

    records = []
    for coefs in (coefs_est, coefs_val):
        offs, amps, phases = coefs

        def theta_fn(tt, offs=offs, amps=amps, phases=phases):
            return fourier_trajectory(tt, offs, amps, phases, base_frequency)

        q, dq, ddq = theta_fn(t)
        if scenario == "flexible":
            q2, dq2, ddq2, w = _elastic_link_motion(theta_fn, t, 2e-3, pi, arm, g, elastic["stiffness"],
                                                    elastic["damping"], disturbance, rng, lead_in=3.0)
            link_q = np.column_stack([q[:, 0], q2])
            link_dq = np.column_stack([dq[:, 0], dq2])
            link_ddq = np.column_stack([ddq[:, 0], ddq2])
            # Link torques of the true motion, minus the disturbance couple acting on link 2;
            # friction acts on the motor side, at the motor velocity.
            tau = regressor(link_q, link_dq, link_ddq, l1=arm.l1, g=g)[:, :, :6] @ pi[:6]
            tau -= w[:, None]
            tau += regressor(q, dq, ddq, l1=arm.l1, g=g)[:, :, 6:] @ pi[6:]
        else:
            tau = regressor(q, dq, ddq, l1=arm.l1, g=g) @ pi
        tau = tau + bias + rng.normal(0.0, noise, size=tau.shape)
        records.append(_record(t, q, dq, ddq, tau, arm, g))

    truth = dict(zip(COLUMN_NAMES, [*pi.tolist(), *bias.tolist()]))
    return SimulatedData(
        scenario=scenario,
        description=_DESCRIPTIONS[scenario],
        estimation=records[0],
        validation=records[1],
        sample_rate=float(sample_rate),
        column_names=MappingProxyType(dict(CANDIDATES)),
        candidates=tuple(CANDIDATES),
        joint_names=JOINT_NAMES,
        true_parameters=MappingProxyType(truth),
        noise=float(noise),
        seed=int(seed),
        mode_frequency=f_damped,
        elastic=elastic,
    )
