"""Physical consistency (issue 23): the check of a robot's parameters, the distance of identified base
parameters to the consistent set, and identification under the constraints.

Bodies are built here from what a body is — a mass, a centre of mass, principal moments about it in
some orientation — by the parallel-axis theorem, never from the module's own pseudo-inertia; every
condition is tested just inside and just outside its boundary. The SDP answers are checked by the
eigenvalues of pinocchio's own pseudo-inertia (or the textbook definition without pinocchio), and
their optimality against feasible points the test constructs.
"""

from __future__ import annotations

import importlib.util
import sys
import time
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import dynval
from dynval.identify import identify
from dynval.robots import have_pinocchio, physical_consistency

needs_pin = pytest.mark.skipif(not have_pinocchio(), reason="pinocchio (PyPI pin) is not installed")
# Looked up, not imported: importing cvxpy imports SCS, whose bundled single-thread OpenBLAS would then
# sit in the process of every later test (tests/test_memory.py counts the BLAS libraries' threads).
HAVE_CVXPY = importlib.util.find_spec("cvxpy") is not None
needs_cvxpy = pytest.mark.skipif(not HAVE_CVXPY, reason="cvxpy (the physical extra) is not installed")

PARAMS = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
EPS = 1e-6


def body(m, c=(0.0, 0.0, 0.0), moments=(1.0, 1.0, 1.0), angles=(0.0, 0.0, 0.0)):
    """Ten parameters (pinocchio's order, inertia about the frame origin) of a body with mass m, centre
    of mass c and principal moments about it along axes turned by ``angles`` (parallel-axis theorem)."""
    rot = Rotation.from_euler("xyz", angles).as_matrix()
    ic = rot @ np.diag(moments) @ rot.T
    c = np.asarray(c, dtype=float)
    io = ic + m * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array([m, *(m * c), io[0, 0], io[0, 1], io[1, 1], io[0, 2], io[1, 2], io[2, 2]])


def names(link="b", joint="j", friction=True):
    return [f"{link}:{p}" for p in PARAMS] + ([f"Fv_{joint}", f"Fc_{joint}"] if friction else [])


def pseudo_inertia(p):
    """J = ∫[x; 1][x; 1]ᵀ ρ dV from the parameters: pinocchio's, else the textbook Σ = ½tr(I)·1 − I."""
    if have_pinocchio():
        import pinocchio as pin

        return pin.PseudoInertia.FromDynamicParameters(np.asarray(p, dtype=float)).toMatrix()
    m, h, (xx, xy, yy, xz, yz, zz) = p[0], p[1:4], p[4:10]
    inertia = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    return np.block([[0.5 * np.trace(inertia) * np.eye(3) - inertia, h[:, None]], [h[None, :], [[m]]]])


def psd(p, rtol=1e-9):
    lam = np.linalg.eigvalsh(pseudo_inertia(p))
    return lam[0] >= -rtol * max(lam[-1], 1.0)


# --------------------------------------------------------------------------- each condition, both sides


def test_a_physical_body_anywhere_in_any_orientation_has_no_finding():
    for k in range(20):
        rng = np.random.default_rng(k)
        moments = rng.uniform(0.01, 1.0, 2)
        moments = [*moments, rng.uniform(abs(moments[0] - moments[1]), moments.sum())]   # a triangle
        p = body(rng.uniform(0.1, 10), rng.normal(0, 0.3, 3), moments, rng.uniform(-3, 3, 3))
        assert physical_consistency(p) == [], k


@pytest.mark.parametrize("mass", [-1e-3, 0.0, 1e-3])
def test_mass_must_be_positive(mass):
    p = body(1.0, moments=(0.1, 0.1, 0.1))
    p[0] = mass                                   # the first moment is zero: only the mass changes
    found = physical_consistency(p)
    if mass > 0:
        assert found == []
        return
    (f,) = found
    assert (f.kind, f.severity, f.joints, f.columns) == ("physical_consistency", "deficiency", (0,), tuple(range(10)))
    assert f.details["condition"] == "mass > 0" and f.effect == -mass and f.effect_unit == "kg"
    assert "link1" in f.message and "mass" in f.message


@pytest.mark.parametrize("side", [-1, 1])
@pytest.mark.parametrize("angles", [(0.0, 0.0, 0.0), (0.4, -1.1, 2.0)])
def test_triangle_inequality_about_the_centre_of_mass(side, angles):
    # principal moments 0.3, 0.5 and 0.8 ± ε: on the far side of 0.3 + 0.5 no body exists
    p = body(2.0, (0.2, -0.1, 0.4), (0.3, 0.5, 0.8 + side * EPS), angles)
    found = physical_consistency(p)
    assert psd(p) == (side < 0)
    if side < 0:
        assert found == []
        return
    (f,) = found
    assert f.details["condition"] == "pseudo-inertia positive semidefinite"
    assert f.effect == pytest.approx(EPS, rel=1e-4) and f.effect_unit == "kg·m²"
    np.testing.assert_allclose(f.details["principal_moments"], [0.3, 0.5, 0.8 + EPS], rtol=1e-9)
    np.testing.assert_allclose(f.details["centre_of_mass"], [0.2, -0.1, 0.4], rtol=1e-12)
    assert f.details["pseudo_inertia_min_eigenvalue"] < 0


