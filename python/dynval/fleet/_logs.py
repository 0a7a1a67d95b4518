"""Which robot a log comes from, when it was taken, and where its arrays are (contract §10).

A log is named either by a manifest (CSV or JSON: one row per log with ``robot``, ``time``,
``tau_meas``, ``tau_pred`` and optionally ``n_params``, ``regressor``, ``log``) or by its path,
``ROBOT__TIME`` followed by ``.npz``, ``.h5``/``.hdf5`` (one file holding ``tau_meas`` and
``tau_pred``) or nothing (a directory holding ``tau_meas.*`` and ``tau_pred.*`` files, and
``regressor.*`` when there is one). Only names travel to the workers; the arrays are read there.
"""

from __future__ import annotations

import csv
import json
import math
import os
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from datetime import datetime, timezone
from typing import Any

from ..checks._errors import InvalidParameter
from ..checks._validation import format_value
from ..io._fileopen import HDF5_SUFFIXES, FileInputError

__all__ = ["LogSpec", "read_manifest", "log_from_path", "log_specs", "time_key", "MANIFEST_COLUMNS"]

MANIFEST_COLUMNS = ("robot", "time", "tau_meas", "tau_pred")
"""The columns every manifest row needs; ``n_params``, ``regressor`` and ``log`` are optional."""
_OPTIONAL_COLUMNS = ("n_params", "regressor", "log")
_NAME = re.compile(r"^(?P<robot>[^/\\]+?)__(?P<time>[^/\\]+)$")
_ARRAY_SUFFIXES = (".npy", ".npz", ".csv", ".tsv", ".txt", ".parquet", ".pq", *HDF5_SUFFIXES)


@dataclass(frozen=True)
class LogSpec:
    """One log: its robot, its time stamp (a number, an ISO 8601 date/time or any text; logs of a
    robot are ordered by it), the files of its arrays as ``dynval.cli.load_array`` names them
    (``file.npz:tau_meas``, ``file.parquet:a,b``, ``file.h5:/x``), its parameter count, and an id."""

    robot: str
    time: str
    tau_meas: str
    tau_pred: str
    n_params: int
    regressor: str | None = None
    log: str = ""

    @property
    def name(self) -> str:
        """The log's id, else its time stamp."""
        return self.log or self.time


def time_key(text: str) -> tuple[int, float, str]:
    """The order of time stamps: numbers by value, then ISO 8601 dates/times by instant, then
    other text alphabetically (``-`` for ``:`` in a time is accepted, as file names need it)."""
    try:
        value = float(text)
        if math.isfinite(value):
            return (0, value, "")
    except ValueError:
        pass
    iso = re.sub(r"T(\d\d)-(\d\d)(?:-(\d\d))?", lambda m: "T" + ":".join(g for g in m.groups() if g), text)
    try:
        stamp = datetime.fromisoformat(iso)
    except ValueError:
        return (2, 0.0, text)
    # a stamp without a zone is taken as UTC, so that every stamp has an instant
    return (1, (stamp if stamp.tzinfo else stamp.replace(tzinfo=timezone.utc)).timestamp(), "")


def _n_params(value: Any, default: int | None, where: str) -> int:
    if value is None or value == "":
        if default is None:
            raise InvalidParameter(f"{where}: n_params is needed: give it to validate_many (--n-params) or as "
                                   "the manifest's n_params column")
        return default
    try:
        number = int(value)
    except (TypeError, ValueError):
        number = -1
    if number < 0 or str(value).strip() not in (str(number), f"{number}.0"):
        raise InvalidParameter(f"{where}: n_params must be an integer >= 0, got {format_value(value)}")
    return number


def _spec_from_row(row: Mapping[str, Any], base: str, default: int | None, where: str) -> LogSpec:
    missing = [c for c in MANIFEST_COLUMNS if not str(row.get(c) or "").strip()]
    if missing:
        raise FileInputError(f"{where}: no {', '.join(missing)} (a manifest row needs {', '.join(MANIFEST_COLUMNS)})")

    def path(spec: Any) -> str:
        text = str(spec).strip()
        return text if os.path.isabs(text) else os.path.join(base, text)

    regressor = str(row.get("regressor") or "").strip()
    return LogSpec(robot=str(row["robot"]).strip(), time=str(row["time"]).strip(), tau_meas=path(row["tau_meas"]),
                   tau_pred=path(row["tau_pred"]), n_params=_n_params(row.get("n_params"), default, where),
                   regressor=path(regressor) if regressor else None, log=str(row.get("log") or "").strip())


def read_manifest(path: str, n_params: int | None = None) -> list[LogSpec]:
    """The logs a manifest names: CSV with a header line, or JSON (a list of objects, or an object
    with a ``logs`` list); relative paths are relative to the manifest's directory.

    Errors are :class:`~dynval.io._files.FileInputError` naming the manifest and the row (CSV
    line, or JSON index from 0) or InvalidParameter for a bad ``n_params``.
    """
    base = os.path.dirname(os.path.abspath(path))
    try:
        with open(path, encoding="utf-8-sig", newline="") as handle:
            if path.lower().endswith(".json"):
                rows = _json_rows(path, handle.read())
            else:
                rows = _csv_rows(path, handle)
    except OSError as exc:
        raise FileInputError(f"{path}: cannot be read as a manifest ({exc.strerror or exc})") from None
    if not rows:
        raise FileInputError(f"{path}: the manifest names no log")
    return [_spec_from_row(row, base, n_params, where) for where, row in rows]


