"""In notebooks: reports render as HTML (``_repr_html_``) and their tables come out as pandas
DataFrames (``to_frame()``), the conventions statsmodels and pandas users expect."""

from __future__ import annotations

import re
import sys

import numpy as np
import pytest

import dynval


@pytest.fixture(scope="module")
def comparison():
    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 10.0, 400)
    tau = np.column_stack([np.sin(t), np.cos(t)])
    return dynval.compare(tau, {"good": (tau + 0.01 * rng.standard_normal(tau.shape), 2), "scaled": (0.9 * tau, 1)},
                          joint_names=["shoulder", "elbow"])


def test_reports_render_as_scoped_html_fragments(comparison):
    for obj in (comparison, comparison.reports["good"]):
        html = obj._repr_html_()
        assert html.startswith('<div class="dynval-report">') and html.endswith("</div>")
        assert "<html" not in html and "<body" not in html and "<script" not in html
        style = re.search(r"<style>(.*?)</style>", html, re.S).group(1)
        selectors = [s.strip() for rule in style.split("}") if "{" in rule for s in rule.split("{")[0].split(",")]
        assert selectors and all(s.startswith(".dynval-report") for s in selectors), selectors
        assert "shoulder" in html and "Provenance" in html
    html = comparison._repr_html_()
    assert "Verdict: accept" in html and "Decision table" in html and "scaled" in html
    assert "Per joint" in comparison.reports["good"]._repr_html_()


def test_validation_frame_is_the_per_joint_table(comparison):
    rep = comparison.reports["good"]
    frame = rep.to_frame()
    assert list(frame.index) == ["shoulder", "elbow"] and frame.index.name == "joint"
    assert list(frame.columns) == [*rep.per_joint, "mean", "variance"]
    for key in rep.per_joint:
        np.testing.assert_array_equal(frame[key].to_numpy(), rep.per_joint[key])
    np.testing.assert_array_equal(frame["mean"].to_numpy(), rep.residuals["mean"])
    unnamed = dynval.validate([[1.0, 2.0], [2.0, 1.0], [3.0, 5.0]], [[1.1, 2.2], [1.9, 1.1], [3.2, 4.7]], n_params=1)
    assert list(unnamed.to_frame().index) == ["joint 1", "joint 2"]


def test_comparison_frame_is_the_pooled_decision_table_in_ranking_order(comparison):
    frame = comparison.to_frame()
    assert list(frame.index) == comparison.ranking and frame.index.name == "model"
    for name in comparison.ranking:
        for key, value in comparison.table["pooled"][name].items():
            assert frame.loc[name, key] == value or (value != value and frame.loc[name, key] != frame.loc[name, key])


def test_frames_say_pandas_is_needed_when_it_is_missing(comparison, monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(ImportError, match=r"ComparisonReport.to_frame needs pandas: pip install pandas"):
        comparison.to_frame()
    with pytest.raises(ImportError, match=r"ValidationReport.to_frame needs pandas"):
        comparison.reports["good"].to_frame()
