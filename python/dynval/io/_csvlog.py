"""Joint states from a vendor's CSV log, read by a declared column mapping (contract §7.3).

A robot controller's own recorder writes one row per control cycle: a time stamp and, per joint,
a position, a velocity and an effort, in columns named by a pattern (UR's RTDE recorder:
``timestamp``, ``actual_q_0`` … ``actual_q_5``, ``actual_qd_*``, ``actual_current_*``). Nothing is
guessed: a :class:`CSVMapping` declares the time column and its unit, each quantity's column pattern,
the effort's unit and the joints; :data:`MAPPINGS` holds the shipped presets, and a JSON file of the
same fields is read by :func:`load_mapping`.

The numbers are parsed by numpy's C reader (``numpy.loadtxt``), only the mapped columns kept: no
Python object per cell, and memory holds the mapped columns as float64 (one copy while they are
split into positions, velocities and efforts). Where numpy refuses a cell, the file is read again
line by line with the CSV rules of contract §7 to name the line and the column.
"""

from __future__ import annotations

import io
import json
import math
import os
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from ..checks._errors import InvalidParameter
from ._fileopen import FileInputError, open_regular
from ._files import _cells, _delimiter, _lines, _shown
from ._ros import EFFORT_UNITS, JointStateLog, _listed, _ordered_stamps, _torque_scale

__all__ = ["CSVMapping", "MAPPINGS", "TIME_UNITS", "load_mapping", "read_csv_log"]

#: Units of a mapping's time column, and their nanoseconds.
TIME_UNITS = {"s": 1e9, "ms": 1e6, "us": 1e3, "ns": 1.0}
_PLACEHOLDERS = ("{i}", "{joint}")
_SHOWN_NAMES = 40  # header names listed in a message about a missing column


