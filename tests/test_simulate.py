"""dynval.simulate: the scenarios of the 2-DOF arm are deterministic, fast, and contain what
their names promise (checked from the data, not from the simulator's own bookkeeping)."""

from __future__ import annotations

import time

import numpy as np
import pytest
import scipy.signal

import dynval
from dynval.identify import identify
from dynval.simulate import (
    CANDIDATES,
    COLUMN_NAMES,
    SCENARIOS,
    base_parameters,
    full_regressor,
    regressor,
    simulate,
)


@pytest.fixture(scope="module")
def data():
    out = {}
    for name in SCENARIOS:
        start = time.perf_counter()
        out[name] = simulate(name, seed=0)
        out[name + ":seconds"] = time.perf_counter() - start
    return out


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_each_scenario_takes_at_most_two_seconds(data, scenario):
    assert data[scenario + ":seconds"] < 2.0


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_records_are_consistent(data, scenario):
    d = data[scenario]
    assert d.scenario == scenario and d.sample_rate == 100.0 and d.n_samples == 2000
    assert d.candidates == ("rigid", "friction", "friction+offset")
    for rec in (d.estimation, d.validation):
        n = rec.t.shape[0]
        assert rec.q.shape == rec.dq.shape == rec.ddq.shape == rec.tau_meas.shape == (n, 2)
        np.testing.assert_allclose(np.diff(rec.t), 0.01, rtol=1e-9)
        np.testing.assert_array_equal(rec.full_regressor, full_regressor(rec.q, rec.dq, rec.ddq))
        for name, cols in CANDIDATES.items():
            idx = [COLUMN_NAMES.index(c) for c in cols]
            np.testing.assert_array_equal(rec.regressors[name], rec.full_regressor[:, :, idx])
            assert d.column_names[name] == cols
        # Velocities and accelerations are the derivatives of the positions.
        np.testing.assert_allclose(np.gradient(rec.q, 0.01, axis=0)[5:-5], rec.dq[5:-5], atol=2e-3)
        np.testing.assert_allclose(np.gradient(rec.dq, 0.01, axis=0)[5:-5], rec.ddq[5:-5], atol=1e-2)


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_deterministic_and_seeded(scenario):
    a, b, c = simulate(scenario, seed=5, n_samples=300), simulate(scenario, seed=5, n_samples=300), \
        simulate(scenario, seed=6, n_samples=300)
    np.testing.assert_array_equal(a.validation.tau_meas, b.validation.tau_meas)
    np.testing.assert_array_equal(a.estimation.q, b.estimation.q)
    assert not np.array_equal(a.estimation.tau_meas, c.estimation.tau_meas)


@pytest.mark.parametrize("scenario", ["rigid", "friction", "offset", "flexible"])
def test_validation_trajectory_differs_from_estimation(data, scenario):
    d = data[scenario]
    assert np.max(np.abs(d.estimation.q - d.validation.q)) > 0.1


def test_repeat_validates_on_the_estimation_trajectory_with_new_noise(data):
    d = data["repeat"]
    np.testing.assert_array_equal(d.estimation.q, d.validation.q)
    np.testing.assert_array_equal(d.estimation.ddq, d.validation.ddq)
    diff = d.estimation.tau_meas - d.validation.tau_meas
    assert np.std(diff) == pytest.approx(0.2 * np.sqrt(2), rel=0.1)


@pytest.mark.parametrize("scenario, friction, offset", [
    ("rigid", False, False), ("friction", True, False), ("offset", True, True), ("repeat", True, False)])
def test_torques_are_the_true_model_plus_noise(data, scenario, friction, offset):
    d = data[scenario]
    pi = base_parameters()
    if not friction:
        pi[6:] = 0.0
    for rec in (d.estimation, d.validation):
        noise = rec.tau_meas - regressor(rec.q, rec.dq, rec.ddq) @ pi
        expected_mean = [0.8, -0.6] if offset else [0.0, 0.0]
        np.testing.assert_allclose(noise.mean(axis=0), expected_mean, atol=0.02)
        np.testing.assert_allclose(noise.std(axis=0), [0.2, 0.2], rtol=0.08)
    truth = np.array([d.true_parameters[c] for c in COLUMN_NAMES])
    np.testing.assert_allclose(truth[:10], pi)
    np.testing.assert_allclose(truth[10:], [0.8, -0.6] if offset else [0.0, 0.0])


