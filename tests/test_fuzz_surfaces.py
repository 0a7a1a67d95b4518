"""Fuzzing the surfaces around a validation: fleets, physical consistency and the names on HTML pages.

As in ``tests/test_fuzz.py``, the outcome of any call is a result or a documented ``dynval.InputError``;
never another exception or a warning (pytest turns warnings into errors).

* Fleets: ``dynval.fleet.validate_many`` on CSV and JSON manifests written from drawn rows (names with
  odd characters, NUL, bytes that are not UTF-8, huge numbers, empty cells, missing files, a log listed
  twice, nested JSON, very long cells, paths with ``..``) that name tiny valid logs and broken ones, with
  every setting (``seed``, ``n_permutations``, ``n_params``, ``min_baseline``, ``ratio_threshold``) of
  every type. A bad log is an error row and the others are kept; a bad manifest is a FileInputError that
  names the manifest (contract §10); a bad setting an InvalidParameter naming it.
* ``dynval.physical_consistency`` on inertial parameter vectors in the column layout of
  :class:`dynval.robots.URDFModel` (masses from subnormal to 1e143, negative, NaN, wrong lengths) and on
  URDF files with odd values (inertias that are not positive semidefinite, zero masses, huge numbers,
  text where a number belongs): a list of findings or an InputError.
* HTML names: ``dynval.html.render_report`` (a validation and a comparison) and ``render_fleet_report``
  with joint, column, model and robot names of any text (``$``, ``\\``, ``<script>``, ``&``, control
  characters, lone surrogates, right-to-left marks, very long names): the page is well-formed XML after
  its doctype with no ``<script`` in it, and the figures draw the names (in a few examples: figures are
  slow) without an exception or a warning.

``DYNVAL_FUZZ_EXAMPLES`` sets the examples per test (scripts/sanitize.sh runs this file too).
"""

from __future__ import annotations

import csv
import io
import json
import os
import tempfile
import xml.etree.ElementTree as ET
from unittest import mock

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import dynval
import dynval.fleet as fleet
from dynval.io._files import FileInputError

