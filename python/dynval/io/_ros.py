"""Joint states from a robot's own log: ROS 2 bags (sqlite3 or MCAP), ROS 1 bags and bare MCAP files
(contract §7.3).

``sensor_msgs/JointState`` messages carry the joints by name, in any order, with header stamps;
several messages may share a stamp (one per group of joints), messages may be dropped or arrive out
of order. :func:`read_joint_states` reads one topic into a :class:`JointStateLog`: time, positions,
velocities and efforts in the caller's joint order, and notes on what it had to do to the stamps.

The bags are read with ``rosbags`` (pure Python, no ROS installation: ``pip install "dynval[ros]"``),
message by message: memory holds the decoded arrays (one row per message) and nothing else.
"""

from __future__ import annotations

import os
from collections.abc import Generator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ._fileopen import FileInputError

__all__ = ["JointStateLog", "read_joint_states", "JOINT_STATE_TYPES", "EFFORT_UNITS"]

#: The message types read as joint states (ROS 2 and ROS 1 names).
JOINT_STATE_TYPES = ("sensor_msgs/msg/JointState", "sensor_msgs/JointState")
#: ``effort_unit`` values: torques as logged, or motor currents turned into torques by a torque constant.
EFFORT_UNITS = ("N·m", "A")

_GAP = 1.5  # a step longer than 1.5 median steps counts as dropped messages


@dataclass(frozen=True)
class JointStateLog:
    """One topic of joint states, in the joint order asked for.

    Attributes
    ----------
    time : ndarray (N,)
        Header stamps in seconds from the first message, increasing, one row per stamp.
    q, dq, tau : ndarray (N, m)
        Positions, velocities and efforts (torques in N·m: currents are multiplied by the torque
        constant). ``dq`` or ``tau`` is None when the messages carry none.
    joint_names : tuple of str
        The joints, in the columns' order.
    path, topic, msgtype : str
        Where the messages came from.
    start_time : float
        The first stamp, seconds since the epoch (``time`` counts from it).
    effort_unit : str
        What the log's effort field held (``"N·m"``, or ``"A"`` with ``torque_constant``).
    torque_constant : ndarray (m,) or None
        N·m per A, per joint, when ``effort_unit="A"``.
    n_messages : int
        Messages read from the topic.
    notes : tuple of str
        What was done to the stamps: messages merged at one stamp, stamps sorted, estimated drops.
    """

    time: np.ndarray
    q: np.ndarray
    dq: np.ndarray | None
    tau: np.ndarray | None
    joint_names: tuple[str, ...]
    path: str
    topic: str
    msgtype: str
    start_time: float
    effort_unit: str = "N·m"
    torque_constant: np.ndarray | None = None
    n_messages: int = 0
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def sample_rate(self) -> float:
        """The median rate of the stamps (Hz)."""
        steps = np.diff(self.time)
        return float(1.0 / np.median(steps)) if steps.size else float("nan")

    def __repr__(self) -> str:
        return (f"JointStateLog({self.path!r}, topic={self.topic!r}, {self.q.shape[0]} stamps × "
                f"{len(self.joint_names)} joints, {self.sample_rate:.4g} Hz, effort in {self.effort_unit}"
                + (f", {len(self.notes)} note(s)" if self.notes else "") + ")")


@dataclass
class _Message:
    index: int
    stamp_ns: int
    names: Sequence[str]
    position: Any
    velocity: Any
    effort: Any


def read_joint_states(path: str | os.PathLike[str], *, joints: Sequence[str] | None = None,
                      topic: str | None = None, effort_unit: str = "N·m",
                      torque_constant: float | Sequence[float] | None = None) -> JointStateLog:
    """Read the ``sensor_msgs/JointState`` messages of one topic of a bag or MCAP file.

    Parameters
    ----------
    path : str or path
        A ROS 2 bag (its directory, with ``metadata.yaml``: sqlite3 or MCAP storage), a ROS 1
        ``.bag`` file, or a bare ``.mcap`` file.
    joints : sequence of str, optional
        The joints to read, in the order wanted (a model's joint order). Default: the first
        message's names, in its order.
    topic : str, optional
        The topic; needed only when the log has several JointState topics.
    effort_unit : {"N·m", "A"}
        What the effort field holds; ``"A"`` needs ``torque_constant``.
    torque_constant : float or sequence of float, optional
        N·m per A (one value, or one per joint in ``joints``' order).

    Returns
    -------
    JointStateLog

    Raises
    ------
    dynval.io.FileInputError
        A file that is missing, truncated or not a bag; no JointState topic, an unknown topic or
        several to choose from; a joint asked for that the messages do not name (both name sets are
        listed); a non-finite value (file, topic and message index named); messages of different
        lengths.
    dynval.InvalidParameter
        A bad ``effort_unit`` or ``torque_constant``.
    """
    where = os.fspath(path)
    scale = _torque_scale(effort_unit, torque_constant, joints)
    topic, msgtype, messages = _open_topic(where, topic)
    rows = _Rows(where, topic, list(joints) if joints is not None else None)
    try:
        for msg in messages:
            rows.add(msg)
    finally:
        messages.close()  # the file is closed at once, also when a message is refused
    return rows.log(msgtype, effort_unit, scale)


