"""The regressor's shared factorisation (docs/conventions.md §6): one R factor per joint block for the
spectrum's range projection, the excitation section and the kinds the model spans without q, and the
colour band's regressor half kept as its columns' transforms. Every expected value here comes from a
plain route on the N rows (numpy's SVD and least squares, direct lagged sums), never from the code
under test, and each tolerance is the one conventions §6 states."""

from __future__ import annotations

import numpy as np
import pytest

import dynval
from dynval import calibration as C
from dynval import simulate as sim
from dynval.report import _motion
from dynval.report import _regressor_algebra as ra
from dynval.statistics import _model_terms, _stats

# conventions §6, the regressor's shared factorisation
PROJECTION_TOL = 1e-11  # the projected residual, relative to ‖b‖, against the exact (SVD) projection
SPECTRUM_RTOL = 1e-9  # the spectrum's power per bin (plus 1e-12 of the joint's largest) and its p-values
DESIGN_RTOL = 1e-10  # the design section's condition numbers
FRACTION_TOL = 1e-10  # the span fractions (absolute)
COLOUR_TOL = 1e-12  # the colour band's sums Σ ρ_e(j) w_j ρ_y(j) (absolute)


def _block(singular_values, n=2000, seed=3):
    """An (n, k) block with these singular values."""
    rng = np.random.default_rng(seed)
    u, _ = np.linalg.qr(rng.normal(size=(n, len(singular_values))))
    v, _ = np.linalg.qr(rng.normal(size=(len(singular_values),) * 2))
    return (u * np.asarray(singular_values)) @ v.T


def _svd_residual(y, b):
    """b less its projection on y's numerical range, lstsq's rank (rcond=None), by numpy's SVD."""
    u, s, _ = np.linalg.svd(y, full_matrices=False)
    rank = int(np.sum(s > np.finfo(float).eps * max(y.shape) * s[0]))
    return b - u[:, :rank] @ (u[:, :rank].T @ b), rank


@pytest.mark.parametrize("span", [1e2, 1e4, 1e6, 1e7, 1e9])
def test_the_range_projection_from_a_kept_r_is_the_svd_projection(span):
    # Twelve kept singular values spanning `span` and two exactly dependent columns. The basis is
    # y V_r S_r^-1 from the R factor when the span is at most 1e6 and the Householder basis beyond:
    # either way within 1e-11 of ‖b‖ (y V_r S_r^-1 alone misses it from a span of 1e7 on).
    y = _block(list(np.geomspace(1.0, 1.0 / span, 12)) + [0.0, 0.0])
    b = np.random.default_rng(4).normal(size=y.shape[0])
    r = np.linalg.qr(y, mode="r")  # any R of y will do: only RᵀR is read
    expected, rank = _svd_residual(y, b)
    proj = ra.RangeProjection(y, r)
    assert proj.rank == rank == np.linalg.lstsq(y, b, rcond=None)[2] == 12
    assert np.max(np.abs(proj.residual(b) - expected)) <= PROJECTION_TOL * np.linalg.norm(b)


def test_the_range_projection_factors_the_block_when_its_basis_is_not_positive_definite(monkeypatch):
    # Should the Cholesky QR of y V_r S_r^-1 fail, the block's own Householder QR gives the basis.
    y = _block([1.0, 0.1, 0.01, 0.0])
    b = np.random.default_rng(6).normal(size=y.shape[0])

    def refuse(a):
        raise np.linalg.LinAlgError("not positive definite")

    monkeypatch.setattr(np.linalg, "cholesky", refuse)
    proj = ra.RangeProjection(y, np.linalg.qr(y, mode="r"))
    expected, rank = _svd_residual(y, b)
    assert proj.rank == rank == 3
    assert np.max(np.abs(proj.residual(b) - expected)) <= PROJECTION_TOL * np.linalg.norm(b)


