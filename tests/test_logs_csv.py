"""dynval.io.read_csv_log and validate-log on a vendor's CSV log: columns by a declared mapping.

The CSV files are written here from the KUKA LWR4+ runs shipped with dynval, with the columns
renamed, reordered and in other units as a mapping declares them, and in the layout of UR's RTDE
recorder (``timestamp``, ``actual_q_0..5``, ...): real in format, known in content.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import dynval
from csv_logs import kuka_csv
from dynval.datasets import load_kuka_lwr4
from dynval.io import MAPPINGS, CSVMapping, FileInputError, load_mapping, read_csv_log

N = 2000


@pytest.fixture(scope="module")
def run3():
    return load_kuka_lwr4(3)


def _kuka_csv(path, run, rows=None, *, delimiter=";"):
    return kuka_csv(path, run, np.arange(N) if rows is None else rows, delimiter=delimiter)


def test_a_renamed_kuka_csv_reads_back_the_arrays_in_the_models_joint_order(tmp_path, run3):
    path, mapping = _kuka_csv(tmp_path / "run3.csv", run3)
    log = read_csv_log(path, mapping, joints=run3.joint_names)
    assert log.joint_names == tuple(run3.joint_names) and log.q.shape == (N, 7)
    np.testing.assert_array_equal(log.q, run3.q[:N])
    np.testing.assert_array_equal(log.dq, run3.dq[:N])
    np.testing.assert_array_equal(log.tau, run3.tau[:N])
    np.testing.assert_allclose(log.time, run3.time[:N] - run3.time[0], atol=1e-9)
    assert log.notes == () and log.n_messages == N and log.msgtype == "CSV (mapping kuka)"


def test_validate_log_on_the_csv_gives_the_array_paths_report(tmp_path, run3):
    pytest.importorskip("pinocchio")
    from dynval.logs import validate_log
    from dynval.robots import URDFModel, differentiate

    path, mapping = _kuka_csv(tmp_path / "run3.csv", run3)
    spec = tmp_path / "kuka.json"
    spec.write_text(json.dumps(mapping), encoding="utf-8")
    cmp = validate_log(path, [run3.urdf], mapping=spec)
    # by hand: the stamps as the contract reads them (ms to integer ns, from the first), the
    # derivatives from the positions at the median rate
    ns = np.round(run3.time[:N] * 1000.0 * 1e6)
    t = (ns - ns[0]) / 1e9
    q, tau = run3.q[:N], run3.tau[:N]
    d = differentiate(q, 1.0 / np.median(np.diff(t)))
    by_hand = dynval.compare(tau, {"kuka_lwr4": {"prediction": URDFModel(run3.urdf).predict(q, d.dq, d.ddq),
                                                 "n_params": 0}},
                             time=t, bandwidth=d.input_bandwidth_hz, q=q, dq=d.dq, ddq=d.ddq,
                             joint_names=list(run3.joint_names))
    assert cmp.verdict.decision == by_hand.verdict.decision
    got = [(f.kind, f.severity, f.joints, f.message) for f in cmp.reports["kuka_lwr4"].findings]
    want = [(f.kind, f.severity, f.joints, f.message) for f in by_hand.reports["kuka_lwr4"].findings]
    assert got == want
    np.testing.assert_array_equal(cmp.reports["kuka_lwr4"].per_joint.rmse, by_hand.reports["kuka_lwr4"].per_joint.rmse)
    assert cmp.log_provenance["mapping"] == "kuka"


def test_the_command_reads_a_csv_by_its_mapping_and_refuses_one_without(tmp_path, run3):
    pytest.importorskip("pinocchio")
    path, mapping = _kuka_csv(tmp_path / "run3.csv", run3)
    spec = tmp_path / "kuka.json"
    spec.write_text(json.dumps(mapping), encoding="utf-8")
    out = subprocess.run([sys.executable, "-m", "dynval", "validate-log", str(path), "--model", str(run3.urdf),
                          "--mapping", str(spec), "--no-progress"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "Verdict:" in out.stdout
    out = subprocess.run([sys.executable, "-m", "dynval", "validate-log", str(path), "--model", str(run3.urdf),
                          "--no-progress"], capture_output=True, text=True)
    assert out.returncode == 1 and "mapping must be a CSV mapping" in out.stderr and "Traceback" not in out.stderr
    out = subprocess.run([sys.executable, "-m", "dynval", "validate-log", str(path), "--model", str(run3.urdf),
                          "--mapping", str(spec), "--effort-unit", "A", "--no-progress"], capture_output=True,
                         text=True)
    assert out.returncode == 1 and "effort_unit must be the mapping's own ('N·m'" in out.stderr


def _rtde_csv(path, rows=500):
    """An RTDE recorder's layout: space-separated, the standard fields with their _0.._5 columns."""
    rng = np.random.default_rng(7)
    fields = ["timestamp"] + [f"{f}_{i}" for f in ("target_q", "actual_q", "actual_qd", "actual_current",
                                                    "target_moment", "actual_TCP_pose") for i in range(6)]
    fields.insert(20, "robot_mode")
    data = rng.normal(size=(rows, len(fields)))
    data[:, 0] = 1234.5 + np.arange(rows) * 0.002
    np.savetxt(path, data, fmt="%.17g", delimiter=" ", header=" ".join(fields), comments="")
    return {name: data[:, k] for k, name in enumerate(fields)}