@dataclass(frozen=True)
class CSVMapping:
    """Which columns of a CSV log hold the time and each joint's position, velocity and effort.

    Parameters
    ----------
    time : str
        The time column's header name.
    q : str
        The positions' column pattern (rad): ``{i}`` stands for the joint's index in the file
        (from ``first_index``), ``{joint}`` for its name (``"actual_q_{i}"``, ``"pos_{joint}"``).
    time_unit : {"s", "ms", "us", "ns"}
        The time column's unit.
    dq, effort : str, optional
        The velocities' (rad/s) and efforts' column patterns; None when the log has none.
    effort_unit : {"N·m", "A"}
        What the effort columns hold: torques, or motor currents (turned into torques by
        ``torque_constant``, N·m per A, one value or one per joint; it may also be given to the reader).
    n_joints : int, optional
        How many joints the file holds (needed with ``{i}`` when neither ``joints`` nor the reader's
        ``joints=`` gives them).
    joints : sequence of str, optional
        The file's joints by name, in index order (``{i}`` = ``first_index``, ``first_index + 1``, …).
        Default: the reader's ``joints=`` (a model's joint order: the file's first joint is the
        model's first).
    first_index : int
        The index ``{i}`` of the file's first joint (0 for RTDE).
    delimiter : str, optional
        The column separator; default: the first of tab, ``;``, ``,`` in the header line, else runs
        of whitespace (contract §7).
    name : str
        How messages name the mapping.
    """

    time: str
    q: str
    time_unit: str = "s"
    dq: str | None = None
    effort: str | None = None
    effort_unit: str = "N·m"
    torque_constant: float | tuple[float, ...] | None = None
    n_joints: int | None = None
    joints: tuple[str, ...] | None = None
    first_index: int = 0
    delimiter: str | None = None
    name: str = "custom"

    def __post_init__(self) -> None:
        from ..checks._validation import parameter_error

        if not isinstance(self.time, str) or not self.time.strip():
            raise parameter_error("mapping.time", "the time column's header name (a non-empty string)", self.time)
        if self.time_unit not in TIME_UNITS:
            raise parameter_error("mapping.time_unit", "one of 's', 'ms', 'us', 'ns'", self.time_unit)
        for field_name in ("q", "dq", "effort"):
            pattern = getattr(self, field_name)
            if pattern is None and field_name != "q":
                continue
            if not isinstance(pattern, str) or not any(p in pattern for p in _PLACEHOLDERS) or \
                    pattern.replace("{i}", "").replace("{joint}", "").count("{") or \
                    pattern.replace("{i}", "").replace("{joint}", "").count("}"):
                raise parameter_error(f"mapping.{field_name}", "a column pattern holding {i} (the joint's index) "
                                      "or {joint} (its name), and no other brace", pattern)
        unit = "N·m" if self.effort_unit == "Nm" else self.effort_unit
        object.__setattr__(self, "effort_unit", unit)
        if unit not in EFFORT_UNITS:
            raise parameter_error("mapping.effort_unit", "'N·m' (torques) or 'A' (currents, with torque_constant)",
                                  self.effort_unit)
        if self.torque_constant is not None and unit != "A":
            raise parameter_error("mapping.torque_constant", "None when effort_unit is 'N·m'", self.torque_constant)
        if isinstance(self.torque_constant, list):
            object.__setattr__(self, "torque_constant", tuple(self.torque_constant))
        if self.joints is not None:
            names = tuple(self.joints) if isinstance(self.joints, (list, tuple)) else ()
            if not names or not all(isinstance(n, str) and n for n in names) or len(set(names)) != len(names):
                raise parameter_error("mapping.joints", "distinct non-empty joint names", self.joints)
            object.__setattr__(self, "joints", names)
        if self.n_joints is not None and (isinstance(self.n_joints, bool) or not isinstance(self.n_joints, int)
                                          or self.n_joints < 1):
            raise parameter_error("mapping.n_joints", "a positive integer", self.n_joints)
        if self.n_joints is not None and self.joints is not None and self.n_joints != len(self.joints):
            raise parameter_error("mapping.n_joints", f"the number of mapping.joints ({len(self.joints)})",
                                  self.n_joints)
        if isinstance(self.first_index, bool) or not isinstance(self.first_index, int) or self.first_index < 0:
            raise parameter_error("mapping.first_index", "a non-negative integer", self.first_index)
        if self.delimiter is not None and (not isinstance(self.delimiter, str) or len(self.delimiter) != 1
                                           or self.delimiter in "\"#\r\n"):
            raise parameter_error("mapping.delimiter", "one character (not a quote, '#' or a line end), or None "
                                  "(whitespace or the header's own)", self.delimiter)


#: The shipped mappings. ``ur_rtde``: UR's RTDE recorder with the measured motor currents
#: (``actual_current_*``, A: give the torque constants); ``ur_rtde_moment``: with the controller's
#: target torques (``target_moment_*``, N·m: the controller's own model and feedback, not a measurement).
MAPPINGS: dict[str, CSVMapping] = {
    "ur_rtde": CSVMapping(time="timestamp", q="actual_q_{i}", dq="actual_qd_{i}", effort="actual_current_{i}",
                          effort_unit="A", n_joints=6, name="ur_rtde"),
    "ur_rtde_moment": CSVMapping(time="timestamp", q="actual_q_{i}", dq="actual_qd_{i}",
                                 effort="target_moment_{i}", n_joints=6, name="ur_rtde_moment"),
}


def load_mapping(spec: str | os.PathLike[str] | CSVMapping | Mapping[str, Any]) -> CSVMapping:
    """A :class:`CSVMapping` from a preset's name (:data:`MAPPINGS`), a JSON file of its fields
    (``.json``), a dict of its fields, or a mapping itself.

    Raises FileInputError for a JSON file that cannot be read (naming the file, and the line and
    column of a syntax error) or that holds a field no mapping has; InvalidParameter for a name that
    is neither a preset nor a ``.json`` file, and for a field's bad value.
    """
    from ..checks._validation import parameter_error

    if isinstance(spec, CSVMapping):
        return spec
    if isinstance(spec, Mapping):
        return _from_fields(dict(spec), "the mapping")
    text = os.fspath(spec)
    if text in MAPPINGS:
        return MAPPINGS[text]
    if not text.lower().endswith(".json"):
        raise parameter_error("mapping", f"one of {', '.join(repr(k) for k in MAPPINGS)} or a .json file of a "
                              "CSVMapping's fields", text)
    handle, _ = open_regular(text)
    with handle:
        raw = handle.read(1 << 20)
    try:
        values = json.loads(raw.decode("utf-8-sig"))
    except UnicodeDecodeError:
        raise FileInputError(f"{text}: not UTF-8 text") from None
    except json.JSONDecodeError as exc:
        raise FileInputError(f"{text}: line {exc.lineno}, column {exc.colno}: not valid JSON ({exc.msg})") from None
    if not isinstance(values, dict):
        raise FileInputError(f"{text}: holds a JSON {type(values).__name__}; a mapping is an object of "
                             "CSVMapping's fields")
    values.setdefault("name", os.path.basename(text))
    return _from_fields(values, text)


