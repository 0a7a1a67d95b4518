"""The physics test on sufficient statistics against a computation on the whitened rows.

:mod:`dynval.statistics._physics` fits every group, selection step and Wald test on R of a QR of
each joint's whitened columns (the rows only for the HC1 meat and the raw residual's sum of
squares). Here the same test is computed from the rows, as it was before: the bases by SVD of the
whitened rows, every fit by ``numpy.linalg.lstsq`` on them, the residual and its sums of squares on
the rows (and one Wald statistic by statsmodels' HC1 OLS). The two must agree on what is named (the
groups kept, the selection, the term, the degrees of freedom) and, within the tolerance stated in
docs/conventions.md (§5.2, "Computed on sufficient statistics"), on the statistics, p-values and
shares: on the calibration scenarios (a right model under jittered stamps, a missing Coulomb
friction, a decoupled model of a coupled arm, the model's columns refitted or its Cov(π̂)
known), the demo, and the KUKA LWR4+ run 3 (7 joints) when pinocchio is installed.

Mutations caught: a group's rank decision, a lost nuisance projection or the Cov(π̂) term left out
of the compressed path, the HC1 scale, a wrong column of a map from R to the rows, a selection
scored on other columns, a share or N_eff taken from the whitened instead of the raw residual.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.stats

import dynval
from dynval import scenarios
from dynval.statistics import _physics

STAT_RTOL = 1e-5  # statistics and p-values (measured at most 1.1e-6 and 4e-6); conventions §5.2
SHARE_RTOL = 1e-7  # shares and N_eff (measured at most 8e-9)
P_FLOOR = 1e-12  # p-values below it are compared on their statistics only


# --------------------------------------------------------------------------- the reference, on rows

def _basis(x, rel, floor=0.0):
    if x.shape[1] == 0:
        return x
    u, s, _ = np.linalg.svd(x, full_matrices=False)
    return u[:, (s > rel * max(s[0], 1e-300)) & (s > floor)]


def _reference_wald(x, yw, idx, gw, cov_p):
    """HC1 Wald statistic of x's columns ``idx`` in the OLS of yw on x, all on the rows (score form)."""
    n, k = x.shape
    b = np.linalg.lstsq(x, yw, rcond=None)[0]
    r = yw - x @ b
    other = np.delete(np.arange(k), idx)
    xt = x[:, idx]
    if other.size:
        xt = xt - x[:, other] @ np.linalg.lstsq(x[:, other], xt, rcond=None)[0]
    score = xt.T @ yw
    h = xt * r[:, None]
    meat = h.T @ h * (n / max(n - k, 1))
    if gw is not None and cov_p is not None:
        meat = meat + (xt.T @ gw) @ cov_p @ (xt.T @ gw).T
    return float(score @ np.linalg.pinv(meat) @ score)


def _reference_fit(ej, nz, lib, a, alpha, g, cov_p):
    w = lambda x: _physics._whiten(x, a)  # noqa: E731
    ew, nzw = w(ej), w(nz)
    gw = None if g is None else w(g)
    basis = _basis(nzw, 1e-7) if nzw.shape[1] else nzw
    perp = (lambda x: x - basis @ (basis.T @ x)) if basis.shape[1] else (lambda x: x)
    yw = perp(ew)
    names, blocks = [], []
    for name, x in lib.items():
        xw = w(x)
        b = _basis(perp(xw), 1e-6, 0.01 * float(np.sqrt(np.max(np.sum(xw * xw, axis=0)))))
        if b.shape[1]:
            names.append(name)
            blocks.append(b)
    if not blocks:
        return None
    xall = np.hstack(blocks)
    n, k = xall.shape
    wald = _reference_wald(xall, yw, np.arange(k), gw, cov_p)
    df2 = max(n - k - basis.shape[1], 1)
    edges = np.cumsum([0] + [b.shape[1] for b in blocks])
    selected: list[int] = []
    while len(selected) < len(blocks):
        best = None
        for i in [i for i in range(len(blocks)) if i not in selected]:
            order = selected + [i]
            cols = np.concatenate([np.arange(edges[s], edges[s + 1]) for s in order])
            ki = blocks[i].shape[1]
            wi = _reference_wald(xall[:, cols], yw, np.arange(cols.size - ki, cols.size), gw, cov_p)
            pi = float(scipy.stats.chi2.sf(wi, ki))
            if best is None or pi < best[1] or (pi == best[1] and wi / ki > best[2]):
                best = (i, pi, wi / ki)
        if best is None or best[1] > alpha / len(blocks):
            break
        selected.append(best[0])
    return {"names": names, "f": wald / k, "k": k, "df2": df2, "pvalue": float(scipy.stats.f.sf(wald / k, k, df2)),
            "selected": selected}


