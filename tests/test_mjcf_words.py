"""The findings' own words name the MJCF attribute to retune (contract §11, conventions §5.2).

On the simulated KUKA case (the packaged MJCF's torque on runs 1 and 3 plus 0.3 N·m white noise),
a model with one wrong damping or armature is validated with its regressor; the deficiency on that
joint says which simulator parameter is too low or too high, by how much in its own unit, and the
value to retune it to: the value MJCFModel.retune refits (identify of the whole regressor).
"""

from __future__ import annotations

import re
import types

import numpy as np
import pytest

from dynval.mjcf import MJCFModel, have_mujoco
from dynval.report._finding_words import simulator_words
from mjcf_cases import simulated_kuka
from port_checks import require_toolchain


@pytest.fixture(autouse=True, scope="module")
def _mujoco():
    require_toolchain("mujoco", [] if have_mujoco() else ["mujoco"], "pip install mujoco (the dynval[mujoco] extra)")


@pytest.fixture(scope="module")
def simulated():
    return simulated_kuka()


def _variant(xml: str, joint: str, attribute: str, value: float) -> str:
    out, n = re.subn(rf'(<joint name="{joint}"[^>]*\b{attribute}=")[^"]*(")', rf"\g<1>{value!r}\g<2>", xml)
    assert n == 1
    return out


def _on_joint(report, joint):
    rep = report.reports["mjcf"] if hasattr(report, "reports") else report
    j = rep.provenance.joint_names.index(joint) if rep.provenance.joint_names else None
    return [f for f in rep.findings if f.severity == "deficiency" and j in f.joints]


@pytest.mark.parametrize(("joint", "attribute", "wrong", "right", "words"), [
    ("lwr_0_joint", "damping", 0.5, 1.3,
     "damping on lwr_0_joint is too low: the residual follows q̇ with +0.8 N·m·s/rad"),
    ("lwr_0_joint", "damping", 2.0, 1.3,
     "damping on lwr_0_joint is too high: the residual follows q̇ with -0.7 N·m·s/rad"),
    ("lwr_3_joint", "armature", 0.1, 0.3,
     "armature on lwr_3_joint is too low: the residual follows q̈ with +0.2 N·m·s²/rad"),
])
@pytest.mark.parametrize("with_estimation", [False, True])
def test_the_finding_names_the_simulator_parameter_and_its_refitted_value(simulated, joint, attribute, wrong, right,
                                                                         words, with_estimation):
    est, val, xml, (tau_est, tau_val) = simulated
    model = MJCFModel(_variant(xml, joint, attribute, wrong))
    report = model.compare(val.q, val.dq, val.ddq, tau_val, time=val.time,
                           estimation=(est.q, est.dq, est.ddq, tau_est) if with_estimation else None)
    first = model.retune(report, val.q, val.dq, val.ddq, tau_val)[0]
    assert (first.joint, first.attribute) == (joint, attribute)
    named = [f for f in _on_joint(report, joint) if words in f.message]
    assert named, [f.message for f in _on_joint(report, joint)]
    # the value the words give is retune's (to the four digits written)
    tail = f"({wrong:.4g} in the model, {first.refitted:.4g} refitted on this run)"
    assert all(tail in f.message for f in named)
    assert all(f.action == f"retune {attribute} on {joint} in the simulator model: {wrong:.4g} → "
               f"{first.refitted:.4g} {words.rsplit(' ', 1)[1]} (refitted on this run; MJCFModel.retune gives its "
               "standard deviation)" for f in named)


def test_the_right_model_and_the_other_joints_name_no_simulator_parameter(simulated):
    _est, val, xml, (_tau_est, tau_val) = simulated
    report = MJCFModel(xml).compare(val.q, val.dq, val.ddq, tau_val, time=val.time)
    assert not any(" is too " in f.message for f in report.reports["mjcf"].findings)
    wrong = MJCFModel(_variant(xml, "lwr_0_joint", "damping", 0.5))
    report = wrong.compare(val.q, val.dq, val.ddq, tau_val, time=val.time)
    others = [f for f in report.reports["mjcf"].findings if 0 not in f.joints]
    assert not any(" is too " in f.message for f in others)


def test_validate_log_with_mjcf_models_only_names_the_parameter(simulated, tmp_path):
    """A CSV log of the simulated run 3 (the wrong model's robot has damping 1.3 on lwr_0_joint) and
    the MJCF with 0.5 there: validate_log passes the MJCF's regressor, so the finding names it (its
    derivatives are Savitzky–Golay's of q, not the ones the torque was simulated with: +0.8x)."""
    from csv_logs import kuka_csv
    from dynval.logs import validate_log

    _est, val, xml, (_tau_est, tau_val) = simulated
    run = types.SimpleNamespace(time=val.time, q=val.q, dq=val.dq, tau=tau_val, joint_names=val.joint_names)
    path, mapping = kuka_csv(tmp_path / "run3.csv", run, np.arange(val.q.shape[0]))
    wrong = tmp_path / "wrong.xml"
    wrong.write_text(_variant(xml, "lwr_0_joint", "damping", 0.5), encoding="utf-8")
    cmp = validate_log(path, {"sim": wrong}, mapping=mapping)
    rep = cmp.reports["sim"]
    assert rep.provenance.column_names == list(MJCFModel(wrong).column_names)
    assert rep.provenance.model_columns == MJCFModel(wrong).model_columns()
    messages = [f.message for f in rep.findings if f.severity == "deficiency" and 0 in f.joints]
    assert any(re.search(r"damping on lwr_0_joint is too low: the residual follows q̇ with \+0\.8\d? N·m·s/rad", m)
               for m in messages), messages


def test_simulator_words_only_for_a_simulator_column_of_the_same_joint():
    assert simulator_words("j1", "damping_j1", 0.5, 1.3)[0].startswith("damping on j1 is too low")
    assert simulator_words("j1", "damping_j2", 0.5, 1.3) is None
    assert simulator_words("j1", "Fv_j1", 0.5, 1.3) is None
    assert simulator_words("j1", "frictionloss_j1", 0.5, float("nan")) is None
    assert "sign q̇ with -0.2 N·m" in simulator_words("j1", "frictionloss_j1", 0.5, 0.3)[0]
