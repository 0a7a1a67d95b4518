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


# One finding of each kind and variant compare words, with the reason compare gave before the kinds moved
# to their modules (docs/architecture.md): the same words, from the kinds' modules now.
_CASES = [
    (Finding(kind='physical_consistency', severity='deficiency', joints=(0,), effect=0.12, effect_unit='kg',
             details={'link': 'L1', 'condition': 'm > 0'}),
     'a: not a robot: L1 breaks m > 0 by 0.12 kg'),
    (Finding(kind='physical_consistency', severity='deficiency', joints=(1,), effect=0.3, effect_unit='N·m',
             details={'joint': 'j2', 'condition': 'Fc >= 0'}),
     'b: not a robot: Fc >= 0 broken by 0.3 N·m'),
    (Finding(kind='physical_consistency', severity='deficiency', effect=0.0312, threshold=0.01,
             effect_unit="share of the estimation run's mean square"),
     "no physically consistent robot has these base parameters (the nearest adds 3.12 % to the estimation run's "
     "residual mean square ≥ 1 %)"),
    (Finding(kind='excitation', severity='design', joints=(0,), effect=0.05, threshold=0.1,
             effect_unit='joint motion (RMS) relative to the estimation run'),
     'design: a: hardly moves (5 % of its estimation-run motion < 10 %)'),
    (Finding(kind='excitation', severity='design', columns=(0, 1), effect=2.0, effect_unit='columns',
             details={'unexcited': [1]}),
     'design: the validation run never excites c2 and cannot separate c1 from the other columns'),
    (Finding(kind='excitation', severity='design', columns=(1,), effect=0.05, threshold=0.1,
             effect_unit='column RMS relative to the estimation run'),
     'design: the validation run excites c2 far less than the estimation run (5.0 % < 10 %)'),
    (Finding(kind='excitation', severity='design', effect=3000.0, threshold=1000.0,
             effect_unit='column-scaled condition number'),
     'design: ill-conditioned validation regressor (column-scaled condition number 3e3 > 1000)'),
    (Finding(kind='low_information', severity='design', joints=(0, 1), effect=0.4, threshold=0.25, effect_unit='x'),
     'design: a, b: too few effective samples (the smallest detectable term removes 40 % of the mean square > 25 %)'),
    (Finding(kind='missing_physics', severity='deficiency', joints=(0,), effect=0.4, threshold=0.05,
             effect_unit="share of the joint's mean square the physical terms remove",
             details={'label': 'viscous friction', 'relation': 'reweight'}),
     'a: mis-weighted or changed between runs (the model has it): viscous friction (the physical terms would remove'
     ' 40 % of the mean square ≥ 5 %)'),
    (Finding(kind='missing_physics', severity='deficiency', joints=(0,), effect=0.4, threshold=0.05,
             effect_unit='share', details={'label': 'viscous friction', 'relation': 'unsupported'}),
     'a: mis-weighted terms, not viscous friction (adding it does not carry to held-out rows; the physical terms '
     'would remove 40 % of the mean square ≥ 5 %)'),
    (Finding(kind='delay', severity='deficiency', joints=(0,), effect=15.0, threshold=10.0, effect_unit='deg',
             details={'delay_s': 0.026, 'delay_samples': 5.2, 'phase_deg': 15.0}),
     "a: torque delayed by 26 ms against the encoders (a 15° phase lag at the information band's edge ≥ 10°)"),
    (Finding(kind='delay', severity='deficiency', joints=(0,), effect=0.08, threshold=0.05,
             effect_unit="share of the joint's mean square realigning removes",
             details={'delay_s': None, 'delay_samples': -2.0, 'phase_deg': None}),
     'a: torque ahead by 2 samples against the encoders (realigning removes 8 % of the mean square ≥ 5 %)'),
    (Finding(kind='bias', severity='deficiency', joints=(0,), columns=(1,), effect=0.3, threshold=0.25,
             effect_unit='|mean| / RMSE'),
     'a: residual bias (|mean| = 30 % of the RMSE ≥ 25 %), which the missing term c2 accounts for'),
    (Finding(kind='oscillation', severity='deficiency', joints=(1,), effect=0.3, threshold=0.05,
             effect_unit='share of residual variance', details={'frequency': 5.0, 'frequency_unit': 'Hz'}),
     'b: oscillation near 5 Hz (30 % of the residual variance ≥ 5 %)'),
    (Finding(kind='prediction_artefact', severity='deficiency', joints=(1,), effect=0.3, threshold=0.05,
             effect_unit='share of residual variance',
             details={'frequency': 5.0, 'frequency_unit': 'Hz', 'line_power_prediction': 2.0,
                      'line_power_measured': 0.1}),
     "b: the prediction's own line near 5 Hz (30 % of the residual variance ≥ 5 %; the prediction holds 2 there, "
     "the measured torque 0.1)"),
    (Finding(kind='whiteness', severity='deficiency', joints=(1,), effect=0.31, details={'decimation': 4}),
     'b: residual not white at the information rate (max |ρ̂(ℓ)| = 0.31), explained by the findings above on this '
     'joint'),
    (Finding(kind='repeat_trajectory', severity='design', effect=0.8, threshold=0.5,
             effect_unit='share of the validation run near the estimation trajectory (q)', details={'share': 0.8}),
     'design: the validation run repeats the estimation run (80 % of it lies near the estimation trajectory at some'
     ' time > 50 %)'),
    (Finding(kind='repeat_trajectory', severity='design', effect=0.05, threshold=0.1,
             effect_unit='relative distance (tau)', details={'measure': 'tau'}),
     'design: the validation run repeats the estimation run (relative tau distance 0.05 < 0.1)'),
    (Finding(kind='predictive_failure', severity='deficiency', joints=(0,), effect=3.1, threshold=2.0,
             effect_unit='x'),
     'a: predictive failure (validation mean square 3.1× what the estimation run allows ≥ 2×)'),
    (Finding(kind='periodic_error', severity='deficiency', joints=(0,), effect=0.08, threshold=0.05,
             effect_unit="share of the residual's variance common to every period"),
     "a: periodic error (share of the residual's variance common to every period = 8 %, threshold 5 %)"),
    (Finding(kind='regressor_correlation', severity='deficiency', joints=(0,), columns=(0, 1), effect=0.04,
             threshold=0.01, effect_unit="share of the residual's mean square the term would remove"),
     "a: missing term c1 (would remove 4 % of the residual's mean square ≥ 1 %); c2 also significant"),
    (Finding(kind='regressor_correlation', severity='deficiency', joints=(0,), columns=(0,), effect=0.3,
             threshold=0.15, effect_unit='|ρ|', details={'in_model': True}),
     'a: residual correlates with c1 (|ρ| up to 0.30 ≥ 0.15): a mis-weighted term (the model has it)'),
    (Finding(kind='worse_than_constant', severity='deficiency', joints=(0,), statistic=-0.5, effect=0.5,
             threshold=0.0),
     'a: worse than a constant (R² = -0.500 < 0)'),
]


@pytest.mark.parametrize("finding, expected", _CASES, ids=[f.kind for f, _ in _CASES])
def test_compare_words_every_kind_as_before_the_move(finding, expected):
    assert finding_reason(finding, _Names()) == expected
