"""Which robot a log comes from, when it was taken, and where its arrays are (contract §10).

A log is named either by a manifest (CSV or JSON: one row per log with ``robot``, ``time``,
``tau_meas``, ``tau_pred`` and optionally ``n_params``, ``log`` and the files of what else
:func:`dynval.validate` takes: ``regressor``, ``q``, ``dq``, ``ddq``, ``timestamps`` and the robot's
estimation run ``estimation_tau``, ``estimation_regressor``, ``estimation_q``) or by its path,
``ROBOT__TIME`` followed by ``.npz``, ``.h5``/``.hdf5`` (one file holding ``tau_meas`` and
``tau_pred``) or nothing (a directory holding ``tau_meas.*`` and ``tau_pred.*`` files, and
``regressor.*``, ``q.*``, ... when there are). Only names travel to the workers; the arrays are read there.
"""

from __future__ import annotations

import csv
import io
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
from ..io._fileopen import HDF5_SUFFIXES, FileInputError, open_regular
from ..io._files import MAX_LINE_BYTES

__all__ = ["LogSpec", "read_manifest", "manifest_logs", "log_from_path", "log_specs", "time_key", "MANIFEST_COLUMNS",
           "parse_name", "check_unique", "is_manifest", "DATA_COLUMNS"]

MANIFEST_COLUMNS = ("robot", "time", "tau_meas", "tau_pred")
"""The columns every manifest row needs; ``n_params``, ``log`` and :data:`DATA_COLUMNS` are optional."""
DATA_COLUMNS = ("regressor", "q", "dq", "ddq", "timestamps", "estimation_tau", "estimation_regressor", "estimation_q")
"""A log's optional files beside its torques: what :func:`dynval.validate` takes as ``regressor``, ``q``,
``dq``, ``ddq``, ``time`` and ``estimation`` (``tau``, ``regressor``, ``q``: the robot's estimation run)."""
_OPTIONAL_COLUMNS = ("n_params", "log", *DATA_COLUMNS)
MAX_MANIFEST_BYTES = 64 << 20
"""Largest manifest (bytes): about half a million rows; a manifest names files, it holds no arrays."""
MAX_CELL_CHARS = 4096
"""Longest cell of a manifest (characters): a path's length on common systems."""
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
    q: str | None = None
    dq: str | None = None
    ddq: str | None = None
    timestamps: str | None = None
    estimation_tau: str | None = None
    estimation_regressor: str | None = None
    estimation_q: str | None = None

    @property
    def data(self) -> dict[str, str]:
        """The optional files it names, by their :data:`DATA_COLUMNS` name."""
        return {name: getattr(self, name) for name in DATA_COLUMNS if getattr(self, name) is not None}

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
    except (TypeError, ValueError, OverflowError):  # inf: OverflowError
        number = -1
    if number < 0 or str(value).strip() not in (str(number), f"{number}.0"):
        raise InvalidParameter(f"{where}: n_params must be an integer >= 0, got {format_value(value)}")
    return number


def _spec_from_row(row: Mapping[str, Any], base: str, default: int | None, where: str) -> LogSpec:
    long = [c for c in row if c is not None and len(str(row[c] or "")) > MAX_CELL_CHARS]
    if long:
        raise _long_cell(f"{where}, column {_cut(str(long[0]))}")
    missing = [c for c in MANIFEST_COLUMNS if not str(row.get(c) or "").strip()]
    if missing:
        raise FileInputError(f"{where}: no {', '.join(missing)} (a manifest row needs {', '.join(MANIFEST_COLUMNS)})")

    def path(spec: Any) -> str:
        text = str(spec).strip()
        return text if os.path.isabs(text) else os.path.join(base, text)

    data = {name: path(text) for name in DATA_COLUMNS if (text := str(row.get(name) or "").strip())}
    if ("estimation_tau" in data) != ("estimation_regressor" in data):
        raise FileInputError(f"{where}: an estimation run is its torques and its regressor: give both "
                             "estimation_tau and estimation_regressor, or neither")
    return LogSpec(robot=str(row["robot"]).strip(), time=str(row["time"]).strip(), tau_meas=path(row["tau_meas"]),
                   tau_pred=path(row["tau_pred"]), n_params=_n_params(row.get("n_params"), default, where),
                   log=str(row.get("log") or "").strip(), **data)


def read_manifest(path: str, n_params: int | None = None) -> list[LogSpec]:
    """The logs a manifest names: CSV with a header line, or JSON (a list of objects, or an object
    with a ``logs`` list); relative paths are relative to the manifest's directory.

    A manifest is read as a data file is (contract §7, §10): a regular file of at most
    :data:`MAX_MANIFEST_BYTES`, UTF-8 text, lines of at most ``MAX_LINE_BYTES`` and cells of at most
    :data:`MAX_CELL_CHARS` characters. Errors are :class:`~dynval.io._files.FileInputError` naming the
    manifest and the row (CSV line, or JSON path such as ``$[3].n_params``) or InvalidParameter for a
    bad ``n_params``.
    """
    return [spec for _, spec in manifest_logs(path, n_params)]


