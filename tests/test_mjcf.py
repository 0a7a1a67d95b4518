"""dynval.mjcf (contract §11): MuJoCo's inverse dynamics of an MJCF arm, its terms, its regressor,
the two engines against each other, and the sim2real findings on the simulated KUKA case.

Skipped where MuJoCo is missing, unless DYNVAL_REQUIRE_TOOLCHAINS names ``mujoco`` (then a failure).
"""

from __future__ import annotations

import importlib.util
import math
import pathlib

import numpy as np
import pytest

import dynval
from dynval.datasets import load_kuka_lwr4
from dynval.mjcf import MJCFModel, have_mujoco
from mjcf_cases import simulated_kuka
from port_checks import require_toolchain


@pytest.fixture(autouse=True, scope="module")
def _mujoco():
    """Every test here needs MuJoCo: skipped without it, failed when DYNVAL_REQUIRE_TOOLCHAINS names it."""
    require_toolchain("mujoco", [] if have_mujoco() else ["mujoco"], "pip install mujoco (the dynval[mujoco] extra)")


ROOT = pathlib.Path(__file__).resolve().parents[1]
G = 9.81

# a pendulum: 2 kg, its centre of mass 0.5 m along +x from a hinge about +y, gravity along −z
PENDULUM = """<mujoco><option gravity="0 0 -9.81"/><worldbody><body name="arm">
<joint name="hinge" axis="0 1 0" armature="{a}" damping="{d}" frictionloss="{f}"/>
<inertial pos="0.5 0 0" mass="2" diaginertia="0.01 0.01 0.01"/></body></worldbody></mujoco>"""


def pendulum(a=0.0, d=0.0, f=0.0) -> MJCFModel:
    return MJCFModel(PENDULUM.format(a=a, d=d, f=f))


def pendulum_torque(q, dq, ddq, a=0.0, d=0.0, f=0.0):
    """By hand: τ = (I_c + m l² + armature)·q̈ + ∂V/∂q + damping·q̇ + frictionloss·sign q̇.

    A rotation by q about +y takes +x to (cos q, 0, −sin q): the mass's height is −l·sin q, its
    potential V = −m g l sin q and ∂V/∂q = −m g l cos q.
    """
    m, length, inertia = 2.0, 0.5, 0.01
    return (inertia + m * length ** 2 + a) * ddq - m * G * length * np.cos(q) + d * dq + f * np.sign(dq)


@pytest.fixture(scope="module")
def kuka():
    return MJCFModel(load_kuka_lwr4(1).mjcf)


def _motion(run, rows=slice(None, None, 10)):
    return run.q[rows], run.dq[rows], run.ddq[rows]


# --------------------------------------------------------------------------- the terms