def _from_fields(values: dict[str, Any], where: str) -> CSVMapping:
    known = [f.name for f in fields(CSVMapping)]
    unknown = [k for k in values if k not in known]
    if unknown:
        raise FileInputError(f"{where}: no mapping field {unknown[0]!r}; the fields are {_listed(known)}")
    missing = [k for k in ("time", "q") if k not in values]
    if missing:
        raise FileInputError(f"{where}: the field {missing[0]!r} is required (the time column and the positions' "
                             "pattern)")
    try:
        return CSVMapping(**values)
    except InvalidParameter as exc:
        if where == "the mapping":
            raise
        raise InvalidParameter(f"{where}: {exc}") from None


@dataclass(frozen=True)
class _Plan:
    """The columns to read: header names in the order numpy returns them, and what each one is."""

    names: tuple[str, ...]
    roles: tuple[str, ...]  # "time", or "<field> of joint '<name>'"
    joints: tuple[str, ...]  # the output's joints, in order
    n: int


def _plan(mapping: CSVMapping, joints: Sequence[str] | None) -> _Plan:
    from ..checks._validation import parameter_error

    own = mapping.joints
    if own is None and joints is not None:
        own = tuple(joints)
        if mapping.n_joints is not None and mapping.n_joints != len(own):
            raise parameter_error("joints", f"{mapping.n_joints} joints, as the mapping {mapping.name} declares "
                                  "(its file's joints are taken in the model's order)", list(own))
    uses_name = any(p is not None and "{joint}" in p for p in (mapping.q, mapping.dq, mapping.effort))
    if own is None:
        if uses_name or mapping.n_joints is None:
            raise parameter_error("joints", f"the joint names (the mapping {mapping.name} declares "
                                  + ("{joint} patterns" if uses_name else "no n_joints") + " and no joints)", None)
        indices = range(mapping.first_index, mapping.first_index + mapping.n_joints)
        own = tuple(mapping.q.format(i=i, joint="") for i in indices)
    index = {name: mapping.first_index + k for k, name in enumerate(own)}
    wanted = tuple(joints) if joints is not None else own
    absent = [j for j in wanted if j not in index]
    if absent:
        raise FileInputError(f"the mapping {mapping.name} names no joint {_listed(absent)}; its joints are "
                             f"{_listed(list(own))}; the joints asked for are {_listed(list(wanted))}")
    names, roles = [mapping.time], ["the time"]
    for field_name in ("q", "dq", "effort"):
        pattern = getattr(mapping, field_name)
        if pattern is None:
            continue
        for j in wanted:
            names.append(pattern.format(i=index[j], joint=j))
            roles.append(f"{field_name} of joint {j!r}")
    return _Plan(tuple(names), tuple(roles), wanted, len(wanted))