def manifest_logs(path: str, n_params: int | None = None) -> list[tuple[str, LogSpec]]:
    """(where, log) of every row of a manifest: ``where`` names the manifest and the row."""
    base = os.path.dirname(os.path.abspath(path))
    text = _manifest_text(path)
    rows = _json_rows(path, text) if path.lower().endswith(".json") else _csv_rows(path, text)
    if not rows:
        raise FileInputError(f"{path}: the manifest names no log")
    out = [(where, _spec_from_row(row, base, n_params, where)) for where, row in rows]
    check_unique(out)
    return out


def check_unique(logs: Iterable[tuple[str, LogSpec]]) -> None:
    """A robot's log listed twice would count twice in its drift test: refused, naming both places."""
    seen: dict[tuple[str, str], str] = {}
    for where, spec in logs:
        key = (spec.robot, spec.name)
        if key in seen:
            raise FileInputError(f"{where}: robot {spec.robot}'s log {spec.name} is listed twice (also {seen[key]}); "
                                 "each log of a robot needs its own time or log id")
        seen[key] = where


def _manifest_text(path: str) -> str:
    """The manifest's text, refused before it is read whole when it is not a bounded UTF-8 text file."""
    handle, size = open_regular(path)
    with handle:
        if size > MAX_MANIFEST_BYTES:
            raise _too_large(path, size)
        data = handle.read(MAX_MANIFEST_BYTES + 1)  # a file that grows after the stat is bounded too
    if len(data) > MAX_MANIFEST_BYTES:
        raise _too_large(path, len(data))
    if b"\x00" in data:
        nul = _line_of(data, data.index(b"\x00"))
        raise FileInputError(f"{path}: line {nul} holds a NUL byte: binary data, not a manifest's text")
    for number, line in enumerate(data.split(b"\n"), 1):
        if len(line.rstrip(b"\r")) > MAX_LINE_BYTES:
            raise FileInputError(f"{path}: line {number} is longer than {MAX_LINE_BYTES} bytes "
                                 "(the limit of a manifest's line)")
    data = data.removeprefix(b"\xef\xbb\xbf")  # a UTF-8 byte-order mark
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        column = exc.start - data.rfind(b"\n", 0, exc.start)
        raise FileInputError(f"{path}: line {_line_of(data, exc.start)} is not UTF-8 text ({exc.reason} at byte "
                             f"{column} of the line); save the manifest as UTF-8") from None


def _line_of(data: bytes, offset: int) -> int:
    return data.count(b"\n", 0, offset) + 1


def _too_large(path: str, size: int) -> FileInputError:
    return FileInputError(f"{path}: {size} bytes, more than a manifest's limit of {MAX_MANIFEST_BYTES} bytes "
                          "(a manifest names logs; their arrays are files of their own)")


def _csv_rows(path: str, text: str) -> list[tuple[str, dict]]:
    reader = csv.DictReader(io.StringIO(text, newline=""))
    done = 0  # the last line read whole: an error is in the one after it
    try:
        header = [h.strip() for h in reader.fieldnames or []]
        lacking = [c for c in MANIFEST_COLUMNS if c not in header]
        if lacking:
            raise FileInputError(f"{path}: a manifest's header needs the columns {', '.join(MANIFEST_COLUMNS)}; "
                                 f"it lacks {', '.join(lacking)} (its header: {_cut(', '.join(header)) or 'none'})")
        reader.fieldnames = header
        done = reader.line_num
        rows = []
        for row in reader:
            where = f"{path} line {reader.line_num}"
            if None in row:
                raise FileInputError(f"{where}: {len(header) + len(row[None])} cells, more than the header's "
                                     f"{len(header)} (a cell that holds a comma is quoted)")
            rows.append((where, row))
            done = reader.line_num
    except csv.Error as exc:
        where = f"{path} line {done + 1}"
        if "field larger than field limit" in str(exc):
            raise _long_cell(where) from None
        raise FileInputError(f"{where}: not valid CSV ({exc})") from None
    return rows


def _long_cell(where: str) -> FileInputError:
    return FileInputError(f"{where}: a cell longer than {MAX_CELL_CHARS} characters (a manifest's cell names a "
                          "robot, a time or a file)")


def _cut(text: str) -> str:
    return text if len(text) <= 200 else text[:200] + "..."