EXAMPLES = int(os.environ.get("DYNVAL_FUZZ_EXAMPLES", "40"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, database=None, suppress_health_check=list(HealthCheck))
# Figures take a second or so each: a few examples, enough to draw every kind of name.
FIGURES = settings(FUZZ, max_examples=max(3, EXAMPLES // 10))

HUGE_INTS = [0, 1, 2, -1, 19, 2**31, 2**62 + 1, 2**63 - 1, 2**63, -(2**63), 10**400]
ANY_SETTING = st.one_of(
    st.sampled_from(HUGE_INTS),
    st.integers(-3, 40),
    st.booleans(),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([None, "", "3", "x", [1, 2], (), {}, b"3", 3.5, 1e400, np.int64(3), np.float64(2.0),
                     np.array(3), np.array([3])]),
)
ODD_TEXT = st.one_of(
    st.text(st.characters(codec=None, blacklist_categories=()), max_size=12),
    st.sampled_from(["", " ", "$\\frac$", "<script>alert(1)</script>", "a&b", "\x00", "r\udcffb", "\ud800",
                     "\u202eevil", "\ufffe", "a,b", 'q"uote', "line\nbreak", "x" * 5000, "..", "../..",
                     "1e400", "nan", "-inf", "2026-03-01T08-00", "9" * 400]),
)


# --------------------------------------------------------------------------- fleets


@pytest.fixture(scope="module")
def fleet_dir(tmp_path_factory):
    """Tiny logs (40 samples × 2 joints) and broken ones, side by side in one directory."""
    root = tmp_path_factory.mktemp("fleet_fuzz")
    rng = np.random.default_rng(7)
    for i in range(3):
        meas = rng.normal(size=(40, 2))
        np.save(root / f"meas{i}.npy", meas)
        np.save(root / f"pred{i}.npy", meas + (0.1 + 0.05 * i) * rng.normal(size=meas.shape))
    np.save(root / "nan.npy", np.full((40, 2), np.nan))
    np.save(root / "short.npy", rng.normal(size=(3, 2)))
    np.save(root / "wide.npy", rng.normal(size=(40, 5)))
    np.save(root / "q.npy", rng.normal(size=(40, 2)))
    (root / "text.npy").write_bytes(b"not an array")
    (root / "empty.csv").write_bytes(b"")
    (root / "sub").mkdir()
    np.savez(root / "r1__1.npz", tau_meas=np.load(root / "meas0.npy"), tau_pred=np.load(root / "pred0.npy"))
    (root / "r1__2").mkdir()
    np.save(root / "r1__2" / "tau_meas.npy", np.load(root / "meas1.npy"))
    np.save(root / "r1__2" / "tau_pred.npy", np.load(root / "pred1.npy"))
    return root


FILES = ["meas0.npy", "meas1.npy", "meas2.npy", "pred0.npy", "pred1.npy", "pred2.npy", "nan.npy", "short.npy",
         "wide.npy", "text.npy", "empty.csv", "missing.npy", "sub", "sub/../meas0.npy", "../meas0.npy",
         "meas0.npy:key", "meas0.npy:0", "/dev/null", "manifest.csv", "manifest.json", "q.npy"]


@st.composite
def manifest_rows(draw):
    """Rows of a manifest: mostly valid logs (so that runs happen), with drawn defects in some cells."""
    rows = []
    for i in range(draw(st.integers(1, 4)) if draw(st.integers(0, 19)) else 0):
        k = draw(st.integers(0, 2))
        row = {"robot": draw(st.sampled_from(["r1", "r2"])), "time": str(i), "tau_meas": f"meas{k}.npy",
               "tau_pred": f"pred{k}.npy", "n_params": draw(st.sampled_from([1, 2, 0, 1, 2, ""]))}
        for _ in range(draw(st.sampled_from([0, 0, 1, 2]))):
            column = draw(st.sampled_from(["robot", "time", "tau_meas", "tau_pred", "n_params", "log", "q",
                                           "regressor", "timestamps", "estimation_tau", "unknown"]))
            row[column] = draw(st.one_of(st.sampled_from(FILES), ODD_TEXT, st.sampled_from(HUGE_INTS),
                                         st.floats(allow_nan=False), st.none()))
        rows.append(row)
    if rows and draw(st.integers(0, 5)) == 0:
        rows.append(dict(rows[0]))  # a log listed twice
    return rows


def _json_cell(draw, value):
    """A JSON cell: as drawn, or now and then a nested object, a list or a boolean."""
    if draw(st.integers(0, 39)) == 0:
        return draw(st.sampled_from([{"a": [1]}, [value], True, None, 1e308, -0.0, [[[[]]]]]))
    return value if isinstance(value, (str, int, float, type(None))) and not (
        isinstance(value, int) and abs(value) > 2**64) else str(value)


def _manifest_bytes(draw, rows, kind):
    if kind == "json":
        cells = [{k: _json_cell(draw, v) for k, v in r.items()} for r in rows]
        data = {"logs": cells} if draw(st.booleans()) else cells
        text = json.dumps(data, ensure_ascii=draw(st.booleans()))
        if draw(st.integers(0, 19)) == 0:
            text = "[" * 100_000 + "]" * 100_000  # nested too deeply
        raw = text.encode("utf-8", "surrogatepass")
    else:
        out = io.StringIO()
        columns = list(dict.fromkeys(c for r in rows for c in r)) or list(fleet.MANIFEST_COLUMNS)
        if draw(st.integers(0, 19)) == 0:
            columns = columns[1:]  # a header without a needed column
        writer = csv.DictWriter(out, columns, extrasaction="ignore")
        writer.writeheader()
        for r in rows:
            writer.writerow({k: "" if v is None else v for k, v in r.items()})
        raw = out.getvalue().encode("utf-8", "surrogatepass")
    defect = draw(st.sampled_from(["none"] * 20 + ["nul", "latin-1", "bom", "truncate", "long line"]))
    if defect == "nul":
        raw = raw[: len(raw) // 2] + b"\x00" + raw[len(raw) // 2:]
    elif defect == "latin-1":
        raw = raw.replace(b"r1", b"r\xe91")
    elif defect == "bom":
        raw = b"\xef\xbb\xbf" + raw
    elif defect == "truncate":
        raw = raw[: draw(st.integers(0, len(raw)))]
    elif defect == "long line":
        raw += b"x" * (1 << 20) + b"\n"
    return raw


@st.composite
def fleet_runs(draw):
    rows = draw(manifest_rows())
    kind = draw(st.sampled_from(["csv", "json"]))
    raw = _manifest_bytes(draw, rows, kind)
    options = {"seed": draw(st.sampled_from([0, 1, 2**63 - 1])), "n_permutations": draw(st.sampled_from([19, 20])),
               "n_params": draw(st.sampled_from([None, 1, 3])), "min_baseline": draw(st.sampled_from([2, 3])),
               "ratio_threshold": draw(st.sampled_from([1.0, 1.1, 1e300]))}
    if draw(st.integers(0, 4)) == 0:  # one setting of any type
        options[draw(st.sampled_from(sorted(options)))] = draw(ANY_SETTING)
    return rows, kind, raw, options


_SETTINGS = ("seed", "n_permutations", "n_params", "min_baseline", "ratio_threshold")


@FUZZ
@given(run=fleet_runs())
def test_fleet_manifests(fleet_dir, run):
    rows, kind, raw, options = run
    with tempfile.TemporaryDirectory(dir=fleet_dir) as tmp:
        manifest = os.path.join(tmp, f"manifest.{kind}")
        with open(manifest, "wb") as handle:
            handle.write(raw)
        for name in ("meas0.npy", "meas1.npy", "meas2.npy", "pred0.npy", "pred1.npy", "pred2.npy"):
            os.symlink(fleet_dir / name, os.path.join(tmp, name))
        try:
            report = fleet.validate_many([manifest], scheduler="single", progress=False, max_lag=2, **options)
        except FileInputError as error:
            event(f"manifest refused: {str(error)[len(manifest):][:50]}")
            assert manifest in str(error), error  # a bad manifest is refused naming the file
            return
        except dynval.InputError as error:
            event(f"refused: {type(error).__name__}: {str(error)[-60:]}")
            # a setting, or n_params of a row (named with the manifest)
            assert any(s in str(error) for s in _SETTINGS) or manifest in str(error), error
            return
    assert len(report.logs) == len(rows)  # every row is a row of the table
    event(f"ran: {sum(r.error is None for r in report.logs)} valid, {sum(r.error is not None for r in report.logs)} "
          "error rows")
    for row in report.logs:
        if row.error is None:
            assert row.decision in ("accept", "refine", "redesign") and np.isfinite(row.rmse)
        else:
            assert row.decision == "error" and row.error.split(":")[0].isidentifier(), row
    report.summary()
    json.dumps(report.to_dict(), allow_nan=False) if hasattr(report, "to_dict") else None


@FUZZ
@given(items=st.lists(st.one_of(
    st.sampled_from(["r1__1.npz", "r1__2", "r2__x.h5", "nopattern.npz", "missing__3", "sub", "r1__1.npz"]),
    st.fixed_dictionaries({"robot": ODD_TEXT, "time": ODD_TEXT,
                           "tau_meas": st.sampled_from(["meas2.npy"] * len(FILES) + FILES),
                           "tau_pred": st.sampled_from(["pred2.npy"] * len(FILES) + FILES),
                           "n_params": st.one_of(st.just(1), ANY_SETTING)})), max_size=4))
def test_fleet_logs_named_by_path_or_mapping(fleet_dir, items):
    """Logs named by a path or a mapping (paths as given, relative to the fixture's directory): a log
    that cannot be named, found or read is an error row; a log listed twice is refused."""
    cwd = os.getcwd()
    os.chdir(fleet_dir)
    try:
        report = fleet.validate_many(items, n_params=1, scheduler="single", progress=False, max_lag=2,
                                     n_permutations=19)
    except dynval.InputError as error:
        event("refused")
        assert "listed twice" in str(error), error
        return
    finally:
        os.chdir(cwd)
    assert len(report.logs) == len(items)
    event(f"ran: {sum(r.error is None for r in report.logs)} valid")
    assert all((r.error is None) == (r.decision != "error") for r in report.logs)


# --------------------------------------------------------------------------- physical consistency

MASSES = [5e-324, 2.2250738585072014e-308, 1e-300, 1e-12, 0.0, -0.0, 1.0, 3.7, 1e80, 1e143, -1.0, -1e143,
          np.nan, np.inf, -np.inf, 1.7976931348623157e308]


@pytest.fixture(scope="module")
def arm():
    pytest.importorskip("pinocchio")
    from dynval.robots import URDFModel, planar_arm_urdf

    return URDFModel(planar_arm_urdf())


@FUZZ
@given(data=st.data())
def test_physical_consistency_of_parameter_vectors(arm, data):
    draw = data.draw
    names = list(arm.column_names())
    values = np.array(arm.parameters(), dtype=float)
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    with np.errstate(all="ignore"):
        values *= draw(st.sampled_from([1.0, 1e-300, 1e-5, 1e5, 1e140, -1.0]))
        for link in range(arm.n_joints):
            if draw(st.booleans()):
                values[10 * link] = draw(st.sampled_from(MASSES))
        for _ in range(draw(st.integers(0, 3)) if draw(st.booleans()) else 0):
            values[int(rng.integers(0, values.size))] = draw(st.sampled_from(MASSES + [0.5, -0.5]))
    shape = draw(st.sampled_from(["vector"] * 5 + ["links", "short", "long", "empty", "2-D", "object"]))
    column_names = names if draw(st.booleans()) else None
    if column_names is None:  # ten per link without names
        values = values[: 10 * arm.n_joints]
    if shape == "links":
        column_names, values = None, values[: 10 * arm.n_joints].reshape(arm.n_joints, 10)
    elif shape == "short":
        values = values[: draw(st.integers(0, values.size - 1))]
    elif shape == "long":
        values = np.concatenate([values, [1.0] * draw(st.integers(1, 11))])
    elif shape == "empty":
        values = np.empty((0,))
    elif shape == "2-D":
        values = values.reshape(1, -1)
    elif shape == "object":
        values = list(values[:10]) + [draw(st.sampled_from(["x", None, 1j, [1.0]]))]
    if column_names is not None and draw(st.integers(0, 9)) == 0:
        column_names = draw(st.sampled_from([names[:-1], names + ["x"], [1] * len(names), "abc",
                                             [n.replace(":", "") for n in names]]))
    keywords = {}
    if draw(st.integers(0, 3)) == 0:
        keywords = {"com_bounds": draw(st.sampled_from([((-1, -1, -1), (1, 1, 1)), ((1, 1, 1), (-1, -1, -1)),
                                                        ((np.nan,) * 3, (1,) * 3), "x", {"nolink": None},
                                                        ((0, 0), (1, 1))]))}
    if draw(st.integers(0, 5)) == 0:
        keywords["tolerance"] = draw(st.one_of(st.sampled_from([0.0, 1e-9, 0.5]), ANY_SETTING))
    if draw(st.integers(0, 3)) == 0:
        keywords["joint_names"] = draw(st.lists(ODD_TEXT, max_size=3))
    _findings_or_input_error(lambda: dynval.physical_consistency(values, column_names=column_names, **keywords))


def _findings_or_input_error(call):
    try:
        found = call()
    except dynval.InputError as error:
        event(f"refused: {type(error).__name__}: {str(error)[:40]}")
        return
    event(f"{len(found)} findings" if len(found) < 3 else "3+ findings")
    assert isinstance(found, list)
    for f in found:
        assert f.kind == "physical_consistency" and f.severity in ("deficiency", "note")
        str(f.message)


URDF_NUMBERS = ["1", "0", "-1", "0.0", "-0", "5e-324", "1e-300", "1e143", "1e308", "1e400", "-1e400", "nan", "inf",
                "-inf", "", "abc", "1,5", "0x10", " 2 ", "1e-7"]


@st.composite
def urdf_texts(draw):
    """The planar arm's URDF with drawn masses, inertias, centres of mass and damping."""
    from dynval.robots import planar_arm_urdf

    text = planar_arm_urdf(name=draw(st.sampled_from(["arm", "a&amp;b", "&lt;script&gt;", ""])))
    root = ET.fromstring(text)
    number = st.one_of(st.sampled_from(URDF_NUMBERS), st.floats(allow_nan=True, allow_infinity=True).map(repr))
    places = [(e, a) for e in root.iter() for a in e.attrib
              if e.tag in ("mass", "inertia", "dynamics") or (e.tag == "origin" and a == "xyz")]
    for _ in range(draw(st.integers(1, 4))):
        element, attribute = draw(st.sampled_from(places))
        if attribute == "xyz":
            element.set(attribute, " ".join(draw(number) for _ in range(draw(st.sampled_from([3, 3, 3, 2, 4])))))
        else:
            element.set(attribute, draw(number))
    if draw(st.integers(0, 5)) == 0:  # a link without its inertial
        for link in root.iter("link"):
            for inertial in link.findall("inertial"):
                link.remove(inertial)
                break
    out = ET.tostring(root, encoding="unicode")
    if draw(st.integers(0, 9)) == 0:
        out = out[: draw(st.integers(0, len(out)))]  # not XML any more
    return out


@FUZZ
@given(text=urdf_texts(), as_path=st.booleans())
def test_physical_consistency_of_urdf_files(arm, tmp_path_factory, text, as_path):
    path = tmp_path_factory.mktemp("urdf") / "robot.urdf"
    path.write_text(text, encoding="utf-8")
    source = str(path) if as_path else path
    _findings_or_input_error(lambda: dynval.physical_consistency(source))


# --------------------------------------------------------------------------- names on HTML pages

NAME = st.one_of(
    st.text(st.characters(codec=None, blacklist_categories=()), min_size=1, max_size=10),
    st.sampled_from(["$", "$$", "$\\frac$", "\\", "\\\\n", "<script>alert(1)</script>", "<SCRIPT", "&", "&amp;",
                     "]]>", "\x00", "\x01\x1b[31m", "\ud800", "r\udcffb", "\u202e\u200f", "\ufeff", "\ufffe",
                     "漢字", "x" * 3000, "a\nb", "\"'", "{}", "%s", "-->"]),
)


# Known, not fixed yet: a column or robot name of thousands of characters collapses a figure's axes (matplotlib's
# "constrained_layout not applied" UserWarning). The pages take any length; figures names up to 200.
DRAWN_NAME = NAME.filter(lambda name: len(name) <= 200)


def _names(draw, n, names=NAME):
    """n distinct names (validate refuses duplicates): a drawn name that is taken gets its index appended."""
    out: list[str] = []
    for i, name in enumerate(draw(st.lists(names, min_size=n, max_size=n))):
        out.append(name if name not in out else f"{name}{i}")
    return out


def _well_formed(page: str) -> None:
    root = ET.fromstring(page.split("\n", 1)[1])  # well-formed XML after the doctype
    assert root.tag == "{http://www.w3.org/1999/xhtml}html"
    assert "<script" not in page.lower()
    assert not any(e.tag.lower().endswith("script") for e in root.iter())
    page.encode("utf-8")  # what write_report writes


def _problem(seed):
    rng = np.random.default_rng(seed)
    tau = rng.normal(size=(60, 2))
    y = rng.normal(size=(60, 2, 3))
    return tau, tau + 0.3 * rng.normal(size=tau.shape), y


def _report_and_page(draw, figures: bool):
    from dynval.html import render_report

    tau, pred, y = _problem(draw(st.integers(0, 2**32 - 1)))
    names = DRAWN_NAME if figures else NAME
    joints, columns = _names(draw, 2, names), _names(draw, 3, names)
    keywords = {"joint_names": joints, "column_names": columns, "sample_rate": 100.0}
    if draw(st.booleans()):
        models = _names(draw, 2, names)
        obj = dynval.compare(tau, {models[0]: (pred, 3, y), models[1]: (pred + 0.1, 3, y)}, **keywords)
    else:
        obj = dynval.validate(tau, pred, n_params=3, regressor=y, **keywords)
    title = draw(NAME)
    if figures:
        return obj, render_report(obj, tau_meas=tau, tau_pred=pred, title=title)
    with mock.patch("dynval.html._have_matplotlib", lambda: False):
        return obj, render_report(obj, title=title)


@FUZZ
@given(data=st.data())
def test_report_pages_with_any_names(data):
    obj, page = _report_and_page(data.draw, figures=False)
    _well_formed(page)
    obj.summary() if hasattr(obj, "summary") else str(obj)


@FIGURES
@given(data=st.data())
def test_report_figures_with_any_names(data):
    _obj, page = _report_and_page(data.draw, figures=True)
    _well_formed(page)
    assert "data:image/png;base64," in page
    import matplotlib.pyplot as plt

    plt.close("all")


@st.composite
def fleet_reports(draw, names=NAME):
    """A FleetReport of drawn robots, times, log ids and errors, its drift tested as validate_many does."""
    from dynval.fleet import LogSummary, _in_fleet_order
    from dynval.fleet._drift import drift_per_robot

    robots = _names(draw, draw(st.integers(1, 3)), names)
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    rows = []
    for i in range(draw(st.integers(1, 9))):
        robot = robots[i % len(robots)]
        log = f"{draw(names)}{i}"
        if draw(st.integers(0, 4)) == 0:
            rows.append(LogSummary(robot, draw(NAME), log, error=f"FileInputError: {draw(NAME)}"))
            continue
        rmse = float(rng.uniform(0.5, 2.0))
        rows.append(LogSummary(robot, str(i), log, n_samples=60, n_joints=2, rmse=rmse, vaf=99.0,
                               rmse_per_joint=(rmse, rmse), decision=draw(st.sampled_from(["accept", "refine"])),
                               n_findings=1, kinds=(draw(NAME),), sees=draw(NAME)))
    ordered = _in_fleet_order(rows)
    drift = drift_per_robot(ordered, level=0.95, min_baseline=2, n_permutations=19, seed=0)
    provenance = {"n_logs": len(ordered), "n_robots": len(drift), "where": draw(NAME), "seconds": 0.1,
                  "min_baseline": 2, "ratio_threshold": 1.1, "n_permutations": 19, "seed": 0}
    return fleet.FleetReport(tuple(ordered), tuple(drift), 0.95, provenance)


@FUZZ
@given(report=fleet_reports(), title=st.one_of(st.none(), NAME))
def test_fleet_pages_with_any_names(report, title):
    from dynval.html import render_fleet_report

    with mock.patch("dynval.html._have_matplotlib", lambda: False):
        _well_formed(render_fleet_report(report, title=title))
    report.summary()


@FIGURES
@given(report=fleet_reports(DRAWN_NAME))
def test_fleet_figures_with_any_names(report):
    from dynval.html import render_fleet_report

    _well_formed(render_fleet_report(report))
    import matplotlib.pyplot as plt

    plt.close("all")
