"""Missing physics named without its column, delays, predictive failure and runs that cannot decide.

Each test says which mutation it catches. The arm is the demo's 2-DOF arm of ``dynval.simulate``
with its own trajectories and noise drawn here; the library test must keep its size on right models
(white and AR(1) noise) and name the joint and the term of a missing one from q alone.
"""

from __future__ import annotations

import math
import re
from dataclasses import replace

import numpy as np
import pytest
import scipy.stats

import dynval
from dynval import simulate as sim
from dynval.report import _motion
from dynval.report._findings import Evidence, Thresholds, compute_findings
from dynval.statistics import _physics

FS = 100.0
N = 2000


def _ar1(n, rho, rng, m):
    w = rng.normal(size=(n, m)) * math.sqrt(1.0 - rho * rho)
    x = np.empty((n, m))
    x[0] = rng.normal(size=m)
    for k in range(1, n):
        x[k] = rho * x[k - 1] + w[k]
    return x


def _run(rng, t):
    k = np.arange(1, 6)
    amplitudes = rng.uniform(0.2, 0.6, size=(2, 5)) / k
    phases = rng.uniform(0.0, 2.0 * math.pi, size=(2, 5))
    offsets = np.array([rng.uniform(-0.5, 0.5), rng.uniform(0.3, 1.2)])
    return sim.fourier_trajectory(t, offsets, amplitudes, phases, 0.1)


def _case(seed, *, arm=sim.DEFAULT_ARM, drop=(), noise="white", sigma=0.2, extra=None, delay=0):
    """Estimation and validation runs; the model lacks ``drop``; the regressor given is its own."""
    rng = np.random.default_rng(seed)
    pi = sim.base_parameters(arm)
    t = np.arange(N + delay) / FS
    runs = []
    for _ in range(2):
        q, dq, ddq = _run(rng, t)
        y = sim.regressor(q, dq, ddq)
        tau = y @ pi
        if delay:  # the torque sensor lags the encoders by ``delay`` samples
            tau = tau[:-delay]
            q, dq, ddq, y = q[delay:], dq[delay:], ddq[delay:], y[delay:]
        noise_x = rng.normal(size=tau.shape) if noise == "white" else _ar1(N, float(noise[2:]), rng, 2)
        tau = tau + sigma * noise_x
        if extra is not None:
            tau = tau + extra(q, dq)
        runs.append((q, y, tau))
    keep = [i for i, nm in enumerate(sim.PARAMETER_NAMES) if nm not in drop]
    (q_e, y_e, tau_e), (q_v, y_v, tau_v) = runs
    coef, *_ = np.linalg.lstsq(y_e[:, :, keep].reshape(-1, len(keep)), tau_e.reshape(-1), rcond=None)
    pred = y_v[:, :, keep] @ coef
    return dict(tau_meas=tau_v, tau_pred=pred, n_params=len(keep), regressor=y_v[:, :, keep],
                column_names=[sim.PARAMETER_NAMES[i] for i in keep], sample_rate=FS, q=q_v, max_lag=50,
                joint_names=["shoulder", "elbow"],
                estimation={"q": q_e, "regressor": y_e[:, :, keep], "tau": tau_e})


def _deficiencies(kw, **extra):
    r = dynval.validate(**{**kw, **extra})
    return r, r.deficiencies


@pytest.mark.parametrize("noise", ["white", "ar0.9"])
def test_right_model_keeps_its_size(noise):
    # Catches: the model's own columns left out of the test (their estimation error is then taken
    # for a missing gravity or inertia term), an AR model fitted after the library (too white), a
    # Wald test without the robust covariance. 30 replicates: ≤ 3 false alarms is the binomial
    # 99.9 % bound for a 2 % rate; the calibration (conventions §5.5) measures the size precisely.
    fired = 0
    for seed in range(30):
        r = dynval.validate(**_case(seed, noise=noise))
        fired += any(f.kind in ("missing_physics", "delay") for f in r.deficiencies)
    assert fired <= 3


def test_missing_coulomb_is_named_on_the_joint_that_has_it_from_q_alone():
    # Only the elbow has Coulomb friction; the model has no friction column at all and the regressor
    # given is the model's own. Catches: the library tested on the wrong joint's velocity, a term
    # named by the wrong group, a missing term left a note.
    arm = replace(sim.DEFAULT_ARM, fc1=0.0, fv1=0.0, fv2=0.0, fc2=0.6)
    kw = _case(1, arm=arm, drop=("Fv1", "Fc1", "Fv2", "Fc2"))
    r, found = _deficiencies(kw)
    physics = [f for f in found if f.kind == "missing_physics"]
    # the shoulder's share of the parameters the missing elbow friction bent is found too since the
    # widening takes Cov(π̂) under the alternative (conventions §5.2): a re-weighting there, never an
    # added term, and it follows the elbow's
    added = [f for f in physics if f.details["relation"] not in ("reweight", "unsupported")]
    assert [f.joints for f in added] == [(1,)]
    assert added[0].details["term"] == "coulomb"
    assert r.deciding[0].finding is added[0]
    assert added[0].effect >= Thresholds().missing_physics
    assert "Coulomb friction" in added[0].action and "elbow" in added[0].action