def _json_rows(path: str, text: str) -> list[tuple[str, dict]]:
    def no_constant(name: str) -> Any:
        raise ValueError(f"{name} is not a number a manifest holds")

    try:
        data = json.loads(text, parse_constant=no_constant)
    except json.JSONDecodeError as exc:
        raise FileInputError(f"{path}: not a JSON manifest ({exc})") from None
    except ValueError as exc:
        raise FileInputError(f"{path}: not a JSON manifest ({exc})") from None
    except RecursionError:
        raise FileInputError(f"{path}: nested too deeply for a JSON manifest (a list of flat objects, or an "
                             "object with a 'logs' list)") from None
    prefix = "$.logs" if isinstance(data, dict) else "$"
    rows = data.get("logs") if isinstance(data, dict) else data
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise FileInputError(f"{path}: a JSON manifest is a list of objects (or an object with a 'logs' list)")
    out = []
    for i, row in enumerate(rows):
        where = f"{path} {prefix}[{i}]"
        for key, value in row.items():
            _check_json_cell(f"{where}.{_cut(str(key))}", value)
        out.append((where, row))
    return out


def _check_json_cell(where: str, value: Any) -> None:
    """A JSON manifest's cell is text, a finite number or null, as a CSV cell would be."""
    if value is None or isinstance(value, str):
        if isinstance(value, str) and len(value) > MAX_CELL_CHARS:
            raise _long_cell(where)
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        kind = {dict: "an object", list: "a list", bool: "true or false"}.get(type(value), type(value).__name__)
        raise FileInputError(f"{where}: a manifest's cell is text or a number, got {kind}")
    if isinstance(value, float) and not math.isfinite(value):
        raise FileInputError(f"{where}: a number beyond float64's range (a manifest's number is finite)")


def log_from_path(path: str, n_params: int | None = None) -> LogSpec:
    """The log a path names by the pattern ``ROBOT__TIME[.npz|.h5|.hdf5]`` (a directory without a
    suffix: its ``tau_meas.*``, ``tau_pred.*`` files, and ``regressor.*``, ``q.*``, ... of :data:`DATA_COLUMNS`).

    Examples
    --------
    >>> spec = log_from_path("/data/arm7__2026-03-01T08-00.npz", n_params=40)
    >>> spec.robot, spec.time, spec.tau_meas
    ('arm7', '2026-03-01T08-00', '/data/arm7__2026-03-01T08-00.npz:tau_meas')
    """
    stripped = path.rstrip("/\\")
    named = parse_name(path)
    if named is None:
        raise FileInputError(f"{path}: a log's name must be ROBOT__TIME (e.g. arm7__2026-03-01T08-00.npz), "
                             "or the log must be listed in a manifest (.csv or .json)")
    robot, time, stem, suffix = named
    n = _n_params(None, n_params, path)
    if suffix:
        key = ":/" if suffix.lower() in HDF5_SUFFIXES else ":"
        return LogSpec(robot, time, f"{stripped}{key}tau_meas", f"{stripped}{key}tau_pred", n, log=stem)
    files = _directory_arrays(stripped)
    data = {name: files[name] for name in DATA_COLUMNS if name in files}
    return LogSpec(robot, time, files["tau_meas"], files["tau_pred"], n, log=stem, **data)


def parse_name(path: str) -> tuple[str, str, str, str] | None:
    """(robot, time, stem, suffix) of a path named ``ROBOT__TIME[.npz|.h5|.hdf5]``, else None; reads nothing."""
    stripped = path.rstrip("/\\")
    stem, suffix = os.path.splitext(os.path.basename(stripped))
    if suffix.lower() not in (".npz", *HDF5_SUFFIXES):
        stem, suffix = os.path.basename(stripped), ""
    match = _NAME.match(stem)
    return None if match is None else (match.group("robot"), match.group("time"), stem, suffix)


def is_manifest(item: Any) -> bool:
    """Whether an item of ``logs`` is a manifest (a path ending in .csv or .json)."""
    return isinstance(item, (str, os.PathLike)) and os.fspath(item).lower().endswith((".csv", ".json"))


def _directory_arrays(path: str) -> dict[str, str]:
    try:
        names = sorted(os.listdir(path))
    except OSError as exc:
        raise FileInputError(f"{path}: a log named ROBOT__TIME without a suffix is a directory holding "
                             f"tau_meas.* and tau_pred.* ({exc.strerror or exc})") from None
    found: dict[str, str] = {}
    for name in names:
        stem, suffix = os.path.splitext(name)
        if stem in ("tau_meas", "tau_pred", *DATA_COLUMNS) and suffix.lower() in _ARRAY_SUFFIXES:
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
        if is_manifest(item):
            out.extend(read_manifest(os.fspath(item), n_params))
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
