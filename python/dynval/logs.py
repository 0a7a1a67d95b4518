"""From a robot's own log and its model files to a verdict (contract §7.3).

:func:`validate_log` reads the joint states of a log (:func:`dynval.io.read_joint_states`: ROS 2
bags, ROS 1 bags, MCAP files; :func:`dynval.io.read_csv_log`: a vendor's CSV by a declared
mapping), takes the joint order from the first model, differentiates the positions with a stated
filter, predicts every model (URDF through pinocchio, MJCF through MuJoCo), identifies each
model's parameters on an estimation log when one is given, and compares the candidates with the
positions, the time stamps, the regressor and the estimation run: what ``dynval validate-log`` runs.

Examples
--------
>>> from dynval.logs import validate_log                               # doctest: +SKIP
>>> cmp = validate_log("run3_bag", ["kuka.urdf"], estimation="run1_bag")  # doctest: +SKIP
>>> print(cmp.summary())                                                # doctest: +SKIP
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["validate_log", "LogMotion", "log_motion", "DERIVATIVES"]

#: Where the velocities come from: the log's own (``"logged"``: the acceleration is still
#: differentiated from the positions), or both from the positions (``"positions"``).
DERIVATIVES = ("positions", "logged")


@dataclass(frozen=True)
class LogMotion:
    """A log's motion ready for a model: positions and their derivatives, the torques, the stamps,
    and how the derivatives were obtained (``source``, the filter's ``bandwidth_hz``)."""

    time: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    tau: np.ndarray
    joint_names: tuple[str, ...]
    sample_rate: float
    bandwidth_hz: float
    source: str
    notes: tuple[str, ...]


def log_motion(path: str | os.PathLike[str], joints: Sequence[str], *, topic: str | None = None,
               derivatives: str = "positions", effort_unit: str | None = None,
               torque_constant: float | Sequence[float] | None = None, mapping: Any = None) -> LogMotion:
    """The joint states of ``path`` in ``joints``' order, with velocities and accelerations.

    ``path`` is a bag or MCAP file (:func:`dynval.io.read_joint_states`), or with ``mapping`` a
    vendor's CSV log (:func:`dynval.io.read_csv_log`: a preset's name, a JSON file or a
    :class:`dynval.io.CSVMapping`); a ``.csv`` file without a mapping is refused (columns are
    never guessed). The derivatives come from the positions through
    :func:`dynval.robots.differentiate` (Savitzky–Golay, 0.1 s, degree 4, zero phase) at the
    stamps' median rate; with ``derivatives="logged"`` the log's velocities are used and only the
    acceleration is differentiated. Either way the report's ``bandwidth`` is the filter's band.
    """
    from .checks._validation import parameter_error
    from .robots import differentiate

    if derivatives not in DERIVATIVES:
        raise parameter_error("derivatives", "'positions' or 'logged'", derivatives)
    log = _read_log(path, joints, topic=topic, effort_unit=effort_unit, torque_constant=torque_constant,
                    mapping=mapping)
    if log.tau is None:
        raise parameter_error("log", "joint states with an effort field (the measured torque)", os.fspath(path))
    rate = log.sample_rate
    d = differentiate(log.q, rate)
    notes = list(log.notes)
    if derivatives == "logged":
        if log.dq is None:
            raise parameter_error("derivatives", "'positions': the log carries no velocities", derivatives)
        dq, source = log.dq, ("velocities as logged; accelerations differentiated from the positions "
                              f"({d.method}, zero phase, {rate:.4g} Hz)")
    else:
        dq, source = d.dq, f"velocities and accelerations differentiated from the positions ({d.method}, zero " \
                           f"phase, {rate:.4g} Hz)"
    if any("gap" in n for n in log.notes):
        notes.append("the derivatives are taken at the median rate across the gaps: samples next to a gap are "
                     "less trustworthy")
    return LogMotion(time=log.time, q=log.q, dq=np.ascontiguousarray(dq), ddq=d.ddq, tau=log.tau,
                     joint_names=log.joint_names, sample_rate=rate, bandwidth_hz=d.input_bandwidth_hz,
                     source=source, notes=tuple(notes))


def _read_log(path: str | os.PathLike[str], joints: Sequence[str], *, topic: str | None, effort_unit: str | None,
              torque_constant: Any, mapping: Any) -> Any:
    """A bag or MCAP file's joint states, or a CSV log's by its mapping (whose effort unit rules)."""
    from .checks._validation import parameter_error
    from .io import read_csv_log, read_joint_states
    from .io._csvlog import load_mapping

    if mapping is None:
        if os.fspath(path).lower().endswith((".csv", ".tsv", ".txt")):
            raise parameter_error("mapping", "a CSV mapping for a CSV log (a preset such as 'ur_rtde', or a JSON "
                                  "file of CSVMapping's fields): dynval does not guess which column is what",
                                  None)
        return read_joint_states(path, joints=joints, topic=topic, effort_unit=effort_unit or "N·m",
                                 torque_constant=torque_constant)
    chosen = load_mapping(mapping)
    if topic is not None:
        raise parameter_error("topic", "None for a CSV log (a topic is a bag's)", topic)
    if effort_unit is not None and ("N·m" if effort_unit == "Nm" else effort_unit) != chosen.effort_unit:
        raise parameter_error("effort_unit", f"the mapping's own ({chosen.effort_unit!r}, mapping {chosen.name}) or "
                              "None: a CSV log's effort unit is declared by its mapping", effort_unit)
    return read_csv_log(path, chosen, joints=joints, torque_constant=torque_constant)


def _load_model(path: str) -> Any:
    """A URDF (pinocchio) or an MJCF (MuJoCo) model, by the file's suffix and root element."""
    from .checks._validation import parameter_error
    from .io._fileopen import FileInputError

    if not os.path.isfile(path):
        raise FileInputError(f"{path}: no such model file")
    with open(path, "rb") as handle:
        head = handle.read(4096).decode("utf-8", "replace")
    if "<robot" in head or path.endswith(".urdf"):
        from .robots import URDFModel

        return URDFModel(path)  # type: ignore[no-untyped-call]
    if "<mujoco" in head:
        try:
            from .mjcf import MJCFModel  # type: ignore[import-not-found,unused-ignore]
        except ImportError as exc:
            raise ImportError(f"{path} is an MJCF model: reading it needs dynval.mjcf and mujoco "
                              "(pip install 'dynval[mujoco]')") from exc
        return MJCFModel(path)
    raise parameter_error("model", "a URDF (<robot>) or MJCF (<mujoco>) file", path)


def validate_log(log: str | os.PathLike[str], models: Sequence[str] | Mapping[str, str], *,
                 estimation: str | os.PathLike[str] | None = None, topic: str | None = None,
                 derivatives: str = "positions", effort_unit: str | None = None,
                 torque_constant: float | Sequence[float] | None = None, mapping: Any = None,
                 identified: Mapping[str, Any] | None = None,
                 progress: Callable[[str], None] | bool | None = None, **keywords: Any) -> Any:
    """Compare model files on a robot's log: the verdict, as :func:`dynval.compare` gives it.

    Parameters
    ----------
    log : str or path
        The validation log (a bag or MCAP file: :func:`dynval.io.read_joint_states`; a vendor's
        CSV log with ``mapping``: :func:`dynval.io.read_csv_log`).
    models : sequence of str, or mapping name → path
        URDF (and, with ``dynval[mujoco]``, MJCF) files; the first one's joint order is the
        columns' order, and every model must name the same joints. Each is a candidate as it is
        (its own parameters; ``n_params`` 0), named by its file's stem.
    estimation : str or path, optional
        A second log of the same robot: each URDF model's parameters (inertial, viscous and
        Coulomb friction, offset) of the first URDF model are identified on it by least squares
        and the fit is a candidate too (``"NAME identified"``); the comparison then has the
        regressor (the fit's base columns), their names and the estimation run.
    topic, effort_unit, torque_constant, derivatives, mapping
        How to read the logs (:func:`log_motion`; the same for both logs). ``effort_unit`` None is
        ``"N·m"`` for a bag and the mapping's own for a CSV log (another value is refused there).
    identified : mapping name → parameter vector, optional
        The user's own identified parameters of a model (``name`` one of ``models``' names): a
        ``.npy``, ``.csv`` or ``.json`` file (a list of numbers, or an object of every column name
        to its value) or an array, one value per column of the model's regressor (a URDF model's
        ``column_names()``: 10 inertial parameters per link, then ``Fv_``, ``Fc_``, ``off_`` per
        joint; an MJCF model's ``column_names``). The candidate ``"NAME identified (STEM)"``
        predicts ``regressor(q, q̇, q̈) @ π̂`` with ``n_params`` the regressor's rank on the run
        (its base parameters, as :func:`dynval.identify.identify` counts them).
    progress : callable, bool or None
        Where to say what is being done (a function of one line; True: stderr; None/False: quiet).
    **keywords
        Passed to :func:`dynval.compare` (``level``, ``criterion``, ``joint_names`` is taken from
        the model).

    Returns
    -------
    dynval.ComparisonReport
        With ``log_provenance`` set on it: the files, topic and derivative source.
    """
    from .checks._validation import parameter_error
    from .comparison._compare import compare

    say = _say(progress)
    named = dict(models) if isinstance(models, Mapping) else {_stem(p): p for p in models}
    if not named:
        raise parameter_error("models", "at least one model file", models)
    loaded = {}
    for name, path in named.items():
        say(f"loading the model {name} ({os.fspath(path)})")
        loaded[name] = _load_model(os.fspath(path))
    joints = tuple(next(iter(loaded.values())).joint_names)
    for name, model in loaded.items():
        if tuple(model.joint_names) != joints:
            raise parameter_error("models", f"models of the same joints in the same order (the first names "
                                  f"{list(joints)})", f"{name}: {list(model.joint_names)}")
    say(f"reading {os.fspath(log)}")
    val = log_motion(log, joints, topic=topic, derivatives=derivatives, effort_unit=effort_unit,
                     torque_constant=torque_constant, mapping=mapping)
    candidates: dict[str, Any] = {}
    for name, model in loaded.items():
        say(f"predicting {name} on {val.q.shape[0]} samples")
        candidates[name] = {"prediction": model.predict(val.q, val.dq, val.ddq), "n_params": 0}
    for name, value in (identified or {}).items():
        say(f"predicting the identified parameters of {name}")
        candidates.update(_user_identified(loaded, name, value, val))
    options: dict[str, Any] = {}
    est = None
    if estimation is not None:
        say(f"reading the estimation log {os.fspath(estimation)}")
        est = log_motion(estimation, joints, topic=topic, derivatives=derivatives, effort_unit=effort_unit,
                         torque_constant=torque_constant, mapping=mapping)
        options.update(_identified(loaded, est, val, candidates, say))
    if all(hasattr(model, "retune") for model in loaded.values()):
        options.update(_simulator_columns(loaded, est, val, candidates, say))
    say(f"comparing {len(candidates)} candidates")
    cmp = compare(val.tau, candidates, time=val.time, bandwidth=val.bandwidth_hz, q=val.q, dq=val.dq,
                  ddq=val.ddq, joint_names=list(joints), **options, **keywords)
    object.__setattr__(cmp, "log_provenance", {
        "log": os.fspath(log), "estimation": None if estimation is None else os.fspath(estimation),
        "models": {n: os.fspath(p) for n, p in named.items()}, "derivatives": val.source,
        "mapping": None if mapping is None else _mapping_name(mapping),
        "notes": list(val.notes)})
    return cmp


def _user_identified(loaded: Mapping[str, Any], name: str, value: Any, val: LogMotion) -> dict[str, Any]:
    """The candidate of a user's identified parameter vector for the model ``name``."""
    from .checks._validation import parameter_error
    from .identify import base_set, default_rcond

    if name not in loaded:
        raise parameter_error("identified", f"parameters of one of the models ({', '.join(map(repr, loaded))})",
                              name)
    model = loaded[name]
    names = _column_names(model)
    source, pi = _parameter_vector(value, names)
    if pi.size != len(names):
        raise parameter_error("identified", f"one value per column of the model {name}'s regressor: {len(names)} "
                              f"columns ({_columns_source(model)}), and {source} holds {pi.size}", name)
    if not np.all(np.isfinite(pi)):
        raise parameter_error("identified", f"finite values ({source} holds {int(np.sum(~np.isfinite(pi)))} that "
                              "are not)", name)
    y = model.regressor(val.q, val.dq, val.ddq)
    n, m, p = y.shape
    rank = base_set(y.reshape(n * m, p), default_rcond(n * m, p))["rank"]
    stem = _stem(source) if source != "the array" else "array"
    return {f"{name} identified ({stem})": {"prediction": y @ pi, "n_params": int(rank)}}


def _column_names(model: Any) -> tuple[str, ...]:
    names = model.column_names
    return tuple(names() if callable(names) else names)


def _columns_source(model: Any) -> str:
    """Where a model's column names come from, for a message about a parameter vector's length."""
    if callable(model.column_names):
        return ("URDFModel.column_names(): 10 inertial parameters per link, then Fv_, Fc_ and off_ per joint, "
                f"of {len(model.joint_names)} joints")
    return f"MJCFModel.column_names: rigid_body_, armature_, damping_, frictionloss_ of {len(model.joint_names)} joints"


def _parameter_vector(value: Any, names: Sequence[str]) -> tuple[str, np.ndarray]:
    """(what names it in messages, the values as a 1-D float array) from an array or a file."""
    from .checks._validation import parameter_error
    from .io._files import load_array

    if not isinstance(value, (str, os.PathLike)):
        arr = np.asarray(value, dtype=float)
        source = "the array"
    else:
        source = os.fspath(value)
        if source.lower().endswith(".json"):
            arr = _json_vector(source, names)
        elif source.lower().endswith((".npy", ".csv")):
            arr = np.asarray(load_array(source), dtype=float)
        else:
            raise parameter_error("identified", "a .npy, .csv or .json file of the parameters", source)
    if arr.ndim == 2 and 1 in arr.shape:
        arr = arr.reshape(-1)
    if arr.ndim != 1:
        raise parameter_error("identified", "one parameter vector (p,)", f"{source}: shape {arr.shape}")
    return source, arr


def _json_vector(path: str, names: Sequence[str]) -> np.ndarray:
    """A JSON list of numbers, or an object of every column name to its value."""
    import json

    from .io._fileopen import FileInputError as error
    from .io._fileopen import open_regular

    handle, _ = open_regular(path)
    with handle:
        try:
            values = json.loads(handle.read(1 << 24).decode("utf-8-sig"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise error(f"{path}: not a JSON list or object of numbers ({exc})") from None
    if isinstance(values, dict):
        unknown = [k for k in values if k not in names]
        missing = [k for k in names if k not in values]
        if unknown or missing:
            raise error(f"{path}: the keys must be the model's column names: "
                        + (f"{unknown[0]!r} is none of them" if unknown else f"{missing[0]!r} has no value")
                        + f" ({len(missing)} of {len(names)} columns missing, {len(unknown)} unknown keys)")
        values = [values[k] for k in names]
    try:
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise error(f"{path}: holds values that are not numbers") from None


def _identified(loaded: Mapping[str, Any], est: LogMotion, val: LogMotion, candidates: dict[str, Any],
                say: Callable[[str], None]) -> dict[str, Any]:
    """The first URDF model identified on the estimation log, as a candidate; the comparison's
    regressor and estimation run: that model's identifiable (base) columns, as examples/kuka_lwr4
    does (the other columns no motion of a fixed-base arm can excite)."""
    options: dict[str, Any] = {}
    for name, model in loaded.items():
        if not hasattr(model, "identify"):
            continue
        say(f"identifying {name} on the estimation log")
        y_est = model.regressor(est.q, est.dq, est.ddq)
        fit = model.identify(est.q, est.dq, est.ddq, est.tau)
        y_val = model.regressor(val.q, val.dq, val.ddq)
        candidates[f"{name} identified"] = {"prediction": fit.predict(y_val), "n_params": fit.rank}
        keep = list(fit.base_columns)
        names = list(model.column_names())
        # one identification: the other URDFs of the same robot have the same columns, so the
        # same least-squares fit
        return {"regressor": np.ascontiguousarray(y_val[:, :, keep]), "column_names": [names[c] for c in keep],
                "estimation": {"q": est.q, "regressor": np.ascontiguousarray(y_est[:, :, keep]), "tau": est.tau}}
    return options


def _mapping_name(mapping: Any) -> str:
    from .io._csvlog import load_mapping

    return load_mapping(mapping).name


def _simulator_columns(loaded: Mapping[str, Any], est: LogMotion | None, val: LogMotion, candidates: dict[str, Any],
                       say: Callable[[str], None]) -> dict[str, Any]:
    """Models that are all MJCF: the first one's regressor (and its estimation run's), its column
    names, and each candidate's non-zero parameters as its model columns, as MJCFModel.compare
    passes them, so that the findings name the simulator parameters to retune."""
    first = next(iter(loaded.values()))
    say(f"the simulator regressor of {next(iter(loaded))} ({len(first.column_names)} columns)")
    for name, model in loaded.items():
        candidates[name]["model_columns"] = model.model_columns()
    options: dict[str, Any] = {"regressor": first.regressor(val.q, val.dq, val.ddq),
                               "column_names": list(first.column_names)}
    if est is not None:
        options["estimation"] = {"q": est.q, "regressor": first.regressor(est.q, est.dq, est.ddq), "tau": est.tau}
    return options


def _stem(path: str | os.PathLike[str]) -> str:
    return os.path.splitext(os.path.basename(os.fspath(path)))[0]


def _say(progress: Callable[[str], None] | bool | None) -> Callable[[str], None]:
    if callable(progress):
        return progress
    if progress:
        return lambda line: print(f"[validate-log] {line}", file=sys.stderr, flush=True)
    return lambda line: None