def test_pendulum_terms_match_the_equation_written_by_hand():
    q = np.array([[0.0], [0.4], [-1.1], [2.0]])
    dq = np.array([[1.5], [-2.0], [3.0], [-1.0]])  # fast enough for frictionloss to saturate
    ddq = np.array([[0.5], [-1.0], [2.0], [0.0]])
    model = pendulum(a=0.2, d=0.7, f=0.3)
    expected = pendulum_torque(q, dq, ddq, a=0.2, d=0.7, f=0.3)
    np.testing.assert_allclose(model.predict(q, dq, ddq), expected, rtol=1e-12, atol=1e-12)
    terms = model.terms(q, dq, ddq)
    assert list(terms) == ["rigid_body", "armature", "damping", "frictionloss"]
    np.testing.assert_allclose(terms["rigid_body"], pendulum_torque(q, dq, ddq), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(terms["armature"], 0.2 * ddq, rtol=0, atol=0)
    np.testing.assert_allclose(terms["damping"], 0.7 * dq, rtol=0, atol=0)
    np.testing.assert_allclose(terms["frictionloss"], 0.3 * np.sign(dq), rtol=1e-12, atol=1e-12)


def test_mj_inverse_includes_frictionloss_as_a_bounded_soft_constraint():
    """Moving fast: exactly frictionloss·sign(q̇); at rest with a small acceleration: inside (0, f)."""
    q, ddq = np.array([[0.3], [0.3]]), np.array([[1.0], [0.01]])
    dq = np.array([[2.0], [0.0]])
    with_f, without = pendulum(f=0.4).predict(q, dq, ddq), pendulum().predict(q, dq, ddq)
    assert with_f[0, 0] - without[0, 0] == pytest.approx(0.4, abs=1e-12)
    assert 0 < with_f[1, 0] - without[1, 0] < 0.4
    assert pendulum(f=0.4).saturated(q, dq, ddq).tolist() == [[True], [False]]


def test_kuka_predict_is_the_sum_of_its_terms_and_the_regressor_times_its_parameters(kuka):
    q, dq, ddq = _motion(load_kuka_lwr4(3))
    pred = kuka.predict(q, dq, ddq)
    terms = kuka.terms(q, dq, ddq)
    scale = np.abs(pred).max()
    assert np.abs(sum(terms.values()) - pred).max() <= 1e-9 * scale
    # every term matters on this arm (a dropped term would not pass the line above)
    assert min(np.abs(t).max() for t in terms.values()) > 1e-3 * scale
    reg = kuka.regressor(q, dq, ddq)
    assert reg.shape == (q.shape[0], 7, 28)
    assert np.abs(reg @ kuka.parameters() - pred).max() <= 1e-9 * scale


def test_regressor_columns_and_parameters_are_the_files_attributes(kuka):
    names = kuka.column_names
    assert names[:2] == ("rigid_body_lwr_0_joint", "rigid_body_lwr_1_joint")
    assert names[7] == "armature_lwr_0_joint" and names[14] == "damping_lwr_0_joint"
    assert names[27] == "frictionloss_lwr_6_joint"
    p = kuka.parameters()
    # the packaged file's values, read here from its text
    assert p[14] == 1.3 and p[7 + 3] == 0.3 and p[21 + 4] == 1.0 and list(p[:7]) == [1.0] * 7
    q, dq, ddq = _motion(load_kuka_lwr4(1), slice(0, 50))
    reg = kuka.regressor(q, dq, ddq)
    np.testing.assert_array_equal(reg[:, 2, 7 + 2], ddq[:, 2])
    np.testing.assert_array_equal(reg[:, 2, 14 + 2], dq[:, 2])
    off_joint = np.ones((7, 28), dtype=bool)
    for j in range(7):
        off_joint[j, [j, 7 + j, 14 + j, 21 + j]] = False
    assert not reg[:, off_joint].any()


def test_identify_on_the_regressor_recovers_the_simulator_parameters(kuka):
    run = load_kuka_lwr4(1)
    q, dq, ddq = _motion(run, slice(None, None, 5))
    fit = dynval.identify(kuka.regressor(q, dq, ddq), kuka.predict(q, dq, ddq), column_names=kuka.column_names)
    assert fit.rank == 28
    np.testing.assert_allclose(fit.estimate, kuka.parameters(), rtol=0, atol=1e-8)


# --------------------------------------------------------------------------- the two engines


@pytest.mark.parametrize("k", [1, 2, 3])
def test_pinocchio_and_mujoco_agree_on_the_kuka_urdf(kuka, k):
    pytest.importorskip("pinocchio")
    from dynval.robots import URDFModel

    run = load_kuka_lwr4(k)
    pin = URDFModel(run.urdf).predict(run.q, run.dq, run.ddq, friction=False)
    mj = kuka.terms(run.q, run.dq, run.ddq)["rigid_body"]
    assert np.abs(pin).max() > 10  # torques of tens of N·m: the tolerance below is rounding
    assert np.abs(mj - pin).max() <= 1e-12


def test_packaged_mjcf_is_what_the_script_writes_from_the_urdf():
    path = ROOT / "examples" / "kuka_lwr4" / "mjcf_from_urdf.py"
    spec = importlib.util.spec_from_file_location("mjcf_from_urdf", path)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    run = load_kuka_lwr4(2)
    text = script.build(run.urdf, script.ARMATURE, script.DAMPING, script.FRICTIONLOSS)
    assert run.mjcf.read_text(encoding="utf-8") == text
    assert MJCFModel(run.mjcf).joint_names == run.joint_names


# --------------------------------------------------------------------------- refusals and errors


def _arm(extra_body: str = "", extra: str = "", joint2: str = 'type="hinge"') -> str:
    return (f"<mujoco><worldbody><body name='l1'><joint name='j1'/><geom size='0.1' mass='1'/>"
            f"<body name='l2' pos='0 0 0.5'><joint name='j2' {joint2}/><geom size='0.1' mass='1'/></body>"
            f"{extra_body}</body></worldbody>{extra}</mujoco>")


REFUSED = {
    "free": (_arm().replace("<joint name='j1'/>", "<freejoint name='j1'/>"), "a free joint 'j1'"),
    "ball": (_arm(joint2='type="ball"'), "a ball joint 'j2'"),
    "slide": (_arm(joint2='type="slide"'), "a slide joint 'j2'"),
    "branch": (_arm(extra_body="<body name='side'><joint name='j3'/><geom size='0.1' mass='1'/></body>"),
               "joints on several branches ('l2' and 'side'"),
    "trees": (_arm().replace("</worldbody>", "<body name='t2'><joint name='j9'/><geom size='.1' mass='1'/></body>"
                                            "</worldbody>"), "joints on several branches ('l2' and 't2'"),
    "equality": (_arm(extra="<equality><joint joint1='j1' joint2='j2'/></equality>"), "1 equality constraints"),
    "tendon": (_arm(extra="<tendon><fixed name='t'><joint joint='j1' coef='1'/></fixed></tendon>"), "1 tendons"),
    "stiffness": (_arm(joint2='stiffness="3"'), "non-zero joint stiffness (springs)"),
    "gravcomp": (_arm().replace("<body name='l1'>", "<body name='l1' gravcomp='1'>"),
                 "non-zero gravity compensation (gravcomp)"),
    "fluid": (_arm().replace("<worldbody>", "<option density='1.2'/><worldbody>"), "fluid forces"),
}


@pytest.mark.parametrize("case", sorted(REFUSED))
def test_refused_features_are_named_with_the_file(tmp_path, case):
    xml, what = REFUSED[case]
    path = tmp_path / f"{case}.xml"
    path.write_text(xml)
    with pytest.raises(dynval.InvalidParameter) as info:
        MJCFModel(path)
    message = str(info.value)
    assert message.startswith(f"{path}: dynval.mjcf takes a fixed-base serial arm of hinge joints; this model has ")
    assert what in message


def test_a_serial_arm_with_ignored_features_loads(tmp_path):
    """Contacts, limits, actuators, sensors and a jointless side body are not terms: the model loads and
    its prediction is the same as without them."""
    extra = ("<actuator><motor joint='j1'/></actuator><sensor><jointpos joint='j2'/></sensor>")
    plain = MJCFModel(_arm())
    dressed = MJCFModel(_arm(extra_body="<body name='side' pos='0.2 0 0'><geom size='0.05' mass='0.5'/></body>",
                             extra=extra).replace("<joint name='j1'/>", "<joint name='j1' range='-0.1 0.1'/>"))
    q, dq, ddq = np.array([[1.0, 0.5]]), np.array([[0.3, -0.2]]), np.array([[0.1, 0.2]])
    assert dressed.joint_names == ("j1", "j2")
    # q[0] = 1.0 is outside j1's range: the limit would push back if it were not ignored; only the side
    # body's mass changes the torque, and only on j1
    diff = dressed.predict(q, dq, ddq) - plain.predict(q, dq, ddq)
    assert diff[0, 1] == pytest.approx(0.0, abs=1e-12) and abs(diff[0, 0]) > 1e-3
    side = MJCFModel(_arm(extra_body="<body name='side' pos='0.2 0 0'><geom size='0.05' mass='0.5'/></body>"))
    np.testing.assert_allclose(dressed.predict(q, dq, ddq), side.predict(q, dq, ddq), rtol=0, atol=1e-12)


def test_unreadable_files_are_named(tmp_path):
    missing = tmp_path / "nope.xml"
    with pytest.raises(dynval.InvalidParameter, match=rf"^{missing}: no such MJCF file$"):
        MJCFModel(missing)
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco><worldbody><body></worldbody></mujoco>")
    with pytest.raises(dynval.InvalidParameter, match=rf"^{broken}: MuJoCo cannot load it: "):
        MJCFModel(broken)
    with pytest.raises(dynval.InvalidParameter, match=r"^path_or_xml must be a path to an MJCF file or its XML text"):
        MJCFModel(3)


def test_motion_is_checked_by_shape_and_finiteness(kuka):
    with pytest.raises(dynval.InvalidParameter, match=r"^q must be an array of shape \(N, 7\), got 'shape \(4, 6\)'"):
        kuka.predict(np.zeros((4, 6)), np.zeros((4, 7)), np.zeros((4, 7)))
    with pytest.raises(dynval.ShapeMismatch, match=r"q, dq and ddq must have the same shape"):
        kuka.regressor(np.zeros((4, 7)), np.zeros((5, 7)), np.zeros((4, 7)))
    dq = np.zeros((4, 7))
    dq[2, 3] = np.nan
    with pytest.raises(dynval.NonFiniteInput, match=r"^dq "):
        kuka.terms(np.zeros((4, 7)), dq, np.zeros((4, 7)))


# --------------------------------------------------------------------------- sim2real


def _variant(xml: str, joint: str, attribute: str, value: float) -> str:
    import re

    out, n = re.subn(rf'(<joint name="{joint}"[^>]*\b{attribute}=")[^"]*(")', rf"\g<1>{value!r}\g<2>", xml)
    assert n == 1
    return out


@pytest.fixture(scope="module")
def simulated():
    return simulated_kuka()


@pytest.mark.parametrize(("joint", "attribute", "wrong", "right"),
                         [("lwr_0_joint", "damping", 0.5, 1.3), ("lwr_3_joint", "armature", 0.1, 0.3)])
def test_a_wrong_simulator_parameter_is_refined_and_named(simulated, joint, attribute, wrong, right):
    est, val, xml, (tau_est, tau_val) = simulated
    model = MJCFModel(_variant(xml, joint, attribute, wrong))
    report = model.compare(val.q, val.dq, val.ddq, tau_val, estimation=(est.q, est.dq, est.ddq, tau_est),
                           time=val.time)
    assert report.verdict.decision == "refine"
    column = f"{attribute}_{joint}"
    named = [report.reports["mjcf"].provenance.column_names[c] for f in report.reports["mjcf"].findings
             if f.severity == "deficiency" for c in f.columns]
    assert column in named
    first = model.retune(report, val.q, val.dq, val.ddq, tau_val)[0]
    assert (first.joint, first.attribute, first.current) == (joint, attribute, wrong)
    assert abs(first.refitted - right) < 4 * first.std + 0.05 * right and first.z > 5


def test_the_right_simulator_model_is_accepted(simulated):
    est, val, xml, (tau_est, tau_val) = simulated
    model = MJCFModel(xml)
    report = model.compare(val.q, val.dq, val.ddq, tau_val, estimation=(est.q, est.dq, est.ddq, tau_est),
                           time=val.time)
    assert report.verdict.decision == "accept"
    assert model.retune(report, val.q, val.dq, val.ddq, tau_val) == []


def test_retune_reads_columns_by_index_without_names_and_skips_the_rigid_body_columns():
    """A report validated without column names: its finding's columns are the regressor's indices."""
    model = pendulum(a=0.2, d=0.7, f=0.3)
    t = np.linspace(0, 20, 2000)
    q, dq, ddq = np.sin(t)[:, None], np.cos(t)[:, None], -np.sin(t)[:, None]
    tau = pendulum_torque(q, dq, ddq, a=0.2, d=1.5, f=0.3)  # the robot's damping is 1.5, not 0.7
    report = dynval.validate(tau, model.predict(q, dq, ddq), n_params=4, regressor=model.regressor(q, dq, ddq))
    assert report.provenance.column_names is None
    assert any(2 in f.columns for f in report.findings if f.severity == "deficiency")
    out = model.retune(report, q, dq, ddq, tau)
    assert (out[0].joint, out[0].attribute) == ("hinge", "damping")
    assert out[0].refitted == pytest.approx(1.5, abs=0.05) and out[0].current == 0.7
    assert all(r.attribute != "rigid" for r in out) and math.isfinite(out[0].z)


def test_retune_puts_the_parameter_that_moved_first_whatever_the_column_order():
    """A wrong frictionloss is named together with damping (an earlier column); the refit moves only
    frictionloss, which comes first."""
    model = pendulum(a=0.2, d=0.7, f=0.3)
    t = np.linspace(0, 20, 2000)
    q, dq, ddq = np.sin(t)[:, None], np.cos(t)[:, None], -np.sin(t)[:, None]
    noise = 0.01 * np.random.default_rng(0).standard_normal(q.shape)
    tau = pendulum_torque(q, dq, ddq, a=0.2, d=0.7, f=1.0) + noise
    report = dynval.validate(tau, model.predict(q, dq, ddq), n_params=4, regressor=model.regressor(q, dq, ddq))
    out = model.retune(report, q, dq, ddq, tau)
    assert [r.attribute for r in out] == ["frictionloss", "damping"]
    assert out[0].refitted == pytest.approx(1.0, abs=0.05) and out[0].z > out[1].z


def test_retune_gives_nan_for_a_column_the_run_cannot_identify_and_puts_it_last():
    """The second joint never moves: its columns are zero (or its rigid-body torque alone); a finding
    that names its damping gets nan, after the identifiable parameter."""
    model = MJCFModel(_arm().replace("<joint name='j1'/>", "<joint name='j1' axis='0 1 0' damping='0.2'/>")
                      .replace("<joint name='j2' type=\"hinge\"/>", "<joint name='j2' axis='0 1 0' damping='0.1'/>"))
    t = np.linspace(0, 20, 1000)
    zero = np.zeros_like(t)
    q, dq, ddq = (np.column_stack([x, zero]) for x in (np.sin(t), np.cos(t), -np.sin(t)))
    tau = model.predict(q, dq, ddq) + np.column_stack([0.5 * dq[:, 0], zero])  # the first joint's damping is 0.7
    names = list(model.column_names)
    finding = dynval.Finding(kind="regressor_correlation", severity="deficiency", joints=(0, 1),
                             columns=(names.index("damping_j2"), names.index("damping_j1")), message="")
    report = type("R", (), {"findings": [finding], "provenance": type("P", (), {"column_names": names})()})()
    out = model.retune(report, q, dq, ddq, tau)
    assert [(r.joint, r.attribute) for r in out] == [("j1", "damping"), ("j2", "damping")]
    assert out[0].refitted == pytest.approx(0.7, abs=1e-9) and math.isnan(out[1].refitted) and math.isnan(out[1].std)


def test_compare_tests_a_zero_parameter_as_a_term_the_model_lacks():
    """The model has no damping (0) where the robot has 0.7: its column is outside model_columns, a
    deficiency names it first, and retune refits it."""
    model = pendulum(a=0.2, d=0.0, f=0.3)
    t = np.linspace(0, 20, 2000)
    q, dq, ddq = np.sin(t)[:, None], np.cos(t)[:, None], -np.sin(t)[:, None]
    noise = 0.01 * np.random.default_rng(1).standard_normal(q.shape)
    tau = pendulum(a=0.2, d=0.7, f=0.3).predict(q, dq, ddq) + noise
    report = model.compare(q, dq, ddq, tau, time=t)
    assert report.reports["mjcf"].provenance.model_columns == [0, 1, 3]
    assert report.verdict.decision == "refine"
    named = [f.columns[0] for f in report.reports["mjcf"].findings if f.severity == "deficiency" and f.columns]
    assert named == [2]
    first = model.retune(report, q, dq, ddq, tau)[0]
    assert (first.attribute, first.current) == ("damping", 0.0) and first.refitted == pytest.approx(0.7, abs=0.01)


def test_validate_log_reads_an_mjcf_model_beside_a_urdf(tmp_path):
    """dynval.logs takes the packaged MJCF as a model file: its candidate is MJCFModel.predict on the
    log's motion (a ROS 2 bag written from run 3's first 1000 rows)."""
    pytest.importorskip("rosbags")
    pytest.importorskip("pinocchio")
    from dynval.logs import log_motion, validate_log
    from ros_logs import write_joint_states

    run = load_kuka_lwr4(3)
    rows = slice(0, 1000)
    bag = write_joint_states(tmp_path / "bag", run.time[rows], run.q[rows], run.dq[rows], run.tau[rows],
                             run.joint_names)
    report = validate_log(bag, {"sim": run.mjcf, "cad": run.urdf})
    motion = log_motion(bag, run.joint_names)
    expected = dynval.rmse(motion.tau, MJCFModel(run.mjcf).predict(motion.q, motion.dq, motion.ddq))
    assert report.table["pooled"]["sim"]["rmse"] == pytest.approx(expected, rel=1e-12)
