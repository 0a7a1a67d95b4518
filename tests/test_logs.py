"""dynval.io.read_joint_states and dynval.logs.validate_log: a robot's own log to a verdict.

The logs are written by rosbags' own writers (ROS 2 bags in sqlite3 and MCAP storage, ROS 1 bags,
bare MCAP files) from the KUKA LWR4+ runs shipped with dynval: real in format, known in content.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags")
pytest.importorskip("mcap")

import dynval
from dynval.datasets import load_kuka_lwr4
from dynval.io import FileInputError, read_joint_states
from ros_logs import write_joint_states

N = 1200
SHUFFLED = [3, 1, 0, 2, 6, 5, 4]


@pytest.fixture(scope="module")
def run1():
    return load_kuka_lwr4(1)


def _write(path, run, **kw):
    return write_joint_states(path, run.time[:N], run.q[:N], run.dq[:N], run.tau[:N], run.joint_names, **kw)


@pytest.mark.parametrize("storage", ["sqlite3", "mcap", "ros1", "bare-mcap"])
def test_every_storage_reads_back_the_arrays_in_the_models_joint_order(tmp_path, run1, storage):
    target = tmp_path / ("log.bag" if storage == "ros1" else "log")
    _write(target, run1, storage="mcap" if storage == "bare-mcap" else storage, order=SHUFFLED)
    if storage == "bare-mcap":
        target = next(target.glob("*.mcap"))
    log = read_joint_states(target, joints=run1.joint_names)
    assert log.joint_names == tuple(run1.joint_names) and log.q.shape == (N, 7)
    np.testing.assert_array_equal(log.q, run1.q[:N])
    np.testing.assert_array_equal(log.dq, run1.dq[:N])
    np.testing.assert_array_equal(log.tau, run1.tau[:N])
    np.testing.assert_allclose(log.time, run1.time[:N] - run1.time[0], atol=1e-9)
    assert log.notes == () and log.n_messages == N and log.topic == "/joint_states"


def test_joint_groups_at_one_stamp_dropped_and_late_messages(tmp_path, run1):
    rows = [k for k in range(N) if k % 100 != 50]  # 12 messages dropped
    rows[10], rows[11] = rows[11], rows[10]  # one message late
    _write(tmp_path / "log", run1, groups=[[4, 5, 6], [0, 1, 2, 3]], rows=rows)
    log = read_joint_states(tmp_path / "log", joints=run1.joint_names)
    kept = sorted(rows)
    np.testing.assert_array_equal(log.q, run1.q[kept])
    notes = " ".join(log.notes)
    assert f"{len(kept)} message(s) shared a stamp" in notes
    assert "12 gap(s)" in notes and "about 12 message(s) dropped" in notes
    assert "out of stamp order" in notes


def test_a_second_topic_must_be_chosen(tmp_path, run1):
    path = tmp_path / "two.bag"
    from rosbags.rosbag1 import Writer  # two JointState topics in one bag
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    js, header, time = (store.types[t] for t in ("sensor_msgs/msg/JointState", "std_msgs/msg/Header",
                                                 "builtin_interfaces/msg/Time"))
    with Writer(path) as w:
        conns = [w.add_connection(t, js.__msgtype__, typestore=store) for t in ("/arm/joint_states", "/gripper/js")]
        for k in range(20):
            for c, names in zip(conns, (run1.joint_names, ["finger"])):
                msg = js(header=header(seq=k, stamp=time(sec=1 + k, nanosec=0), frame_id=""), name=list(names),
                         position=np.ones(len(names)), velocity=np.zeros(len(names)), effort=np.zeros(len(names)))
                w.write(c, (1 + k) * 10**9, store.serialize_ros1(msg, js.__msgtype__))
    with pytest.raises(FileInputError, match=r"several JointState topics \('/arm/joint_states', '/gripper/js'\)"):
        read_joint_states(path)
    assert read_joint_states(path, topic="/arm/joint_states").q.shape == (20, 7)
    with pytest.raises(FileInputError, match="no topic '/nope'"):
        read_joint_states(path, topic="/nope")


def test_a_missing_joint_lists_both_name_sets(tmp_path, run1):
    _write(tmp_path / "log", run1)
    with pytest.raises(FileInputError) as err:
        read_joint_states(tmp_path / "log", joints=[*run1.joint_names[:6], "wrist_3"])
    text = str(err.value)
    assert "no position for 'wrist_3'" in text and "'lwr_6_joint'" in text and str(tmp_path / "log") in text


def test_a_nan_effort_names_the_file_topic_and_message(tmp_path, run1):
    tau = run1.tau[:N].copy()
    tau[37, 2] = np.nan
    write_joint_states(tmp_path / "log", run1.time[:N], run1.q[:N], run1.dq[:N], tau, run1.joint_names)
    with pytest.raises(FileInputError, match=r"log: topic '/joint_states', message 37: effort of 'lwr_2_joint' is nan"):
        read_joint_states(tmp_path / "log")


def test_a_truncated_bag_is_a_clear_error(tmp_path, run1):
    path = _write(tmp_path / "log.bag", run1, storage="ros1")
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(FileInputError, match=str(path)):
        read_joint_states(path)
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not an mcap file at all")
    with pytest.raises(FileInputError, match="cannot be read as an MCAP file"):
        read_joint_states(junk)
    with pytest.raises(FileInputError, match="no such file"):
        read_joint_states(tmp_path / "absent")


def test_a_topic_of_another_type_is_refused(tmp_path, run1):
    _write(tmp_path / "log", run1, extra_topics=["/chatter"])
    with pytest.raises(FileInputError, match="'/chatter' holds std_msgs/msg/String, not sensor_msgs/JointState"):
        read_joint_states(tmp_path / "log", topic="/chatter")


def test_currents_become_torques_through_the_torque_constant(tmp_path, run1):
    k = np.arange(1.0, 8.0)
    write_joint_states(tmp_path / "log", run1.time[:N], run1.q[:N], None, run1.tau[:N] / k, run1.joint_names)
    log = read_joint_states(tmp_path / "log", effort_unit="A", torque_constant=k, joints=run1.joint_names)
    np.testing.assert_allclose(log.tau, run1.tau[:N], rtol=1e-15)
    assert log.dq is None and log.effort_unit == "A"
    for bad in (None, -1.0, [1.0, 2.0]):
        with pytest.raises(dynval.InvalidParameter, match="torque_constant"):
            read_joint_states(tmp_path / "log", effort_unit="A", torque_constant=bad, joints=run1.joint_names)
    with pytest.raises(dynval.InvalidParameter, match="effort_unit"):
        read_joint_states(tmp_path / "log", effort_unit="mA")


@pytest.fixture(scope="module")
def kuka_bag(tmp_path_factory, run1):
    pytest.importorskip("pinocchio")
    run3 = load_kuka_lwr4(3)
    path = tmp_path_factory.mktemp("bag") / "run3"
    write_joint_states(path, run3.time[:2000], run3.q[:2000], run3.dq[:2000], run3.tau[:2000], run3.joint_names,
                       order=SHUFFLED)
    return path, run3


def test_validate_log_gives_the_array_paths_report(kuka_bag):
    from dynval.logs import validate_log
    from dynval.robots import URDFModel, differentiate

    path, run3 = kuka_bag
    cmp = validate_log(path, [run3.urdf])
    # the same by hand from the arrays: stamps from 0, derivatives from the positions at the median rate
    t = run3.time[:2000] - run3.time[0]
    q, tau = run3.q[:2000], run3.tau[:2000]
    d = differentiate(q, 1.0 / np.median(np.diff(np.round(t * 1e9) / 1e9)))
    model = URDFModel(run3.urdf)
    by_hand = dynval.compare(tau, {"kuka_lwr4": {"prediction": model.predict(q, d.dq, d.ddq), "n_params": 0}},
                             time=t, bandwidth=d.input_bandwidth_hz, q=q, dq=d.dq, ddq=d.ddq,
                             joint_names=list(run3.joint_names))
    assert cmp.verdict.decision == by_hand.verdict.decision
    got = [(f.kind, f.severity, f.joints) for f in cmp.reports["kuka_lwr4"].findings]
    want = [(f.kind, f.severity, f.joints) for f in by_hand.reports["kuka_lwr4"].findings]
    assert got == want
    np.testing.assert_allclose(cmp.reports["kuka_lwr4"].per_joint.rmse, by_hand.reports["kuka_lwr4"].per_joint.rmse,
                               rtol=1e-9)
    assert "differentiated from the positions" in cmp.log_provenance["derivatives"]


def test_the_command_prints_the_verdict_and_refuses_a_broken_log(kuka_bag, tmp_path):
    path, run3 = kuka_bag
    out = subprocess.run([sys.executable, "-m", "dynval", "validate-log", str(path), "--model", f"cad={run3.urdf}",
                          "--no-progress", "--html", str(tmp_path / "r.html")], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "Verdict:" in out.stdout and (tmp_path / "r.html").is_file()
    broken = tmp_path / "broken.bag"
    broken.write_bytes(b"#ROSBAG V2.0\n" + b"\0" * 100)
    out = subprocess.run([sys.executable, "-m", "dynval", "validate-log", str(broken), "--model", str(run3.urdf)],
                         capture_output=True, text=True)
    assert out.returncode == 1 and str(broken) in out.stderr and "Traceback" not in out.stderr


def test_models_must_name_the_same_joints(kuka_bag, tmp_path):
    from dynval.logs import validate_log
    from dynval.robots import planar_arm_urdf
    from dynval.simulate import ArmParameters

    path, run3 = kuka_bag
    other = tmp_path / "arm.urdf"
    other.write_text(planar_arm_urdf(ArmParameters()), encoding="utf-8")
    with pytest.raises(dynval.InvalidParameter, match="models of the same joints"):
        validate_log(path, [run3.urdf, str(other)])
    assert Path(run3.urdf).is_file()