@pytest.mark.parametrize("seed", range(5))
def test_point_masses_and_rods_off_the_origin_are_on_the_boundary_not_beyond_it(seed):
    # J has rank 1 (a point mass) or 2 (a thin rod): exactly on the boundary; I_C = I − m(|c|²·1 − ccᵀ)
    # is zero (or singular) only up to the rounding of the parallel-axis subtraction
    rng = np.random.default_rng(seed)
    for _ in range(200):
        m, c, rod = rng.uniform(0.1, 10.0), rng.normal(0.0, 0.5, 3), rng.uniform(0.0, 0.3)
        p = body(m, c, (0.0, rod, rod), rng.uniform(-3, 3, 3))
        assert physical_consistency(p) == [], (m, c, rod)
        # and just beyond: the moment along the rod's axis below zero by 1e-6 of the largest moment
        # about the origin (1000 times the tolerance)
        beyond = body(m, c, (-1e-6 * (rod + m * c @ c), rod, rod), rng.uniform(-3, 3, 3))
        (f,) = physical_consistency(beyond)
        assert f.details["condition"] == "pseudo-inertia positive semidefinite"


def test_a_negative_principal_moment_breaks_the_triangle():
    (f,) = physical_consistency(body(1.0, (0.1, 0, 0), (-0.1, 1.0, 1.0)))
    assert f.effect == pytest.approx(0.1)       # 1 − (−0.1) − 1


def test_the_condition_is_about_the_centre_of_mass_not_the_joint_frame():
    # 0.01, 0.01, 0.03 about the centre of mass is no body; 1 m away the joint-frame inertia obeys every
    # triangle inequality, which a check at the frame origin would accept
    p = body(1.0, (0.0, 0.0, 1.0), (0.01, 0.01, 0.03))
    frame = np.linalg.eigvalsh(np.array([[p[4], p[5], p[7]], [p[5], p[6], p[8]], [p[7], p[8], p[9]]]))
    assert frame[0] + frame[1] >= frame[2]
    (f,) = physical_consistency(p)
    assert f.effect == pytest.approx(0.01)


@needs_pin
def test_findings_agree_with_pinocchios_pseudo_inertia():
    import pinocchio as pin

    for k in range(40):
        rng = np.random.default_rng(100 + k)
        p = body(rng.uniform(0.1, 5), rng.normal(0, 0.5, 3), rng.uniform(-0.2, 1.0, 3), rng.uniform(-3, 3, 3))
        negative = np.linalg.eigvalsh(pin.PseudoInertia.FromDynamicParameters(p).toMatrix())[0] < -1e-12
        assert bool(physical_consistency(p)) == negative, k
    np.testing.assert_allclose(dynval.report._consistency.pseudo_inertia(p), pin.PseudoInertia.FromDynamicParameters(p)
                               .toMatrix(), rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize(("axis", "bound", "delta"), [(0, "upper", EPS), (0, "upper", -EPS), (2, "lower", EPS),
                                                      (2, "lower", -EPS)])
def test_centre_of_mass_box(axis, bound, delta):
    lower, upper = np.array([-0.1, -0.2, -0.3]), np.array([0.1, 0.2, 0.3])
    c = np.zeros(3)
    c[axis] = upper[axis] + delta if bound == "upper" else lower[axis] - delta
    p = body(3.0, c, (0.1, 0.1, 0.1))
    assert physical_consistency(p) == []                     # no box, no condition
    found = physical_consistency(p, com_bounds=(lower, upper))
    assert physical_consistency(p, com_bounds={"link1": (lower, upper)}) == found
    if delta < 0:
        assert found == []
        return
    (f,) = found
    assert f.details["condition"] == "centre of mass inside its box"
    assert f.effect == pytest.approx(EPS, rel=1e-6) and f.effect_unit == "m"


@pytest.mark.parametrize("kind", ["Fv", "Fc"])
@pytest.mark.parametrize("value", [-1e-3, 0.0, 1e-3])
def test_friction_must_resist(kind, value):
    p = np.concatenate([body(1.0), [0.5, 0.5]])
    column = 10 if kind == "Fv" else 11
    p[column] = value
    found = physical_consistency(p, column_names=names(joint="elbow"), joint_names=["shoulder", "elbow"])
    if value >= 0:
        assert found == []
        return
    (f,) = found
    assert (f.joints, f.columns, f.effect) == ((1,), (column,), -value)
    assert f.effect_unit == ("N·m·s/rad" if kind == "Fv" else "N·m")
    assert f.message.startswith(f"elbow: {'viscous' if kind == 'Fv' else 'Coulomb'} friction {kind}")


def test_every_violation_is_reported_with_its_link_and_joint():
    p = np.concatenate([body(-1.0), body(1.0, moments=(0.1, 0.1, 0.3)), [1.0, -0.1, -0.2, 0.3]])
    cols = names("a", friction=False) + names("b", friction=False) + ["Fv_j1", "Fv_j2", "Fc_j1", "Fc_j2"]
    found = physical_consistency(p, column_names=cols)
    assert [(f.joints, f.columns[:1], f.details["condition"]) for f in found] == [
        ((0,), (0,), "mass > 0"), ((1,), (10,), "pseudo-inertia positive semidefinite"),
        ((1,), (21,), "viscous friction >= 0"), ((0,), (22,), "Coulomb friction >= 0")]
    assert all(f.kind in dynval.FINDING_KINDS for f in found)


def test_bad_arguments():
    with pytest.raises(dynval.InvalidParameter, match="column_names"):
        physical_consistency(np.ones(12))
    with pytest.raises(dynval.InvalidParameter, match="column_names"):
        physical_consistency(np.ones(12), column_names=names()[:11])
    with pytest.raises(dynval.InvalidParameter, match="com_bounds"):
        physical_consistency(body(1.0), com_bounds=([0.1, 0, 0], [0.0, 1, 1]))
    with pytest.raises(dynval.InvalidParameter, match="com_bounds"):
        physical_consistency(body(1.0), com_bounds={"nolink": ([0, 0, 0], [1, 1, 1])})
    with pytest.raises(dynval.NonFiniteInput):
        physical_consistency([np.nan] * 10)


# --------------------------------------------------------------------------- the KUKA URDFs


@needs_pin
def test_kuka_identified_urdf_has_negative_friction_and_infeasible_links_the_cad_urdf_none():
    import pinocchio as pin

    from dynval.datasets import load_kuka_lwr4
    from dynval.robots import URDFModel

    run = load_kuka_lwr4(1)
    assert physical_consistency(URDFModel(run.urdf)) == []
    model = URDFModel(run.urdf_identified)
    found = physical_consistency(model)
    friction = {j.get("name"): float(d.get("friction")) for j in ET.parse(run.urdf_identified).iter("joint")
                for d in j.findall("dynamics")}
    coulomb = {f.details["joint"]: f.effect for f in found if f.details["condition"] == "Coulomb friction >= 0"}
    assert coulomb == {name: -value for name, value in friction.items() if value < 0}
    assert sorted(coulomb) == ["lwr_3_joint", "lwr_4_joint", "lwr_5_joint", "lwr_6_joint"]
    infeasible = {model.link_names[j - 1] for j in range(1, model.model.njoints)
                  if np.linalg.eigvalsh(pin.PseudoInertia.FromInertia(model.model.inertias[j]).toMatrix())[0] < 0}
    links = {f.details["link"]: f for f in found if f.details["condition"].startswith("pseudo-inertia")}
    assert set(links) == infeasible and infeasible
    for f in links.values():
        assert f.effect > 0 and f.severity == "deficiency" and str(f.details["link"]) in f.message


# --------------------------------------------------------------------------- identification under the constraints


def test_without_cvxpy_physical_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "cvxpy", None)
    x = np.random.default_rng(0).normal(size=(50, 12))
    with pytest.raises(ImportError, match=r"dynval\[physical\]"):
        identify(x, x @ np.ones(12), column_names=names(), physical=True)