def test_missing_viscous_friction_is_named():
    arm = replace(sim.DEFAULT_ARM, fc1=0.0, fc2=0.0, fv1=2.0, fv2=0.0)
    # Only the shoulder has (viscous) friction. Its biased estimate leaves structure on the elbow
    # too (a real, smaller finding there); the largest names the shoulder's viscous friction, and
    # the realignment (a missing viscous term looks like a small delay) does not take its place.
    _, found = _deficiencies(_case(2, arm=arm, drop=("Fv1", "Fc1", "Fv2", "Fc2")))
    physics = sorted((f for f in found if f.kind == "missing_physics"), key=lambda f: -f.effect)
    assert physics[0].joints == (0,) and physics[0].details["term"] == "viscous"
    assert not any(f.kind == "delay" for f in found)


def test_without_q_there_is_no_physics_section():
    kw = _case(3)
    kw.pop("q")
    r = dynval.validate(**kw)
    assert r.physics is None
    assert not any(f.kind == "missing_physics" for f in r.findings)


def test_a_sensor_delay_is_found_in_milliseconds():
    # The measured torque lags by 3 samples (30 ms). Catches: the delay's sign, its units (samples
    # against seconds), a delay reported as a missing term.
    _, found = _deficiencies(_case(4, delay=3, sigma=0.05))
    delays = [f for f in found if f.kind == "delay"]
    assert len(delays) == 1
    assert delays[0].details["delay_s"] == pytest.approx(0.03, rel=0.2)
    assert delays[0].details["delay_samples"] == pytest.approx(3.0, rel=0.2)
    assert re.search(r"lags the prediction by (2[89]|3[01])\.?\d* ms", delays[0].message)
    assert not any(f.kind == "missing_physics" for f in found)


def test_an_offset_on_one_joint_is_found_on_that_joint():
    # A 2σ offset on the elbow. On the elbow's short range of angles a constant and cos q₂ are
    # nearly the same column, so the term named may be the offset or a gravity term; the joint
    # with the largest share must be the elbow (the offset also biases the shoulder's estimate).
    _, found = _deficiencies(_case(5, extra=lambda q, dq: np.array([0.0, 0.4])))
    physics = sorted((f for f in found if f.kind == "missing_physics"), key=lambda f: -f.effect)
    assert physics and physics[0].joints == (1,)
    assert physics[0].details["term"] in ("offset", "gravity")


def test_derivatives_are_differentiated_when_not_given_and_say_so():
    kw = _case(6)
    r = dynval.validate(**kw)
    assert r.physics["derivatives"].startswith("Savitzky–Golay")
    q = kw["q"]
    dq = np.gradient(q, 1.0 / FS, axis=0)
    r2 = dynval.validate(**kw, dq=dq, ddq=np.gradient(dq, 1.0 / FS, axis=0))
    assert r2.physics["derivatives"] == "given"


def test_dq_without_q_is_an_input_error():
    kw = _case(6)
    q = kw.pop("q")
    with pytest.raises(dynval.InvalidParameter, match="dq"):
        dynval.validate(**kw, dq=q)


def test_information_band_comes_from_the_prediction_not_the_sensor_noise():
    # A 1 kHz log: a 0.5 Hz motion and white sensor noise that fills the measured torque's band.
    # Taken from the measured torque the band was near Nyquist and no decimation happened.
    rng = np.random.default_rng(7)
    fs = 1000.0
    t = np.arange(20000) / fs
    pred = np.column_stack([np.sin(2 * np.pi * 0.5 * t), 0.05 * np.cos(2 * np.pi * 0.7 * t)])
    meas = pred + rng.normal(0.0, [0.01, 0.2], size=pred.shape)
    r = dynval.validate(meas, pred, n_params=2, sample_rate=fs, max_lag=50)
    assert r.whiteness["information_band_source"] == "prediction"
    assert r.whiteness["information_band"] < 5.0
    assert r.whiteness["decimation"] >= 50


# ----------------------------------------------------------------- the rules on evidence records


def _evidence(**kw):
    base = dict(n_samples=1000, level=0.95, joint_names=["a", "b"], r2=np.array([0.9, 0.9]), pooled_r2=0.9,
                constant_target=np.array([False, False]))
    base.update(kw)
    return Evidence(**base)


