"""The report's sections are typed, read-only records (contract §4, ``dynval.report._records``).

Each is read as attributes and as a mapping of the contract's names, holds only what the route
computed, cannot be changed, survives pickling (dask moves reports between processes) and writes
the same JSON as the mapping it was built from.
"""

from __future__ import annotations

import dataclasses
import json
import pickle
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pytest

import dynval
from dynval.report import _records as rec

ROOT = Path(__file__).resolve().parents[1]

SECTIONS = {
    "provenance": rec.Provenance, "per_joint": rec.PerJoint, "pooled": rec.Pooled, "aggregates": rec.Aggregates,
    "residuals": rec.Residuals, "autocorrelation": rec.Autocorrelation, "ljung_box": rec.LjungBox,
    "cross_correlation": rec.CrossCorrelation, "information_criteria": rec.InformationCriteria, "bias": rec.Bias,
    "whiteness": rec.Whiteness, "spectrum": rec.Spectrum, "design": rec.Design, "physics": rec.Physics,
    "predictive": rec.Predictive, "periodic": rec.Periodic, "timing": rec.Timing,
}


@pytest.fixture(scope="module")
def full_report():
    """A report with every section: regressor, q, time stamps, the estimation run, named segments."""
    rng = np.random.default_rng(7)
    n, m, p = 1200, 2, 3
    t = np.arange(n) / 100.0
    q = np.column_stack([np.sin(2 * np.pi * 0.5 * t), np.cos(2 * np.pi * 0.5 * t)])
    reg = rng.standard_normal((n, m, p))
    tau = reg @ np.array([1.0, 0.5, -0.3]) + 0.05 * rng.standard_normal((n, m))
    pred = tau + 0.02 * rng.standard_normal((n, m)) + 0.3 * np.sign(np.gradient(q, axis=0))
    est = {"q": q, "regressor": reg, "tau": tau}
    return dynval.validate(tau, pred, n_params=p, regressor=reg, q=q, time=t, estimation=est,
                           segments={"first": 600, "second": 600}, model_columns=[0, 1])


def test_every_section_is_its_record_read_as_attributes_and_as_a_mapping(full_report):
    for name, cls in SECTIONS.items():
        section = getattr(full_report, name)
        assert type(section) is cls, name
        assert len(section) == len(list(section)) > 0, name
        for key in section:
            assert section[key] is getattr(section, key), (name, key)
        decoded = json.loads(full_report.to_json())[name]
        assert list(decoded) == list(section), name
        for key in section:
            _assert_same_value(section[key], decoded[key], (name, key))
    for seg in full_report.segment_metrics.values():
        assert type(seg) is rec.Segment and {"n_samples", "start", "per_joint", "mean", "pooled"} <= set(seg)


def test_a_quantity_not_computed_is_absent_not_none():
    r = dynval.validate([1.0, 2.0, 3.0, 4.0, 5.0], [1.1, 1.9, 3.2, 3.9, 5.1], n_params=1, max_lag=0)
    ic = r.information_criteria
    assert "n_eff" not in ic and "aic" in ic
    assert ic.n_eff is rec.ABSENT and repr(rec.ABSENT) == "ABSENT"
    with pytest.raises(KeyError):
        ic["n_eff"]
    assert ic.get("n_eff") is None and "n_eff" not in ic.to_dict()
    assert r.autocorrelation is None and r.ljung_box is None  # a section not computed is None
    lagged = dynval.validate([1.0, 2.0, 3.0, 4.0, 5.0, 6.0], [1.1, 1.9, 3.2, 3.9, 5.1, 6.2], n_params=1)
    assert isinstance(lagged.information_criteria["n_eff"], float)


def test_records_cannot_be_changed(full_report):
    with pytest.raises(dataclasses.FrozenInstanceError):
        full_report.per_joint.r2 = np.zeros(2)
    with pytest.raises(TypeError):
        full_report.per_joint["r2"] = np.zeros(2)


def test_a_section_builder_that_disagrees_with_its_record_fails_loudly():
    with pytest.raises(TypeError, match="Pooled has no field 'rsme'"):
        rec.Pooled.of({"sse": 1.0, "rsme": 2.0})


def test_records_survive_pickling_with_their_keys_and_absent_values(full_report):
    back = pickle.loads(pickle.dumps(full_report))
    assert back.to_json() == full_report.to_json()
    for name in SECTIONS:
        assert list(getattr(back, name)) == list(getattr(full_report, name))
    small = pickle.loads(pickle.dumps(dynval.validate([1.0, 2.0, 3.0, 4.0], [1.1, 2.1, 2.9, 4.2], n_params=1,
                                                      max_lag=0)))
    assert small.information_criteria.n_eff is rec.ABSENT


