"""A rigid-body kind the model holds on no joint is named where the test selects it
(conventions §5.2, "A kind the model lacks on every joint").

Each test names the mutation it kills."""

from __future__ import annotations

import numpy as np
import pytest

from dynval import scenarios
from dynval.statistics import _model_terms
from dynval.statistics._model_terms import name_absent_kinds
from dynval.statistics._physics import PhysicsTest

N = 2000


def _case(seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(N) / 100.0
    ddq = np.column_stack([np.sin(2 * np.pi * 0.4 * t), np.cos(2 * np.pi * 0.9 * t)])
    posture = np.column_stack([np.sin(0.3 * t), np.cos(0.3 * t)])
    e = np.zeros((N, 2))
    e[:, 1] = ddq @ np.array([1.0, 0.5]) + 0.2 * posture[:, 0] + 0.05 * rng.standard_normal(N)
    lib = {"gravity": posture, "inertia": ddq, "coulomb": np.sign(ddq)}
    return e, [lib, lib]


def _test(term="gravity", selected=("gravity", "inertia")):
    return PhysicsTest(1, 10.0, (4, N), 1e-9, 0.9, term, 0.3, list(selected))


HELD = [{"gravity": True, "inertia": False, "coulomb": False}, {"gravity": False, "inertia": False, "coulomb": False}]


def test_the_kind_the_model_lacks_everywhere_is_named():
    """Kills: the rule removed; the share not the cross-fitted one."""
    e, libs = _case()
    t = _test()
    name_absent_kinds([t], HELD, e, libs, 0.05)
    assert (t.term, t.refit_run) == ("inertia", "absent")
    total = float(e[:, 1] @ e[:, 1])
    assert t.term_share == pytest.approx((total - _model_terms.crossfit_sse(e[:, 1], libs[1]["inertia"])) / total)


@pytest.mark.parametrize("change", ["held_somewhere", "not_selected", "named_not_held", "small", "no_kinds"])
def test_the_kind_is_named_only_where_the_rule_says(change):
    """Kills, one case each: a kind held on another joint counted as absent; a kind the test did not
    select named; a named term the model does not hold replaced; a share below the practical one
    accepted; kinds unknown (no regressor) read as all absent."""
    e, libs = _case()
    kinds = [dict(k) for k in HELD]
    t = _test()
    practical = 0.05
    if change == "held_somewhere":
        kinds[0]["inertia"] = True
    elif change == "not_selected":
        t = _test(selected=("gravity",))
    elif change == "named_not_held":
        t = _test(term="coulomb", selected=("coulomb", "inertia"))
    elif change == "small":
        practical = 0.999
    name_absent_kinds([t], None if change == "no_kinds" else kinds, e, libs, practical)
    assert t.term == ("coulomb" if change == "named_not_held" else "gravity")
    assert t.refit_run is None


def test_a_friction_kind_every_model_lacks_is_not_named_so():
    """Kills: the rule applied to any kind the model lacks (Coulomb here, selected, practical)."""
    e, libs = _case()
    e[:, 1] += 3.0 * libs[1]["coulomb"][:, 0]
    t = _test(selected=("gravity", "coulomb"))
    name_absent_kinds([t], HELD, e, libs, 0.05)
    assert t.term == "gravity"


def test_a_gravity_only_model_is_told_to_add_inertia():
    """gravity_only:white:arm7@100 replicate 1: the base joint (vertical: the model's gravity
    columns are zero there) was told to add "a position-dependent term", the kind the model holds.
    Kills: the rule removed."""
    s = next(x for x in scenarios.library() if x.key == "gravity_only:white:arm7@100")
    rep = scenarios.simulate(s, 1)
    report = scenarios.validate_replicate(rep, False, prediction=scenarios.fit(rep))
    first = report.deciding[0].finding
    assert first.kind == "missing_physics" and first.details["term"] == "inertia"
    assert first.details["refit_run"] == "absent" and "holds an inertial term" in first.message
    assert not scenarios.adds_what_it_has(report, s, False, rep.model_columns)