def _phys_ev(p, share, term="coulomb", term_share=None, shares=None):
    tests = []
    for j in range(len(p)):
        ts = share[j] if term_share is None else term_share[j]
        tests.append({"joint": j, "statistic": 10.0, "df": [5, 900], "pvalue": p[j], "share": share[j],
                      "term": term, "term_share": ts, "selected": [term],
                      "shares": shares[j] if shares else {term: ts}, "n_eff": 900.0,
                      "ar_order": 1})
    return {"tests": tests, "pvalue": np.array(p), "method": "m", "derivatives": "given"}


def test_physics_rule_needs_significance_at_the_report_level():
    # p = 0.02 on both joints: Holm over 2 tests gives 0.04, a finding at level 0.95, none at 0.99.
    # Catches: α fixed at 0.05 whatever the level; the physics p-values left out of the Holm family.
    ev = _evidence(physics=_phys_ev([0.02, 0.02], [0.3, 0.3]))
    assert {f.kind for f in compute_findings(ev)} == {"missing_physics"}
    ev.level = 0.99
    assert compute_findings(ev) == []


def test_physics_rule_effect_threshold_makes_a_note():
    # Catches: the threshold's direction, a small share called a deficiency.
    ev = _evidence(physics=_phys_ev([1e-9, 1e-9], [0.049, 0.051]))
    by_joint = {f.joints: f.severity for f in compute_findings(ev)}
    assert by_joint == {(0,): "note", (1,): "deficiency"}
    ev = _evidence(physics=_phys_ev([1e-9, 1e-9], [0.2, 0.2]), )
    found = compute_findings(ev, Thresholds(missing_physics=0.25))
    assert {f.severity for f in found} == {"note"}


def test_delay_rule_reports_one_finding_with_its_size():
    # Catches: the threshold on the realigned share, a delay taking the place of a larger missing
    # term, samples reported as milliseconds.
    phys = _phys_ev([0.5, 0.5, 0.5], [0.1, 0.1, 0.6])
    phys["delay"] = {"shift_samples": 2.0, "share": np.array([0.3, 0.04, 0.3]), "pvalue": np.full(3, 1e-9)}
    ev = _evidence(physics=phys, sample_rate=100.0, joint_names=["a", "b", "c"], r2=np.full(3, 0.9),
                   constant_target=np.zeros(3, bool))
    found = compute_findings(ev)
    delays = [f for f in found if f.kind == "delay"]
    assert len(delays) == 1 and delays[0].joints == (0,)  # b: below the threshold; c: the library explains more
    assert delays[0].details["delay_samples"] == pytest.approx(2.0)
    assert delays[0].details["delay_s"] == pytest.approx(0.02)
    assert "lags the prediction by 20 ms" in delays[0].message


def test_predictive_rule_needs_the_ratio_and_the_test():
    pred = {"ratio": np.array([2.5, 1.9]), "pvalue": np.array([1e-6, 1e-6]), "expected_mse": np.ones(2),
            "validation_mse": np.array([2.5, 1.9])}
    found = compute_findings(_evidence(predictive=pred))
    assert [(f.kind, f.joints) for f in found] == [("predictive_failure", (0,))]
    pred["pvalue"] = np.array([0.2, 1e-6])
    assert compute_findings(_evidence(predictive=pred)) == []


def test_an_unmoved_joint_and_a_run_that_cannot_decide_are_design_findings():
    ev = _evidence(joint_motion_ratio=np.array([0.02, 0.8]), detectable_share=np.array([0.1, 0.6]),
                   noise_n_eff=np.array([500.0, 8.0]))
    found = compute_findings(ev)
    kinds = {(f.kind, f.severity, f.joints) for f in found}
    assert kinds == {("excitation", "design", (0,)), ("low_information", "design", (1,))}
    assert compute_findings(ev, Thresholds(joint_motion=0.01, detectable_share=0.7)) == []
    # where a term at least as large as the run can detect (60 %) was found, the run did decide:
    # no low-information finding on that joint (the boundary itself is decided)
    for term_share in (0.6, 0.7):
        ev.physics = _phys_ev([1e-9, 1e-9], [0.0, 0.8], term_share=[0.0, term_share])
        assert not any(f.kind == "low_information" for f in compute_findings(ev)), term_share
    # where the term named removes less than that, the deficiency stands and the run still cannot
    # tell which term it is: both are said
    ev.physics = _phys_ev([1e-9, 1e-9], [0.0, 0.8], term_share=[0.0, 0.5])
    found = compute_findings(ev)
    low = [f for f in found if f.kind == "low_information"]
    assert [(f.joints, f.details["unresolved"]) for f in low] == [((1,), [1])]
    assert "found deficient, but Coulomb friction removes 50 %, less)" in low[0].message
    assert [(f.kind, f.severity) for f in found if f.joints == (1,) and f.kind == "missing_physics"] == [
        ("missing_physics", "deficiency")]
    # a joint deficient by another rule too (here a bias) is decided whatever the term's share
    ev.mean, ev.rmse = np.array([0.0, 0.9]), np.array([1.0, 1.0])
    ev.bias_statistic, ev.bias_pvalue, ev.n_eff = np.array([0.0, 30.0]), np.array([1.0, 1e-12]), np.array([900.0, 8.0])
    found = compute_findings(ev)
    assert [(f.kind, f.joints) for f in found if f.kind == "bias" and f.severity == "deficiency"] == [("bias", (1,))]
    assert not any(f.kind == "low_information" for f in found)