def _singular_run(seed=0, n=1200):
    """A 2-joint arm's regressor with a column that is the sum of the others (every joint block and
    the stack singular), torques from it, and a prediction that misses part of them."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 100.0
    q, dq, ddq = C._trajectory(rng, t)
    y0 = sim.regressor(q, dq, ddq)
    y = np.ascontiguousarray(np.concatenate([y0, y0.sum(axis=2, keepdims=True)], axis=2))
    pi = sim.base_parameters(sim.DEFAULT_ARM)
    tau = y0 @ pi + 0.3 * np.sin(2 * np.pi * 7.0 * t)[:, None] + rng.normal(0.0, 0.2, (n, 2))
    return y, tau, y0 @ (pi * 1.05)


def test_the_spectrum_of_a_singular_regressor_is_welch_of_the_lstsq_residual():
    y, tau, pred = _singular_run()
    rep = dynval.validate(tau, pred, n_params=10, regressor=y, sample_rate=100.0, max_lag=20)
    e = tau - pred
    x = np.column_stack([e[:, j] - y[:, j, :] @ np.linalg.lstsq(y[:, j, :], e[:, j], rcond=None)[0]
                         for j in range(y.shape[1])])
    expected = _stats.residual_spectrum(x, np.zeros(1, dtype=np.int64), sample_rate=100.0)
    power = np.asarray(rep.spectrum["power"])
    np.testing.assert_allclose(power, expected.power, rtol=SPECTRUM_RTOL, atol=1e-12 * expected.power.max())
    got = {(p["joint"], p["frequency"]): p["pvalue"] for p in rep.spectrum["peaks"]}
    want = {(p["joint"], p["frequency"]): p["pvalue"] for p in expected.peaks}
    assert got and set(got) <= set(want)
    for key, pvalue in got.items():
        assert pvalue == pytest.approx(want[key], rel=SPECTRUM_RTOL, abs=1e-300)


def test_the_design_sections_condition_numbers_are_the_svd_ones():
    # The stack is singular, so the excitation takes R of the joints' R factors (not its Gram matrix).
    y, tau, pred = _singular_run(1)
    exc = dynval.validate(tau, pred, n_params=10, regressor=y, max_lag=10).design["excitation"]
    stacked = y.reshape(-1, y.shape[2])
    dropped = set(exc["inseparable"]) | set(exc["unexcited"])
    kept = [c for c in range(stacked.shape[1]) if c not in dropped]
    assert exc["inseparable"] == [stacked.shape[1] - 1]  # the sum column, the last of its dependent set
    raw = np.linalg.svd(stacked[:, kept], compute_uv=False)
    scaled = np.linalg.svd(stacked[:, kept] / np.linalg.norm(stacked[:, kept], axis=0), compute_uv=False)
    assert exc["condition_raw"] == pytest.approx(raw[0] / raw[-1], rel=DESIGN_RTOL)
    assert exc["condition_scaled"] == pytest.approx(scaled[0] / scaled[-1], rel=DESIGN_RTOL)


def _kinds_regressor(n=3000, seed=5):
    """Three joints: joint 0 holds a constant column (an offset), joint 1 a ramp (a drift) beside
    smooth columns, joint 2 smooth columns only, and a column that is zero on joint 0."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 200.0
    y = np.zeros((n, 3, 6))
    for j in range(3):
        for c in range(4):
            y[:, j, c] = np.sin(2 * np.pi * rng.uniform(0.2, 3.0) * t + rng.uniform(0, 6)) * rng.uniform(0.5, 4.0)
    y[:, 0, 4] = 2.5  # an offset column on joint 0
    y[:, 1, 5] = np.linspace(-2.0, 2.0, n) + 0.05 * np.sin(7.0 * t)  # nearly a ramp on joint 1
    y[:, 2, 4] = 1e-3 * np.cos(3.0 * t)  # small but not zero on joint 2
    y[:, 1, 4] = 0.3 * np.sin(2.0 * t) + 0.2  # partly offset on joint 1 (fraction outside ≈ 0.7)
    return y


def _plain_fractions(y_j, n):
    """The span fractions on the N rows, by numpy's SVD: each library column's fraction outside the
    model's unit-RMS columns' span (singular values above 1e-8 of the largest), and each model
    column's fraction outside each group's span."""
    rms = np.sqrt(np.mean(y_j * y_j, axis=0))
    active = rms > 1e-12 * rms.max()
    u, s, _ = np.linalg.svd(y_j[:, active] / rms[active], full_matrices=False)
    basis = u[:, s > 1e-8 * s[0]]
    t = (np.arange(n) - 0.5 * (n - 1)) / (n - 1)
    lib = {"offset": np.ones((n, 1)), "drift": np.column_stack([t, t * t - np.mean(t * t)])}
    outside = {}
    inside_group = {}
    for g, cols in lib.items():
        left = cols - basis @ (basis.T @ cols)
        outside[g] = np.linalg.norm(left, axis=0) / np.linalg.norm(cols, axis=0)
        live = y_j[:, rms > 0]
        fit = cols @ np.linalg.lstsq(cols, live, rcond=None)[0]
        inside_group[g] = np.linalg.norm(live - fit, axis=0) / np.linalg.norm(live, axis=0)
    return outside, inside_group


def test_the_kinds_spanned_without_q_are_the_n_rows_ones():
    y = _kinds_regressor()
    n, m, p = y.shape
    cols = list(range(p))
    kinds = ra.kinds_without_q(y, cols, None)
    for j in range(m):
        y_r, lib_r = ra.span_coordinates(y, j, cols)
        assert y_r.shape[0] <= p + 3  # R's rows, not the N rows
        outside, inside_group = _plain_fractions(y[:, j, :], n)
        got = _model_terms.outside_fractions(y_r, lib_r)
        for g in ("offset", "drift"):
            np.testing.assert_allclose(got[g], outside[g], rtol=0, atol=FRACTION_TOL)
            got_in = _model_terms.outside_fraction(_model_terms.span_basis(lib_r[g]), y_r)
            np.testing.assert_allclose(got_in, inside_group[g], rtol=0, atol=FRACTION_TOL)
            spanned = bool(np.any(outside[g] <= _model_terms.SPAN_TOLERANCE)
                           or np.any(inside_group[g] <= _model_terms.SPAN_TOLERANCE))
            assert kinds[j][g] is spanned, (j, g)
    assert [k["offset"] for k in kinds] == [True, False, False]
    assert [k["drift"] for k in kinds] == [False, True, False]


