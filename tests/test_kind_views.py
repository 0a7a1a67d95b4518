"""The motion's sections as the rules read them (report/kinds/_views.py): each view's attribute is
the section entry's key of the same meaning, a missing key fails where the view is built, and the
named term's out-of-sample effect reads the attribute its rule says (conventions §5.2).

Each test names the mutation it kills."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import dynval
from dynval import simulate as sim
from dynval.report.kinds._evidence import term_effect
from dynval.report.kinds._views import Delay, JointPhysics, Periodic

FIELDS = {"joint": "joint", "statistic": "statistic", "share": "share", "term": "term", "term_share": "term_share",
          "selected": "selected", "shares": "shares", "selected_share": "selected_share", "n_eff": "n_eff",
          "refit_run": "refit_run", "refit_shares": "refit_shares", "heldout_share": "heldout_share",
          "carried_share": "carried_share", "relation": "relation"}


@pytest.fixture(scope="module")
def physics_tests():
    """A 2-joint arm whose model lacks the elbow's Coulomb friction, validated with the estimation
    run: every joint's test entry as the report's JSON form holds it."""
    rng = np.random.default_rng(3)
    arm = dataclasses.replace(sim.DEFAULT_ARM, fc1=0.0, fc2=0.6)
    t = np.arange(3000) / 200.0
    runs = []
    for _ in range(2):
        q = np.column_stack([0.8 * np.sin(2 * math.pi * f * t + rng.uniform(0, 6)) for f in (0.31, 0.47)])
        dq, ddq = np.gradient(q, t, axis=0), np.gradient(np.gradient(q, t, axis=0), t, axis=0)
        y = sim.regressor(q, dq, ddq)
        runs.append((q, y, y @ sim.base_parameters(arm) + 0.05 * rng.standard_normal(q.shape)))
    keep = [i for i, name in enumerate(sim.PARAMETER_NAMES) if name not in ("Fc1", "Fc2")]
    (q_e, y_e, tau_e), (q_v, y_v, tau_v) = runs
    coef, *_ = np.linalg.lstsq(y_e[:, :, keep].reshape(-1, len(keep)), tau_e.reshape(-1), rcond=None)
    report = dynval.validate(tau_v, y_v[:, :, keep] @ coef, n_params=len(keep), regressor=y_v[:, :, keep],
                             sample_rate=200.0, q=q_v,
                             estimation={"q": q_e, "regressor": y_e[:, :, keep], "tau": tau_e})
    return report.to_dict()["physics"]["tests"]


def test_each_attribute_is_the_entry_of_its_name(physics_tests):
    """Kills: an attribute read from another key (the held-out share from the carried one, the
    selected share from the term's), a value converted on the way (a rule passing it on into a
    finding's details would write something else than the section holds)."""
    assert any(t["term"] is not None for t in physics_tests)
    for j, t in enumerate(physics_tests):
        view = JointPhysics.of(t, j)
        for attribute, key in FIELDS.items():
            held = t.get(key)
            got = getattr(view, attribute)
            assert type(got) is type(held) and (got == held or (got != got and held != held)), attribute
        assert view.relation_name == (None if t.get("relation") is None else t["relation"]["relation"])


def test_a_missing_key_fails_where_the_view_is_built(physics_tests):
    """Kills: a view that reads a missing key as None (a renamed key would pass silently)."""
    entry = {k: v for k, v in physics_tests[0].items() if k != "term_share"}
    with pytest.raises(KeyError, match="term_share"):
        JointPhysics.of(entry, 0)
    with pytest.raises(KeyError, match="shift_samples"):
        Delay.of({"share": [0.1]})
    with pytest.raises(KeyError, match="effect_net"):
        Periodic.of({"statistic": [1.0], "noise_variance": [1.0], "n_periods": 3, "period": 1.0})


def _view(**kw) -> JointPhysics:
    base = dict(joint=0, statistic=10.0, share=0.9, term="coulomb", term_share=0.6, selected=["coulomb"],
                shares={"coulomb": 0.6}, selected_share=0.6, n_eff=900.0, refit_run=None, refit_shares={},
                heldout_share=0.3, carried_share=0.2, relation=None)
    base.update(kw)
    return JointPhysics(**base)


@pytest.mark.parametrize(("kw", "expected"), [
    ({"refit_run": "estimation"}, 0.6),  # refitted with the model there and carried here
    ({"refit_run": "validation"}, 0.6),  # a fallback refit, cross-fitted on this run
    ({}, 0.3),  # columns unknown: its own effect alone, cross-fitted
    ({"relation": {"relation": "partial", "reweight_share": 0.8}}, 0.2),  # beyond the model's columns
    ({"relation": {"relation": "reweight", "reweight_share": 0.8}}, 0.8),  # re-identifying them
    ({"relation": {"relation": "unsupported", "reweight_share": 0.7}}, 0.7),
    ({"heldout_share": float("nan")}, 0.6),  # nothing measured out of sample: the term's share
    ({"heldout_share": None}, 0.6),
])
def test_the_named_terms_effect_reads_the_share_its_rule_says(kw, expected):
    """Kills: the refit's share ignored, the carried share for a re-weighting, the held-out share
    with a relation known, nan or None taken as the effect."""
    assert term_effect(_view(**kw)) == pytest.approx(expected)