def test_detectable_share_formula():
    # s = c/(N_eff + c), c = (z_{α/(2T)} + z_0.9)²: checked against the t statistic it promises.
    n_eff = np.array([10.0, 100.0, 1000.0])
    s = _motion.detectable_share(n_eff, 2, 0.95)
    c = (scipy.stats.norm.isf(0.025 / 2) + scipy.stats.norm.ppf(0.9)) ** 2
    np.testing.assert_allclose(np.sqrt(n_eff * s / (1 - s)), math.sqrt(c))
    assert np.all(np.diff(s) < 0)


def test_unmoved_joint_in_validate():
    # The elbow moves 2 % of its estimation motion: a design finding names it.
    kw = _case(8)
    q = kw["q"].copy()
    q[:, 1] = q[:, 1].mean() + 0.02 * (q[:, 1] - q[:, 1].mean())
    r = dynval.validate(**{**kw, "q": q})
    ex = [f for f in r.findings if f.kind == "excitation" and f.joints == (1,)]
    assert ex and ex[0].severity == "design"
    assert r.design["joint_motion_ratio"][1] == pytest.approx(0.02 * np.std(kw["q"][:, 1])
                                                              / np.std(kw["estimation"]["q"][:, 1]), rel=1e-9)


def test_library_groups_and_shapes():
    rng = np.random.default_rng(9)
    q = rng.normal(size=(300, 3))
    lib = _physics.library(1, q, q, q, rng.normal(size=300), 100.0)
    assert set(lib) == set(_physics.GROUPS)
    assert lib["gravity"].shape[1] == 2 * 2 * 2  # chains i ≤ 1 ≤ k over 3 joints: 4 sums, sin and cos
    assert lib["inertia"].shape[1] == 3
    np.testing.assert_allclose(np.sqrt(np.mean(lib["coulomb"] ** 2, axis=0)), 1.0)


# ----------------------------------------------------------------- periodic trajectories


def _periodic_case(seed, drop=(), rho=0.0, sigma=0.2, periodic=True):
    """Runs of 40 s whose trajectory has a 10 s period (4 periods), or none (incommensurate)."""
    rng = np.random.default_rng(seed)
    pi = sim.base_parameters(sim.DEFAULT_ARM)
    n = 4000
    t = np.arange(n) / FS
    runs = []
    for _ in range(2):
        k = np.arange(1, 6) if periodic else np.array([1.0, 1.37, 2.71, 3.3, 4.49])
        amp = rng.uniform(0.2, 0.6, (2, 5)) / np.arange(1, 6)
        phases = rng.uniform(0, 2 * math.pi, (2, 5))
        off = np.array([rng.uniform(-0.5, 0.5), rng.uniform(0.3, 1.2)])
        w = 2 * np.pi * 0.1 * k
        arg = np.multiply.outer(t, w)[:, None, :] + phases[None]
        q = off + np.sum(amp * np.sin(arg), axis=2)
        dq = np.sum(amp * w * np.cos(arg), axis=2)
        ddq = -np.sum(amp * w**2 * np.sin(arg), axis=2)
        y = sim.regressor(q, dq, ddq)
        noise = _ar1(n, rho, rng, 2) if rho else rng.normal(size=(n, 2))
        runs.append((q, y, y @ pi + sigma * noise))
    keep = [i for i, nm in enumerate(sim.PARAMETER_NAMES) if nm not in drop]
    (q_e, y_e, tau_e), (q_v, y_v, tau_v) = runs
    coef, *_ = np.linalg.lstsq(y_e[:, :, keep].reshape(-1, len(keep)), tau_e.reshape(-1), rcond=None)
    return dict(tau_meas=tau_v, tau_pred=y_v[:, :, keep] @ coef, n_params=len(keep), regressor=y_v[:, :, keep],
                sample_rate=FS, q=q_v, max_lag=50,
                estimation={"q": q_e, "regressor": y_e[:, :, keep], "tau": tau_e})