def _one_link_problem(truth, seed=0, noise=1e-3, n=400):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, 12))
    return a, a @ truth + rng.normal(0.0, noise, n)


@needs_cvxpy
def test_sdp_answer_is_a_robot_and_no_feasible_point_fits_better():
    # data from an impossible link (0.1 + 0.1 < 0.3) with negative Coulomb friction
    truth = np.concatenate([body(2.0, (0.1, 0.2, -0.1), (0.1, 0.1, 0.3), (0.3, 0.2, 0.1)), [0.5, -0.4]])
    a, b = _one_link_problem(truth)
    ls = identify(a, b, column_names=names())
    fit = identify(a, b, column_names=names(), physical=True, prior_weight=0.0)
    full = fit.full_parameters
    assert not psd(truth[:10]) and psd(full[:10]) and full[10] >= 0 and full[11] >= 0
    assert physical_consistency(fit) == []
    np.testing.assert_allclose(fit.estimate, fit.combination @ full, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(fit.predict(a), (a @ full)[:, None], rtol=1e-9, atol=1e-9)
    sse = float(np.sum((b - a @ full) ** 2))
    assert sse == pytest.approx(fit.residual_sse, rel=1e-9) and sse > ls.residual_sse
    # optimality: no consistent link the test can think of fits better
    rng = np.random.default_rng(1)
    for k in range(30):
        m = rng.uniform(0.5, 4)
        moments = sorted(rng.uniform(0.0, 0.3, 3))
        moments[2] = min(moments[2], moments[0] + moments[1])
        cand = np.concatenate([body(m, rng.normal(0, 0.3, 3), moments, rng.uniform(-3, 3, 3)), rng.uniform(0, 1, 2)])
        assert float(np.sum((b - a @ cand) ** 2)) >= sse * (1 - 1e-7), k
    assert fit.physical["distance2"] == pytest.approx((sse - ls.residual_sse) / ls.sigma2, rel=1e-9)
    assert fit.to_dict()["full_parameters"] == pytest.approx(full.tolist())


@needs_cvxpy
def test_sdp_keeps_the_centre_of_mass_in_its_box_and_pulls_towards_the_prior():
    truth = np.concatenate([body(2.0, (0.3, 0.0, 0.0), (0.1, 0.2, 0.25)), [0.5, 0.4]])
    a, b = _one_link_problem(truth)
    box = ([-0.1, -0.1, -0.1], [0.1, 0.1, 0.1])
    fit = identify(a, b, column_names=names(), physical=True, com_bounds=box)
    c = fit.full_parameters[1:4] / fit.full_parameters[0]
    assert np.all(c <= 0.1 + 1e-9) and c[0] == pytest.approx(0.1, abs=1e-6)      # the box binds on x
    assert physical_consistency(fit, com_bounds=box) == []
    # a column the data never see stays at the prior (to the solver's tolerance)
    a[:, 11] = 0.0
    prior = truth + 0.05
    for weight in (1e-6, 1e-3):                       # the default weight and a stronger pull
        fit = identify(a, b, column_names=names(), physical=True, prior=prior, prior_weight=weight)
        assert fit.full_parameters[11] == pytest.approx(prior[11], abs=1e-6)


@needs_cvxpy
def test_entropic_prior_keeps_every_pseudo_inertia_positive_definite_and_pulls_towards_the_prior():
    # data from an impossible link: least squares under the constraints ends on the boundary (a
    # singular J); the entropic prior's −log det keeps J strictly inside, the Euclidean prior does not
    truth = np.concatenate([body(2.0, (0.1, 0.2, -0.1), (0.1, 0.1, 0.3), (0.3, 0.2, 0.1)), [0.5, 0.4]])
    a, b = _one_link_problem(truth)
    prior = np.concatenate([body(2.0, (0.1, 0.2, -0.1), (0.15, 0.15, 0.2)), [0.5, 0.4]])
    lam = {}
    for metric in ("euclidean", "entropic"):
        fit = identify(a, b, column_names=names(), physical=True, prior=prior, prior_weight=1e-3,
                       prior_metric=metric)
        assert physical_consistency(fit) == [] and fit.physical["prior_metric"] == metric
        lam[metric] = np.linalg.eigvalsh(pseudo_inertia(fit.full_parameters[:10]))
    assert lam["euclidean"][0] < 1e-6 * lam["euclidean"][-1]                     # on the boundary
    assert lam["entropic"][0] > 1e-4 * lam["entropic"][-1]                       # inside
    # a strong pull lands on the prior, whatever the metric (it is consistent and positive definite)
    for metric in ("euclidean", "entropic"):
        fit = identify(a, b, column_names=names(), physical=True, prior=prior, prior_weight=1e6, prior_metric=metric)
        np.testing.assert_allclose(fit.full_parameters, prior, rtol=1e-3, atol=1e-4)


@needs_cvxpy
def test_physical_identification_rejects_bad_arguments():
    a, b = _one_link_problem(np.concatenate([body(1.0), [0.1, 0.1]]), n=50)
    with pytest.raises(dynval.InvalidParameter, match="physical must be True or False"):
        identify(a, b, column_names=names(), physical="yes")
    with pytest.raises(dynval.InvalidParameter, match="column_names"):
        identify(a, b, physical=True)
    with pytest.raises(dynval.InvalidParameter, match="prior must be"):
        identify(a, b, column_names=names(), physical=True, prior=np.zeros(3))
    with pytest.raises(dynval.InvalidParameter, match="prior_weight"):
        identify(a, b, column_names=names(), physical=True, prior_weight=-1.0)
    with pytest.raises(dynval.InvalidParameter,
                       match=r"^prior_metric must be one of 'euclidean', 'entropic', got 'kl'$"):
        identify(a, b, column_names=names(), physical=True, prior_metric="kl")
    with pytest.raises(dynval.InvalidParameter,
                       match=r"^prior must be given .* with prior_metric='entropic', got None"):
        identify(a, b, column_names=names(), physical=True, prior_metric="entropic")
    rod = np.concatenate([[1.0, 0.5, 0, 0, 0.0, 0, 1 / 3, 0, 0, 1 / 3], [0.1, 0.1]])   # J singular: no log det
    with pytest.raises(dynval.InvalidParameter, match=r"positive definite pseudo-inertia .*\(b: smallest eigenvalue"):
        identify(a, b, column_names=names(), physical=True, prior=rod, prior_metric="entropic")


@pytest.fixture(scope="module")
def demo_arm():
    from dynval.robots import URDFModel, planar_arm_urdf
    from dynval.simulate import ArmParameters, simulate

    # viscous friction of the elbow at its bound: noise alone can make its estimate negative
    arm = ArmParameters(fv2=0.0)
    data = simulate("friction", seed=3, arm=arm, noise=0.5)
    return URDFModel(planar_arm_urdf(arm)), data


@needs_pin
@needs_cvxpy
def test_demo_arm_identified_under_constraints_recovers_its_parameters(demo_arm):
    model, data = demo_arm
    est = data.estimation
    motion = (est.q, est.dq, est.ddq)
    truth = model.parameters(offset=False)
    assert physical_consistency(model) == []
    ls = model.identify(*motion, est.tau_meas, offset=False)
    fit = model.identify(*motion, est.tau_meas, offset=False, physical=True, prior_weight=0.0)
    assert physical_consistency(fit) == [] and fit.rank == ls.rank
    full = fit.full_parameters
    assert all(psd(full[10 * k:10 * k + 10]) for k in range(2)) and np.all(full[20:] >= 0)
    # every identifiable combination within four standard deviations of the truth
    z = (fit.estimate - fit.combination @ truth) / fit.std
    assert np.all(np.abs(z) < 4), z
    # projecting onto a convex set that holds the truth never moves away from it: the constrained
    # prediction of the noise-free torques is at least as close as the unconstrained one
    y = model.regressor(*motion, offset=False)
    clean = y @ truth
    err_ls = np.linalg.norm(ls.predict(y) - clean)
    err_fit = np.linalg.norm(y @ full - clean)
    assert err_fit <= err_ls * (1 + 1e-6)
    # the two routes to the distance of the base estimate agree: the fit's and the metric of Cov(β̂)
    bc = dynval.robots.base_consistency(ls)
    assert bc.distance2 == pytest.approx(fit.physical["distance2"], rel=1e-3, abs=1e-4)


@needs_pin
@needs_cvxpy
def test_base_parameters_of_no_robot_are_a_deficiency_that_names_the_bound(demo_arm):
    from dynval.robots import URDFModel, planar_arm_urdf
    from dynval.simulate import ArmParameters, simulate

    model, data = demo_arm
    est = data.estimation
    found = physical_consistency(model.identify(est.q, est.dq, est.ddq, est.tau_meas, offset=False))
    assert all(f.severity == "note" for f in found)            # a consistent truth: at most a note
    # a Coulomb friction that pushes (−1 N·m on the elbow), measured with little noise
    arm = ArmParameters(fc2=-1.0)
    bad = simulate("friction", seed=3, arm=arm, noise=0.05).estimation
    bad_model = URDFModel(planar_arm_urdf(arm))
    ls = bad_model.identify(bad.q, bad.dq, bad.ddq, bad.tau_meas, offset=False)
    (f,) = physical_consistency(ls)
    assert (f.kind, f.severity) == ("physical_consistency", "deficiency")
    assert f.pvalue < 1e-10 and f.effect >= 0.01 and "elbow Fc" in f.details["binding"]
    assert f.joints == (1,) and bad_model.column_names(offset=False).index("Fc_elbow") in f.columns


@pytest.mark.slow
@needs_pin
@needs_cvxpy
def test_kuka_identified_under_constraints_is_a_robot_and_predicts_run_3_as_well():
    import pinocchio as pin

    from dynval.datasets import load_kuka_lwr4
    from dynval.robots import URDFModel

    start = time.perf_counter()
    est, val = load_kuka_lwr4(1), load_kuka_lwr4(3)
    cad = URDFModel(est.urdf)
    ls = cad.identify(est.q, est.dq, est.ddq, est.tau, offset=False)
    fit = cad.identify(est.q, est.dq, est.ddq, est.tau, offset=False, physical=True)
    full = fit.full_parameters
    for k in range(7):
        j = pin.PseudoInertia.FromDynamicParameters(full[10 * k:10 * k + 10]).toMatrix()
        lam = np.linalg.eigvalsh(j)
        assert lam[0] >= -1e-9 * lam[-1], (k, lam)
    assert np.all(full[70:] >= 0) and physical_consistency(fit) == []
    y = cad.regressor(val.q, val.dq, val.ddq, offset=False)
    rmse = [float(np.sqrt(np.mean((val.tau - r.predict(y)) ** 2))) for r in (ls, fit)]
    assert rmse[1] <= 1.05 * rmse[0], rmse                     # measured: 0.642 against 0.770 N·m
    # the entropic prior: every link strictly inside the consistent set, the same prediction
    ent = cad.identify(est.q, est.dq, est.ddq, est.tau, offset=False, physical=True, prior_metric="entropic")
    for k in range(7):
        lam = np.linalg.eigvalsh(pin.PseudoInertia.FromDynamicParameters(ent.full_parameters[10 * k:10 * k + 10])
                                 .toMatrix())
        assert lam[0] > 0, (k, lam)
    assert float(np.sqrt(np.mean((val.tau - ent.predict(y)) ** 2))) <= 1.05 * rmse[0]
    assert time.perf_counter() - start < 90


# --------------------------------------------------------------------------- in validate and compare


def _one_joint_run(n=2000, seed=0):
    rng = np.random.default_rng(seed)
    x = np.sin(2 * np.pi * 0.3 * np.arange(n) / 100.0)
    return 3.0 * x + rng.normal(0.0, 0.1, n), 3.0 * x


def test_validate_appends_the_parameters_findings_as_deficiencies():
    tau, pred = _one_joint_run()
    plain = dynval.validate(tau, pred, n_params=1, sample_rate=100.0)
    sound = dynval.validate(tau, pred, n_params=1, sample_rate=100.0, parameters=body(2.0, (0.1, 0, 0)))
    assert [f.message for f in sound.findings] == [f.message for f in plain.findings]
    assert not any(f.kind == "physical_consistency" for f in plain.findings)
    # ten per link, no names: columns () (no regressor column is named so), the parameters named
    bad_mass = body(2.0)
    bad_mass[0] = -0.5
    report = dynval.validate(tau, pred, n_params=1, sample_rate=100.0, parameters=bad_mass)
    (f,) = [f for f in report.findings if f.kind == "physical_consistency"]
    assert (f.severity, f.joints, f.columns, f.effect) == ("deficiency", (0,), (), 0.5)
    assert f.details["condition"] == "mass > 0" and f.details["parameters"] == [f"link1:{p}" for p in PARAMS]
    assert f.details["parameter_columns"] == list(range(10))
    assert f in report.deficiencies
    assert report.warnings_text == [g.message for g in report.findings]
    severities = [g.severity for g in report.findings]
    assert severities == sorted(severities, key=("deficiency", "design", "note").index)
    assert "physical_consistency" in report.to_json()


def test_validate_reads_a_vector_with_the_regressors_column_names_and_points_at_its_columns():
    tau, pred = _one_joint_run()
    bad = np.concatenate([body(2.0, (0.1, 0, 0), (0.1, 0.1, 0.3)), [0.5, -0.2]])
    regressor = np.random.default_rng(1).normal(size=(tau.size, 1, 12))
    # the regressor's columns in another order: a finding points at the columns of the same names
    order = [11, 10, *range(10)]
    report = dynval.validate(tau, pred, n_params=1, regressor=regressor, column_names=[names()[c] for c in order],
                             parameters=bad[order], joint_names=["j"], max_lag=0)
    found = [f for f in report.findings if f.kind == "physical_consistency"]
    assert [f.details["condition"] for f in found] == ["pseudo-inertia positive semidefinite", "Coulomb friction >= 0"]
    assert all(f.severity == "deficiency" and f.joints == (0,) for f in found)
    assert found[0].effect == pytest.approx(0.1) and found[1].effect == pytest.approx(0.2)
    assert found[0].columns == tuple(range(2, 12)) and found[1].columns == (0,)
    assert found[1].details["parameters"] == ["Fc_j"] and found[1].details["parameter_columns"] == [0]


def test_validate_refuses_parameters_of_more_joints_than_the_data():
    tau, pred = _one_joint_run(200)
    two_links = np.concatenate([body(1.0), body(1.0)])
    with pytest.raises(dynval.InvalidParameter) as info:
        dynval.validate(tau, pred, n_params=1, parameters=two_links, max_lag=0)
    assert str(info.value) == ("parameters must be the parameters of a robot with at most m=1 joints (link k "
                               "moved by joint k, the data's column k), got '2 links and friction on 0 joints'")
    with pytest.raises(dynval.InvalidParameter, match="column_names must be given"):
        dynval.validate(tau, pred, n_params=1, parameters=np.ones(12), max_lag=0)


def test_compare_ranks_a_candidate_that_is_no_robot_after_a_sound_one():
    tau, pred = _one_joint_run()
    no_robot = body(2.0, (0.1, 0, 0), (0.1, 0.1, 0.3))
    candidates = {"a": {"prediction": pred, "n_params": 1, "parameters": no_robot},
                  "b": {"prediction": pred, "n_params": 1, "parameters": body(2.0)}}
    cmp = dynval.compare(tau, candidates, sample_rate=100.0)
    assert cmp.ranking == ["b", "a"] and cmp.verdict.decision == "accept" and cmp.verdict.model == "b"
    assert cmp.table["pooled"]["a"]["n_deficiencies"] == 1
    (reason,) = cmp.reasons["a"]
    assert reason == "joint 1: not a robot: link1 breaks pseudo-inertia positive semidefinite by 0.1 kg·m²"
    # without the parameters the two tie and the name decides
    plain = dynval.compare(tau, {n: {"prediction": pred, "n_params": 1} for n in "ab"}, sample_rate=100.0)
    assert plain.ranking == ["a", "b"]
    # alone, it is refined for what it is
    alone = dynval.compare(tau, {"a": candidates["a"]}, sample_rate=100.0)
    assert alone.verdict.decision == "refine"
    assert [d.kind for d in alone.verdict.decided_by] == ["physical_consistency"]
    with pytest.raises(dynval.InvalidParameter) as info:
        dynval.compare(tau, {"a": (pred, 1)}, parameters=no_robot)
    assert str(info.value) == ("parameters must be given per candidate, not to compare, "
                               "got <float64 array of shape (10,)>")


def test_physical_consistency_checks_level_and_tolerance():
    with pytest.raises(dynval.InvalidParameter, match=r"^level must be a number with 0 < level < 1, got 1.5$"):
        physical_consistency(body(1.0), level=1.5)
    with pytest.raises(dynval.InvalidParameter, match=r"^tolerance must be a finite number >= 0, got -1.0$"):
        physical_consistency(body(1.0), tolerance=-1.0)
    # an integer beyond float64 was a raw OverflowError
    with pytest.raises(dynval.InvalidParameter, match=r"^tolerance must be a finite number >= 0"):
        physical_consistency(body(1.0), tolerance=10**400)
    with pytest.raises(dynval.InvalidParameter, match=r"^level must be a number with 0 < level < 1"):
        physical_consistency(body(1.0), level=10**400)


@needs_pin
def test_kuka_identified_urdf_findings_have_their_sizes_and_reach_validate():
    from dynval.datasets import load_kuka_lwr4
    from dynval.robots import URDFModel

    run = load_kuka_lwr4(3)
    model = URDFModel(run.urdf_identified)
    found = physical_consistency(model)
    coulomb = {f.joints[0]: round(f.effect, 2) for f in found if f.details["condition"] == "Coulomb friction >= 0"}
    assert coulomb == {3: 0.39, 4: 0.47, 5: 1.2, 6: 0.26}                     # N·m, joints lwr_3 … lwr_6
    deficits = [f.effect for f in found if f.details["condition"].startswith("pseudo-inertia")]
    assert len(deficits) == 7 and min(deficits) > 0.014 and max(deficits) < 0.07  # kg·m²
    pred = model.predict(run.q, run.dq, run.ddq)
    report = dynval.validate(run.tau, pred, n_params=84, max_lag=0, parameters=model,
                             joint_names=list(run.joint_names))
    assert [f.message for f in report.findings if f.kind == "physical_consistency"] == [f.message for f in found]
    cad = dynval.validate(run.tau, URDFModel(run.urdf).predict(run.q, run.dq, run.ddq), n_params=0, max_lag=0,
                          parameters=URDFModel(run.urdf))
    assert not any(f.kind == "physical_consistency" for f in cad.findings)


# --------------------------------------------------------------------------- degenerate input


@pytest.mark.parametrize("mass", [5e-324, 1e-310, 1e-200, 1e-100, 1e-30])
def test_a_mass_tiny_against_its_first_moment_is_a_finding_not_an_overflow(mass):
    """h·hᵀ/m beyond float64 (a subnormal mass) was numpy's LinAlgError: no body has such a link."""
    p = body(1.0, c=(0.1, 0.0, 0.2), moments=(0.01, 0.02, 0.02))
    p[0] = mass
    found = physical_consistency(p)
    assert [f.details["condition"] for f in found] == ["pseudo-inertia positive semidefinite"]
    assert found[0].severity == "deficiency" and found[0].effect > 0 and np.isfinite(found[0].effect)
    # the pseudo-inertia is indefinite, and the finding's eigenvalue says so
    assert found[0].details["pseudo_inertia_min_eigenvalue"] < 0
    assert np.linalg.eigvalsh(pseudo_inertia(p))[0] < 0


def test_a_subnormal_mass_with_no_first_moment_is_a_point_body():
    """m = 5e-324 at the origin: J = diag(Σ, m) is positive semidefinite."""
    p = body(1.0, moments=(1.0, 1.0, 1.0))
    p[0] = 5e-324
    assert physical_consistency(p) == []


@pytest.mark.parametrize("mass", [5e-324, 1e-310])
def test_a_centre_of_mass_beyond_float64_is_not_checked_against_its_box(mass):
    """With a box given, h/m overflowed (numpy's RuntimeWarning): the far-centre finding alone says it."""
    p = body(1.0, c=(0.1, 0.0, 0.2), moments=(0.01, 0.02, 0.02))
    p[0] = mass
    found = physical_consistency(p, com_bounds=((-1, -1, -1), (1, 1, 1)))
    assert [f.details["condition"] for f in found] == ["pseudo-inertia positive semidefinite"]
    assert found[0].details["centre_of_mass"] is None


@needs_pin
@pytest.mark.parametrize("attribute, value", [("mass value", "1e308"), ("ixx", "1e300"), ("mass value", "1e145")])
def test_a_urdf_number_beyond_the_data_range_is_non_finite_input(tmp_path, attribute, value):
    """A URDF mass of 1e308 read as 'too small for its first moment': its numbers are data (|x| <= 1e144)."""
    import re

    from dynval.robots import planar_arm_urdf

    path = tmp_path / "arm.urdf"
    path.write_text(re.sub(f'{attribute}="[^"]*"', f'{attribute}="{value}"', planar_arm_urdf(), count=1))
    with pytest.raises(dynval.NonFiniteInput, match="parameters has a value out of range"):
        physical_consistency(str(path))


@pytest.mark.parametrize("scale", [1e-143, 1e-30, 1.0, 1e30, 1e143])
def test_the_verdict_does_not_depend_on_the_size_of_the_body(scale):
    """Zero, negative and huge inertias: the same findings at every scale inside the data range."""
    sound = body(2.0, c=(0.1, 0.0, 0.0), moments=(0.1, 0.2, 0.25))
    flat = body(2.0, moments=(0.1, 0.1, 0.3))             # 0.1 + 0.1 < 0.3: no body
    negative = body(2.0, moments=(-0.1, 0.2, 0.2))
    zero = np.r_[1.0, 0.0, 0.0, 0.0, np.zeros(6)]          # a point mass at the origin: a body
    conditions = [[f.details["condition"] for f in physical_consistency(p * scale)]
                  for p in (sound, flat, negative, zero)]
    psd = ["pseudo-inertia positive semidefinite"]
    assert conditions == [[], psd, psd, []]
    assert [f.details["condition"] for f in physical_consistency(-sound * scale)] == ["mass > 0"]


@pytest.mark.parametrize("value, kind", [
    (np.r_[np.nan, np.ones(9)], dynval.NonFiniteInput),
    (np.r_[1e145, np.ones(9)], dynval.NonFiniteInput),
    (np.array([]), dynval.InvalidParameter),
    (np.ones((2, 10, 1)), dynval.InvalidParameter),
    (np.ones((3, 5)), dynval.InvalidParameter),
    (np.ones(7), dynval.InvalidParameter),
    (1.0, dynval.InvalidParameter),
    (None, dynval.InvalidType),
    ({"m": 1.0}, dynval.InvalidType),
])
def test_malformed_parameters_are_input_errors(value, kind):
    with pytest.raises(kind):
        physical_consistency(value)


@needs_pin
def test_a_urdf_path_is_read_as_its_model(tmp_path):
    """physical_consistency(path) said 'parameters must be an array of real numbers, got object'."""
    from dynval.datasets import load_kuka_lwr4
    from dynval.robots import URDFModel

    run = load_kuka_lwr4(1)
    want = [f.message for f in physical_consistency(URDFModel(run.urdf_identified))]
    assert want
    for given in (run.urdf_identified, str(run.urdf_identified)):
        assert [f.message for f in physical_consistency(given)] == want
        assert [f.message for f in dynval.physical_consistency(given)] == want
    # validate(parameters=path) and a candidate's parameters read it the same way
    rng = np.random.default_rng(0)
    tau = rng.normal(size=(300, 7))
    report = dynval.validate(tau, tau + 0.1 * rng.normal(size=tau.shape), n_params=3, parameters=run.urdf_identified)
    assert sum(f.kind == "physical_consistency" for f in report.findings) == len(want)


@needs_pin
@pytest.mark.parametrize("make, why", [
    (lambda d: d / "missing.urdf", "No such file or directory"),
    (lambda d: d, "not a regular file"),
    (lambda d: (d / "t.urdf").write_text("not xml") and d / "t.urdf", "not URDF XML"),
    (lambda d: (d / "b.urdf").write_bytes(b"\xff\xfe<") and d / "b.urdf", "not URDF XML"),
    (lambda d: (d / "e.urdf").write_text("<robot name='x'/>") and d / "e.urdf", "not a URDF model"),
])
def test_an_unreadable_urdf_path_is_refused_by_name(tmp_path, make, why):
    path = make(tmp_path)
    with pytest.raises(dynval.InvalidParameter, match="the path of a readable URDF file, got") as info:
        physical_consistency(path)
    assert repr(str(path)) in str(info.value) and why in str(info.value)


def _two_link_problem(seed=37, n=300):
    """Two links (one impossible: 0.1 + 0.1 < 0.3) and their friction, columns of unequal sizes."""
    truth = np.concatenate([body(2.0, (0.1, 0.2, -0.1), (0.1, 0.1, 0.3), (0.3, 0.2, 0.1)),
                            body(0.5, (0.0, 0.1, 0.0), (0.01, 0.02, 0.02)), [0.5, -0.4, 0.1, 0.2]])
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, 24)) * np.geomspace(0.1, 30.0, 24)
    cols = ([f"a:{p}" for p in PARAMS] + [f"b:{p}" for p in PARAMS] + ["Fv_j1", "Fc_j1", "Fv_j2", "Fc_j2"])
    return a, a @ truth + rng.normal(0.0, 0.05, n), cols


