"""The embedded demo: its physics (regressor vs an independent Newton–Euler routine), its
identification, and the report it prints."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

from dynval import cli
from dynval.demo import (
    DEFAULT_ARM,
    GRAVITY,
    PARAMETER_NAMES,
    base_parameters,
    fourier_trajectory,
    identify,
    regressor,
    run_demo,
)


def _cross(a, b):
    """z-component of the planar cross product a × b (a, b of shape (..., 2))."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _rot(angle, v):
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[0] - s * v[1], s * v[0] + c * v[1]], axis=-1)


def newton_euler(arm, q, qd, qdd, g=GRAVITY):
    """Inverse dynamics of the planar 2R arm from its physical parameters.

    Written independently of dynval.demo.regressor: forward recursion of link velocities
    and centre-of-mass accelerations in world coordinates, backward recursion of forces and
    moments about each joint axis, then viscous and Coulomb friction.
    """
    q1, q2 = q[:, 0], q[:, 1]
    w1, w2 = qd[:, 0], qd[:, 0] + qd[:, 1]
    a1, a2 = qdd[:, 0], qdd[:, 0] + qdd[:, 1]
    gvec = np.array([0.0, -g])

    def accel(origin_acc, alpha, omega, r):
        # a_c = a_o + α × r + ω × (ω × r); in the plane α × r = α (−r_y, r_x), ω × (ω × r) = −ω² r
        perp = np.stack([-r[:, 1], r[:, 0]], axis=-1)
        return origin_acc + alpha[:, None] * perp - (omega**2)[:, None] * r

    zero = np.zeros((q.shape[0], 2))
    r_c1 = _rot(q1, (arm.cx1, arm.cy1))            # joint 1 → COM 1
    r_12 = _rot(q1, (arm.l1, 0.0))                 # joint 1 → joint 2
    r_c2 = _rot(q1 + q2, (arm.cx2, arm.cy2))       # joint 2 → COM 2
    acc_c1 = accel(zero, a1, w1, r_c1)
    acc_j2 = accel(zero, a1, w1, r_12)
    acc_c2 = accel(acc_j2, a2, w2, r_c2)

    f2 = arm.m2 * (acc_c2 - gvec)                  # force of link 1 on link 2
    n2 = arm.I2 * a2 + _cross(r_c2, f2)            # moment about joint 2
    f1_own = arm.m1 * (acc_c1 - gvec)
    n1 = arm.I1 * a1 + _cross(r_c1, f1_own) + n2 + _cross(r_12, f2)
    tau = np.column_stack([n1, n2])
    tau[:, 0] += arm.fv1 * qd[:, 0] + arm.fc1 * np.sign(qd[:, 0])
    tau[:, 1] += arm.fv2 * qd[:, 1] + arm.fc2 * np.sign(qd[:, 1])
    return tau


def test_regressor_reproduces_newton_euler():
    rng = np.random.default_rng(7)
    q = rng.uniform(-np.pi, np.pi, size=(500, 2))
    qd = rng.normal(0.0, 2.0, size=(500, 2))
    qdd = rng.normal(0.0, 5.0, size=(500, 2))
    expected = newton_euler(DEFAULT_ARM, q, qd, qdd)
    got = regressor(q, qd, qdd) @ base_parameters(DEFAULT_ARM)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-11)


def test_regressor_with_other_arm_and_gravity():
    from dynval.demo import ArmParameters

    arm = ArmParameters(l1=0.8, m1=3.0, cx1=0.3, cy1=-0.02, I1=0.05, m2=1.5, cx2=0.25, cy2=0.03,
                        I2=0.02, fv1=0.1, fc1=0.4, fv2=0.2, fc2=0.3)
    rng = np.random.default_rng(3)
    q, qd, qdd = (rng.normal(size=(50, 2)) for _ in range(3))
    np.testing.assert_allclose(regressor(q, qd, qdd, l1=arm.l1, g=3.7) @ base_parameters(arm),
                               newton_euler(arm, q, qd, qdd, g=3.7), rtol=1e-12, atol=1e-12)