@pytest.mark.parametrize("rho", [0.0, 0.99])
def test_a_periodic_run_measures_its_own_noise_and_keeps_the_size(rho):
    # Catches: the parameters' periodic estimation error taken for model error (AR(1) 0.99 makes it
    # large), the periodic p-values left out of Holm, the section missing on a periodic run.
    fired = 0
    for seed in range(10):
        r = dynval.validate(**_periodic_case(seed, rho=rho))
        assert r.periodic is not None and r.periodic["n_periods"] >= 3
        assert r.periodic["period"]["seconds"] == pytest.approx(10.0, rel=1e-3)
        fired += any(f.kind == "periodic_error" and f.severity == "deficiency" for f in r.findings)
    assert fired <= 1
    assert "noise measured from the period-to-period variation" in r.summary()


def test_a_periodic_run_finds_model_error_common_to_every_period():
    r = dynval.validate(**_periodic_case(11, drop=("Fc1", "Fc2"), rho=0.9))
    per = [f for f in r.deficiencies if f.kind == "periodic_error"]
    assert {f.joints for f in per} == {(0,), (1,)}
    assert all(f.effect >= Thresholds().periodic_error for f in per)


def test_no_period_no_periodic_section():
    r = dynval.validate(**_periodic_case(12, periodic=False))
    assert r.periodic is None


def test_a_weakly_excited_column_is_a_design_finding():
    # The validation run's Fv2 column (elbow velocity) scaled to 3 % of itself while the estimation
    # run keeps it: the validation cannot test it. Catches: the ratio's direction, columns that
    # neither run excites reported.
    kw = _case(13)
    reg = kw["regressor"].copy()
    c = kw["column_names"].index("Fv2")
    reg[:, :, c] *= 0.03
    r = dynval.validate(**{**kw, "regressor": reg})
    ex = [f for f in r.findings if f.kind == "excitation" and f.columns]
    assert [f.columns for f in ex] == [(c,)] and ex[0].severity == "design"
    est_rms = np.sqrt(np.mean(kw["estimation"]["regressor"][:, :, c] ** 2))
    before = np.sqrt(np.mean(kw["regressor"][:, :, c] ** 2)) / est_rms
    assert r.design["excitation"]["column_motion_ratio"][c] == pytest.approx(0.03 * before, rel=1e-9)


def test_demo_rigid_model_without_friction_columns_is_told_friction_from_q_alone():
    # Issue's acceptance case: the demo's friction scenario, its rigid candidate, no regressor and no
    # friction column: the report names friction (Coulomb or viscous: the arm has both) on both
    # joints.
    from dynval.simulate import simulate

    d = simulate("friction", seed=0)
    est, val = d.estimation, d.validation
    fit = dynval.identify(est.regressors["rigid"], est.tau_meas)
    r = dynval.validate(val.tau_meas, fit.predict(val.regressors["rigid"]), n_params=fit.rank, q=val.q,
                        sample_rate=d.sample_rate, joint_names=list(d.joint_names))
    named = {f.joints: f.details["term"] for f in r.deficiencies if f.kind == "missing_physics"}
    assert set(named) == {(0,), (1,)} and set(named.values()) <= {"coulomb", "viscous"}


def test_a_term_no_estimation_refit_helps_is_named_from_the_validation_run():
    """When no library group, refitted on the estimation run, removes a practical share of the
    validation mean square (another joint's noise moves the shared parameters more than the term
    does, or the model's columns absorbed it there), the term is named from the validation run
    with the model's columns refitted there: the wrist offset of the calibration's arm4 scenario,
    named a position harmonic before (replicate 14)."""
    pytest.importorskip("pinocchio")
    from dynval import scenarios as S
    from dynval.statistics import _model_terms

    y = np.random.default_rng(0).standard_normal((500, 3))
    tau = y @ [1.0, -2.0, 0.5] + 0.3
    groups = {"offset": np.ones((500, 1)), "noise": np.random.default_rng(1).standard_normal((500, 2))}
    gains = _model_terms.validation_refit_gains(tau, y, groups)
    assert gains["offset"] == pytest.approx(1.0) and abs(gains["noise"]) < 0.05

    sc = next(s for s in S.library() if s.key == "offset:white:arm4@100")
    report = S.validate_replicate(S.simulate(sc, 14), False)
    wrist = report.physics["tests"][3]
    assert wrist["term"] == "offset" and wrist["refit_run"] == "validation"
    assert max(wrist["refit_shares"], key=wrist["refit_shares"].get) in ("offset", "gravity")
    # Replicate 72: the best estimation refit helps, but by 0.1 % (the wrist's gravity columns took the
    # offset in the estimation run), far below a practical share: named from the validation run
    # too, and a deficiency (it had been a "negligible" viscous note beside 52 % of structure).
    report = S.validate_replicate(S.simulate(sc, 72), False)
    wrist = report.physics["tests"][3]
    assert wrist["term"] == "offset" and wrist["refit_run"] == "validation" and wrist["term_share"] > 0.05
    assert [f.joints for f in report.deficiencies if f.kind == "missing_physics"] == [(3,)]


