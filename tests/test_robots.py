"""dynval.robots: the URDF regressor (pinocchio) on the project's own two-link URDF, cross-checked
against the closed-form regressor of the demo arm; and the zero-phase differentiation helper."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import dynval
from dynval.identify import identify
from dynval.robots import differentiate, have_pinocchio, planar_arm_urdf
from dynval.simulate import DEFAULT_ARM, ArmParameters, base_parameters, regressor, simulate

needs_pin = pytest.mark.skipif(not have_pinocchio(), reason="pinocchio (PyPI pin) is not installed")


@pytest.fixture(scope="module")
def arm_model():
    from dynval.robots import URDFModel

    return URDFModel(planar_arm_urdf())


@pytest.fixture(scope="module")
def motion():
    rng = np.random.default_rng(0)
    return tuple(rng.normal(0.0, s, size=(300, 2)) for s in (1.5, 2.0, 5.0))


@needs_pin
def test_urdf_file_and_text_give_the_same_model(tmp_path, arm_model, motion):
    from dynval.robots import URDFModel

    path = tmp_path / "arm.urdf"
    path.write_text(planar_arm_urdf())
    from_file = URDFModel(path)
    assert from_file.joint_names == ("shoulder", "elbow") == arm_model.joint_names
    assert from_file.link_names == ("link1", "link2")
    np.testing.assert_array_equal(from_file.regressor(*motion), arm_model.regressor(*motion))


@needs_pin
def test_column_names(arm_model):
    names = arm_model.column_names()
    assert len(names) == 26
    assert names[:3] == ("link1:m", "link1:mx", "link1:my") and names[19] == "link2:Izz"
    assert names[20:] == ("Fv_shoulder", "Fv_elbow", "Fc_shoulder", "Fc_elbow", "off_shoulder", "off_elbow")
    assert len(arm_model.column_names(friction=False, offset=False)) == 20


@needs_pin
def test_urdf_prediction_equals_closed_form_torques(arm_model, motion):
    q, dq, ddq = motion
    expected = regressor(q, dq, ddq) @ base_parameters(DEFAULT_ARM)   # includes friction
    np.testing.assert_allclose(arm_model.predict(q, dq, ddq), expected, rtol=1e-12, atol=1e-11)
    np.testing.assert_allclose(arm_model.regressor(q, dq, ddq) @ arm_model.parameters(), expected,
                               rtol=1e-12, atol=1e-11)
    rigid = regressor(q, dq, ddq)[:, :, :6] @ base_parameters(DEFAULT_ARM)[:6]
    np.testing.assert_allclose(arm_model.predict(q, dq, ddq, friction=False), rigid, rtol=1e-12, atol=1e-11)


@needs_pin
def test_urdf_parameters_are_the_physical_ones(arm_model):
    a = DEFAULT_ARM
    p1, p2 = arm_model.inertial_parameters().reshape(2, 10)
    np.testing.assert_allclose(p1[:4], [a.m1, a.m1 * a.cx1, a.m1 * a.cy1, 0.0], atol=1e-14)
    # Izz about the joint axis: I1 + m1 (cx1² + cy1²)
    assert p1[9] == pytest.approx(a.I1 + a.m1 * (a.cx1**2 + a.cy1**2), rel=1e-14)
    assert p2[9] == pytest.approx(a.I2 + a.m2 * (a.cx2**2 + a.cy2**2), rel=1e-14)


@needs_pin
def test_urdf_regressor_spans_the_same_space_as_the_closed_form(arm_model, motion):
    q, dq, ddq = motion
    y_pin = arm_model.regressor(q, dq, ddq, friction=False, offset=False).reshape(-1, 20)
    y_cf = regressor(q, dq, ddq)[:, :, :6].reshape(-1, 6)
    tol = 1e-9 * np.linalg.norm(y_pin)
    assert np.linalg.matrix_rank(y_pin, tol) == 6
    assert np.linalg.matrix_rank(np.hstack([y_pin, y_cf]), tol) == 6
    # Friction columns are the closed form's, exactly.
    y = arm_model.regressor(q, dq, ddq)
    cf = regressor(q, dq, ddq)
    np.testing.assert_array_equal(y[:, 0, 20], cf[:, 0, 6])
    np.testing.assert_array_equal(y[:, 1, 21], cf[:, 1, 8])
    np.testing.assert_array_equal(y[:, 0, 22], cf[:, 0, 7])
    np.testing.assert_array_equal(y[:, 1, 23], cf[:, 1, 9])
    assert np.all(y[:, 1, [20, 22, 24]] == 0) and np.all(y[:, 0, [21, 23, 25]] == 0)
    np.testing.assert_array_equal(y[:, 0, 24], 1.0)


@needs_pin
def test_base_reduction_matches_the_closed_form_identification(arm_model):
    # The same simulated data identified through the URDF regressor and through the closed
    # form give the same base-set size (10 + 2 offsets) and the same predictions.
    d = simulate("offset", n_samples=600, seed=2)
    est, val = d.estimation, d.validation
    res_pin = arm_model.identify(est.q, est.dq, est.ddq, est.tau_meas)
    assert res_pin.rank == 12
    res_cf = identify(est.full_regressor, est.tau_meas)
    assert res_cf.rank == 12
    pred_pin = res_pin.predict(arm_model.regressor(val.q, val.dq, val.ddq))
    np.testing.assert_allclose(pred_pin, res_cf.predict(val.full_regressor), rtol=1e-8, atol=1e-8)
    assert res_pin.sigma2 == pytest.approx(res_cf.sigma2, rel=1e-8)
    # The identified offsets carry their own names.
    names = dict(zip(res_pin.base_names, res_pin.estimate))
    assert names["off_shoulder"] == pytest.approx(0.8, abs=0.1)
    assert names["off_elbow"] == pytest.approx(-0.6, abs=0.1)


@needs_pin
def test_other_arm_and_gravity(motion):
    from dynval.robots import URDFModel

    arm = ArmParameters(l1=0.8, m1=3.0, cx1=0.3, cy1=-0.02, I1=0.05, m2=1.5, cx2=0.25, cy2=0.03,
                        I2=0.02, fv1=0.1, fc1=0.4, fv2=0.2, fc2=0.3)
    model = URDFModel(planar_arm_urdf(arm), gravity=[0.0, 0.0, -3.7])
    q, dq, ddq = motion
    np.testing.assert_allclose(model.predict(q, dq, ddq),
                               regressor(q, dq, ddq, l1=0.8, g=3.7) @ base_parameters(arm), rtol=1e-12, atol=1e-11)


@needs_pin
def test_negative_coulomb_in_urdf_is_kept(tmp_path, motion):
    from dynval.robots import URDFModel

    text = planar_arm_urdf().replace('friction="1.2"', 'friction="-0.4"')
    model = URDFModel(text)
    np.testing.assert_allclose(model.coulomb, [2.0, -0.4])


@needs_pin
def test_bad_motion_shape(arm_model):
    with pytest.raises(dynval.InvalidParameter):
        arm_model.regressor(np.zeros((5, 3)), np.zeros((5, 3)), np.zeros((5, 3)))
    with pytest.raises(dynval.ShapeMismatch):
        arm_model.regressor(np.zeros((5, 2)), np.zeros((4, 2)), np.zeros((5, 2)))
    with pytest.raises(dynval.NonFiniteInput):
        arm_model.predict(np.full((5, 2), np.nan), np.zeros((5, 2)), np.zeros((5, 2)))


# --------------------------------------------------------------------------- differentiation


@pytest.mark.parametrize("method", ["savgol", "butterworth"])
def test_differentiation_is_accurate_in_band_and_zero_phase(method):
    fs = 200.0
    t = np.arange(4000) / fs
    f1, f2 = 0.5, 1.3
    q = np.column_stack([np.sin(2 * np.pi * f1 * t), 0.3 * np.cos(2 * np.pi * f2 * t)])
    d = differentiate(q, fs, method=method)
    inner = slice(200, -200)
    w1, w2 = 2 * np.pi * f1, 2 * np.pi * f2
    np.testing.assert_allclose(d.dq[inner, 0], w1 * np.cos(w1 * t[inner]), atol=2e-3 * w1)
    np.testing.assert_allclose(d.ddq[inner, 1], -0.3 * w2**2 * np.cos(w2 * t[inner]), atol=1e-2 * 0.3 * w2**2)
    assert d.delay_s == 0.0
    # Zero phase: the derivative's zero crossings are where cos is zero, not shifted.
    lag = np.argmax(np.correlate(d.dq[inner, 0], w1 * np.cos(w1 * t[inner]), mode="full")) - (t[inner].size - 1)
    assert lag == 0
    assert d.description.startswith(d.method) and "bandwidth" in d.description


@pytest.mark.parametrize("method, kwargs", [("savgol", {"window": 0.2}), ("butterworth", {"cutoff": 8.0})])
def test_stated_bandwidth_is_the_measured_minus_3db_point(method, kwargs):
    fs = 100.0
    probe = differentiate(np.zeros(1000), fs, method=method, **kwargs)
    fb = probe.bandwidth_hz
    assert 0.5 < fb < fs / 2
    t = np.arange(4000) / fs
    gains = []
    for f in (0.5 * fb, fb, 2.0 * fb):
        x = np.sin(2 * np.pi * f * t)
        y = differentiate(x, fs, method=method, **kwargs).q[:, 0]
        inner = slice(500, -500)
        gains.append(np.sqrt(np.mean(y[inner] ** 2) / np.mean(x[inner] ** 2)))
    assert gains[0] > 0.9
    assert gains[1] == pytest.approx(1 / np.sqrt(2), abs=0.03)
    assert gains[2] < 0.6
    if method == "butterworth":
        # filtfilt applies |H|² : the stated bandwidth is below the design cutoff.
        assert fb < 8.0
    # The derivative filters' stated bands, measured against the exact derivatives.
    for k, fk in enumerate(probe.derivative_bandwidth_hz, start=1):
        assert 0.5 < fk < fs / 2
        ratios = []
        for f in (0.3 * fk, fk):
            w = 2 * np.pi * f
            d = differentiate(np.sin(w * t), fs, method=method, **kwargs)
            got = (d.dq if k == 1 else d.ddq)[500:-500, 0]
            exact = (w * np.cos(w * t) if k == 1 else -w**2 * np.sin(w * t))[500:-500]
            ratios.append(np.sqrt(np.mean(got**2) / np.mean(exact**2)))
        assert ratios[0] > 0.95, (k, ratios)
        assert ratios[1] == pytest.approx(1 / np.sqrt(2), abs=0.03), (k, ratios)


def test_differentiation_on_simulated_arm_reproduces_the_regressor():
    d = simulate("friction", n_samples=1000)
    rec = d.estimation
    der = differentiate(rec.q, d.sample_rate, window=0.15)
    inner = slice(20, -20)
    np.testing.assert_allclose(der.dq[inner], rec.dq[inner], atol=5e-3)
    np.testing.assert_allclose(der.ddq[inner], rec.ddq[inner], atol=0.1)


@pytest.mark.parametrize("kwargs", [{"method": "spline"}, {"sample_rate": -1.0},
                                    {"cutoff": 80.0, "method": "butterworth"},
                                    {"polyorder": 1}, {"polyorder": 3.0}, {"window": 100.0}])
def test_differentiation_bad_arguments(kwargs):
    args = {"sample_rate": 100.0} | kwargs
    with pytest.raises(dynval.InvalidParameter):
        differentiate(np.zeros(500), **args)


KUKA = Path(__file__).resolve().parents[2] / "shared" / "data" / "robots" / "kuka_lwr4_flobaroid"


@needs_pin
@pytest.mark.skipif(not (KUKA / "data" / "measurements_1.npz").is_file(), reason="KUKA LWR4 data not present")
def test_kuka_urdfs_load_and_predict_the_logged_torques():
    from dynval.robots import URDFModel

    cad = URDFModel(KUKA / "model" / "kuka_lwr4.urdf")
    ident = URDFModel(KUKA / "model" / "kuka_lwr4_identified.urdf")   # negative Coulomb values inside
    assert cad.joint_names == tuple(f"lwr_{j}_joint" for j in range(7))
    assert ident.coulomb[5] == pytest.approx(-1.2011052139867655)
    with np.load(KUKA / "data" / "measurements_1.npz") as f:
        q, dq, ddq, tau = (f[k][:1500] for k in ("positions", "velocities", "accelerations", "torques"))
    # The a-priori model explains the big gravity torques: errors of about 1 N·m on 25 N·m.
    rmse = np.sqrt(np.mean((tau - cad.predict(q, dq, ddq)) ** 2, axis=0))
    assert np.all(rmse < 3.0) and rmse[1] < 0.15 * np.sqrt(np.mean(tau[:, 1] ** 2))
    y = cad.regressor(q, dq, ddq, friction=False, offset=False)
    np.testing.assert_allclose(y @ cad.inertial_parameters(), cad.predict(q, dq, ddq, friction=False),
                               rtol=1e-9, atol=1e-9)
    res = identify(y, tau, column_names=cad.column_names(friction=False, offset=False))
    # Link 1 turns about its own axis only: of its ten parameters only Izz reaches the torques.
    assert not any(n.startswith("lwr_1_link:") and not n.startswith("lwr_1_link:Izz") for n in
                   (res.column_names[c] for c in res.base_columns))
    assert 40 <= res.rank <= 50


def test_input_bandwidth_is_the_narrowest_band_of_q_dq_ddq():
    """``validate(bandwidth=)`` takes the band where all three inputs are trustworthy."""
    from dynval.robots import differentiate

    t = np.arange(2000) / 200.0
    for kw in ({}, {"window": 0.505}, {"method": "butterworth", "cutoff": 20.0}):
        d = differentiate(np.sin(t)[:, None], 200.0, **kw)
        bands = (d.bandwidth_hz, *d.derivative_bandwidth_hz)
        assert d.input_bandwidth_hz == min(bands) < max(bands)
    d = differentiate(np.sin(t)[:, None], 200.0, window=0.505)
    assert d.input_bandwidth_hz == pytest.approx(2.47, abs=0.01)   # the 101-sample window of a real log


@pytest.fixture(scope="module")
def kuka_raw():
    """The KUKA LWR4+ URDF's raw 91-column regressor: the model identified on run 1, validated on run 3."""
    from dynval.datasets import load_kuka_lwr4
    from dynval.robots import URDFModel

    r1, r3 = load_kuka_lwr4(1), load_kuka_lwr4(3)
    model = URDFModel(r1.urdf)
    y1 = model.regressor(r1.q, r1.dq, r1.ddq)
    fit = identify(y1, r1.tau)
    return model, r1, r3, y1, fit


