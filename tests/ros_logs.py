"""Bags and MCAP files of sensor_msgs/JointState written from arrays, for the tests of dynval.io's
log readers: real in format (rosbags' own writers), made from the shipped KUKA runs."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np


def write_joint_states(path: Path, time: np.ndarray, q: np.ndarray, dq: np.ndarray | None, effort: np.ndarray | None,
                       joint_names: Sequence[str], *, topic: str = "/joint_states", storage: str = "sqlite3",
                       start_ns: int = 1_700_000_000_000_000_000, order: Sequence[int] | None = None,
                       groups: Sequence[Sequence[int]] | None = None, extra_topics: Sequence[str] = (),
                       rows: Sequence[int] | None = None) -> Path:
    """One message per row (or one per group of joints at each row's stamp), joints in ``order``.

    ``storage``: "sqlite3" or "mcap" (ROS 2 bag directories) or "ros1" (a .bag file).
    ``rows`` writes only those rows, in that order (drops and reordering).
    """
    if storage == "ros1":
        from rosbags.rosbag1 import Writer as Writer1
        from rosbags.typesys import Stores, get_typestore

        store = get_typestore(Stores.ROS1_NOETIC)
        msgtype = "sensor_msgs/msg/JointState"
        writer = Writer1(path)
        serialize = store.serialize_ros1
    else:
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore

        store = get_typestore(Stores.ROS2_HUMBLE)
        msgtype = "sensor_msgs/msg/JointState"
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        writer = Writer(path, version=9, storage_plugin=plugin)
        serialize = store.serialize_cdr
    JointState = store.types[msgtype]
    Header = store.types["std_msgs/msg/Header"]
    Time = store.types["builtin_interfaces/msg/Time"]
    order = list(range(q.shape[1])) if order is None else list(order)
    groups = [order] if groups is None else [list(g) for g in groups]
    rows = range(q.shape[0]) if rows is None else rows
    with writer:
        conn = writer.add_connection(topic, msgtype, typestore=store)
        others = [writer.add_connection(t, "std_msgs/msg/String", typestore=store) for t in extra_topics]
        for i, k in enumerate(rows):
            ns = start_ns + int(round(time[k] * 1e9))
            received = start_ns + i * 1000  # the bag's own time: in writing order, whatever the stamps
            stamp = Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
            for g in groups:
                header = (Header(seq=int(k), stamp=stamp, frame_id="") if storage == "ros1"
                          else Header(stamp=stamp, frame_id=""))
                msg = JointState(
                    header=header, name=[joint_names[j] for j in g],
                    position=np.asarray(q[k, g], dtype=np.float64),
                    velocity=np.asarray(dq[k, g] if dq is not None else [], dtype=np.float64),
                    effort=np.asarray(effort[k, g] if effort is not None else [], dtype=np.float64))
                writer.write(conn, received, serialize(msg, msgtype))
            for other in others:
                text = store.types["std_msgs/msg/String"](data="hello")
                writer.write(other, received, serialize(text, "std_msgs/msg/String"))
    return path
