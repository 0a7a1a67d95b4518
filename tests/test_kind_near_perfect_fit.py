"""The ``near_perfect_fit`` note (docs/conventions.md §5.11, contract §4): a joint whose residual
holds less than ``near_perfect_fit`` (1e-6) of the measured torque's variance.

The kind is declared in its own module (``report/kinds/near_perfect_fit.py``); these tests check
that validate, the stream, compare, the thresholds and the coverage declaration all find it there.
"""

from __future__ import annotations

import numpy as np
import pytest

import dynval
from dynval.coverage import TESTS
from dynval.report._findings import Evidence, Thresholds, compute_findings
from dynval.stream import ValidationAccumulator

RNG_SEED = 7


def _signals(noise: float, n: int = 600) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(RNG_SEED)
    t = np.arange(n) / 100.0
    tau = np.c_[30.0 * np.sin(2 * np.pi * 0.5 * t), 2.0 * np.cos(2 * np.pi * 0.3 * t)]
    return tau, tau + noise * rng.standard_normal(tau.shape)


def _notes(report) -> list:
    return [f for f in report.findings if f.kind == "near_perfect_fit"]


def test_a_prediction_equal_to_the_torque_up_to_rounding_is_noted_on_each_joint(backend):
    tau, pred = _signals(1e-5)
    report = dynval.validate(tau, pred, n_params=2, backend=backend)
    notes = _notes(report)
    assert [f.joints for f in notes] == [(0,), (1,)]
    assert all(f.severity == "note" and f.threshold == 1e-6 for f in notes)
    # the effect is 1 − R², computed here from the signals themselves (the report's R² rounds at 1e-16)
    e = tau - pred
    share = (e ** 2).sum(axis=0) / ((tau - tau.mean(axis=0)) ** 2).sum(axis=0)
    np.testing.assert_allclose([f.effect for f in notes], share, rtol=1e-6, atol=1e-15)
    np.testing.assert_allclose([f.statistic for f in notes], 1.0 - share, rtol=0, atol=1e-15)  # R²
    assert "computed from these torques" in notes[0].message and "joint 1" in notes[0].message
    assert not report.deficiencies  # a note: the verdict does not change


def test_a_measured_torque_with_sensor_noise_is_not_noted():
    # 1 % of joint 2's amplitude: 1 − R² ≈ 5e-5 there, far above 1e-6; joint 1 (30 N·m) ≈ 2e-7 is
    tau, pred = _signals(0.02)
    assert [f.joints for f in _notes(dynval.validate(tau, pred, n_params=2))] == [(0,)]
    tau, pred = _signals(0.2)
    assert _notes(dynval.validate(tau, pred, n_params=2)) == []


def test_the_threshold_is_set_by_name_and_stated_in_the_provenance():
    tau, pred = _signals(0.2)  # 1 − R² ≈ 1e-4 on joint 1, 1e-2 on joint 2
    report = dynval.validate(tau, pred, n_params=2, thresholds={"near_perfect_fit": 1e-3})
    assert [f.joints for f in _notes(report)] == [(0,)]
    assert _notes(report)[0].threshold == 1e-3
    assert report.provenance["thresholds"]["near_perfect_fit"] == 1e-3
    assert dynval.validate(tau, pred, n_params=2).provenance["thresholds"]["near_perfect_fit"] == 1e-6
    with pytest.raises(dynval.InputError, match=r"thresholds\['near_perfect_fit'\] must be a finite number >= 0"):
        dynval.validate(tau, pred, n_params=2, thresholds={"near_perfect_fit": -1.0})


def test_a_constant_joint_is_not_judged():
    tau, _ = _signals(0.0)
    tau[:, 1] = 3.0
    notes = _notes(dynval.validate(tau, tau.copy(), n_params=2))
    assert [f.joints for f in notes] == [(0,)]


def test_the_stream_and_compare_find_the_kind_in_its_module():
    tau, pred = _signals(1e-5)
    acc = ValidationAccumulator(n_params=2, max_lag=10)
    for lo in range(0, tau.shape[0], 150):
        acc.update(tau[lo:lo + 150], pred[lo:lo + 150])
    assert [f.joints for f in _notes(acc.result())] == [(0,), (1,)]
    cmp = dynval.compare(tau, {"a": (pred, 2), "b": (pred + 1e-3, 2)})
    assert [f.joints for f in _notes(cmp.reports["a"])] == [(0,), (1,)]
    assert not any("near perfect" in r or "near_perfect" in r for r in cmp.verdict.reasons)


def test_the_kind_is_declared_with_its_test_and_description():
    assert "near_perfect_fit" in dynval.FINDING_KINDS
    assert "near_perfect_fit" in next(t for t in TESTS if t.name == "worse_than_constant").kinds


def _evidence(r2: list[float], constant: list[bool] | None = None, pooled: float = 0.9) -> Evidence:
    m = len(r2)
    return Evidence(n_samples=1000, level=0.95, joint_names=[f"j{j}" for j in range(m)], r2=np.array(r2),
                    pooled_r2=pooled, constant_target=np.array(constant or [False] * m))


def test_the_threshold_itself_is_not_below_it():
    share = 1.0 - (1.0 - 3e-7)  # the share the rule computes from this R², exactly
    th = Thresholds(declared=(("near_perfect_fit", share),))
    assert [f.kind for f in compute_findings(_evidence([1.0 - 3e-7]), th)] == []
    th = Thresholds(declared=(("near_perfect_fit", share * (1 + 1e-9)),))
    assert [f.kind for f in compute_findings(_evidence([1.0 - 3e-7]), th)] == ["near_perfect_fit"]


def test_a_constant_joint_predicted_exactly_is_not_noted():
    # scikit-learn's force_finite rule reports R² = 1 for an exact prediction of a constant torque
    found = compute_findings(_evidence([1.0, 1.0], constant=[True, False], pooled=1.0))
    assert [(f.kind, f.joints) for f in found if f.kind == "near_perfect_fit"] == [("near_perfect_fit", (1,))]


def test_an_undefined_r2_is_not_noted():
    assert [f for f in compute_findings(_evidence([np.nan, -np.inf])) if f.kind == "near_perfect_fit"] == []


def test_the_note_follows_the_fit_s_notes_in_the_rules_order():
    # joint 0 near perfect, joint 1 hidden by the pooled R² (a pooling note, place 110): the kind's place is 120
    found = compute_findings(_evidence([1.0 - 1e-9, 0.5], pooled=0.9))
    assert [f.kind for f in found] == ["pooling", "near_perfect_fit"]
