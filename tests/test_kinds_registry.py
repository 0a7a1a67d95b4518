"""The registry of finding kinds (``dynval.report.kinds``, docs/architecture.md "Adding a finding kind"):
one module per kind, discovered, run in its declared order, its thresholds and compare reason found."""

from __future__ import annotations

import pkgutil

import numpy as np
import pytest

import dynval
from dynval.comparison._reasons import finding_reason
from dynval.report import _findings
from dynval.report import kinds as registry
from dynval.report.kinds._base import Context, Finding, Kind, Threshold, Thresholds, declare


def test_every_module_of_the_package_is_a_kind_of_its_own_name():
    modules = [m.name for m in pkgutil.iter_modules(registry.__path__) if not m.name.startswith("_")]
    assert sorted(registry.KINDS) == sorted(modules)
    assert all(registry.KINDS[name].name == name for name in modules)
    # every declared kind is in the vocabulary, and nothing is declared twice
    assert set(registry.KINDS) <= set(dynval.FINDING_KINDS)
    assert not set(registry.KINDS) & set(_findings._LISTED)


def test_the_rules_run_in_the_order_of_their_places():
    ruled = [k for k in registry.KINDS.values() if k.rule is not None]
    places = [order for order, _ in _findings._RULES] + [k.order for k in ruled]
    assert len(set(places)) == len(places), "two rules share a place"
    rules = list(_findings._ALL_RULES)
    assert len(rules) == len(places)
    order = {rule: place for place, rule in _findings._RULES} | {k.rule: k.order for k in ruled}
    assert [order[r] for r in rules] == sorted(order[r] for r in rules)
    # whiteness (700) reads the joints the earlier rules called deficient: those of the kinds' modules too
    deciding = ("worse_than_constant", "predictive_failure", "periodic_error")
    assert all(registry.KINDS[name].order < 700 for name in deciding)


def test_the_vocabulary_is_in_the_order_of_the_rules():
    names = list(dynval.FINDING_KINDS)
    place = {**_findings.ORDER, **{k.name: k.order for k in registry.KINDS.values()}}
    assert [place[n] for n in names] == sorted(place[n] for n in names)


def test_a_threshold_declared_twice_or_over_a_field_is_refused():
    rule = lambda r: []  # noqa: E731
    with pytest.raises(ValueError, match="'bias' is declared twice"):
        declare(Kind("x", "x", 1, rule, thresholds=(Threshold("bias", 1.0, ""),)))
    with pytest.raises(ValueError, match="'near_perfect_fit' is declared twice"):
        declare(Kind("y", "y", 1, rule, thresholds=(Threshold("near_perfect_fit", 1.0, ""),)))


def test_a_declared_threshold_reads_its_default_or_the_value_given():
    t = registry.KINDS["near_perfect_fit"].thresholds[0]
    assert Thresholds().value(t) == 1e-6
    th = _findings.resolve_thresholds({"near_perfect_fit": 0.5, "bias": 0.3})
    assert th.value(t) == 0.5 and th.bias == 0.3
    assert th.as_dict()["near_perfect_fit"] == 0.5 and "declared" not in th.as_dict()
    with pytest.raises(dynval.InputError, match=r"keys among .*'near_perfect_fit'"):
        _findings.resolve_thresholds({"near_perfect_fits": 0.5})


class _Names:
    def __init__(self) -> None:
        self.provenance = {"joint_names": ["a", "b"], "column_names": ["c1", "c2"]}


def test_compare_words_a_declared_kind_by_its_module_and_an_unworded_one_generically():
    wtc = Finding(kind="worse_than_constant", severity="deficiency", joints=(1,), statistic=-0.25, effect=0.25,
                  threshold=0.0)
    assert finding_reason(wtc, _Names()) == "b: worse than a constant (R² = -0.250 < 0)"  # as before the move
    periodic = Finding(kind="periodic_error", severity="deficiency", joints=(0,), effect=0.0812, threshold=0.05,
                       effect_unit="share of the residual's variance common to every period")
    # a kind without its own reason: its name, its effect and threshold (percent, as the kind declares)
    assert finding_reason(periodic, _Names()) == ("a: periodic error (share of the residual's variance common to "
                                                  "every period = 8.12 %, threshold 5 %)")


def test_a_rule_of_a_kind_module_sees_what_the_earlier_rules_found():
    # worse_than_constant (100) marks joint 0 deficient before whiteness (700) reads it
    ev = _findings.Evidence(n_samples=100, level=0.95, joint_names=["a"], r2=np.array([-0.5]), pooled_r2=-0.5,
                            constant_target=np.array([False]))
    ctx = Context(ev, Thresholds(), 0.05, {})
    found = registry.KINDS["worse_than_constant"].rule(ctx)
    assert [f.kind for f in found] == ["worse_than_constant"] and ctx.deficient == {0}