@needs_cvxpy
def test_the_constrained_fit_does_not_depend_on_the_units():
    # N2: the same data with torques in a unit 1e10 times smaller gave a fit 14 times worse,
    # reported "optimal"; 1e5 moved the parameters by half; 1e-6 raised RuntimeError. The program
    # is solved in working units (contract §8): the torques' unit, and a unit per link (its ten
    # columns alike) or per friction coefficient, scale the answer and change nothing else.
    a, b, cols = _two_link_problem()
    ref = identify(a, b, column_names=cols, physical=True)
    assert ref.physical["status"] == "optimal"

    def rms(full, scale=1.0):
        return float(np.sqrt(np.mean((b - a @ (full * scale)) ** 2)))

    for c in (2.0**33, 1e10, 1e5, 1e-6, 1e-12):
        fit = identify(a, b * c, column_names=cols, physical=True)
        assert fit.physical["status"] == "optimal", c
        full = fit.full_parameters / c
        assert rms(full) == pytest.approx(rms(ref.full_parameters), rel=1e-6), c
        np.testing.assert_allclose(full, ref.full_parameters, rtol=0, atol=1e-3 * np.abs(ref.full_parameters).max())
        assert fit.physical["distance2"] == pytest.approx(ref.physical["distance2"], rel=1e-4, abs=1e-6), c
        if c == 2.0**33:  # a power of two: the same program but for the prior's weights' rounding
            np.testing.assert_allclose(full, ref.full_parameters, rtol=1e-8, atol=0)
    # a unit per link and per friction coefficient, with the Euclidean prior (weighted per column by its
    # link's curvature: one weight for all pulled the others 1e12 times harder) and without it
    s = np.ones(24)
    s[:10], s[10:20], s[21] = 1e6, 2.0**-20, 1e-4  # link a in one unit, link b in another, one friction
    for weight in (1e-6, 0.0):
        ref = identify(a, b, column_names=cols, physical=True, prior_weight=weight)
        fit = identify(a * s, b, column_names=cols, physical=True, prior_weight=weight)
        assert fit.physical["status"] == "optimal", weight
        assert rms(fit.full_parameters, s) == pytest.approx(rms(ref.full_parameters), rel=1e-6)
        assert fit.physical["distance2"] == pytest.approx(ref.physical["distance2"], rel=1e-6)
        np.testing.assert_allclose(fit.full_parameters * s, ref.full_parameters, rtol=0,
                                   atol=1e-3 * np.abs(ref.full_parameters).max())


