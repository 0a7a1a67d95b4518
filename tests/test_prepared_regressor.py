"""dynval.prepare_regressor: the regressor's residual-independent work done once, the same reports."""

from __future__ import annotations

import numpy as np
import pytest

import dynval
from dynval import calibration as C
from dynval import simulate as sim
from dynval.report import _motion, _regressor_algebra, _sections

NAMES = list(sim.PARAMETER_NAMES)
NO_FC = [i for i, n in enumerate(NAMES) if not n.startswith("Fc")]


def _run(seed=0, n=800):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 100.0
    q, dq, ddq = C._trajectory(rng, t)
    y = np.ascontiguousarray(sim.regressor(q, dq, ddq))
    pi = sim.base_parameters(sim.DEFAULT_ARM)
    return q, y, y @ pi + rng.normal(0.0, 0.2, (n, 2))


@pytest.fixture(scope="module")
def runs():
    return _run(0), _run(1)


def _fit(y, tau, cols):
    return np.linalg.lstsq(y[:, :, cols].reshape(-1, len(cols)), tau.reshape(-1), rcond=None)[0]


def _predictions(runs):
    (_, y_e, tau_e), (_, y_v, _) = runs
    full = list(range(len(NAMES)))
    return {"rigid+viscous": y_v[:, :, NO_FC] @ _fit(y_e, tau_e, NO_FC), "full": y_v @ _fit(y_e, tau_e, full),
            "half": 0.5 * (y_v @ _fit(y_e, tau_e, full))}