def test_the_spectrum_section_carries_no_working_arrays_and_its_tests_still_decide(full_report):
    assert not [k for k in full_report.spectrum if k.startswith("_")]
    t = np.arange(4000) / 200.0
    rng = np.random.default_rng(3)
    tau = np.sin(2 * np.pi * 0.3 * t)[:, None] * 10.0
    pred = tau + 0.05 * rng.standard_normal((4000, 1)) + 0.4 * np.sin(2 * np.pi * 17.0 * t)[:, None]
    r = dynval.validate(tau, pred, n_params=1, sample_rate=200.0)
    # the 17 Hz line is in the prediction, not in the measured torque: the prediction's own line
    # (conventions §5.2, prediction_artefact), found by the same spectrum tests
    peak = [f for f in r.findings if f.kind == "prediction_artefact"]
    assert peak and abs(peak[0].details["frequency"] - 17.0) < 0.5


def test_strict_json_of_non_finite_values():
    r = dynval.validate([2.0, 2.0, 2.0], [2.0, 2.0, 2.0], n_params=1)  # R² nan, AIC -inf
    text = r.to_json(indent=None)
    assert not re.search(r"\bNaN\b(?!\")|(?<!\")-?Infinity\b(?!\")", text.replace('"NaN"', "").replace(
        '"Infinity"', "").replace('"-Infinity"', ""))
    d = json.loads(text)
    assert d["pooled"]["r2"] == "NaN" and d["information_criteria"]["aic"] == "-Infinity"


@pytest.mark.parametrize("cls", [*SECTIONS.values(), rec.Segment, rec.MissingTerms], ids=lambda c: c.__name__)
def test_every_field_is_named_in_the_contract(cls):
    """One documented attribute per quantity: contract §4 names every field of every record."""
    text = (ROOT / "docs" / "contract.md").read_text(encoding="utf-8")
    section4 = text[text.index("## 4. `validate` and the report"):text.index("## 5. Backends")]
    missing = [f.name for f in dataclasses.fields(cls) if f.name != "_order" and f"`{f.name}`" not in section4]
    assert not missing, f"{cls.__name__}: {missing} not in contract §4"


def test_a_record_shows_its_values_not_only_its_names():
    rng = np.random.default_rng(0)
    tau = rng.normal(size=(400, 2)) * [30.0, 2.0]
    report = dynval.validate(tau, tau + rng.normal(scale=0.5, size=tau.shape), n_params=4)
    text = repr(report.per_joint)
    for name in report.per_joint:
        assert f"{name}=[" in text
    assert f"{report.per_joint.rmse[0]:.4g}"[:5] in text
    assert f"rmse_per_sample={report.pooled.rmse_per_sample:.4g}" in repr(report.pooled)
    html = report.per_joint._repr_html_()
    assert html.count("<tr>") == len(report.per_joint) and "PerJoint" in html


def test_a_long_array_or_mapping_is_abbreviated_in_a_repr():
    long = rec.PerJoint.of({"rmse": np.arange(1000.0)})
    assert "..." in repr(long) and len(repr(long)) < 200
    prov = rec.Provenance.of({"conventions": {f"k{i}": i for i in range(30)}})
    assert "30 entries" in repr(prov) and "k29" not in repr(prov)


def test_a_finding_prints_on_one_line():
    from dynval import Finding

    f = Finding(kind="bias", severity="deficiency", joints=(1,), pvalue_adjusted=1.234e-7,
                message="joint 2: the residual's mean is " + "x" * 300)
    text = repr(f)
    assert "\n" not in text and text.startswith("<Finding deficiency bias joints=[1] p_adj=1.23e-07: joint 2")
    assert len(text) < 200 and text.endswith("…>")


