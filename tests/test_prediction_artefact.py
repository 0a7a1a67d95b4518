"""A residual line the prediction holds and the measured torque does not is the model's own
(conventions §5.2, ``prediction_artefact``); a line in the measurement is still a mode.

Each test names the mutation it kills."""

from __future__ import annotations

import numpy as np
import pytest

import dynval
from dynval.report._findings import Evidence, compute_findings
from dynval.scenarios import mode_signal

FS, N = 100.0, 4000


def _motion():
    t = np.arange(N) / FS
    q = np.c_[0.8 * np.sin(2 * np.pi * 0.1 * t) + 0.3 * np.sin(2 * np.pi * 0.23 * t), np.sin(2 * np.pi * 0.13 * t)]
    dq = np.gradient(q, t, axis=0)
    rigid = np.c_[5.0 * np.cos(q[:, 0]), 3.0 * np.cos(q[:, 1])]
    return t, q, dq, rigid


def test_friction_chatter_in_the_prediction_is_not_called_a_mode():
    """The model's sign(q̇) on a velocity estimate with a 6.9 Hz limit cycle: the prediction
    chatters where the joint moves slowly, the robot does not. Kills: the line called "an
    unmodelled mode: add compliance"; the first step taken from the friction term the library reads
    in the chatter ("add Coulomb friction" to a model that has it)."""
    rng = np.random.default_rng(1)
    t, q, dq, rigid = _motion()
    fc = np.array([1.0, 0.8])
    dither = 0.3 * np.std(dq, axis=0) * np.sign(np.sin(2 * np.pi * 6.9 * t))[:, None]
    meas = rigid + fc * np.sign(dq) + 0.05 * rng.normal(size=(N, 2))
    pred = rigid + fc * np.sign(dq + dither)
    r = dynval.validate(meas, pred, n_params=4, sample_rate=FS, q=q)
    assert not [f for f in r.findings if f.kind == "oscillation"]
    lines = [f for f in r.findings if f.kind == "prediction_artefact"]
    assert [f.joints for f in lines] == [(0,), (1,)] and {f.severity for f in lines} == {"deficiency"}
    f = lines[0]
    assert f.details["frequency"] == pytest.approx(6.9, rel=0.05)
    assert f.details["line_power_prediction"] > 10 * f.details["line_power_measured"]
    assert "is the prediction's own" in f.message and "compliance" not in f.message
    assert "smooth the friction model's sign" in f.action and "do not add compliance" in f.action
    assert r.first_step == f.action
    assert r.first_reason.startswith("first because it explains")


def test_a_mode_in_the_measured_torque_is_still_a_mode():
    """Kills: every residual line called the prediction's (the comparison of sides inverted)."""
    rng = np.random.default_rng(2)
    _, q, dq, rigid = _motion()
    tau = rigid + np.array([1.0, 0.8]) * np.sign(dq)
    meas = tau + 0.05 * rng.normal(size=(N, 2))
    meas[:, 1] += mode_signal(rng, N, 6.9, FS, 0.3)
    r = dynval.validate(meas, tau, n_params=4, sample_rate=FS, q=q)
    assert not [f for f in r.findings if f.kind == "prediction_artefact"]
    (mode,) = [f for f in r.findings if f.kind == "oscillation"]
    assert mode.joints == (1,) and mode.severity == "deficiency" and "compliance" in mode.action


def _ev(measured: float, predicted: float, residual: float | None = None) -> Evidence:
    """One joint, one significant peak at bin 20, the two sides' and the residual's power there (the
    residual's: the sides' difference unless given)."""
    f = np.arange(64) * 0.5
    pv = np.full((64, 1), np.nan)
    pv[20, 0] = 1e-12
    peak = np.zeros((64, 1), bool)
    peak[20, 0] = True
    share = np.full((64, 1), 0.3)
    pm, pp = np.full((64, 1), 1e-3), np.full((64, 1), 1e-3)
    pm[18:23, 0], pp[18:23, 0] = measured, predicted
    pr = np.full((64, 1), 1e-3)
    pr[18:23, 0] = abs(predicted - measured) if residual is None else residual
    return Evidence(n_samples=4000, level=0.95, joint_names=["wrist"], r2=np.array([0.9]), pooled_r2=0.9,
                    constant_target=np.zeros(1, bool), spectrum_frequency=f, spectrum_pvalue=pv,
                    spectrum_ratio=np.full((64, 1), 20.0), spectrum_share=share, spectrum_is_peak=peak,
                    frequency_unit="Hz", spectrum_power=pr, spectrum_power_measured=pm,
                    spectrum_power_prediction=pp)