def test_friction_scenario_is_identified_and_the_rigid_candidate_is_not_enough(data):
    d = data["friction"]
    res = identify(d.estimation.regressors["friction"], d.estimation.tau_meas)
    np.testing.assert_allclose(res.estimate, base_parameters(), rtol=0.05, atol=0.02)
    rigid = identify(d.estimation.regressors["rigid"], d.estimation.tau_meas)
    e_rigid = d.validation.tau_meas - rigid.predict(d.validation.regressors["rigid"])
    e_fric = d.validation.tau_meas - res.predict(d.validation.regressors["friction"])
    assert np.all(e_rigid.std(axis=0) > 5 * e_fric.std(axis=0))


def test_flexible_residual_oscillates_at_the_simulated_mode(data):
    d = data["flexible"]
    assert d.mode_frequency == pytest.approx(7.0 * np.sqrt(1 - 0.02**2))
    assert d.elastic["stiffness"] == pytest.approx(base_parameters()[3] * (2 * np.pi * 7.0) ** 2)
    for name in d.candidates:
        res = identify(d.estimation.regressors[name], d.estimation.tau_meas)
        e = d.validation.tau_meas - res.predict(d.validation.regressors[name])
        f, p = scipy.signal.welch(e, fs=d.sample_rate, nperseg=1024, axis=0)
        above_1hz = f > 1.0
        for j in range(2):
            peak = f[above_1hz][np.argmax(p[above_1hz, j])]
            assert peak == pytest.approx(d.mode_frequency, rel=0.05), (name, j, peak)
            # A narrow peak: far above the median level of the spectrum.
            assert p[above_1hz, j].max() > 50 * np.median(p[:, j])
        report = dynval.validate(d.validation.tau_meas, d.validation.tau_meas - e, n_params=res.rank)
        assert np.all(np.asarray(report.ljung_box["pvalue"]) < 1e-10)


def test_flexible_mode_frequency_follows_the_spring():
    # A softer spring moves the residual's peak to the new frequency.
    d = simulate("flexible", mode_frequency=4.0, n_samples=4000)
    res = identify(d.estimation.regressors["friction"], d.estimation.tau_meas)
    e = d.validation.tau_meas - res.predict(d.validation.regressors["friction"])
    f, p = scipy.signal.welch(e[:, 1], fs=100.0, nperseg=2048)
    assert f[np.argmax(p * (f > 1.0))] == pytest.approx(4.0, rel=0.03)


def test_rigid_scenario_has_no_friction_to_find(data):
    d = data["rigid"]
    res = identify(d.estimation.regressors["friction"], d.estimation.tau_meas,
                   column_names=d.column_names["friction"])
    friction = res.estimate[6:]
    assert np.all(np.abs(friction) < 4 * res.std[6:])


@pytest.mark.parametrize("kwargs", [{"scenario": "wobbly"}, {"n_samples": 10}, {"noise": -1.0},
                                    {"sample_rate": 0.0}])
def test_bad_arguments(kwargs):
    with pytest.raises(dynval.InvalidParameter):
        simulate(**kwargs)


def test_elastic_joint_integration_has_converged():
    # Halving the RK4 step changes the link motion by far less than the sensor noise would show.
    from dynval.simulate import DEFAULT_ARM, GRAVITY, _elastic_link_motion, fourier_trajectory

    rng_coefs = np.random.default_rng(0)
    offs, amps, phases = rng_coefs.uniform(-1, 1, 2), rng_coefs.uniform(0.6, 1.2, (2, 5)) / np.arange(1, 6), \
        rng_coefs.uniform(0, 2 * np.pi, (2, 5))

    def theta(tt):
        return fourier_trajectory(tt, offs, amps, phases, 0.1)

    pi = base_parameters()
    t = np.arange(600) / 100.0
    k = pi[3] * (2 * np.pi * 7.0) ** 2
    runs = [_elastic_link_motion(theta, t, h, pi, DEFAULT_ARM, GRAVITY, k, 0.4, 0.3, np.random.default_rng(1), 1.0)
            for h in (2e-3, 1e-3)]
    # As spring torque K·Δq2 and link torque ZZ2·Δq̈2: 200 times below the 0.2 N·m sensor noise.
    assert k * np.max(np.abs(runs[0][0] - runs[1][0])) < 1e-3
    assert pi[3] * np.max(np.abs(runs[0][2] - runs[1][2])) < 1e-3
    # and the link really deflects from the motor: the elastic joint is not a rigid one
    assert np.max(np.abs(runs[0][0] - theta(t)[0][:, 1])) > 1e-3