def _assert_same_value(value, decoded, where):
    """A section's value against its JSON text, decoded here: arrays as nested lists, non-finite
    numbers as the strings "NaN", "Infinity", "-Infinity" (contract §4)."""
    if isinstance(value, Mapping):
        assert isinstance(decoded, dict) and list(decoded) == [str(k) for k in value], where
        for k, v in value.items():
            _assert_same_value(v, decoded[str(k)], (*where, k))
    elif isinstance(value, (np.ndarray, list, tuple)) and not isinstance(value, str):
        arr = np.asarray(value, dtype=object)
        got = np.asarray(decoded, dtype=object)
        assert arr.shape == got.shape, where
        for a, b in zip(arr.ravel(), got.ravel()):
            _assert_same_value(a, b, where)
    elif isinstance(value, (float, np.floating)) and not np.isfinite(value):
        assert decoded == ("NaN" if np.isnan(value) else ("Infinity" if value > 0 else "-Infinity")), where
    elif isinstance(value, (bool, np.bool_)) or value is None or isinstance(value, str):
        assert decoded == (bool(value) if isinstance(value, np.bool_) else value), where
    else:
        assert decoded == pytest.approx(float(value), rel=1e-15, abs=0.0), where


def test_a_section_completed_later_keeps_each_names_place_and_adds_new_names_last():
    # a later step completes a section (the cross-correlation's parameter_error, the design's motion):
    # the record it gets lists its names as the mapping updated in place would, so the JSON is the same
    section = rec.CrossCorrelation.of({"max_lag": 3, "band": 0.1, "level": 0.95})
    done = section.with_(band=0.2, parameter_error=True)
    assert list(done) == ["max_lag", "band", "level", "parameter_error"]
    assert done.band == 0.2 and done.parameter_error is True
    assert list(section) == ["max_lag", "band", "level"] and section.band == 0.1  # the first record is unchanged
    with pytest.raises(TypeError, match="no field 'rho_typo'"):
        section.with_(rho_typo=1.0)


def test_present_reads_a_quantity_not_computed_as_none():
    design = rec.Design.of({"noise_n_eff": np.array([10.0])})
    assert rec.present(design.repeat) is None
    assert rec.present(design.noise_n_eff) is design.noise_n_eff
    assert rec.present(0.0) == 0.0  # a computed falsy value stays


def test_the_assembler_takes_the_builders_records_as_they_are(full_report):
    # validate's sections are built once, frozen: a route cannot write a section after the fact
    from dynval.report._assembly import Sections

    names = {f.name for f in dataclasses.fields(Sections)}
    assert {"per_joint", "bias", "white", "cross", "design", "physics"} <= names
    b = Sections(km={}, per_joint=full_report.per_joint, pooled=full_report.pooled,
                 aggregates=full_report.aggregates, residuals=full_report.residuals,
                 ic=full_report.information_criteria)
    with pytest.raises(dataclasses.FrozenInstanceError):
        b.bias = full_report.bias  # type: ignore[misc]


def test_the_missing_terms_are_a_record_written_as_the_contracts_mapping():
    # the added-variable test on a residual that holds half of an absent column: its record's
    # attributes are what the rules read, and the report writes the same names as a mapping
    rng = np.random.default_rng(3)
    n, m, p = 400, 1, 2
    reg = rng.standard_normal((n, m, p))
    e = 0.5 * reg[:, :, 1] + 0.1 * rng.standard_normal((n, m))
    tau = reg[:, :, 0] + e
    report = dynval.validate(tau, reg[:, :, 0], n_params=1, regressor=reg, model_columns=[0], max_lag=5)
    section = report.cross_correlation.missing_terms
    assert isinstance(section, dict)  # contract §4: a mapping inside the cross-correlation's record
    from dynval.statistics import _estimation

    found = rec.record_or_none(rec.MissingTerms, _estimation.added_variable(e, reg, [0], np.array([0]), None))
    assert isinstance(found, rec.MissingTerms)
    assert found.columns == [1] and found.method == "added_variable"
    assert list(section) == list(found)
    assert rec.present(found.alone) is None  # the refit's alone, not the added-variable test's
    assert found.share[0, 0] > 0.5  # e holds mostly 0.5·Y_1: the column removes most of its mean square


def test_a_model_of_every_column_has_no_missing_terms_with_or_without_the_estimation_run():
    # every column in model_columns: neither the refit nor the added-variable test has a column to try
    rng = np.random.default_rng(4)
    n, m, p = 300, 1, 2
    reg = rng.standard_normal((n, m, p))
    tau = reg.sum(axis=2) + 0.1 * rng.standard_normal((n, m))
    est = {"regressor": reg, "tau": tau}
    for estimation in (None, est):
        report = dynval.validate(tau, reg.sum(axis=2), n_params=2, regressor=reg, model_columns=[0, 1],
                                 estimation=estimation, max_lag=5)
        assert "missing_terms" not in report.cross_correlation