def _torque_scale(effort_unit: str, torque_constant: Any, joints: Sequence[str] | None) -> np.ndarray | None:
    from ..checks._validation import parameter_error

    if effort_unit not in EFFORT_UNITS:
        raise parameter_error("effort_unit", "'N·m' (torques) or 'A' (currents, with torque_constant)", effort_unit)
    if effort_unit == "N·m":
        if torque_constant is not None:
            raise parameter_error("torque_constant", "None when effort_unit='N·m' (the effort is a torque already)",
                                  torque_constant)
        return None
    k = np.atleast_1d(np.asarray(torque_constant if torque_constant is not None else np.nan, dtype=float))
    if k.ndim != 1 or not np.all(np.isfinite(k)) or not np.all(k > 0):
        raise parameter_error("torque_constant", "positive numbers in N·m/A (one, or one per joint) with "
                              "effort_unit='A'", torque_constant)
    if k.size != 1 and (joints is None or k.size != len(joints)):
        raise parameter_error("torque_constant", "one value, or one per joint of joints=", torque_constant)
    return k


def _open_topic(where: str, topic: str | None) -> tuple[str, str, Generator[_Message, None, None]]:
    if not os.path.exists(where):
        raise FileInputError(f"{where}: no such file or bag directory")
    if os.path.isfile(where) and where.endswith(".mcap"):
        return _mcap_topic(where, topic)
    return _rosbags_topic(where, topic)


def _choose(where: str, topics: dict[str, str], topic: str | None) -> str:
    joint_topics = sorted(t for t, typ in topics.items() if typ in JOINT_STATE_TYPES)
    if topic is not None:
        if topic not in topics:
            raise FileInputError(f"{where}: no topic {topic!r}; its topics: {_listed(sorted(topics))}")
        if topics[topic] not in JOINT_STATE_TYPES:
            raise FileInputError(f"{where}: topic {topic!r} holds {topics[topic]}, not sensor_msgs/JointState "
                                 f"(JointState topics: {_listed(joint_topics) or 'none'})")
        return topic
    if not joint_topics:
        raise FileInputError(f"{where}: no sensor_msgs/JointState topic; its topics: "
                             + (_listed([f"{t} ({typ})" for t, typ in sorted(topics.items())]) or "none"))
    if len(joint_topics) > 1:
        raise FileInputError(f"{where}: several JointState topics ({_listed(joint_topics)}): choose one with topic=")
    return joint_topics[0]


def _listed(names: Sequence[str], most: int = 12) -> str:
    shown = ", ".join(repr(n) for n in names[:most])
    return shown + (f", … ({len(names)} in all)" if len(names) > most else "")