def test_the_side_with_more_power_in_the_line_owns_it():
    """Kills: the rule reading one bin only, or a strict threshold that calls an equal split the model's."""
    (f,) = compute_findings(_ev(0.002, 0.72))
    assert f.kind == "prediction_artefact" and f.severity == "deficiency"
    assert f.details["line_power_prediction"] == pytest.approx(5 * 0.72 * 0.5)
    assert f.details["line_power_measured"] == pytest.approx(5 * 0.002 * 0.5)
    assert compute_findings(_ev(0.72, 0.002))[0].kind == "oscillation"
    assert compute_findings(_ev(0.5, 0.5))[0].kind == "oscillation"
    # a difference of sides below half the residual's line cannot say which side holds it: the
    # robot's own torque at that frequency moves both by its cross term with the line
    assert compute_findings(_ev(0.5, 0.6, residual=0.7))[0].kind == "oscillation"
    assert compute_findings(_ev(0.5, 0.86, residual=0.7))[0].kind == "prediction_artefact"
    assert compute_findings(_ev(0.5, 0.84, residual=0.7))[0].kind == "oscillation"
    # without the sides (a streamed report) the rule is the oscillation rule
    ev = _ev(0.002, 0.72)
    ev.spectrum_power_measured = ev.spectrum_power_prediction = None
    assert compute_findings(ev)[0].kind == "oscillation"


def test_the_chatter_scenario_puts_the_line_in_the_prediction_only():
    """dynval.scenarios' ``chatter`` rows: the measured torque is the robot's (no line), the
    prediction flips the elbow's Coulomb term at 6.9 Hz where the joint is slow, and ``named_right``
    asks for a ``prediction_artefact`` there. Kills: a scenario whose line is in the measurement (it
    would test the mode rule), or one on every joint."""
    from dataclasses import replace

    import dynval.scenarios as S

    s = replace(next(x for x in S.library() if x.key == "chatter:white:planar2@100"), duration=20.0)
    rep = S.simulate(s, 0)
    extra = rep.prediction_extra
    assert extra is not None and not np.any(extra[:, 0]) and np.any(extra[:, 1])
    # the flips are ±2 Fc, only where |q̇| is below the limit cycle's amplitude
    fc = S.ARMS["planar2"].links[1].coulomb
    assert set(np.unique(np.round(np.abs(extra[:, 1]) / fc, 9))) <= {0.0, 2.0}
    slow = np.abs(rep.validation.dq[:, 1]) < S.CHATTER_DITHER * np.sqrt(np.mean(rep.validation.dq[:, 1] ** 2))
    assert not np.any(extra[~slow, 1])
    # the measured torque is the physics without it; the effect is what the prediction adds, negated
    assert np.max(np.abs(rep.validation.tau_true - rep.validation.regressor @ rep.truth)) < 1e-9
    assert np.allclose(rep.effect, -extra)
    r = S.validate_replicate(rep, False)
    assert S.named_right(r, s.expected, False)
    assert not any(f.kind == "oscillation" and f.joints == (1,) for f in r.findings)


def test_a_line_in_the_measured_torque_over_a_large_torque_is_not_the_predictions():
    """A 7 Hz line in the measured torque of a joint whose own torque is broad and large (white, 20
    times the line's power in its five bins): the sides' powers differ by the cross term of the two,
    which here makes the prediction's side the larger by chance. Kills: the sides compared without
    the residual's line as the yardstick (the line called the model's own, "smooth the friction
    model's sign" to a model with no friction)."""
    rng = np.random.default_rng(0)
    n = 5000
    t = np.arange(n) / 100.0
    tau = rng.standard_normal((n, 2))
    pred = tau - 0.1 * rng.standard_normal((n, 2))
    tau[:, 1] += 0.05 * np.sin(2 * np.pi * 7.0 * t)
    r = dynval.validate(tau, pred, n_params=2, max_lag=20, sample_rate=100.0)
    assert [(f.kind, f.joints) for f in r.findings if "oscillation" in f.kind or "artefact" in f.kind] == [
        ("oscillation", (1,))]