def test_a_missing_column_below_what_the_run_detects_leaves_the_joint_unresolved():
    """The same rule for a column offered and refitted in (regressor_correlation with a share): a
    joint is unresolved when every deficiency names a term below the smallest detectable share."""
    from dynval.report._findings import Finding
    from dynval.report.kinds.low_information import unresolved as _unresolved

    ev = _evidence(detectable_share=np.array([0.5, 0.5]), noise_n_eff=np.array([10.0, 10.0]),
                   column_names=["Fv1", "Fv2"])
    unit = "share of the residual's mean square the term would remove"

    def missing(j, share):  # as the missing-term rule writes it: an added-variable test of a column
        return Finding(kind="regressor_correlation", severity="deficiency", joints=(j,), columns=(0,), effect=share,
                       effect_unit=unit, threshold=0.01, details={"lag": 0, "added_variable": True})

    assert _unresolved(ev, [missing(0, 0.3), missing(1, 0.5)], {0, 1}) == {0: [("Fv1", 0.3, None)]}
    # whiteness follows from the other findings: it does not resolve the joint
    white = Finding(kind="whiteness", severity="deficiency", joints=(0,), effect=0.9, effect_unit="max |ρ̂(ℓ)|")
    assert _unresolved(ev, [missing(0, 0.3), white], {0}) == {0: [("Fv1", 0.3, None)]}
    # a correlation of the residual with a column (|ρ|, no share), a bias, or a term at the detectable
    # share resolve it
    rho = Finding(kind="regressor_correlation", severity="deficiency", joints=(0,), columns=(1,), effect=0.4,
                  effect_unit="|ρ|", threshold=0.15, details={"lag": 3, "rho": 0.4})
    bias = Finding(kind="bias", severity="deficiency", joints=(0,), effect=0.4, effect_unit="|mean|/RMSE")
    for other in (rho, bias, missing(0, 0.5)):
        assert _unresolved(ev, [missing(0, 0.3), other], {0}) == {}, other.kind
    # a joint no rule found deficient is not asked about
    assert _unresolved(ev, [missing(0, 0.3)], set()) == {}


def test_the_forward_selections_tests_from_the_compressed_rows_equal_the_row_based_wald():
    # Any set of the groups' blocks, in any order, its last block tested: the Wald statistic from R
    # of the stacked blocks (coefficients) and the rows' residual (HC1 meat), with the model's
    # parameter error, equals _wald's on the rows (well conditioned blocks: the two forms agree).
    rng = np.random.default_rng(7)
    n = 300
    blocks = [np.linalg.qr(rng.normal(size=(n, k)))[0] for k in (1, 3, 2)]
    gw, cov_p = rng.normal(size=(n, 4)), np.diag([0.5, 0.1, 0.2, 0.3])
    yw = blocks[1] @ np.array([0.3, -0.2, 0.1]) + rng.normal(size=n) * (1 + np.abs(blocks[0][:, 0]) * 5)
    x = np.hstack(blocks)
    r = np.linalg.qr(np.column_stack([x, yw, gw]), mode="r")
    tests = _physics._Tests(r[:, :6], r[:, 6], x, yw, n, r[:, :6].T @ r[:, 7:], cov_p)
    edges = [0, 1, 4, 6]
    for order in ([0], [2, 0], [1, 2, 0], [0, 1, 2]):
        cols = np.concatenate([np.arange(edges[i], edges[i + 1]) for i in order])
        idx = np.arange(cols.size - (edges[order[-1] + 1] - edges[order[-1]]), cols.size)
        direct = _physics._wald(x[:, cols], yw, idx, gw, cov_p)
        w = tests.step(cols[:idx[0]], [cols[idx]])[0]
        assert w == pytest.approx(direct[0], rel=1e-10)
        assert w != pytest.approx(_physics._wald(x[:, cols], yw, idx)[0], rel=1e-3)
    # every candidate of a step at once: each as if alone
    base, cands = np.arange(1), [np.arange(1, 4), np.arange(4, 6)]
    both = tests.step(base, cands)
    assert both == [pytest.approx(tests.step(base, [c])[0], rel=1e-12) for c in cands]


# --------------------------------------------------------------------------- dithering, quantised q, standstill