def read_csv_log(path: str | os.PathLike[str], mapping: str | os.PathLike[str] | CSVMapping | Mapping[str, Any], *,
                 joints: Sequence[str] | None = None,
                 torque_constant: float | Sequence[float] | None = None) -> JointStateLog:
    """Read a vendor's CSV log by a declared column mapping.

    Parameters
    ----------
    path : str or path
        A CSV file with a header line naming its columns.
    mapping : str, path, CSVMapping or dict
        A preset's name (``"ur_rtde"``, ``"ur_rtde_moment"``: :data:`MAPPINGS`), a ``.json`` file of
        :class:`CSVMapping`'s fields, or the mapping.
    joints : sequence of str, optional
        The joints wanted, in order (a model's). With a mapping that names its joints they are
        matched by name; otherwise the file's joints are these, in index order.
    torque_constant : float or sequence of float, optional
        N·m per A (one, or one per joint of the output) for a mapping whose efforts are currents;
        replaces the mapping's own.

    Returns
    -------
    JointStateLog
        ``topic`` is ``""``, ``msgtype`` ``"CSV (mapping NAME)"``, ``n_messages`` the data rows; the
        stamps are sorted, rows sharing a stamp merged and gaps counted as the bag reader does (notes).
        ``q``, ``dq`` and ``tau`` are views of the one array numpy parsed (strided columns).

    Raises
    ------
    dynval.io.FileInputError
        No header line, a mapped column the header does not name (the header's names listed), a
        row with fewer values than the header, a cell that is not a number or not finite (file,
        line, column and the column's name), a file that is not a regular file or not text.
    dynval.InvalidParameter
        A bad mapping, ``joints`` of another count than the mapping declares, a missing or bad
        torque constant.
    """
    where = os.fspath(path)
    chosen = load_mapping(mapping)
    plan = _plan(chosen, joints)
    constant = torque_constant if torque_constant is not None else chosen.torque_constant
    if chosen.effort is None:
        constant = None
    elif chosen.effort_unit == "A" and constant is None:
        from ..checks._validation import parameter_error

        raise parameter_error("torque_constant", f"positive numbers in N·m/A: the mapping {chosen.name} reads "
                              "motor currents (effort_unit 'A'); give one value or one per joint", None)
    scale = _torque_scale(chosen.effort_unit if chosen.effort is not None else "N·m", constant, plan.joints)
    header_line, header, delimiter = _header(where, chosen)
    columns = _columns(where, header, header_line, plan, chosen)
    data = _parse(where, header_line, delimiter, columns, len(header), plan)
    stamps = _stamps_ns(where, data[:, 0], chosen, columns[0])
    rows = data[:, 1:]
    stamps, rows, notes = _ordered_stamps(stamps, rows, "row")
    m = plan.n
    has = [getattr(chosen, f) is not None for f in ("dq", "effort")]
    # views of the one array numpy parsed (no second copy of a long log); the columns are strided
    q = rows[:, :m]
    dq = rows[:, m:2 * m] if has[0] else None
    tau = rows[:, (1 + has[0]) * m:(2 + has[0]) * m] if has[1] else None
    if tau is not None and scale is not None:
        tau *= scale
    return JointStateLog(time=(stamps - stamps[0]) / 1e9, q=q, dq=dq, tau=tau, joint_names=plan.joints, path=where,
                         topic="", msgtype=f"CSV (mapping {chosen.name})", start_time=stamps[0] / TIME_UNITS["s"],
                         effort_unit=chosen.effort_unit if tau is not None else "N·m", torque_constant=scale,
                         n_messages=int(q.shape[0]), notes=tuple(notes))


def _header(where: str, mapping: CSVMapping) -> tuple[int, list[str], str | None]:
    """The header line's number, its names and the delimiter (the mapping's, or sniffed from it)."""
    handle, _ = open_regular(where)
    with handle:
        for number, line in _lines(handle, where):
            stripped = line.strip()
            if not stripped or stripped.startswith("#"):
                continue
            delimiter = mapping.delimiter if mapping.delimiter is not None else _delimiter(stripped)
            if delimiter == " ":
                delimiter = None  # runs of spaces are one separator, as contract §7 reads a file without one
            return number, _cells(stripped, delimiter, where, number), delimiter
    raise FileInputError(f"{where}: no header line (the file holds no line but blank lines and comments)")