def _plain_colour_sums(x, bounds, big, rho_e, p):
    """Σ_{j=1..J} ρ_e(j) w_j ρ_y(j) per column of x, by direct lagged sums within each segment
    (overall means; nan ρ_y, a constant or zero column, as 0)."""
    xc = x - x.mean(axis=0)
    acov = np.zeros((big + 1, x.shape[1]))
    for a, b in zip(bounds[:-1], bounds[1:]):
        for lag in range(min(big, b - a - 1) + 1):
            acov[lag] += np.einsum("ij,ij->j", xc[a + lag:b], xc[a:b - lag])
    w = 1.0 - np.arange(1, big + 1) / (big + 1.0)
    out = np.zeros(x.shape[1])
    for c in range(x.shape[1]):
        if acov[0, c] > 0:
            out[c] = np.sum(rho_e[1:, c // p] * w * acov[1:, c] / acov[0, c])
    return out


@pytest.mark.parametrize("starts", [[0], [0, 700, 1500]], ids=["one segment", "three segments"])
def test_the_colour_bands_regressor_half_from_transforms_is_the_lagged_sums(starts):
    rng = np.random.default_rng(8)
    n, m, p, big = 2000, 2, 4, 150
    x = np.cumsum(rng.normal(size=(n, m * p)), axis=0) * 0.05 + rng.normal(size=(n, m * p))
    x[:, 1] = 0.0  # a zero column
    x[:, 6] = 3.0  # a constant column
    rho_e = np.vstack([np.ones(m), 0.9 ** np.arange(1, big + 1)[:, None] * np.array([1.0, -0.5])])
    bounds = starts + [n]
    live = np.flatnonzero(np.any(x != 0, axis=0))
    powers = _stats.column_powers(x, np.asarray(starts, dtype=np.int64), big, m, live)
    got = powers.weighted_sums(rho_e).ravel()
    np.testing.assert_allclose(got, _plain_colour_sums(x, bounds, big, rho_e, p), rtol=0, atol=COLOUR_TOL)
    assert got[1] == got[6] == 0.0


def _findings(report):
    return [(f.kind, f.severity, tuple(f.joints), tuple(f.columns), f.action) for f in report.findings]


def test_the_shared_routes_give_the_findings_of_the_row_routes(monkeypatch):
    # The same comparison with each shared route replaced by its route on the N rows (the block's
    # Householder basis, the lag-domain autocorrelations of the columns, the kinds' QR of the rows):
    # the same findings (with the bias finding's words, which the kinds decide) and verdict, and the
    # numbers within the tolerances above.
    y, tau, pred = _singular_run(2)
    cands = {"scaled": (pred, 10), "offset": (pred + 0.4, 10), "right": (y[:, :, :-1] @ sim.base_parameters(
        sim.DEFAULT_ARM), 10)}
    shared = dynval.compare(tau, cands, regressor=y, sample_rate=100.0, max_lag=150)

    def lag_domain(x, starts, big, m, live=None, largest=None):
        return _stats.weighted_column_acf(_stats.acf_fft(x, starts, big, live=live).reshape(big + 1, m, -1))

    def row_kinds(reg3, cols, declared, memo):
        n, m = reg3.shape[:2]
        libraries = [_model_terms.library_for(j, None, None, None, n, None) for j in range(m)]
        return _model_terms.model_kinds(np.zeros((n, m)), reg3, cols, libraries, declared)

    monkeypatch.setattr(ra, "_BASIS_COND", 0.0)
    monkeypatch.setattr(_stats, "column_powers", lag_domain)
    monkeypatch.setattr(_motion, "kinds_without_q", row_kinds)
    rows = dynval.compare(tau, cands, regressor=y, sample_rate=100.0, max_lag=150)
    assert (shared.verdict.decision, shared.verdict.model) == (rows.verdict.decision, rows.verdict.model)
    assert shared.ranking == rows.ranking
    for name in cands:
        a, b = shared.reports[name], rows.reports[name]
        assert _findings(a) == _findings(b) and _findings(a)
        np.testing.assert_allclose(a.spectrum["power"], b.spectrum["power"], rtol=SPECTRUM_RTOL,
                                   atol=1e-12 * np.max(b.spectrum["power"]))
        np.testing.assert_allclose(a.cross_correlation["colour_factor"], b.cross_correlation["colour_factor"],
                                   rtol=1e-10)