def _excitation_findings(report):
    return [f for f in report.findings if f.kind == "excitation" and f.effect_unit in ("columns", "structural columns")]


@needs_pin
def test_the_models_structure_tells_structural_columns_without_the_estimation_run(kuka_raw):
    """A raw URDF regressor validated without the estimation run's regressor used to get REDESIGN:
    "never excites lwr_1_link:m, …", parameters no fixed-base motion can excite. Prepared with the
    model's structure (its regressor at random states) the same 27 columns are structural, as the
    estimation run's regressor tells them (an independent source). Kills: the structure ignored (the
    design finding back), or used as the estimation run for the motion ratios."""
    model, r1, r3, y1, fit = kuka_raw
    names = list(model.column_names())
    y3 = model.regressor(r3.q, r3.dq, r3.ddq)
    pred = fit.predict(y3)
    kw = dict(n_params=fit.rank, column_names=names, sample_rate=r3.sample_rate)
    plain = dynval.validate(r3.tau, pred, regressor=y3, **kw)
    assert [f.severity for f in _excitation_findings(plain)] == ["design"]
    assert "never excites lwr_1_link:m" in _excitation_findings(plain)[0].message
    prepared = dynval.validate(r3.tau, pred, regressor=model.prepared_regressor(r3.q, r3.dq, r3.ddq), **kw)
    with_est = dynval.validate(r3.tau, pred, regressor=y3, estimation={"regressor": y1, "tau": r1.tau}, **kw)
    (note,) = _excitation_findings(prepared)
    assert note.severity == "note" and "at every state of the model's structure" in note.message
    x, x_est = prepared.design["excitation"], with_est.design["excitation"]
    assert x["structural_source"] == "model" and x_est["structural_source"] == "estimation"
    assert x["structural"] == x_est["structural"] and len(x["structural"]) == 27
    assert x["identifiable_rank"] == x_est["identifiable_rank"] == 64
    assert "column_motion_ratio" not in x and "column_motion_ratio" in x_est
    assert plain.design["excitation"]["structural_source"] is None


@needs_pin
def test_structure_states_lie_within_the_joint_limits(kuka_raw):
    model = kuka_raw[0]
    q, dq, ddq = model.structure_states(500, seed=3)
    lo, hi = np.asarray(model.model.lowerPositionLimit), np.asarray(model.model.upperPositionLimit)
    assert q.shape == dq.shape == ddq.shape == (500, 7)
    assert np.all(q >= np.maximum(lo, -np.pi)) and np.all(q <= np.minimum(hi, np.pi))
    again = model.structure_states(500, seed=3)
    assert all(np.array_equal(a, b) for a, b in zip((q, dq, ddq), again))