def _white_run(n=3000, m=2, seed=0):
    rng = np.random.default_rng(seed)
    meas = rng.normal(size=(n, m))
    return meas, meas + 0.1 * rng.normal(size=(n, m))


@pytest.mark.parametrize("sample_rate", [1000.0, None])
@pytest.mark.parametrize("count", [1e-6, 1.0, 2 * math.pi / 2**17])
def test_an_encoder_dithering_at_standstill_is_a_note_not_an_error(sample_rate, count):
    # q alternating by one count every sample has a period of 2 samples, which has no harmonic below
    # the Nyquist frequency: validate raised TooFewSamples and the whole report was lost
    meas, pred = _white_run()
    q = 0.5 + count * (np.arange(3000) % 2)[:, None] * np.ones((1, 2))
    report = dynval.validate(meas, pred, n_params=2, q=q, sample_rate=sample_rate)
    per = report.periodic
    assert per["used"] is False and per["period"]["samples"] == pytest.approx(2.0)
    assert "an encoder dithering by a count at standstill" in per["note"]
    assert "Periodic trajectory: q repeats every 2 samples" in report.summary()
    assert not any(f.kind == "periodic_error" for f in report.findings)
    assert report.to_dict()["periodic"]["used"] is False


def test_a_dithering_encoder_beside_a_moving_joint_and_in_the_estimation_run():
    meas, pred = _white_run()
    k = np.arange(3000)
    dither = 1e-6 * (k % 2)[:, None] * np.ones((1, 2))
    rng = np.random.default_rng(5)
    y = rng.normal(size=(3000, 2, 3))
    est = {"q": dither, "regressor": rng.normal(size=(3000, 2, 3)), "tau": meas}
    report = dynval.validate(meas, pred, n_params=3, regressor=y, q=dither, estimation=est, sample_rate=500.0)
    assert report.periodic["used"] is False and report.design is not None
    q = np.c_[np.sin(2 * np.pi * k / 500.0), 1e-6 * (k % 2)]
    assert dynval.validate(meas, pred, n_params=2, q=q, sample_rate=500.0).physics is not None


@pytest.mark.parametrize("q0", [0.0, 0.3, -2.5])
def test_a_joint_at_rest_tests_no_velocity_term(q0):
    # the derivative filter's rounding noise (1e-14) was scaled to unit RMS and tested as motion:
    # "Coulomb friction" on a robot that never moved (Holm p = 3e-7)
    meas, pred = _white_run()
    q = np.full((3000, 2), q0)
    report = dynval.validate(meas, pred, n_params=2, q=q, sample_rate=1000.0)
    assert not any(f.kind == "missing_physics" for f in report.findings)
    assert "joints 1, 2 at rest (q constant)" in report.physics["derivatives"]
    d = _physics.derivatives(q, 1000.0)
    assert not d.dq.any() and not d.ddq.any()


def test_only_the_resting_joint_and_only_derived_derivatives_are_zeroed():
    k = np.arange(2000)
    q = np.c_[np.sin(k / 100.0), np.full(2000, 0.4)]
    given_dq = np.full((2000, 2), 0.25)
    d = _physics.derivatives(q, 100.0, dq=given_dq)
    assert np.array_equal(d.dq, given_dq) and not d.ddq[:, 1].any() and d.ddq[:, 0].any()
    assert "joint 2 at rest" in d.method
    assert _physics.derivatives(q, 100.0).dq[:, 0].any()


@pytest.mark.parametrize("kind", ["quantised", "long_standstill", "standstill_dither", "staircase"])
def test_quantised_q_and_long_standstills_give_a_report(kind):
    meas, pred = _white_run()
    k = np.arange(3000)
    wave = np.sin(2 * np.pi * k / 1500.0)[:, None] * np.ones((1, 2))
    q = {"quantised": np.round(wave * 10) / 10,
         "long_standstill": np.r_[np.zeros((2900, 2)), np.linspace(0, 1, 100)[:, None] * np.ones((1, 2))],
         "standstill_dither": np.r_[1e-6 * (k[:2900] % 2)[:, None] * np.ones((1, 2)),
                                    np.linspace(0, 1, 100)[:, None] * np.ones((1, 2))],
         "staircase": np.repeat(np.arange(750), 4)[:, None] * np.ones((1, 2)) * 1e-3}[kind]
    rng = np.random.default_rng(2)
    est = {"q": q[::-1].copy(), "regressor": rng.normal(size=(3000, 2, 3)), "tau": meas}
    report = dynval.validate(meas, pred, n_params=3, regressor=rng.normal(size=(3000, 2, 3)), q=q, estimation=est,
                             sample_rate=1000.0)
    assert report.physics is not None and report.design is not None
    report.summary()


