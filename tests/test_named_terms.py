"""The physics test's named terms as one statistics call (statistics/_named_terms.name_terms) and the
naming on the validation run (statistics/_model_terms.name_on_validation).

Each test names the mutation it kills."""

from __future__ import annotations

import numpy as np
import pytest

import dynval
from dynval.statistics import _model_terms, _named_terms
from dynval.statistics._physics import PhysicsTest

N, FS = 3000, 100.0


def _posture():
    t = np.arange(N) / FS
    return np.column_stack([np.sin(2 * np.pi * 0.2 * t), np.cos(2 * np.pi * 0.13 * t)])


def _test(term):
    return PhysicsTest(0, 10.0, (2, N), 1e-9, 0.9, term, 0.3, [term])


@pytest.mark.parametrize("offset", [3.0, 0.0])
def test_the_validation_run_names_what_the_model_columns_leave_else_the_reweighting(offset):
    """An offset the model lacks is named by the cross-fitted refit (its gains returned, the term left
    to the caller); without one, the offset the test named is replaced by the held kind the model's
    re-weighting adds (gravity here). Kills: the cross-fitted gains not returned (the re-weighting
    tried instead), the gains returned below the practical share."""
    rng = np.random.default_rng(0)
    y = _posture()
    meas = y @ np.array([2.0, -1.0]) + offset + 0.01 * rng.standard_normal(N)
    lib = {"gravity": y, "offset": np.ones((N, 1))}
    t = _test("offset")
    got = _model_terms.name_on_validation(t, meas, y, np.array([1.0, -0.5]), lib, 1, 0.05, {"gravity"})
    if offset:
        assert got is not None and got["offset"] > 0.9 and t.term == "offset"
    else:
        assert got is None and t.term == "gravity"


def test_a_held_term_is_left_as_named():
    """The model's own columns refitted leave only noise: no gains are returned and a term the model's
    names declare stays. Kills: the gains returned below the practical share."""
    y = _posture()
    meas = 2.0 * y[:, 0] + 0.01 * np.random.default_rng(2).standard_normal(N)
    t = _test("gravity")
    lib = {"gravity": y, "offset": np.ones((N, 1))}
    assert _model_terms.name_on_validation(t, meas, y, np.array([1.0, 0.0]), lib, 1, 0.05, {"gravity"}) is None
    assert t.term == "gravity"


def _run(seed=1, m=2):
    rng = np.random.default_rng(seed)
    t = np.arange(N) / FS
    q = np.column_stack([np.sin(2 * np.pi * (0.1 + 0.05 * j) * t + j) for j in range(m)])
    reg = np.zeros((N, m, 2 * m))
    for j in range(m):
        reg[:, j, 2 * j] = np.sin(q[:, j])
        reg[:, j, 2 * j + 1] = np.gradient(q[:, j], 1.0 / FS)
    pred = reg @ np.arange(1.0, 2 * m + 1)
    meas = pred + 0.05 * rng.standard_normal((N, m))
    return q, reg, pred, meas


@pytest.mark.parametrize("regressor", [False, True])
def test_the_record_says_how_the_model_columns_entered_and_the_report_words_it(regressor):
    """Without a regressor the model's columns are unknown (nothing refitted, no kinds); with one
    alone they are refitted on the validation run; the report's physics section words the same.
    Kills: the two cases of how the columns enter the test swapped, or the kinds read without columns."""
    q, reg, pred, meas = _run()
    reg3 = reg if regressor else None
    cols = list(range(reg.shape[2])) if regressor else None
    named = _named_terms.name_terms(meas - pred, pred, q, None, None, FS, reg3, cols, None, 0.95, None, meas)
    assert len(named.tests) == q.shape[1] and [t.joint for t in named.tests] == [0, 1]
    assert named.named_on_estimation is False and named.alternative is None
    assert named.model_columns == ("validation" if regressor else "none")
    assert (named.model_kinds is None) is (not regressor)
    report = dynval.validate(meas, pred, n_params=reg.shape[2], q=q, sample_rate=FS,
                             **({"regressor": reg} if regressor else {}))
    words = report.to_dict()["physics"]["model_columns"]
    assert words.startswith("refitted on the validation run" if regressor else "none (no regressor")