def _rosbags_topic(where: str, topic: str | None) -> tuple[str, str, Generator[_Message, None, None]]:
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError as exc:
        raise ImportError("reading ROS bags needs rosbags: pip install 'dynval[ros]'") from exc
    from pathlib import Path

    reader = AnyReader([Path(where)], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
    try:
        reader.open()
    except Exception as exc:  # rosbags raises its own errors for every kind of broken bag
        raise FileInputError(f"{where}: cannot be read as a ROS bag ({type(exc).__name__}: {exc})") from None
    topics = {c.topic: c.msgtype for c in reader.connections}
    try:
        chosen = _choose(where, topics, topic)
    except FileInputError:
        reader.close()
        raise
    connections = [c for c in reader.connections if c.topic == chosen]

    def messages() -> Generator[_Message, None, None]:
        try:
            for index, (conn, _t, raw) in enumerate(reader.messages(connections=connections)):
                try:
                    msg = reader.deserialize(raw, conn.msgtype)
                except Exception as exc:
                    raise FileInputError(f"{where}: topic {chosen!r}, message {index}: cannot be decoded "
                                         f"({type(exc).__name__}: {exc})") from None
                yield _message(index, msg, _t)
        except FileInputError:
            raise
        except Exception as exc:
            raise FileInputError(f"{where}: topic {chosen!r}: the bag ends or breaks while reading "
                                 f"({type(exc).__name__}: {exc})") from None
        finally:
            reader.close()

    return chosen, topics[chosen], messages()


def _mcap_topic(where: str, topic: str | None) -> tuple[str, str, Generator[_Message, None, None]]:
    try:
        from mcap.reader import make_reader
        from rosbags.typesys import Stores, get_typestore
    except ImportError as exc:
        raise ImportError("reading MCAP files needs mcap and rosbags: pip install 'dynval[ros]'") from exc
    store = get_typestore(Stores.ROS2_HUMBLE)
    handle = open(where, "rb")  # noqa: SIM115 (closed by the generator below or on error)
    try:
        reader = make_reader(handle)
        summary = reader.get_summary()
        channels = summary.channels if summary is not None else {}
        schemas = summary.schemas if summary is not None else {}
        topics = {ch.topic: schemas[ch.schema_id].name if ch.schema_id in schemas else "?" for ch in channels.values()}
    except Exception as exc:
        handle.close()
        raise FileInputError(f"{where}: cannot be read as an MCAP file ({type(exc).__name__}: {exc})") from None
    try:
        chosen = _choose(where, topics, topic)
    except FileInputError:
        handle.close()
        raise
    msgtype = topics[chosen]

    def messages() -> Generator[_Message, None, None]:
        try:
            for index, (_schema, _channel, message) in enumerate(reader.iter_messages(topics=[chosen])):
                try:
                    msg = store.deserialize_cdr(message.data, msgtype)
                except Exception as exc:
                    raise FileInputError(f"{where}: topic {chosen!r}, message {index}: cannot be decoded "
                                         f"({type(exc).__name__}: {exc})") from None
                yield _message(index, msg, message.log_time)
        except FileInputError:
            raise
        except Exception as exc:
            raise FileInputError(f"{where}: topic {chosen!r}: the file ends or breaks while reading "
                                 f"({type(exc).__name__}: {exc})") from None
        finally:
            handle.close()

    return chosen, msgtype, messages()


def _message(index: int, msg: Any, received_ns: int) -> _Message:
    stamp = msg.header.stamp
    ns = int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)
    return _Message(index, ns if ns else int(received_ns), list(msg.name), msg.position, msg.velocity, msg.effort)


class _Rows:
    """The messages' values in the wanted joint order, one row per message, in blocks."""

    def __init__(self, where: str, topic: str, joints: list[str] | None) -> None:
        self.where, self.topic, self.joints = where, topic, joints
        self.stamps: list[np.ndarray] = []
        self.blocks: list[np.ndarray] = []
        self._stamp: list[int] = []
        self._rows: list[np.ndarray] = []
        self.count = 0
        self.has_velocity = self.has_effort = False
        self._order: dict[tuple[str, ...], np.ndarray] = {}

    def add(self, msg: _Message) -> None:
        if self.joints is None:
            self.joints = list(msg.names)
        m = len(self.joints)
        names = tuple(msg.names)
        where = self._order.get(names)
        if where is None:
            where = self._columns(names, msg.index)
        row = np.full(3 * m, np.nan)
        for k, values in enumerate((msg.position, msg.velocity, msg.effort)):
            values = np.asarray(values, dtype=float)
            if values.size == 0:
                continue
            if values.size != len(names):
                field_name = ("position", "velocity", "effort")[k]
                raise FileInputError(f"{self.where}: topic {self.topic!r}, message {msg.index}: {values.size} "
                                     f"{field_name} values for {len(names)} joint names")
            picked = np.full(m, np.nan)
            inside = where >= 0
            picked[where[inside]] = values[np.flatnonzero(inside)]
            bad = np.flatnonzero(inside & ~np.isfinite(values))
            if bad.size:
                field_name = ("position", "velocity", "effort")[k]
                raise FileInputError(f"{self.where}: topic {self.topic!r}, message {msg.index}: {field_name} of "
                                     f"{names[bad[0]]!r} is {float(values[bad[0]])!r}; every value must be finite")
            row[k * m:(k + 1) * m] = picked
            self.has_velocity |= k == 1
            self.has_effort |= k == 2
        self._stamp.append(msg.stamp_ns)
        self._rows.append(row)
        self.count += 1
        if len(self._rows) >= 65536:
            self._flush()

    def _columns(self, names: tuple[str, ...], index: int) -> np.ndarray:
        """For each name of a message, its column among the wanted joints (-1: not wanted)."""
        assert self.joints is not None
        if len(set(names)) != len(names):
            raise FileInputError(f"{self.where}: topic {self.topic!r}, message {index}: a joint named twice "
                                 f"({_listed(list(names))})")
        wanted = {n: j for j, n in enumerate(self.joints)}
        where = np.array([wanted.get(n, -1) for n in names], dtype=np.intp)
        self._order[names] = where
        return where

    def _flush(self) -> None:
        if self._rows:
            self.stamps.append(np.array(self._stamp, dtype=np.int64))
            self.blocks.append(np.vstack(self._rows))
            self._stamp, self._rows = [], []

    def log(self, msgtype: str, effort_unit: str, scale: np.ndarray | None) -> JointStateLog:
        self._flush()
        if not self.count or self.joints is None:
            raise FileInputError(f"{self.where}: topic {self.topic!r} holds no message")
        m = len(self.joints)
        stamps = np.concatenate(self.stamps)
        rows = np.vstack(self.blocks)
        stamps, rows, notes = _ordered_stamps(stamps, rows, "message")
        missing = [self.joints[j] for j in range(m) if np.all(np.isnan(rows[:, j]))]
        if missing:
            seen = sorted({n for names in self._order for n in names})
            raise FileInputError(f"{self.where}: topic {self.topic!r}: no position for {_listed(missing)}; the "
                                 f"messages name {_listed(seen)}; the joints asked for are {_listed(self.joints)}")
        incomplete = np.flatnonzero(np.any(np.isnan(rows[:, :m]), axis=1))
        if incomplete.size:
            raise FileInputError(f"{self.where}: topic {self.topic!r}: the stamp {stamps[incomplete[0]] / 1e9:.9f} s "
                                 f"has no position for some joint ({incomplete.size} stamp(s) so); the joints asked "
                                 f"for must be in every stamp")
        q = rows[:, :m]
        dq = rows[:, m:2 * m] if self.has_velocity else None
        tau = rows[:, 2 * m:] if self.has_effort else None
        for name, values in (("velocity", dq), ("effort", tau)):
            if values is not None and np.any(np.isnan(values)):
                raise FileInputError(f"{self.where}: topic {self.topic!r}: some stamps carry no {name} for some "
                                     "joints while others do")
        if tau is not None and scale is not None:
            tau = tau * scale
        elif tau is None and scale is not None:
            raise FileInputError(f"{self.where}: topic {self.topic!r}: effort_unit='A', but the messages carry "
                                 "no effort")
        return JointStateLog(time=(stamps - stamps[0]) / 1e9, q=np.ascontiguousarray(q),
                             dq=None if dq is None else np.ascontiguousarray(dq),
                             tau=None if tau is None else np.ascontiguousarray(tau), joint_names=tuple(self.joints),
                             path=self.where, topic=self.topic, msgtype=msgtype, start_time=stamps[0] / 1e9,
                             effort_unit=effort_unit, torque_constant=scale, n_messages=self.count, notes=tuple(notes))