def _reference_joint(j, ej, lib, nz, alpha, g, cov_p):
    """The joint's test as :func:`dynval.statistics._physics._joint_test` defines it, on the rows."""
    n = ej.shape[0]
    total = float(ej @ ej)
    nz = np.zeros((n, 0)) if nz is None else np.asarray(nz, float).reshape(n, -1)
    a, _ = _physics._ar_prewhitener(ej, min(2, n // 50))
    fit = _reference_fit(ej, nz, lib, a, alpha, g, cov_p)
    assert fit is not None
    if fit["selected"]:
        chosen = np.hstack([nz] + [lib[fit["names"][s]] for s in fit["selected"]])
        a, _ = _physics._ar_prewhitener(ej - chosen @ np.linalg.lstsq(chosen, ej, rcond=None)[0], min(2, n // 50))
        fit = _reference_fit(ej, nz, lib, a, alpha, g, cov_p) or fit
    names = fit["names"]
    ew = _physics._whiten(ej, a)

    def sse(groups):
        cols = np.hstack([nz] + [lib[names[i]] for i in groups])
        if cols.shape[1] == 0:
            return total, np.zeros(0)
        coef = np.linalg.lstsq(_physics._whiten(cols, a), ew, rcond=None)[0]
        return float(np.sum((ej - cols @ coef) ** 2)), coef

    base, _ = sse([])
    full, coef = sse(range(len(names)))
    _, n_eff = _physics._ar_prewhitener(ej - np.hstack([nz] + [lib[x] for x in names]) @ coef, min(2, n // 50))
    out = dict(fit, share=max(0.0, (base - full) / total), n_eff=n_eff, ar_order=int(a.size), alone={}, shares={})
    if fit["selected"]:
        sel = fit["selected"]
        fit_all, _ = sse(sel)
        out["shares"] = {names[s]: max(0.0, (sse([t for t in sel if t != s])[0] - fit_all) / total) for s in sel}
        out["alone"] = {names[i]: max(0.0, (base - sse([i])[0]) / total) for i in range(len(names))}
    return out


# --------------------------------------------------------------------------- the cases

def _captured(monkeypatch, run):
    """The physics_test calls ``run`` makes (args, kwargs)."""
    calls = []
    real = _physics.physics_test

    def spy(*args, **kwargs):
        calls.append((args, kwargs))
        return real(*args, **kwargs)

    monkeypatch.setattr(_physics, "physics_test", spy)
    run()
    monkeypatch.undo()
    assert calls
    return calls


def _close(new, ref, what, rtol=SHARE_RTOL):
    assert math.isclose(new, ref, rel_tol=rtol, abs_tol=1e-12), f"{what}: {new} against {ref} from the rows"


def _compare_call(args, kwargs):
    e, pred, q, dq, ddq = args
    assert e.shape[0] <= _physics._MAX_ROWS  # no decimation in these cases: the same rows on both sides
    # the rows at the logged rate on both sides: without the band, which would decimate the
    # 500 Hz scenario (decimated against not: tests/test_physics_decimation.py)
    kwargs = {k: v for k, v in kwargs.items() if k != "band"}
    tests = _physics.physics_test(*args, **kwargs)
    libs = kwargs.get("libraries")
    checked = 0
    for j, t in enumerate(tests):
        lib = libs[j] if libs is not None else _physics.library(j, q, dq, ddq, pred[:, j], kwargs.get("sample_rate"))
        nz = None if kwargs.get("nuisance") is None else kwargs["nuisance"][j]
        g = None if kwargs.get("model_regressor") is None else kwargs["model_regressor"][:, j, :]
        if not float(e[:, j] @ e[:, j]) > 0:
            continue
        ref = _reference_joint(j, e[:, j], lib, nz, kwargs["alpha"], g, kwargs.get("parameter_covariance"))
        where = f"joint {j}"
        assert t.selected == [ref["names"][s] for s in ref["selected"]], where
        assert t.df == (ref["k"], ref["df2"]) and t.ar_order == ref["ar_order"], where
        _close(t.statistic, ref["f"], f"{where} F", STAT_RTOL)
        if ref["pvalue"] > P_FLOOR:
            _close(t.pvalue, ref["pvalue"], f"{where} p-value", STAT_RTOL)
        else:
            assert t.pvalue <= 10 * P_FLOOR, where
        _close(t.share, ref["share"], f"{where} share")
        _close(t.n_eff, ref["n_eff"], f"{where} N_eff")
        assert set(t.shares) == set(ref["shares"]), where
        for name, v in ref["shares"].items():
            _close(t.shares[name], v, f"{where} share of {name}")
        if ref["alone"]:
            top = max(ref["alone"].values())
            # conventions §5.2: at least 80 % of the best share, leaving at most 1.5× what it leaves + 0.01
            near = [x for x, v in ref["alone"].items() if v >= 0.8 * top and 1 - v <= 1.5 * (1 - top) + 0.01]
            named = min(near, key=lambda x: (lib[x].shape[1], -ref["alone"][x]))
            assert t.term == named or t.refit_run is not None, where
        checked += 1
    return checked


SCENARIOS = ["right:jitter:arm4@500", "no_coulomb:white:anthro3@500", "no_coulomb:ar0.9:planar2@100",
             "decoupled:white:arm4@100"]


@pytest.mark.parametrize("key", SCENARIOS)
@pytest.mark.parametrize("offered", [True, False])
def test_the_compressed_test_equals_the_rows_on_calibration_scenarios(monkeypatch, key, offered):
    s = next(x for x in scenarios.library() if x.key == key)
    rep = scenarios.simulate(s, 0)
    calls = _captured(monkeypatch, lambda: scenarios.validate_replicate(rep, offered))
    assert sum(_compare_call(*c) for c in calls) >= 2


def test_the_compressed_test_equals_the_rows_with_the_models_columns_refitted(monkeypatch):
    # a regressor without the estimation run: the model's columns are nuisance refitted on the run
    s = next(x for x in scenarios.library() if x.key == "no_coulomb:white:anthro3@500")
    rep = scenarios.simulate(s, 0)
    cols = list(rep.model_columns)
    pi, rank = scenarios.fit(rep)
    val = rep.validation
    pred = val.regressor[:, :, cols] @ pi

    def run():
        dynval.validate(val.tau, pred, n_params=rank, regressor=val.regressor[:, :, cols], q=val.q,
                        sample_rate=s.sample_rate)

    calls = _captured(monkeypatch, run)
    assert calls[0][1].get("nuisance") is not None
    assert _compare_call(*calls[0]) == val.q.shape[1]


def test_the_compressed_test_equals_the_rows_on_the_demo(monkeypatch):
    from dynval.demo import run_demo

    calls = _captured(monkeypatch, lambda: run_demo("friction", progress=None))
    assert sum(_compare_call(*c) for c in calls) >= 2


def test_the_compressed_test_equals_the_rows_on_the_kuka_run(monkeypatch):
    pytest.importorskip("pinocchio")
    from dynval.datasets import load_kuka_lwr4
    from dynval.robots import URDFModel

    run = load_kuka_lwr4(3)
    cad = URDFModel(run.urdf)
    y = cad.regressor(run.q, run.dq, run.ddq)[:, :, :84]
    active = np.flatnonzero(np.any(y.reshape(-1, 84) != 0, axis=0))

    def validate():
        dynval.validate(run.tau, cad.predict(run.q, run.dq, run.ddq), n_params=0, regressor=y[:, :, active],
                        q=run.q, dq=run.dq, ddq=run.ddq, time=run.time)

    calls = _captured(monkeypatch, validate)
    assert _compare_call(*calls[0]) == 7


def test_one_wald_statistic_equals_statsmodels_hc1():
    # the full test of a joint without the model's columns: statsmodels' OLS with HC1 on the whitened
    # rows and the groups' orthonormal blocks gives the same Wald statistic as the compressed path
    sm = pytest.importorskip("statsmodels.api")
    rng = np.random.default_rng(3)
    n = 3000
    t = np.arange(n) / 200.0
    q = np.column_stack([np.sin(0.7 * t), 0.5 * np.sin(1.3 * t + 1.0)])
    dq = np.gradient(q, 1 / 200.0, axis=0)
    ddq = np.gradient(dq, 1 / 200.0, axis=0)
    e = 0.3 * np.sign(dq[:, 0]) + rng.normal(size=n) * (1 + 0.5 * np.abs(q[:, 0]))
    lib = _physics.library(0, q, dq, ddq, e, 200.0)
    a, _ = _physics._ar_prewhitener(e, 2)
    fit = _physics._whitened_fit(_physics._Compressed(_physics._Stack(e, np.zeros((n, 0)), lib), a), 0.05)
    blocks = []
    for x in lib.values():
        xw = _physics._whiten(x, a)
        blocks.append(_basis(xw, 1e-6, 0.01 * float(np.sqrt(np.max(np.sum(xw * xw, axis=0))))))
    x = np.hstack(blocks)
    res = sm.OLS(_physics._whiten(e, a), x).fit(cov_type="HC1")
    wald = res.wald_test(np.eye(x.shape[1]), scalar=True, use_f=False).statistic
    assert fit["k"] == x.shape[1]
    assert fit["f"] * fit["k"] == pytest.approx(float(wald), rel=1e-6)


@pytest.mark.parametrize("case", ["plain", "zero column", "dependent columns", "no model columns"])
def test_the_kinds_outside_the_models_span_from_one_qr_equal_the_svd_of_the_rows(case):
    # outside_fractions (R of one QR of the model's and the groups' columns) against span_basis's
    # SVD of the rows and outside_fraction on them; zero and repeated columns as a serial arm has
    from dynval.statistics import _model_terms

    rng = np.random.default_rng(5)
    n = 5000  # more than one piece of the QR
    y = rng.normal(size=(n, 8)) * rng.uniform(0.01, 100.0, 8)
    if case == "zero column":
        y[:, 3] = 0.0
    elif case == "dependent columns":
        y[:, 5] = 3.0 * y[:, 1] + y[:, 2]
    elif case == "no model columns":
        y = np.zeros((n, 0))
    inside = y[:, 0] if y.size else np.ones(n)
    groups = {"in": np.column_stack([inside, rng.normal(size=n)]), "offset": np.ones((n, 1)),
              "half": np.column_stack([inside + rng.normal(size=n), np.zeros(n)])}
    got = _model_terms.outside_fractions(y, groups)
    basis = _model_terms.span_basis(y)
    for g, cols in groups.items():
        np.testing.assert_allclose(got[g], _model_terms.outside_fraction(basis, cols), rtol=0, atol=1e-12)