def test_the_rtde_presets_read_currents_through_the_torque_constant_or_the_target_moment(tmp_path):
    cols = _rtde_csv(tmp_path / "rtde.csv")
    k = np.array([13.0, 13.0, 13.0, 9.3, 9.3, 9.3])
    log = read_csv_log(tmp_path / "rtde.csv", "ur_rtde", torque_constant=k)
    assert log.q.shape == (500, 6) and log.effort_unit == "A"
    np.testing.assert_array_equal(log.q, np.column_stack([cols[f"actual_q_{i}"] for i in range(6)]))
    np.testing.assert_array_equal(log.dq, np.column_stack([cols[f"actual_qd_{i}"] for i in range(6)]))
    np.testing.assert_array_equal(log.tau, np.column_stack([cols[f"actual_current_{i}"] for i in range(6)]) * k)
    np.testing.assert_allclose(log.time, np.arange(500) * 0.002, atol=1e-9)
    assert log.start_time == pytest.approx(1234.5) and log.joint_names[0] == "actual_q_0"
    moment = read_csv_log(tmp_path / "rtde.csv", "ur_rtde_moment", joints=[f"j{i}" for i in range(6)])
    np.testing.assert_array_equal(moment.tau, np.column_stack([cols[f"target_moment_{i}"] for i in range(6)]))
    assert moment.joint_names == tuple(f"j{i}" for i in range(6))
    with pytest.raises(dynval.InvalidParameter, match="torque_constant must be positive numbers in N·m/A: the "
                                                      "mapping ur_rtde reads motor currents"):
        read_csv_log(tmp_path / "rtde.csv", "ur_rtde")
    with pytest.raises(dynval.InvalidParameter, match="joints must be 6 joints, as the mapping ur_rtde declares"):
        read_csv_log(tmp_path / "rtde.csv", "ur_rtde", joints=[f"j{i}" for i in range(7)], torque_constant=1.0)


def test_a_missing_column_lists_what_the_file_has(tmp_path):
    _rtde_csv(tmp_path / "rtde.csv")
    text = (tmp_path / "rtde.csv").read_text().replace("actual_qd_3", "actual_qd_x", 1)
    (tmp_path / "rtde.csv").write_text(text)
    with pytest.raises(FileInputError) as err:
        read_csv_log(tmp_path / "rtde.csv", "ur_rtde_moment")
    msg = str(err.value)
    assert msg.startswith(f"{tmp_path / 'rtde.csv'}: no column 'actual_qd_3' (dq of joint 'actual_q_3', mapping "
                          "ur_rtde_moment); the header (line 1) names 'timestamp', 'target_q_0'")
    assert "'actual_qd_x'" in msg and msg.endswith("'actual_TCP_pose_5'")  # all 38 names


@pytest.mark.parametrize("cell, words", [
    ("abc", "'abc' is not a number"),
    ("nan", "nan; every mapped value must be finite"),
    ("-inf", "-inf; every mapped value must be finite"),
])
def test_a_bad_cell_names_the_file_line_and_column(tmp_path, cell, words):
    path = tmp_path / "log.csv"
    lines = ["t,a_0,b_0,a_1,b_1", "0,1,2,3,4", "", "# a comment", "0.1,1,2,3,4", "0.2,1,2,3,4"]
    lines[4] = f"0.1,1,2,{cell},4"
    path.write_text("\n".join(lines) + "\n")
    mapping = CSVMapping(time="t", q="a_{i}", effort="b_{i}", n_joints=2, name="m")
    with pytest.raises(FileInputError, match=rf"log.csv: line 5, column 4 \('a_1', q of joint 'a_1'\): {words}"):
        read_csv_log(path, mapping)