def _ordered_stamps(stamps: np.ndarray, rows: np.ndarray, what: str) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Rows in stamp order, one per stamp, and the notes on what that took (``what``: "message" for a
    bag's messages, "row" for a CSV file's rows): late ones put in order, ones sharing a stamp merged
    (a later one's value wins), gaps longer than 1.5 median steps counted as dropped."""
    notes: list[str] = []
    late = int(np.sum(np.diff(stamps) < 0))
    if late:
        notes.append(f"{late} {what}(s) arrived out of stamp order; they were put in order")
        order = np.argsort(stamps, kind="stable")
        stamps, rows = stamps[order], rows[order]
    stamps, rows, merged = _merge_equal_stamps(stamps, rows)
    if merged:
        notes.append(f"{merged} {what}(s) shared a stamp with another and were merged into its row "
                     f"(a later {what}'s value wins)")
    return stamps, rows, notes + _gap_notes(stamps, what)


def _merge_equal_stamps(stamps: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """One row per stamp: messages at one stamp (joint groups published apart) filled into one row."""
    starts = np.flatnonzero(np.r_[True, np.diff(stamps) != 0])
    if starts.size == stamps.size:
        return stamps, rows, 0
    out = rows[starts].copy()
    for k in range(1, int(np.max(np.diff(np.r_[starts, stamps.size])))):
        later = starts + k
        same = later < np.r_[starts[1:], stamps.size]
        idx = later[same]
        block = rows[idx]
        target = out[same]
        filled = ~np.isnan(block)
        target[filled] = block[filled]
        out[same] = target
    return stamps[starts], out, stamps.size - starts.size


def _gap_notes(stamps: np.ndarray, what: str = "message") -> list[str]:
    steps = np.diff(stamps)
    if steps.size < 2:
        return []
    median = float(np.median(steps))
    gaps = steps > _GAP * median
    if not np.any(gaps):
        return []
    dropped = int(np.sum(np.round(steps[gaps] / median) - 1))
    return [f"{int(gaps.sum())} gap(s) in the stamps longer than {_GAP:g} median steps ({median / 1e6:.4g} ms): "
            f"about {dropped} {what}(s) dropped; validate splits the run there when given time="]
