"""Simulated fleets of the 2-DOF arm of :mod:`dynval.simulate`, some robots degrading from a log on.

Each robot is the arm with its own masses (±5 %) and an identified model a little off its truth
(every base parameter ±3 %): the model every log is validated against. Each log is a new excitation
trajectory with coloured torque noise (AR(1)); a degradation changes the robot's true parameters
from one log on (friction grows, or a payload is added at link 2), the model staying as identified.
The drift test (``benchmarks/calibrate_fleet.py``) is calibrated on these fleets.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from datetime import datetime, timedelta, timezone

import numpy as np

from ..simulate import DEFAULT_ARM, ArmParameters, _trajectory_coefficients, base_parameters, fourier_trajectory
from ..simulate import regressor as arm_regressor
from ._logs import LogSpec

__all__ = ["Degradation", "FleetLog", "simulate_fleet", "write_fleet", "robot_names"]

_PAYLOAD_DISTANCE = 0.4  # m along link 2: where a payload is held


@dataclass(frozen=True)
class Degradation:
    """A change of a robot's true parameters from log ``from_log`` (0-based) on: ``friction``
    multiplies its viscous and Coulomb friction by ``1 + size``; ``payload`` adds ``size`` kg at
    0.4 m along link 2."""

    kind: str
    from_log: int
    size: float

    def __post_init__(self) -> None:
        from ..checks._validation import check_choice, parameter_error

        check_choice("kind", self.kind, ("friction", "payload"))
        if not isinstance(self.from_log, int) or self.from_log < 0:
            raise parameter_error("from_log", "an integer >= 0", self.from_log)


@dataclass(frozen=True)
class FleetLog:
    """One simulated log in memory."""

    robot: str
    time: str
    tau_meas: np.ndarray
    tau_pred: np.ndarray
    regressor: np.ndarray


def robot_names(n: int) -> list[str]:
    """``r01``, ``r02``, ..."""
    return [f"r{i + 1:02d}" for i in range(n)]


def _degraded(arm: ArmParameters, change: Degradation) -> ArmParameters:
    if change.kind == "friction":
        f = 1.0 + change.size
        return replace(arm, fv1=arm.fv1 * f, fc1=arm.fc1 * f, fv2=arm.fv2 * f, fc2=arm.fc2 * f)
    if change.kind == "payload":
        mass = arm.m2 + change.size
        cx2 = (arm.m2 * arm.cx2 + change.size * _PAYLOAD_DISTANCE) / mass
        inertia = arm.I2 + arm.m2 * (cx2 - arm.cx2) ** 2 + change.size * (_PAYLOAD_DISTANCE - cx2) ** 2
        return replace(arm, m2=mass, cx2=cx2, I2=inertia)
    raise AssertionError(change.kind)  # checked by Degradation


def _ar1(rng: np.random.Generator, shape: tuple[int, int], sd: float, colour: float) -> np.ndarray:
    import scipy.signal

    white = rng.normal(0.0, sd * np.sqrt(1.0 - colour**2), size=shape)
    white[0] = rng.normal(0.0, sd, size=shape[1])  # the stationary start
    return np.asarray(scipy.signal.lfilter([1.0], [1.0, -colour], white, axis=0))


def _robot(rng: np.random.Generator) -> tuple[ArmParameters, np.ndarray]:
    scale = 1.0 + 0.05 * rng.uniform(-1.0, 1.0, size=2)
    arm = replace(DEFAULT_ARM, m1=DEFAULT_ARM.m1 * scale[0], m2=DEFAULT_ARM.m2 * scale[1])
    model = base_parameters(arm) * (1.0 + 0.03 * rng.uniform(-1.0, 1.0, size=10))
    return arm, model


def simulate_fleet(*, n_robots: int = 6, n_logs: int = 12, n_samples: int = 1000,
                   degradations: dict[str, Degradation] | None = None, seed: int = 0, noise: float = 0.2,
                   colour: float = 0.9, sample_rate: float = 100.0) -> list[FleetLog]:
    """Logs of ``n_robots`` robots (``r01``, ...), ``n_logs`` each, one a day from 2026-01-01;
    ``degradations`` maps a robot to its change. Deterministic for a seed.

    Examples
    --------
    >>> logs = simulate_fleet(n_robots=2, n_logs=3, n_samples=200)
    >>> len(logs), logs[0].robot, logs[0].time, logs[0].tau_meas.shape
    (6, 'r01', '2026-01-01T08:00', (200, 2))
    """
    changes = degradations or {}
    root = np.random.SeedSequence(seed)
    out = []
    start = datetime(2026, 1, 1, 8, 0, tzinfo=timezone.utc)
    t = np.arange(n_samples) / sample_rate
    for robot, child in zip(robot_names(n_robots), root.spawn(n_robots)):
        rng = np.random.default_rng(child)
        arm, model = _robot(rng)
        change = changes.get(robot)
        for k in range(n_logs):
            truth = _degraded(arm, change) if change is not None and k >= change.from_log else arm
            offsets, amplitudes, phases = _trajectory_coefficients(rng)
            q, dq, ddq = fourier_trajectory(t, offsets, amplitudes, phases, 0.1)
            y = arm_regressor(q, dq, ddq, l1=arm.l1)
            tau = y @ base_parameters(truth) + _ar1(rng, (n_samples, 2), noise, colour)
            stamp = (start + timedelta(days=k)).strftime("%Y-%m-%dT%H:%M")
            out.append(FleetLog(robot, stamp, tau, y @ model, y))
    return out


def write_fleet(logs: list[FleetLog], directory: str, n_params: int = 10, regressor: bool = False) -> list[LogSpec]:
    """Write each log as a directory ``ROBOT__TIME`` of ``.npy`` files (``:`` of the time as ``-``)
    under ``directory``, and a ``manifest.csv`` naming them; returns their LogSpecs."""
    specs = []
    for log in logs:
        folder = os.path.join(directory, f"{log.robot}__{log.time.replace(':', '-')}")
        os.makedirs(folder, exist_ok=True)
        np.save(os.path.join(folder, "tau_meas.npy"), log.tau_meas)
        np.save(os.path.join(folder, "tau_pred.npy"), log.tau_pred)
        reg = None
        if regressor:
            reg = os.path.join(folder, "regressor.npy")
            np.save(reg, log.regressor)
        specs.append(LogSpec(log.robot, log.time, os.path.join(folder, "tau_meas.npy"),
                             os.path.join(folder, "tau_pred.npy"), n_params, reg, os.path.basename(folder)))
    with open(os.path.join(directory, "manifest.csv"), "w", encoding="utf-8") as handle:
        handle.write("robot,time,log,tau_meas,tau_pred,regressor,n_params\n")
        for s in specs:
            handle.write(f"{s.robot},{s.time},{s.log},{os.path.relpath(s.tau_meas, directory)},"
                         f"{os.path.relpath(s.tau_pred, directory)},"
                         f"{'' if s.regressor is None else os.path.relpath(s.regressor, directory)},{s.n_params}\n")
    return specs