def test_a_row_cut_short_is_refused_and_an_unmapped_text_column_is_not_read(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text("t,a_0,note\n0,1,x\n0.1,2,y\n0.2,3\n")
    mapping = CSVMapping(time="t", q="a_{i}", n_joints=1)
    with pytest.raises(FileInputError, match=r"log.csv: line 4 has 2 values; the header \(line 1\) names 3 columns"):
        read_csv_log(path, mapping)
    path.write_text("t,a_0,note\n0,1,x\n0.1,2,y\n0.2,3,z\n")
    np.testing.assert_array_equal(read_csv_log(path, mapping).q.ravel(), [1.0, 2.0, 3.0])


def test_stamps_out_of_order_shared_and_missing_are_noted_as_the_bag_reader_does(tmp_path, run3):
    rows = [k for k in range(N) if k % 100 != 50]  # 20 rows dropped
    rows[10], rows[11] = rows[11], rows[10]  # one row late
    rows.insert(30, rows[29])  # one stamp twice
    path, mapping = _kuka_csv(tmp_path / "log.csv", run3, rows, delimiter=",")
    log = read_csv_log(path, mapping, joints=run3.joint_names)
    np.testing.assert_array_equal(log.q, run3.q[sorted(set(rows))])
    notes = " ".join(log.notes)
    assert "1 row(s) arrived out of stamp order" in notes
    assert "1 row(s) shared a stamp with another" in notes
    assert "20 gap(s)" in notes and "about 20 row(s) dropped" in notes


def test_mappings_from_json_and_their_errors(tmp_path):
    good = tmp_path / "m.json"
    good.write_text(json.dumps({"time": "ts", "q": "p{i}", "effort": "c{i}", "effort_unit": "A",
                                "torque_constant": [1, 2], "n_joints": 2}))
    m = load_mapping(good)
    assert m == CSVMapping(time="ts", q="p{i}", effort="c{i}", effort_unit="A", torque_constant=(1, 2), n_joints=2,
                           name="m.json")
    assert load_mapping("ur_rtde") is MAPPINGS["ur_rtde"]
    bad = tmp_path / "bad.json"
    bad.write_text('{"time": "ts",\n "q": "p{i}" "dq": 1}')
    with pytest.raises(FileInputError, match=r"bad.json: line 2, column 14: not valid JSON"):
        load_mapping(bad)
    bad.write_text(json.dumps({"time": "ts", "q": "p{i}", "velocity": "v{i}"}))
    with pytest.raises(FileInputError, match=r"bad.json: no mapping field 'velocity'; the fields are 'time', 'q'"):
        load_mapping(bad)
    bad.write_text(json.dumps({"time": "ts", "q": "p_0"}))
    with pytest.raises(dynval.InvalidParameter, match=r"bad.json: mapping.q must be a column pattern holding \{i\}"):
        load_mapping(bad)
    with pytest.raises(dynval.InvalidParameter, match=r"mapping must be one of 'ur_rtde', 'ur_rtde_moment' or a "
                                                      r"\.json file"):
        load_mapping("kuka")
    with pytest.raises(dynval.InvalidParameter, match=r"mapping\.time_unit must be one of"):
        CSVMapping(time="t", q="q{i}", time_unit="min")
    with pytest.raises(dynval.InvalidParameter, match=r"mapping\.torque_constant must be None when effort_unit"):
        CSVMapping(time="t", q="q{i}", torque_constant=2.0)


ARM6 = """<mujoco><option gravity="0 0 -9.81"/><worldbody>
<body name="base_link"><joint name="shoulder_pan_joint" axis="0 0 1" damping="0.8" armature="0.1" frictionloss="0.4"/>
<inertial pos="0 0 0.05" mass="3.7" diaginertia="0.010 0.010 0.007"/>
<body name="upper_arm" pos="0 0.13 0.09"><joint name="shoulder_lift_joint" axis="0 1 0" damping="0.8" armature="0.1"/>
<inertial pos="0.21 0 0" mass="8.4" diaginertia="0.02 0.13 0.13"/>
<body name="forearm" pos="0.42 -0.12 0"><joint name="elbow_joint" axis="0 1 0" damping="0.5" armature="0.05"/>
<inertial pos="0.2 0 0" mass="2.3" diaginertia="0.005 0.03 0.03"/>
<body name="wrist_1" pos="0.39 0 0"><joint name="wrist_1_joint" axis="0 1 0" damping="0.2"/>
<inertial pos="0 0.1 0" mass="1.2" diaginertia="0.002 0.002 0.002"/>
<body name="wrist_2" pos="0 0.1 0"><joint name="wrist_2_joint" axis="0 0 1" damping="0.2"/>
<inertial pos="0 0 0.1" mass="1.2" diaginertia="0.002 0.002 0.002"/>
<body name="wrist_3" pos="0 0 0.1"><joint name="wrist_3_joint" axis="0 1 0" damping="0.1"/>
<inertial pos="0 0.02 0" mass="0.25" diaginertia="0.0002 0.0002 0.0002"/>
</body></body></body></body></body></body></worldbody></mujoco>"""


def test_an_rtde_log_of_a_six_joint_arm_gives_the_array_paths_report(tmp_path):
    """An RTDE-layout CSV (currents in A) of a simulated 6-joint arm, its MJCF with a wrong damping
    as the model: validate-log --mapping ur_rtde --torque-constant gives the report of the array path."""
    pytest.importorskip("mujoco")
    from dynval.logs import validate_log
    from dynval.mjcf import MJCFModel
    from dynval.robots import differentiate

    model = MJCFModel(ARM6)
    rate, rows = 500.0, 6000
    t = np.arange(rows) / rate
    f = np.array([0.11, 0.17, 0.23, 0.29, 0.31, 0.37])
    a = np.array([1.0, 0.8, 0.9, 1.2, 1.1, 1.5])
    w = 2 * np.pi * f
    q, dq, ddq = a * np.sin(w * t[:, None]), a * w * np.cos(w * t[:, None]), -a * w**2 * np.sin(w * t[:, None])
    robot = MJCFModel(ARM6.replace('damping="0.8" armature="0.1" frictionloss', 'damping="1.6" armature="0.1" '
                                   'frictionloss'))  # the robot's shoulder pan damping is twice the model's
    tau = robot.predict(q, dq, ddq) + 0.05 * np.random.default_rng(3).standard_normal(q.shape)
    k = np.array([13.0, 13.0, 13.0, 9.3, 9.3, 9.3])
    names = ["timestamp"] + [f"{x}_{i}" for x in ("target_q", "actual_q", "actual_qd", "actual_current")
                             for i in range(6)]
    table = np.column_stack([1234.5 + t, q, q, dq, tau / k])
    path = tmp_path / "rtde.csv"
    np.savetxt(path, table, fmt="%.17g", delimiter=" ", header=" ".join(names), comments="")
    arm = tmp_path / "arm.xml"
    arm.write_text(ARM6, encoding="utf-8")
    cmp = validate_log(path, {"arm": arm}, mapping="ur_rtde", torque_constant=k)
    # by hand: the arrays the file holds, the stamps from 0 in integer ns, the model's own regressor
    ns = np.round((1234.5 + t) * 1e9)
    stamps = (ns - ns[0]) / 1e9
    log_q, log_tau = table[:, 7:13], table[:, 19:25] * k
    d = differentiate(log_q, 1.0 / np.median(np.diff(stamps)))
    by_hand = dynval.compare(
        log_tau, {"arm": {"prediction": model.predict(log_q, d.dq, d.ddq), "n_params": 0,
                          "model_columns": [c for c, v in enumerate(model.parameters()) if v != 0]}},
        regressor=model.regressor(log_q, d.dq, d.ddq), column_names=list(model.column_names), time=stamps,
        bandwidth=d.input_bandwidth_hz, q=log_q, dq=d.dq, ddq=d.ddq, joint_names=list(model.joint_names))
    assert cmp.verdict.decision == by_hand.verdict.decision
    assert [f.message for f in cmp.reports["arm"].findings] == [f.message for f in by_hand.reports["arm"].findings]
    np.testing.assert_array_equal(cmp.reports["arm"].per_joint.rmse, by_hand.reports["arm"].per_joint.rmse)
    out = subprocess.run([sys.executable, "-m", "dynval", "validate-log", str(path), "--mapping", "ur_rtde",
                          "--torque-constant", "13,13,13,9.3,9.3,9.3", "--model", f"arm={arm}", "--no-progress"],
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == by_hand.summary().strip()
    assert cmp.verdict.decision == "refine" and "damping on shoulder_pan_joint is too low" in out.stdout


@pytest.mark.parametrize("delimiter", ["\t", ";", ",", " "])
def test_every_delimiter_of_contract_7_and_a_declared_one(tmp_path, run3, delimiter):
    path, mapping = _kuka_csv(tmp_path / "run3.csv", run3, np.arange(50), delimiter=delimiter)
    sniffed = read_csv_log(path, mapping, joints=run3.joint_names)
    declared = read_csv_log(path, {**mapping, "delimiter": delimiter}, joints=run3.joint_names)
    for log in (sniffed, declared):
        np.testing.assert_array_equal(log.q, run3.q[:50])
        np.testing.assert_array_equal(log.tau, run3.tau[:50])
    if delimiter == "\t":  # a tab is one separator: an empty cell is refused, not skipped
        text = path.read_text().splitlines()
        cells = text[3].split("\t")
        cells[1] = ""
        text[3] = "\t".join(cells)
        path.write_text("\n".join(text) + "\n")
        with pytest.raises(FileInputError, match="line 4, column 2"):
            read_csv_log(path, mapping, joints=run3.joint_names)