def test_the_term_named_is_the_fewest_columns_near_the_best_by_share_and_by_what_is_left():
    """Kills: the left-over condition dropped (q̇|q̇|'s one column named for a wrist's missing Coulomb
    friction, which removes 99.7 % against 95.7 %), the share condition dropped (a group removing
    10 % named beside one removing 30 %), fewest columns dropped (the 24-column posture group named
    for a friction it mimics), or the ratio read the other way."""
    from dynval.statistics._physics import name_group

    widths = {"coulomb": 5, "velocity_squared": 1, "gravity": 24, "offset": 1}
    assert name_group({"coulomb": 0.997, "velocity_squared": 0.957}, widths) == "coulomb"
    assert name_group({"coulomb": 0.997, "velocity_squared": 0.9925}, widths) == "velocity_squared"
    assert name_group({"coulomb": 0.85, "gravity": 0.90}, widths) == "coulomb"
    assert name_group({"coulomb": 0.30, "offset": 0.10}, widths) == "coulomb"
    assert name_group({"coulomb": 0.30, "offset": 0.25}, widths) == "offset"
    assert name_group({"gravity": 0.9, "coulomb": 0.5}, widths) == "gravity"


def test_validate_differentiates_its_checked_q_without_checking_it_again(monkeypatch):
    # validate checks q once (contract §2.1); its physics library derives q̇, q̈ through the checked
    # inner filter, not the public differentiate, which would read q again for its own checks
    from dynval.statistics import _derivatives

    def read_again(*args, **kwargs):
        raise AssertionError("q checked a second time")

    rng = np.random.default_rng(3)
    t = np.arange(600) / 100.0
    q = np.column_stack([np.sin(t), np.cos(0.7 * t)])
    tau = q + 0.05 * rng.normal(size=q.shape)
    monkeypatch.setattr(_derivatives, "check_finite", read_again)
    monkeypatch.setattr(_derivatives, "to_float_array", read_again)
    report = dynval.validate(tau, q, n_params=2, q=q, sample_rate=100.0)
    assert report.physics["derivatives"].startswith("Savitzky")
    monkeypatch.undo()
    # the public function still checks what it is given
    with pytest.raises(dynval.NonFiniteInput, match="q has a non-finite value"):
        dynval.robots.differentiate(np.where(t > 3.0, np.nan, t), 100.0)


def _whole_shift_by_loop(meas, pred, big):
    """The delay test's whole shift as a loop over every shift finds it (the first on a tie)."""
    n = meas.shape[0]
    inner = slice(big + 1, n - big - 1)
    sse0 = np.sum((meas - pred)[inner] ** 2, axis=0)

    def sse(shift):
        lo = inner.start - int(shift)
        return np.sum((meas[inner] - pred[lo:lo + inner.stop - inner.start]) ** 2, axis=0)

    whole = np.arange(-big, big + 1, dtype=float)
    return float(whole[int(np.argmin([np.sum(sse(d) / sse0) for d in whole]))]), inner, sse, sse0


def test_the_delay_tests_whole_shift_is_the_loops_ties_included():
    # the costs of every whole shift come from one correlation; the near-best are scored again exactly,
    # so the shift chosen is the loop's, also where shifts tie (a constant or periodic prediction)
    from dynval.statistics import _physics

    rng = np.random.default_rng(3)
    cases = []
    for k in range(20):
        n, m = int(rng.integers(300, 2500)), int(rng.integers(1, 4))
        t = np.arange(n)[:, None]
        pred = np.sin(t * rng.uniform(0.01, 0.3, m)) + (rng.normal(size=(n, m)) if k % 3 == 0 else 0.0)
        meas = np.roll(pred, int(rng.integers(-5, 6)), axis=0) + rng.normal(0.0, 0.1, (n, m))
        cases.append((meas, pred, int(rng.integers(1, 12))))
    flat = np.ones((500, 2))
    cases.append((flat + rng.normal(size=(500, 2)), flat, 10))  # every shift ties
    square = np.tile([1.0, -1.0], 250)[:, None]
    cases.append((square + 0.1, square, 10))  # every other shift ties
    for period in (3, 7):  # every period-th shift ties exactly in the loop, not in a running sum's rounding
        wave = np.tile(rng.uniform(-2.0, 2.0, period), 3000 // period)[:, None] * np.array([[1.0, 0.37]])
        cases.append((wave + rng.normal(0.0, 0.5, wave.shape), wave, 20))
    for meas, pred, big in cases:
        want, inner, sse, sse0 = _whole_shift_by_loop(meas, pred, big)
        assert _physics._best_whole_shift(meas, pred, inner, big, sse, sse0) == want
