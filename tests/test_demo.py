"""The embedded demo: its physics (regressor vs an independent Newton–Euler routine), each
scenario's decision, the printed report, and the files it writes."""

from __future__ import annotations

import json
import time
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import dynval
from dynval import cli
from dynval.demo import (
    DEFAULT_ARM,
    GRAVITY,
    PARAMETER_NAMES,
    base_parameters,
    fourier_trajectory,
    regressor,
    run_demo,
)
from dynval.identify import identify

HAVE_COMPARE = hasattr(dynval, "compare")
needs_compare = pytest.mark.skipif(not HAVE_COMPARE, reason="dynval.compare is not in this build yet")


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
    res = identify(Y, tau)
    assert res.rank == 10
    np.testing.assert_allclose(res.estimate, base_parameters(DEFAULT_ARM), rtol=1e-8)


@pytest.fixture(scope="module")
def results():
    return {}


def _run(results, scenario):
    if scenario not in results:
        results[scenario] = run_demo(scenario, progress=None)
    return results[scenario]


def _deficiencies(report):
    return [f for f in report.findings if f.severity == "deficiency"]


def test_friction_scenario_friction_model_wins_and_passes(results):
    r = _run(results, "friction")
    assert r.chosen == "friction"
    assert _deficiencies(r.reports["friction"]) == []
    # The rigid candidate misses friction, and its findings name the friction columns.
    rigid = _deficiencies(r.reports["rigid"])
    named = {PARAMETER_NAMES[c] for f in rigid for c in f.columns if c < len(PARAMETER_NAMES)}
    assert named & {"Fc1", "Fc2", "Fv1", "Fv2"}
    # σ = 0.2 N·m on 4000 torque samples: the parameters come back within a few percent.
    np.testing.assert_allclose(r.identified["friction"].estimate, base_parameters(), rtol=0.05, atol=0.01)
    assert r.reports["friction"].per_joint["rmse"] == pytest.approx([0.2, 0.2], rel=0.1)


def test_flexible_scenario_names_the_simulated_mode(results):
    r = _run(results, "flexible")
    mode = r.data.mode_frequency
    osc = [f for f in r.reports[r.chosen].findings if f.kind == "oscillation"]
    assert osc, [f.kind for f in r.reports[r.chosen].findings]
    for f in osc:
        assert f.severity == "deficiency"
        assert f.details["frequency"] == pytest.approx(mode, rel=0.10)
    assert {j for f in osc for j in f.joints} == {0, 1}


def test_rigid_scenario_has_no_deficiency(results):
    r = _run(results, "rigid")
    assert r.chosen == "rigid"
    assert _deficiencies(r.reports["rigid"]) == []


def test_offset_scenario_needs_the_offset_columns(results):
    r = _run(results, "offset")
    assert r.chosen == "friction+offset"
    assert _deficiencies(r.reports["friction+offset"]) == []
    assert any(f.kind == "bias" for f in _deficiencies(r.reports["friction"]))
    est = dict(zip(r.identified["friction+offset"].base_names, r.identified["friction+offset"].estimate))
    assert est["off1"] == pytest.approx(0.8, abs=0.1) and est["off2"] == pytest.approx(-0.6, abs=0.1)


def test_repeat_scenario_warns_about_the_design(results):
    r = _run(results, "repeat")
    for name in r.names:
        design = [f for f in r.reports[name].findings if f.severity == "design"]
        assert design, name


@needs_compare
@pytest.mark.parametrize("scenario, decision, model", [("friction", "accept", "friction"), ("rigid", "accept", "rigid"),
                                                       ("offset", "accept", "friction+offset"),
                                                       ("repeat", "redesign", None)])
def test_verdicts(results, scenario, decision, model):
    r = _run(results, scenario)
    assert r.comparison.verdict.decision == decision, r.comparison.verdict.reasons
    if model is not None:
        assert r.comparison.verdict.model == model


@needs_compare
def test_flexible_verdict_is_refine_with_the_mode(results):
    # Every candidate is rigid: none can explain the elastic joint's oscillation, and the
    # oscillation (not the colour it causes) is the reason given.
    r = _run(results, "flexible")
    assert r.comparison.verdict.decision == "refine"
    assert any("oscillates near" in reason for reason in r.comparison.verdict.reasons)


def test_summary_and_json(results):
    r = _run(results, "friction")
    text = r.summary()
    assert "scenario 'friction'" in text and "Decision table" in text
    if HAVE_COMPARE:
        assert "Comparison on the validation trajectory" in text and r.comparison.summary() in text
    else:
        assert "Findings for the chosen model 'friction'" in text
    for name in ("rigid", "friction", "friction+offset"):
        assert name in text
    data = json.loads(json.dumps(r.to_dict(), allow_nan=False))
    assert set(data["models"]) == {"rigid", "friction", "friction+offset"}
    assert data["models"]["rigid"]["report"]["provenance"]["n_params"] == 6
    assert data["chosen"] == "friction"


def test_demo_writes_plots_json_and_html(tmp_path):
    pytest.importorskip("matplotlib")
    out = tmp_path / "demo"
    r = run_demo("flexible", out=out, progress=None, n_samples=800)
    names = {p.name for p in out.iterdir()}
    assert {"demo.json", "report.html", "prediction.png", "residuals.png", "autocorrelation.png",
            "autocorrelation_candidates.png", "metrics.png", "cross_correlation.png", "spectrum.png"} <= names
    for p in out.glob("*.png"):
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    json.loads((out / "demo.json").read_text())
    html = (out / "report.html").read_text(encoding="utf-8")
    ET.fromstring(html.split("\n", 1)[1])
    assert "scenario 'flexible'" in html and "data:image/png;base64," in html
    assert sorted(r.files) == sorted(str(out / n) for n in names)


def test_demo_command_runs_in_a_few_seconds(capsys):
    start = time.perf_counter()
    code = cli.main(["demo", "--n-samples", "1000", "--seed", "3"])
    elapsed = time.perf_counter() - start
    out, err = capsys.readouterr()
    assert code == 0
    assert "Decision table" in out and "scenario 'friction'" in out
    assert "[dynval demo]" in err and "[dynval demo]" not in out  # progress goes to stderr
    assert elapsed < 15.0


@pytest.mark.parametrize("scenario", ["rigid", "offset"])
def test_demo_command_scenario_option(capsys, scenario):
    assert cli.main(["demo", "--scenario", scenario, "--n-samples", "500"]) == 0
    assert f"scenario '{scenario}'" in capsys.readouterr().out


def test_demo_command_json(capsys):
    assert cli.main(["demo", "--json", "--n-samples", "500"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["n_samples"] == 500 and data["scenario"] == "friction"


@pytest.mark.parametrize("args", [["--n-samples", "10"], ["--noise", "-1"], ["--scenario", "wobbly"]])
def test_demo_rejects_bad_options(args, capsys):
    try:
        code = cli.main(["demo", *args])
    except SystemExit as exc:  # argparse rejects an unknown choice itself
        code = exc.code
    assert code == 2
    assert "error" in capsys.readouterr().err


def test_readme_figure_command(tmp_path):
    pytest.importorskip("matplotlib")
    from dynval.demo import main

    target = tmp_path / "fig" / "demo.png"
    assert main(["--readme-figure", str(target)]) == 0
    assert target.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