def _csv_rows(path: str, handle: Any) -> list[tuple[str, dict]]:
    reader = csv.DictReader(handle)
    header = [h.strip() for h in reader.fieldnames or []]
    lacking = [c for c in MANIFEST_COLUMNS if c not in header]
    if lacking:
        raise FileInputError(f"{path}: a manifest's header needs the columns {', '.join(MANIFEST_COLUMNS)}; "
                             f"it lacks {', '.join(lacking)} (its header: {', '.join(header) or 'none'})")
    reader.fieldnames = header
    return [(f"{path} line {reader.line_num}", row) for row in reader]


def _json_rows(path: str, text: str) -> list[tuple[str, dict]]:
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise FileInputError(f"{path}: not a JSON manifest ({exc})") from None
    rows = data.get("logs") if isinstance(data, dict) else data
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise FileInputError(f"{path}: a JSON manifest is a list of objects (or an object with a 'logs' list)")
    return [(f"{path} log {i}", row) for i, row in enumerate(rows)]


def log_from_path(path: str, n_params: int | None = None) -> LogSpec:
    """The log a path names by the pattern ``ROBOT__TIME[.npz|.h5|.hdf5]`` (a directory without a
    suffix: its ``tau_meas.*``, ``tau_pred.*`` and ``regressor.*`` files).

    Examples
    --------
    >>> spec = log_from_path("/data/arm7__2026-03-01T08-00.npz", n_params=40)
    >>> spec.robot, spec.time, spec.tau_meas
    ('arm7', '2026-03-01T08-00', '/data/arm7__2026-03-01T08-00.npz:tau_meas')
    """
    stripped = path.rstrip("/\\")
    stem, suffix = os.path.splitext(os.path.basename(stripped))
    if suffix.lower() not in (".npz", *HDF5_SUFFIXES):
        stem, suffix = os.path.basename(stripped), ""
    match = _NAME.match(stem)
    if match is None:
        raise FileInputError(f"{path}: a log's name must be ROBOT__TIME (e.g. arm7__2026-03-01T08-00.npz), "
                             "or the log must be listed in a manifest (.csv or .json)")
    robot, time = match.group("robot"), match.group("time")
    n = _n_params(None, n_params, path)
    if suffix:
        key = ":/" if suffix.lower() in HDF5_SUFFIXES else ":"
        return LogSpec(robot, time, f"{stripped}{key}tau_meas", f"{stripped}{key}tau_pred", n, log=stem)
    files = _directory_arrays(stripped)
    return LogSpec(robot, time, files["tau_meas"], files["tau_pred"], n, regressor=files.get("regressor"), log=stem)


def _directory_arrays(path: str) -> dict[str, str]:
    try:
        names = sorted(os.listdir(path))
    except OSError as exc:
        raise FileInputError(f"{path}: a log named ROBOT__TIME without a suffix is a directory holding "
                             f"tau_meas.* and tau_pred.* ({exc.strerror or exc})") from None
    found: dict[str, str] = {}
    for name in names:
        stem, suffix = os.path.splitext(name)
        if stem in ("tau_meas", "tau_pred", "regressor") and suffix.lower() in _ARRAY_SUFFIXES:
            found.setdefault(stem, os.path.join(path, name))
    lacking = [k for k in ("tau_meas", "tau_pred") if k not in found]
    if lacking:
        raise FileInputError(f"{path}: the log directory holds no {' or '.join(lacking)} file "
                             f"(tau_meas.npy, tau_pred.parquet, ...)")
    return found


def log_specs(logs: Iterable[Any], n_params: int | None = None) -> list[LogSpec]:
    """Every log of ``logs``: LogSpecs, mappings (a manifest's row), manifests (``.csv``/``.json``) and
    paths named ``ROBOT__TIME``, in that order of the input."""
    out: list[LogSpec] = []
    for item in logs:
        if isinstance(item, (str, os.PathLike)) and str(item).lower().endswith((".csv", ".json")):
            out.extend(read_manifest(str(item), n_params))
        else:
            out.append(as_spec(item, n_params))
    return out


def as_spec(item: Any, n_params: int | None = None) -> LogSpec:
    """One log from a LogSpec, a mapping (a manifest row, paths taken as given) or a path."""
    if isinstance(item, LogSpec):
        return item
    if isinstance(item, Mapping):
        row = dict(item)
        return _spec_from_row(item, "", n_params, f"log {format_value(row.get('log') or row.get('tau_meas'))}")
    if isinstance(item, (str, os.PathLike)):
        return log_from_path(os.fspath(item), n_params)
    raise InvalidParameter(f"a log must be a path, a manifest, a mapping or a LogSpec, got {type(item).__name__}")
