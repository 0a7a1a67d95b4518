"""Simulated fleets of the 2-DOF arm of :mod:`dynval.simulate`, some robots degrading from a log on.

Each robot is the arm with its own masses (±5 %) and a model identified by least squares on an
estimation run of its own (an excitation trajectory with the logs' noise): the model every log is
validated against, off its truth by what that run's noise leaves (``model_error=0.03`` instead gives
the earlier simulator's model, every base parameter ±3 % off its truth, far beyond that noise). Each log
is a new excitation trajectory with coloured torque noise (AR(1)), with its joint positions and their
derivatives, its regressor and its time stamps; a degradation changes the robot's true parameters from
one log on (friction grows, or a payload is added at link 2), the model staying as identified. The drift
test (``benchmarks/calibrate_fleet.py``) is calibrated on these fleets.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from datetime import datetime, timedelta, timezone

import numpy as np

from ..simulate import DEFAULT_ARM, ArmParameters, base_parameters, fourier_trajectory, trajectory_coefficients
from ..simulate import regressor as arm_regressor
from ._logs import DATA_COLUMNS, LogSpec

__all__ = ["Degradation", "FleetLog", "EstimationRun", "simulate_fleet", "write_fleet", "robot_names"]

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
class EstimationRun:
    """The run a robot's model was identified on: torques (N, 2), regressor (N, 2, 10), positions (N, 2)."""

    tau: np.ndarray
    regressor: np.ndarray
    q: np.ndarray


@dataclass(frozen=True)
class FleetLog:
    """One simulated log in memory: torques, the model's prediction, the regressor (N, 2, 10), the joint
    positions, velocities and accelerations (N, 2), the time stamps (s) and the robot's estimation run
    (None for a model ``model_error`` off its truth, which no run identified)."""

    robot: str
    time: str
    tau_meas: np.ndarray
    tau_pred: np.ndarray
    regressor: np.ndarray
    q: np.ndarray | None = None
    dq: np.ndarray | None = None
    ddq: np.ndarray | None = None
    timestamps: np.ndarray | None = None
    estimation: EstimationRun | None = None


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


def _robot(rng: np.random.Generator, model_error: float = 0.03) -> tuple[ArmParameters, np.ndarray]:
    scale = 1.0 + 0.05 * rng.uniform(-1.0, 1.0, size=2)
    arm = replace(DEFAULT_ARM, m1=DEFAULT_ARM.m1 * scale[0], m2=DEFAULT_ARM.m2 * scale[1])
    model = base_parameters(arm) * (1.0 + model_error * rng.uniform(-1.0, 1.0, size=10))
    return arm, model


def _identified(arm: ArmParameters, seed: np.random.SeedSequence, t: np.ndarray, noise: float,
                colour: float) -> tuple[np.ndarray, EstimationRun]:
    """The model least squares gives on an estimation run of the robot (its own stream, so that the
    logs' trajectories and noise are those of the earlier simulator)."""
    rng = np.random.default_rng(seed)
    offsets, amplitudes, phases = trajectory_coefficients(rng)
    q, dq, ddq = fourier_trajectory(t, offsets, amplitudes, phases, 0.1)
    y = arm_regressor(q, dq, ddq, l1=arm.l1)
    tau = y @ base_parameters(arm) + _ar1(rng, (t.size, 2), noise, colour)
    model = np.linalg.lstsq(y.reshape(-1, y.shape[-1]), tau.reshape(-1), rcond=None)[0]
    return model, EstimationRun(tau, y, q)


def simulate_fleet(*, n_robots: int = 6, n_logs: int = 12, n_samples: int = 1000,
                   degradations: dict[str, Degradation] | None = None, seed: int = 0, noise: float = 0.2,
                   colour: float = 0.9, sample_rate: float = 100.0, model_error: float | None = None) -> list[FleetLog]:
    """Logs of ``n_robots`` robots (``r01``, ...), ``n_logs`` each, one a day from 2026-01-01;
    ``degradations`` maps a robot to its change. Each robot's model is identified on an estimation run
    of ``n_samples`` samples, or, with ``model_error``, is its truth with every base parameter off by
    up to that share (no estimation run). Deterministic for a seed.

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
        arm, model = _robot(rng, 0.03 if model_error is None else model_error)
        run = None
        if model_error is None:
            model, run = _identified(arm, child.spawn(1)[0], t, noise, colour)
        change = changes.get(robot)
        for k in range(n_logs):
            truth = _degraded(arm, change) if change is not None and k >= change.from_log else arm
            offsets, amplitudes, phases = trajectory_coefficients(rng)
            q, dq, ddq = fourier_trajectory(t, offsets, amplitudes, phases, 0.1)
            y = arm_regressor(q, dq, ddq, l1=arm.l1)
            tau = y @ base_parameters(truth) + _ar1(rng, (n_samples, 2), noise, colour)
            stamp = (start + timedelta(days=k)).strftime("%Y-%m-%dT%H:%M")
            out.append(FleetLog(robot, stamp, tau, y @ model, y, q, dq, ddq, t, run))
    return out


def write_fleet(logs: list[FleetLog], directory: str, n_params: int = 10, regressor: bool = True) -> list[LogSpec]:
    """Write each log as a directory ``ROBOT__TIME`` (``:`` of the time as ``-``) of ``.npy`` files under
    ``directory`` — its torques, prediction, and, with ``regressor`` (default), its regressor, joint
    positions, velocities, accelerations and time stamps — each robot's estimation run under
    ``estimation/ROBOT/``, and a ``manifest.csv`` naming them all; returns their LogSpecs.
    ``regressor=False`` writes the torques alone (the logs' decisions then see the residual only)."""
    specs = []
    runs: dict[str, dict[str, str]] = {}
    for log in logs:
        folder = os.path.join(directory, f"{log.robot}__{log.time.replace(':', '-')}")
        os.makedirs(folder, exist_ok=True)
        files = {name: _save(folder, name, value) for name, value in (("tau_meas", log.tau_meas),
                                                                       ("tau_pred", log.tau_pred))}
        if regressor:
            files.update({name: _save(folder, name, value) for name, value in
                          (("regressor", log.regressor), ("q", log.q), ("dq", log.dq), ("ddq", log.ddq),
                           ("timestamps", log.timestamps)) if value is not None})
            if log.estimation is not None:
                if log.robot not in runs:
                    where = os.path.join(directory, "estimation", log.robot)
                    os.makedirs(where, exist_ok=True)
                    runs[log.robot] = {"estimation_tau": _save(where, "tau", log.estimation.tau),
                                       "estimation_regressor": _save(where, "regressor", log.estimation.regressor),
                                       "estimation_q": _save(where, "q", log.estimation.q)}
                files.update(runs[log.robot])
        specs.append(LogSpec(log.robot, log.time, n_params=n_params, log=os.path.basename(folder), **files))
    columns = ("robot", "time", "log", "tau_meas", "tau_pred", *DATA_COLUMNS, "n_params")
    with open(os.path.join(directory, "manifest.csv"), "w", encoding="utf-8") as handle:
        handle.write(",".join(columns) + "\n")
        for s in specs:
            cells = [s.robot, s.time, s.log] + [_relative(getattr(s, c), directory) for c in columns[3:-1]]
            handle.write(",".join(cells + [str(s.n_params)]) + "\n")
    return specs


def _save(folder: str, name: str, value: np.ndarray) -> str:
    path = os.path.join(folder, f"{name}.npy")
    np.save(path, value)
    return path


def _relative(path: str | None, directory: str) -> str:
    return "" if path is None else os.path.relpath(path, directory)