def _columns(where: str, header: list[str], line: int, plan: _Plan, mapping: CSVMapping) -> list[int]:
    out = []
    for name, role in zip(plan.names, plan.roles):
        count = header.count(name)
        if count == 1:
            out.append(header.index(name))
            continue
        if count > 1:
            raise FileInputError(f"{where}: line {line}: the header names {name!r} {count} times ({role}, mapping "
                                 f"{mapping.name}); a mapped column must be named once")
        raise FileInputError(f"{where}: no column {name!r} ({role}, mapping {mapping.name}); the header (line "
                             f"{line}) names {_listed(header, _SHOWN_NAMES)}")
    return out


def _parse(where: str, header_line: int, delimiter: str | None, columns: list[int], width: int,
           plan: _Plan) -> np.ndarray:
    """The mapped columns as float64 (rows, columns), every value finite; the last column of the
    header is read as well (and dropped) so that a row cut short is refused, not read shifted."""
    try:
        data = _loadtxt(where, header_line, delimiter, [*columns, width - 1])[:, :-1]
    except (ValueError, UnicodeDecodeError) as exc:
        _locate(where, header_line, delimiter, columns, width, plan, None)
        try:  # every row is wide enough and every mapped cell a number: the last column is text
            data = _loadtxt(where, header_line, delimiter, columns)
        except (ValueError, UnicodeDecodeError):
            raise FileInputError(f"{where}: cannot be read as numbers ({exc})") from None
    if data.shape[0] == 0:
        raise FileInputError(f"{where}: no data rows after the header (line {header_line})")
    bad = ~np.isfinite(data)
    if np.any(bad):
        first = int(np.flatnonzero(np.any(bad, axis=1))[0])
        _locate(where, header_line, delimiter, columns, width, plan, first)
        raise FileInputError(f"{where}: data row {first + 1} holds a value that is not finite")  # pragma: no cover
    return data


def _loadtxt(where: str, header_line: int, delimiter: str | None, usecols: list[int]) -> np.ndarray:
    handle, _ = open_regular(where)
    with handle, io.TextIOWrapper(handle, encoding="utf-8-sig", newline=None) as text, warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # no data rows: said by the caller
        return np.loadtxt(text, delimiter=delimiter, usecols=usecols, skiprows=header_line, comments="#",
                          quotechar='"', dtype=np.float64, ndmin=2)


def _locate(where: str, header_line: int, delimiter: str | None, columns: list[int], width: int, plan: _Plan,
            row: int | None) -> None:
    """Read the file again line by line (contract §7's rules) and raise at the first bad line: a row
    of another width, a mapped cell that is not a number, or (up to data row ``row``) not finite."""
    handle, _ = open_regular(where)
    seen = 0
    with handle:
        for number, line in _lines(handle, where):
            stripped = line.strip()
            if number <= header_line or not stripped or stripped.startswith("#"):
                continue
            cells = _cells(stripped, delimiter, where, number)
            if len(cells) < width:
                raise FileInputError(f"{where}: line {number} has {len(cells)} values; the header (line "
                                     f"{header_line}) names {width} columns")
            for c, role, name in zip(columns, plan.roles, plan.names):
                try:
                    value = float(cells[c])
                except ValueError:
                    raise FileInputError(f"{where}: line {number}, column {c + 1} ({name!r}, {role}): "
                                         f"{_shown(cells[c])} is not a number") from None
                if not math.isfinite(value):
                    raise FileInputError(f"{where}: line {number}, column {c + 1} ({name!r}, {role}): {value!r}; "
                                         "every mapped value must be finite")
            if row is not None and seen >= row:
                return
            seen += 1


def _stamps_ns(where: str, time: np.ndarray, mapping: CSVMapping, column: int) -> np.ndarray:
    """The stamps as integer nanoseconds (the bag reader's unit), refused beyond int64's range."""
    ns = np.round(time * TIME_UNITS[mapping.time_unit])
    if np.any(np.abs(ns) >= 2.0**63):
        raise FileInputError(f"{where}: column {column + 1} ({mapping.time!r}, the time in {mapping.time_unit}) "
                             f"holds values beyond ±2**63 ns (about 292 years): is time_unit right?")
    return ns.astype(np.int64)