CASES = {
    "plain": {"sample_rate": 100.0},
    "segments": {"segments": [300, 500], "max_lag": 20},
    "python backend": {"backend": "python", "max_lag": 12},
    "estimation and model columns": {"sample_rate": 100.0, "model_columns": NO_FC, "estimation": True},
    "estimation refit": {"sample_rate": 100.0, "estimation": True},
    "full detail": {"cross_correlation_detail": "full", "max_lag": 15},
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_prepared_regressor_gives_the_plain_report_bit_for_bit(runs, case):
    options = dict(CASES[case])
    (q_e, y_e, tau_e), (q_v, y_v, tau_v) = runs
    if options.pop("estimation", False):
        options["estimation"] = {"q": q_e, "regressor": y_e, "tau": tau_e}
    prepared = dynval.prepare_regressor(y_v)
    for pred in _predictions(runs).values():  # the later calls read what the first kept
        plain = dynval.validate(tau_v, pred, n_params=10, regressor=y_v, q=q_v, **options)
        shared = dynval.validate(tau_v, pred, n_params=10, regressor=prepared, q=q_v, **options)
        assert shared.to_json() == plain.to_json()
    assert repr(prepared).startswith("PreparedRegressor(shape=(800, 2, 10), kept=") and len(prepared._cache) > 0


def test_the_stacked_form_and_omitted_rows_give_the_plain_report(runs):
    _, (_, y_v, tau_v) = runs
    pred = _predictions(runs)["full"]
    stacked = y_v.reshape(-1, y_v.shape[2])
    prepared = dynval.prepare_regressor(stacked)
    a = dynval.validate(tau_v, pred, n_params=10, regressor=prepared, n_joints=2, max_lag=10)
    assert a.to_json() == dynval.validate(tau_v, pred, n_params=10, regressor=stacked, n_joints=2,
                                          max_lag=10).to_json()
    # Omitted rows make the call's regressor a copy without them: nothing kept may serve it.
    holed = tau_v.copy()
    holed[100, 1] = np.nan
    b = dynval.validate(holed, pred, n_params=10, regressor=prepared, n_joints=2, max_lag=10, nan_policy="omit")
    assert b.to_json() == dynval.validate(holed, pred, n_params=10, regressor=stacked, n_joints=2, max_lag=10,
                                          nan_policy="omit").to_json()


def test_another_estimation_run_is_not_served_what_the_first_one_gave(runs):
    (q_e, y_e, tau_e), (q_v, y_v, tau_v) = runs
    pred = _predictions(runs)["rigid+viscous"]
    prepared = dynval.prepare_regressor(y_v)
    for scale in (1.0, 1.5):  # the same arrays' shapes, other values
        est = {"q": q_e, "regressor": y_e * scale, "tau": tau_e}
        shared = dynval.validate(tau_v, pred, n_params=7, regressor=prepared, q=q_v, estimation=est,
                                 model_columns=NO_FC, sample_rate=100.0)
        plain = dynval.validate(tau_v, pred, n_params=7, regressor=y_v, q=q_v, estimation=est,
                                model_columns=NO_FC, sample_rate=100.0)
        assert shared.to_json() == plain.to_json()


def test_kept_arrays_are_read_only(runs):
    _, (_, y_v, tau_v) = runs
    prepared = dynval.prepare_regressor(y_v)
    dynval.validate(tau_v, _predictions(runs)["full"], n_params=10, regressor=prepared, sample_rate=100.0)
    kept = [x for v in prepared._cache.values() for x in (v if isinstance(v, tuple) else (v,))]
    kept += [x for v in prepared._cache.values() if hasattr(v, "__dict__") for x in vars(v).values()]
    arrays = [x for x in kept if isinstance(x, np.ndarray)]
    assert arrays and not any(x.flags.writeable for x in arrays)
    assert not prepared.array.flags.writeable and y_v.flags.writeable  # the caller's array stays its own


def _count_calls(monkeypatch, module, name):
    calls = []
    original = getattr(module, name)

    def counting(*args, **kwargs):
        calls.append(name)
        return original(*args, **kwargs)

    monkeypatch.setattr(module, name, counting)
    return calls


@pytest.mark.parametrize("own", [False, True], ids=["shared regressor", "each candidate's own, one array"])
def test_compare_does_the_regressor_work_once_for_all_candidates(runs, monkeypatch, own):
    (q_e, y_e, tau_e), (q_v, y_v, tau_v) = runs
    est = {"q": q_e, "regressor": y_e, "tau": tau_e}
    # lags to N/4: every candidate's band then takes the regressor's autocorrelations to the same lag
    plain = {n: dynval.validate(tau_v, p, n_params=10, regressor=y_v, q=q_v, estimation=est, max_lag=200)
             for n, p in _predictions(runs).items()}
    grams = _count_calls(monkeypatch, _regressor_algebra, "JointGrams")
    excitation = _count_calls(monkeypatch, _sections, "_excitation")
    residual_acf = _count_calls(monkeypatch, _sections, "_biased_acf")
    regressor_band = _count_calls(monkeypatch, _sections, "_regressor_band")
    candidates = {n: (p, 10, y_v) if own else (p, 10) for n, p in _predictions(runs).items()}
    cmp = dynval.compare(tau_v, candidates, regressor=None if own else y_v, q=q_v, estimation=est, max_lag=200)
    assert len(grams) == 1 and len(excitation) == 1
    # each residual's own autocorrelation, and the regressor's half of the band (its columns'
    # transforms at 200 lags) once per number of colour lags (the band's J depends on the residual's N_eff)
    colour_lags = {r.cross_correlation["colour_lags"] for r in cmp.reports.values()}
    assert len(residual_acf) == 3 and len(regressor_band) == len(colour_lags) and colour_lags == {200}
    assert {n: r.to_json() for n, r in cmp.reports.items()} == {n: r.to_json() for n, r in plain.items()}


def test_compare_leaves_other_regressors_as_given(runs, monkeypatch):
    # A float32 array (converted by each validate) is not prepared: its errors and results stay its own.
    _, (_, y_v, tau_v) = runs
    grams = _count_calls(monkeypatch, _regressor_algebra, "JointGrams")
    preds = _predictions(runs)
    dynval.compare(tau_v, {n: (p, 10) for n, p in preds.items()}, regressor=y_v.astype(np.float32), max_lag=5)
    assert len(grams) == 3


def test_prepare_regressor_refuses_what_is_not_real_numbers():
    with pytest.raises(dynval.InvalidType, match="regressor must be an array of real numbers, got <U1"):
        dynval.prepare_regressor([["a", "b"]])
    prepared = dynval.prepare_regressor(np.ones((10, 1, 2)))
    assert dynval.prepare_regressor(prepared) is prepared
    with pytest.raises(dynval.ShapeMismatch, match="regressor must have shape"):
        dynval.validate(np.ones((12, 1)), np.ones((12, 1)), n_params=1, regressor=prepared)


def _singular_blocks(runs):
    """The validation run with a column that is the sum of the others (each joint's block singular),
    the candidates' predictions and their plain validate reports."""
    _, (_, y_v, tau_v) = runs
    y = np.ascontiguousarray(np.concatenate([y_v, y_v.sum(axis=2, keepdims=True)], axis=2))
    preds = _predictions(runs)
    plain = {n: dynval.validate(tau_v, p, n_params=10, regressor=y, max_lag=10) for n, p in preds.items()}
    return tau_v, y, preds, plain


def test_compare_factors_a_rank_deficient_block_once(runs, monkeypatch):
    # A column that is the sum of the others makes each joint's block singular: the spectrum's projection
    # then takes the block's numerical range, factored once per joint for all candidates (not one
    # lstsq per residual).
    tau_v, y, preds, plain = _singular_blocks(runs)
    factored = _count_calls(monkeypatch, _regressor_algebra, "RangeProjection")
    cmp = dynval.compare(tau_v, {n: (p, 10) for n, p in preds.items()}, regressor=y, max_lag=10)
    assert len(factored) == y.shape[1]
    assert {n: r.to_json() for n, r in cmp.reports.items()} == {n: r.to_json() for n, r in plain.items()}


def test_compare_scales_each_joint_block_once_for_the_projection_and_the_excitation(runs, monkeypatch):
    # A singular block is scaled by powers of two for the spectrum's range projection, and the
    # excitation section's R factor of the same block (its Gram matrices do not decide a singular
    # stack) is taken from that scaling, not from a second one.
    tau_v, y, preds, plain = _singular_blocks(runs)
    scaled = _count_calls(monkeypatch, _regressor_algebra, "_scaled_live_block")
    factored = _count_calls(monkeypatch, _regressor_algebra, "_r_factor")
    cmp = dynval.compare(tau_v, {n: (p, 10) for n, p in preds.items()}, regressor=y, max_lag=10)
    assert len(scaled) == len(factored) == y.shape[1]
    assert {n: r.to_json() for n, r in cmp.reports.items()} == {n: r.to_json() for n, r in plain.items()}


def test_a_well_conditioned_stack_factors_each_joint_block_once_for_its_projection(monkeypatch):
    # Each joint's block singular, the stacked regressor not: the excitation takes its singular
    # values from the Gram matrix and stacks no R factor; each singular block's one R factor is its
    # range projection's (joint_factor), once per joint for both candidates.
    rng = np.random.default_rng(11)
    y = rng.normal(size=(600, 2, 3))
    y[:, 0, 2] = y[:, 0, 0] + y[:, 0, 1]  # joint 1's block singular
    y[:, 1, 0] = y[:, 1, 1] - y[:, 1, 2]  # joint 2's too, by another combination
    tau = y @ np.array([1.0, 2.0, 3.0]) + rng.normal(0.0, 0.1, (600, 2))
    factored = _count_calls(monkeypatch, _regressor_algebra, "_r_factor")
    projected = _count_calls(monkeypatch, _regressor_algebra, "RangeProjection")
    stacked = _count_calls(monkeypatch, _regressor_algebra, "_stacked_r")
    dynval.compare(tau, {"a": (y @ np.array([1.0, 2.0, 3.1]), 3), "b": (y @ np.array([1.1, 2.0, 3.0]), 3)},
                   regressor=y, max_lag=10)
    assert len(projected) == len(factored) == 2 and not stacked


def _block(singular_values, n=400, seed=3):
    """An (n, k) block with these singular values, and its left singular vectors (n, k)."""
    rng = np.random.default_rng(seed)
    u, _ = np.linalg.qr(rng.normal(size=(n, len(singular_values))))
    v, _ = np.linalg.qr(rng.normal(size=(len(singular_values),) * 2))
    return (u * np.asarray(singular_values)) @ v.T, u


@pytest.mark.parametrize("singular_values", [
    [1.0, 0.3, 0.1],  # full rank
    [1.0, 0.5, 0.2, 0.0, 0.0],  # two exactly dependent columns
    [0.0, 0.0],  # a zero block: nothing to project on
])
def test_the_range_projection_gives_the_lstsq_residual(singular_values):
    y, _ = _block(singular_values)
    b = np.random.default_rng(4).normal(size=y.shape[0])
    proj = _regressor_algebra.RangeProjection(y)
    beta, _, rank, _ = np.linalg.lstsq(y, b, rcond=None)
    assert proj.rank == rank == sum(s > 0 for s in singular_values)
    np.testing.assert_allclose(proj.residual(b), b - y @ beta, rtol=0, atol=1e-12 * np.linalg.norm(b))


def test_the_range_projection_cuts_where_lstsq_does():
    # lstsq's rule keeps s > eps·max(N, p)·s_max ≈ 8.9e-14 here: 1e-13 is kept, 2e-14 is not (a
    # cut at eps·s_max, or at a fixed 1e-12, would differ)
    y, _ = _block([1.0, 1e-3, 1e-13, 2e-14, 0.0])
    proj = _regressor_algebra.RangeProjection(y)
    assert proj.rank == np.linalg.lstsq(y, y[:, 0], rcond=None)[2] == 3


def test_compare_computes_the_model_columns_gram_of_the_predictive_test_once(runs, monkeypatch):
    (q_e, y_e, tau_e), (q_v, y_v, tau_v) = runs
    est = {"q": q_e, "regressor": y_e, "tau": tau_e}
    preds = _predictions(runs)
    plain = {n: dynval.validate(tau_v, p, n_params=10, regressor=y_v, q=q_v, estimation=est, max_lag=10)
             for n, p in preds.items()}
    grams = _count_calls(monkeypatch, _motion, "model_gram")
    cmp = dynval.compare(tau_v, {n: (p, 10) for n, p in preds.items()}, regressor=y_v, q=q_v, estimation=est,
                         max_lag=10)
    assert len(grams) == 1 and all(r.predictive is not None for r in cmp.reports.values())
    assert {n: r.to_json() for n, r in cmp.reports.items()} == {n: r.to_json() for n, r in plain.items()}


def test_a_prepared_regressor_is_searched_for_non_finite_values_once(runs, monkeypatch):
    # Its values do not change: the search runs on the first call, and its finding is kept, so
    # every call refuses a non-finite value with the plain array's message (a kept "finite"
    # that skipped the search, or a search that is never kept, would each fail here).
    from dynval.checks import _validation as v

    _, (_, y_v, tau_v) = runs
    searched = []
    real = v.first_nonfinite

    def spy(a):
        searched.append(a.size)
        return real(a)

    monkeypatch.setattr(v, "first_nonfinite", spy)
    prepared = dynval.prepare_regressor(y_v)
    for _ in range(3):
        dynval.validate(tau_v, tau_v * 0.9, n_params=10, regressor=prepared, max_lag=5)
    assert searched.count(y_v.size) == 1
    bad = y_v.copy()
    bad[7, 1, 3] = np.inf
    with pytest.raises(dynval.NonFiniteInput) as plain:
        dynval.validate(tau_v, tau_v * 0.9, n_params=10, regressor=bad, max_lag=5)
    prepared_bad = dynval.prepare_regressor(bad)
    for _ in range(2):
        with pytest.raises(dynval.NonFiniteInput) as kept:
            dynval.validate(tau_v, tau_v * 0.9, n_params=10, regressor=prepared_bad, max_lag=5)
        assert str(kept.value) == str(plain.value)


def test_compare_computes_the_kernels_regressor_moments_once(runs, monkeypatch):
    # The compiled cross-correlation's first pass (the columns' moments, half its time on a log of
    # few lags) is kept by the prepared regressor: once for three candidates, the same reports.
    pytest.importorskip("dynval._core")
    from dynval import _core

    _, (_, y_v, tau_v) = runs
    preds = _predictions(runs)
    plain = {n: dynval.validate(tau_v, p, n_params=10, regressor=y_v, max_lag=10, backend="cpp")
             for n, p in preds.items()}
    calls = []
    real = _core.regressor_moments
    monkeypatch.setattr(_core, "regressor_moments", lambda y: calls.append(y.shape) or real(y))
    cmp = dynval.compare(tau_v, {n: (p, 10) for n, p in preds.items()}, regressor=y_v, max_lag=10, backend="cpp")
    assert len(calls) == 1
    assert {n: r.to_json() for n, r in cmp.reports.items()} == {n: r.to_json() for n, r in plain.items()}


def test_a_structure_is_checked_against_the_regressor():
    """Kills: a structure of another width accepted (the excitation section would compare columns
    that are not the same), a nan in it accepted, the structure dropped on a second preparation."""
    rng = np.random.default_rng(5)
    y = rng.normal(size=(50, 2, 3))
    with pytest.raises(dynval.ShapeMismatch, match=r"structure must be \(K, m, p\) or \(K\*m, p\) with the "
                                                   r"regressor's p = 3 columns, got shape \(10, 2, 4\)"):
        dynval.prepare_regressor(y, structure=rng.normal(size=(10, 2, 4)))
    with pytest.raises(dynval.ShapeMismatch, match="got shape"):
        dynval.prepare_regressor(y, structure=rng.normal(size=3))
    bad = rng.normal(size=(10, 3))
    bad[4, 1] = np.nan
    with pytest.raises(dynval.NonFiniteInput, match=r"structure has a non-finite value .* at row 4, column 1"):
        dynval.prepare_regressor(y, structure=bad)
    with pytest.raises(dynval.InvalidType, match="structure"):
        dynval.prepare_regressor(y, structure="abc")
    plain = dynval.prepare_regressor(y)
    assert plain.structure is None and dynval.prepare_regressor(plain) is plain
    again = dynval.prepare_regressor(plain, structure=rng.normal(size=(20, 2, 3)))
    assert again is not plain and np.shares_memory(again.array, plain.array) and again.structure.shape == (40, 3)
    assert not again.structure.flags.writeable


def test_compare_without_q_finds_the_kinds_the_model_spans_once(runs, monkeypatch):
    # Without q the model's columns still say whether it spans an offset: each joint's span of the
    # regressor (read from the joint's R factor) depends on the regressor and the model's columns
    # alone, so the candidates of one compare with the same columns compute it once, and the reports
    # are those of validate on the plain array.
    _, (_, y_v, tau_v) = runs
    preds = _predictions(runs)
    plain = {n: dynval.validate(tau_v, p, n_params=10, regressor=y_v, max_lag=10) for n, p in preds.items()}
    kinds = _count_calls(monkeypatch, _motion, "kinds_without_q")
    cmp = dynval.compare(tau_v, {n: (p, 10) for n, p in preds.items()}, regressor=y_v, max_lag=10)
    assert len(kinds) == 1
    assert {n: r.to_json() for n, r in cmp.reports.items()} == {n: r.to_json() for n, r in plain.items()}
    # other model columns are another span
    kinds.clear()
    dynval.compare(tau_v, {n: {"prediction": p, "n_params": 10, "model_columns": NO_FC} if n == "half" else (p, 10)
                           for n, p in preds.items()}, regressor=y_v, max_lag=10)
    assert len(kinds) == 2


def test_a_plain_regressor_has_its_small_shared_results_computed_once_per_call(runs, monkeypatch):
    # Without a prepared regressor, one call still computes each joint column's largest value (a
    # pass over the whole regressor) and each singular block's R factor once, for the Gram
    # matrices, the projection, the colour band, the excitation and the kinds without q alike;
    # the next call computes them again (nothing is kept beyond the call), and the report is the one
    # a prepared regressor gives.
    tau_v, y, preds, _ = _singular_blocks(runs)
    largest = _count_calls(monkeypatch, _regressor_algebra, "_largest_of")
    factored = _count_calls(monkeypatch, _regressor_algebra, "_factor_with_library")
    pred = next(iter(preds.values()))
    plain = dynval.validate(tau_v, pred, n_params=10, regressor=y, max_lag=10)
    assert len(largest) == 1 and len(factored) == y.shape[1]
    again = dynval.validate(tau_v, pred, n_params=10, regressor=y, max_lag=10)
    assert len(largest) == 2 and len(factored) == 2 * y.shape[1]
    shared = dynval.validate(tau_v, pred, n_params=10, regressor=dynval.prepare_regressor(y), max_lag=10)
    assert plain.to_json() == again.to_json() == shared.to_json()


def test_the_columns_largest_values_come_from_the_kernels_moments(runs, monkeypatch):
    # With the compiled core, each column's largest |x| is read from the moments the cross-correlation
    # kernel takes (one pass, kept for the call), not from two more passes of numpy's max and min:
    # a plain call computes the moments once and takes no numpy pass; the values are numpy's exactly,
    # for negative, zero, tiny and huge columns.
    pytest.importorskip("dynval._core")
    from dynval import _core

    _, (_, y_v, tau_v) = runs
    pred = next(iter(_predictions(runs).values()))
    numpy_passes = _count_calls(monkeypatch, _regressor_algebra, "_column_largest")
    calls = []
    real = _core.regressor_moments
    monkeypatch.setattr(_core, "regressor_moments", lambda y: calls.append(y.shape) or real(y))
    dynval.validate(tau_v, pred, n_params=10, regressor=y_v, max_lag=10, backend="cpp")
    assert calls == [(y_v.shape[0], y_v.shape[1] * y_v.shape[2])] and numpy_passes == []
    y = np.random.default_rng(3).normal(size=(300, 2, 5))
    y[:, 0, 0] = 0.0
    y[:, 0, 1] = -np.abs(y[:, 0, 1]) * 1e300
    y[:, 1, 2] *= 1e-300
    y[:, 1, 3] = np.abs(y[:, 1, 3])
    largest = _regressor_algebra.column_largest(y)
    np.testing.assert_array_equal(largest, np.maximum(y.max(axis=0), -y.min(axis=0)))