def test_static_gravity_torque_closed_form():
    # Arm horizontal and at rest: τ2 = g·m2·cx2, τ1 = g·(m1·cx1 + m2·(l1 + cx2)); Coulomb sign(0) = 0.
    z = np.zeros((1, 2))
    tau = regressor(z, z, z) @ base_parameters(DEFAULT_ARM)
    a = DEFAULT_ARM
    assert tau[0, 1] == pytest.approx(GRAVITY * a.m2 * a.cx2, rel=1e-14)
    assert tau[0, 0] == pytest.approx(GRAVITY * (a.m1 * a.cx1 + a.m2 * (a.l1 + a.cx2)), rel=1e-14)


def test_fourier_trajectory_derivatives_match_finite_differences():
    t = np.linspace(0.0, 3.0, 30001)
    amp = np.array([[0.5, 0.2], [0.3, 0.1]])
    ph = np.array([[0.1, 1.0], [2.0, 0.5]])
    q, qd, qdd = fourier_trajectory(t, np.array([0.1, -0.2]), amp, ph, 0.3)
    dt = t[1] - t[0]
    np.testing.assert_allclose(np.gradient(q, dt, axis=0)[1:-1], qd[1:-1], atol=1e-6)
    np.testing.assert_allclose(np.gradient(qd, dt, axis=0)[1:-1], qdd[1:-1], atol=1e-5)


def test_least_squares_recovers_true_parameters_from_noise_free_data():
    rng = np.random.default_rng(11)
    t = np.arange(2000) / 100.0
    k = np.arange(1, 6)
    q, qd, qdd = fourier_trajectory(t, rng.uniform(-0.5, 0.5, 2), rng.uniform(0.3, 0.8, (2, 5)) / k,
                                    rng.uniform(0, 2 * np.pi, (2, 5)), 0.1)
    Y = regressor(q, qd, qdd)
    tau = newton_euler(DEFAULT_ARM, q, qd, qdd)
    pi_hat = identify(Y, tau)
    np.testing.assert_allclose(pi_hat, base_parameters(DEFAULT_ARM), rtol=1e-8)


@pytest.fixture(scope="module")
def demo_result():
    return run_demo(seed=0, n_samples=2000, noise=0.2)


def test_demo_identifies_and_prefers_the_full_model(demo_result):
    full, reduced = demo_result.models
    assert full.name == "full" and reduced.name == "reduced"
    # σ = 0.2 N·m on 4000 torque samples: the parameters come back within a few percent.
    np.testing.assert_allclose(full.parameters, demo_result.true_parameters, rtol=0.05, atol=0.01)
    assert full.report.information_criteria["aic"] < reduced.report.information_criteria["aic"]
    assert full.report.information_criteria["bic"] < reduced.report.information_criteria["bic"]
    # The reduced model leaves Coulomb friction in the residual: strongly non-white ...
    assert np.all(np.asarray(reduced.report.ljung_box["log_pvalue"]) < np.log(1e-10))
    # ... and most correlated with a Coulomb column of the full regressor.
    joint, column, lag, rho, ratio = reduced.report.cross_correlation["outside"][0]
    assert PARAMETER_NAMES[column].startswith("Fc")
    assert ratio > 5
    # The full model's RMSE is close to the sensor noise.
    assert full.report.per_joint["rmse"] == pytest.approx([0.2, 0.2], rel=0.1)


def test_demo_summary_and_json(demo_result):
    text = demo_result.summary()
    assert "Model 'full'" in text and "Model 'reduced'" in text
    assert "AIC prefers the full model" in text
    assert "Fc" in text.splitlines()[-1]
    data = json.loads(json.dumps(demo_result.to_dict(), allow_nan=False))
    assert set(data["models"]) == {"full", "reduced"}
    assert data["models"]["reduced"]["report"]["provenance"]["n_params"] == 8


def test_demo_command_runs_in_a_few_seconds(capsys):
    start = time.perf_counter()
    code = cli.main(["demo", "--n-samples", "1000", "--seed", "3"])
    elapsed = time.perf_counter() - start
    out, err = capsys.readouterr()
    assert code == 0
    assert "dynval validation report" in out and "Comparison on the validation trajectory" in out
    assert "[dynval demo]" in err  # progress goes to stderr, not into the report
    assert elapsed < 10.0


def test_demo_command_json(capsys):
    assert cli.main(["demo", "--json", "--n-samples", "500"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["n_samples"] == 500


@pytest.mark.parametrize("args", [["--n-samples", "10"], ["--noise", "-1"]])
def test_demo_rejects_bad_options(args, capsys):
    assert cli.main(["demo", *args]) == 2
    assert "error" in capsys.readouterr().err
