"""Cov(π̂) under the alternative (conventions §5.2 "Cov(π̂) under the alternative"): the physics
test's widening takes the covariance of the noise the estimation run leaves once the structure its
own test finds there is removed, not the covariance of a residual that holds the missing term.

Each test names the mutation it kills."""

from __future__ import annotations

import numpy as np
import pytest

from dynval import scenarios
from dynval.statistics import _estimation


def _runs(seed=0, n=3000, amplitude=5.0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 100.0
    reg = np.zeros((n, 2, 3))
    reg[:, 0, 0] = np.sin(2 * np.pi * 0.7 * t)
    reg[:, 1, 1] = np.cos(2 * np.pi * 1.1 * t)
    reg[:, :, 2] = np.sign(np.sin(2 * np.pi * 0.3 * t))[:, None]
    noise = 0.1 * rng.standard_normal((n, 2))
    tau = reg @ np.array([1.0, -2.0, 0.5]) + noise
    slow = np.sin(2 * np.pi * 0.05 * t + 0.3)  # a slow term the model lacks, on joint 1
    with_term = tau.copy()
    with_term[:, 1] += amplitude * slow
    return reg, tau, with_term, slow[:, None]


def test_the_noise_covariance_is_the_one_without_the_missing_term():
    """Kills: the structure not removed (the sandwich of the residual that holds the term, orders of
    magnitude wider), or removed from the wrong joint."""
    reg, tau, with_term, slow = _runs()
    clean = _estimation.fit_columns(reg, tau, [0, 1, 2])
    bent = _estimation.fit_columns(reg, with_term, [0, 1, 2])
    assert np.trace(bent.covariance) > 20 * np.trace(clean.covariance)  # the premise
    got = _estimation.noise_covariance(bent, reg, [None, slow])
    assert np.diag(got) == pytest.approx(np.diag(clean.covariance), rel=0.01)
    wrong_joint = _estimation.noise_covariance(bent, reg, [slow, None])
    assert np.trace(wrong_joint) > 20 * np.trace(clean.covariance)


def test_no_structure_leaves_the_estimation_covariance():
    """Kills: the dof scale or a projection applied to joints with nothing to remove."""
    reg, tau, _, _ = _runs(seed=1)
    fit = _estimation.fit_columns(reg, tau, [0, 1, 2])
    np.testing.assert_allclose(_estimation.noise_covariance(fit, reg, [None, None]), fit.covariance,
                               rtol=1e-12, atol=0.0)


def _report(key, replicate):
    s = next(x for x in scenarios.library() if x.key == key)
    rep = scenarios.simulate(s, replicate)
    return scenarios.validate_replicate(rep, False, prediction=scenarios.fit(rep))


def test_a_gravity_only_model_is_not_excused_by_its_own_misfit():
    """gravity_only:white:arm7@100 replicate 0: the last joint's residual, 99.96 % of it removed by
    the library, tested at p ≈ 1 with the estimation fit's covariance (a model lacking every
    inertial term leaves them in its estimation residual, read there as coloured noise).
    Kills: the estimation fit's covariance passed to the physics test."""
    report = _report("gravity_only:white:arm7@100", 0)
    physics = report.to_dict()["physics"]
    last = physics["tests"][6]
    assert last["pvalue"] < 1e-6
    assert "selects" in physics["model_columns"] and "inertia" in physics["model_columns"]
    assert report.deciding[0].finding.kind == "missing_physics"


def test_a_right_model_keeps_the_estimation_covariance(monkeypatch):
    """The estimation run's own test selects nothing for a right model: the widening is the
    estimation fit's, and the physics section is the one the estimation fit's covariance gives.
    Kills: a structure removed where its test found none (every group taken, a level of 1)."""
    from dynval.statistics import _term_refit

    physics = _report("right:white:arm6@200", 0).to_dict()["physics"]
    assert "selects" not in physics["model_columns"]
    monkeypatch.setattr(_term_refit, "alternative_covariance", lambda *a, **k: None)
    plain = _report("right:white:arm6@200", 0).to_dict()["physics"]
    assert [t["pvalue"] for t in physics["tests"]] == [t["pvalue"] for t in plain["tests"]]


def test_the_parameters_a_missing_term_bent_are_cleared_on_every_joint():
    """gravity_only:white:arm6@200 replicate 4: the estimation run's test selects inertia and gravity
    on some joints; the last wrist's residual there is the error of parameters the missing inertia
    bent. With the groups on the selected joints alone its widening stayed, the wrist tested at
    p = 0.31 and a correlation with its own column led. Kills: a rigid-body group taken only on the
    joints where it was selected."""
    report = _report("gravity_only:white:arm6@200", 4)
    assert report.to_dict()["physics"]["tests"][5]["pvalue"] < 1e-6
    first = report.deciding[0].finding
    assert first.kind == "missing_physics" and first.details["term"] == "inertia"


def test_the_refit_is_the_stacked_least_squares():
    """The normal equations assembled joint by joint give the residual of numpy's least squares on
    the stacked design [model columns | each joint's structure on its rows], scaled by the rank the
    structure adds. Kills: a block on the wrong joint's rows, the model's columns left out of the
    refit, the rank scale dropped."""
    reg, _, with_term, slow = _runs(seed=3)
    fit = _estimation.fit_columns(reg, with_term, [0, 1, 2])
    rng = np.random.default_rng(4)
    structure = [rng.standard_normal((reg.shape[0], 2)), np.hstack([slow, slow ** 2])]
    n, m, k = reg.shape
    design = np.zeros((n, m, k + 4))
    design[:, :, :k] = reg
    design[:, 0, k:k + 2] = structure[0]
    design[:, 1, k + 2:] = structure[1]
    flat = design.reshape(n * m, -1)
    coef, _, rank, _ = np.linalg.lstsq(flat, fit.residual.reshape(-1), rcond=None)
    left = (fit.residual.reshape(-1) - flat @ coef).reshape(n, m) * np.sqrt(n * m / (n * m - (rank - 3)))
    expected = _estimation._sandwich(reg, left)[0]
    np.testing.assert_allclose(_estimation.noise_covariance(fit, reg, structure), expected, rtol=1e-7, atol=0.0)