@needs_cvxpy
def test_the_base_parameters_distance_does_not_depend_on_the_torques_unit():
    # the same program (whitened by the estimate's covariance) behind physical_consistency of a
    # least-squares result: d², its p-value and the binding constraints are unit-free
    a, b, cols = _two_link_problem()
    want = dynval.robots.base_consistency(identify(a, b, column_names=cols))
    assert want.distance2 > 1.0 and want.solver["status"] == "optimal"
    for c in (1e10, 1e-6, 1e-12):
        got = dynval.robots.base_consistency(identify(a, b * c, column_names=cols))
        assert got.solver["status"] == "optimal", c
        assert got.distance2 == pytest.approx(want.distance2, rel=1e-5), c
        assert [label for label, _, _ in got.binding] == [label for label, _, _ in want.binding], c
        np.testing.assert_allclose(got.nearest_full / c, want.nearest_full, rtol=0,
                                   atol=1e-3 * np.abs(want.nearest_full).max())


def test_an_optimal_answer_that_the_clip_moves_is_not_called_optimal():
    # A solver that stops "optimal" with a pseudo-inertia well outside the cone (what tiny units did
    # to Clarabel) is clipped into it; when the clip raises the fit's sum of squares beyond 1e-6 of
    # it, the status says so instead of repeating the solver's "optimal".
    from dynval.report import _consistency

    rng = np.random.default_rng(41)
    g = rng.normal(size=(12, 12))
    inside = np.concatenate([body(2.0, (0.1, 0.0, 0.0), (0.1, 0.2, 0.25)), [0.5, 0.4]])
    outside = np.concatenate([body(2.0, (0.1, 0.2, -0.1), (0.1, 0.1, 0.3), (0.3, 0.2, 0.1)), [0.5, -0.4]])
    lay = _consistency.layout(names())
    for pi, expected in ((inside, "optimal"), (outside, "optimal_inaccurate")):
        # the data's own least-squares point, returned as the constrained optimum
        got = _consistency._checked_status("optimal", g, g @ pi, pi, _consistency._clip(pi, lay))
        assert got == expected
    assert _consistency._checked_status("optimal_inaccurate", g, g @ inside, inside, inside) == "optimal_inaccurate"
