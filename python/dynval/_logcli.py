"""``dynval validate-log``: :func:`dynval.logs.validate_log` from the command line."""

from __future__ import annotations

import argparse
from typing import Any


def add_validate_log(sub: Any, exit_codes: str) -> None:
    cmd = sub.add_parser(
        "validate-log", help="a robot's log (ROS bag, MCAP, vendor CSV) and its model files (URDF, MJCF) to a "
                             "verdict",
        description="Read the sensor_msgs/JointState messages of a ROS 2 bag (sqlite3 or MCAP), a ROS 1 bag or an "
                    "MCAP file (or a vendor's CSV log by --mapping), in the first model's joint order; differentiate "
                    "the positions (Savitzky–Golay, zero phase; or take the logged velocities); predict every model; "
                    "identify the first URDF model on --estimation when given; compare the candidates with the "
                    "positions, the time stamps, the regressor and the estimation run; print the verdict "
                    "(contract §7.3).",
        epilog="Example: dynval validate-log run3_bag --model kuka.urdf --estimation run1_bag --html report.html. "
               + exit_codes)
    cmd.add_argument("log", metavar="LOG", help="a ROS 2 bag directory, a ROS 1 .bag file, an .mcap file, or a "
                                                "vendor's CSV log with --mapping")
    cmd.add_argument("--mapping", metavar="PRESET|FILE.json",
                     help="how a CSV log's columns map to time, q, dq and effort: a preset (ur_rtde: RTDE's "
                          "actual_q/qd/current, needs --torque-constant; ur_rtde_moment: target_moment in N·m) or a "
                          "JSON file of dynval.io.CSVMapping's fields")
    cmd.add_argument("--model", action="append", required=True, metavar="[NAME=]FILE",
                     help="a URDF file (repeat for several; NAME= names the candidate, else the file's stem)")
    cmd.add_argument("--identified", action="append", default=[], metavar="NAME=FILE",
                     help="your own identified parameters of the model NAME (.npy, .csv or .json, one value per "
                          "column of its regressor), a candidate predicting regressor·parameters (repeatable)")
    cmd.add_argument("--estimation", metavar="LOG2", help="a second log of the same robot to identify the model on")
    cmd.add_argument("--topic", help="the JointState topic (needed when the log has several)")
    cmd.add_argument("--derivatives", choices=("positions", "logged"), default="positions",
                     help="velocities from the positions (default) or as logged; accelerations always from the "
                          "positions")
    cmd.add_argument("--effort-unit", choices=("N·m", "Nm", "A"), default=None,
                     help="what the effort field holds: torque (a bag's default) or motor current (needs "
                          "--torque-constant); a CSV log's is its mapping's")
    cmd.add_argument("--torque-constant", metavar="K[,K...]",
                     help="N·m per A, one value or one per joint (with --effort-unit A)")
    cmd.add_argument("--level", type=float, default=0.95, metavar="X", help="confidence level (default 0.95)")
    cmd.add_argument("--json", action="store_true", help="print the comparison as JSON")
    cmd.add_argument("--html", metavar="FILE", help="write the self-contained HTML report")
    cmd.add_argument("--progress", action=argparse.BooleanOptionalAction, default=True,
                     help="say on stderr what is being done (default on)")
    cmd.add_argument("--output", "-o", metavar="FILE", help="write the summary (or JSON) to FILE")
    cmd.set_defaults(sample_rate=None, time=None)


def _models(values: list[str]) -> dict[str, str]:
    import os

    out: dict[str, str] = {}
    for value in values:
        name, sep, path = value.partition("=")
        if not sep or not name or os.path.exists(value):
            path, name = value, os.path.splitext(os.path.basename(value))[0]
        if name in out:
            raise argparse.ArgumentTypeError(f"two models named {name!r}: give them names with NAME=FILE")
        out[name] = path
    return out


def _identified(values: list[str]) -> dict[str, str]:
    out: dict[str, str] = {}
    for value in values:
        name, sep, path = value.partition("=")
        if not sep or not name or not path:
            raise argparse.ArgumentTypeError(f"--identified: expected NAME=FILE (NAME one of the --model names), "
                                             f"got {value!r}")
        if name in out:
            raise argparse.ArgumentTypeError(f"--identified: two parameter files for the model {name!r}")
        out[name] = path
    return out


def _torque_constant(text: str | None) -> Any:
    if text is None:
        return None
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"--torque-constant: expected numbers separated by commas, got {text!r}"
                                         ) from None
    return values[0] if len(values) == 1 else values


def run_validate_log(args: Any, error: Any, emit: Any, write_html: Any) -> int:
    """The command; ``error``, ``emit`` and ``write_html`` are the command line's own helpers."""
    from .checks._errors import InputError
    from .logs import validate_log

    try:
        models = _models(args.model)
        constant = _torque_constant(args.torque_constant)
        identified = _identified(args.identified)
    except argparse.ArgumentTypeError as exc:
        return int(error("validate-log", str(exc)))
    unit = None if args.effort_unit is None else "N·m" if args.effort_unit in ("N·m", "Nm") else "A"
    try:
        cmp = validate_log(args.log, models, estimation=args.estimation, topic=args.topic,
                           derivatives=args.derivatives, effort_unit=unit, torque_constant=constant,
                           mapping=args.mapping, identified=identified, level=args.level,
                           progress=args.progress)
    except InputError as exc:
        return int(error("validate-log", f"{type(exc).__name__}: {exc}"))
    except ImportError as exc:
        return int(error("validate-log", str(exc)))
    code = write_html("validate-log", args, cmp)
    return int(code) if code else int(emit("validate-log", args, cmp.to_json() if args.json else cmp.summary()))
