"""dynval.html: the report is one well-formed, self-contained file with the tables, findings,
figures and provenance, and it opens in a headless browser where one is installed."""

from __future__ import annotations

import base64
import re
import shutil
import subprocess
import xml.etree.ElementTree as ET
from html.parser import HTMLParser
from types import SimpleNamespace

import numpy as np
import pytest

pytest.importorskip("matplotlib")  # the figures are part of what is checked

import dynval
from dynval.html import render_report, write_report
from dynval.identify import identify
from dynval.simulate import simulate

XHTML = "{http://www.w3.org/1999/xhtml}"


@pytest.fixture(scope="module")
def scenario():
    d = simulate("friction", n_samples=800)
    est, val = d.estimation, d.validation
    reports, preds = {}, {}
    for name in d.candidates:
        res = identify(est.regressors[name], est.tau_meas)
        preds[name] = res.predict(val.regressors[name])
        reports[name] = dynval.validate(val.tau_meas, preds[name], n_params=res.rank, regressor=val.full_regressor,
                                        sample_rate=d.sample_rate, joint_names=list(d.joint_names),
                                        column_names=list(d.full_column_names))
    return d, reports, preds


class _TagBalance(HTMLParser):
    VOID = frozenset({"meta", "img", "br", "hr", "link", "input"})

    def __init__(self):
        super().__init__()
        self.stack, self.errors, self.tags = [], [], []

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))
        if tag not in self.VOID:
            self.stack.append(tag)

    def handle_startendtag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))

    def handle_endtag(self, tag):
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"unexpected </{tag}> (open: {self.stack[-3:]})")
        else:
            self.stack.pop()


def _check_self_contained(text):
    parser = _TagBalance()
    parser.feed(text)
    assert not parser.errors and not parser.stack
    root = ET.fromstring(text.split("\n", 1)[1])  # well-formed XML after the doctype
    assert root.tag == XHTML + "html"
    ids = {attrs["id"] for _tag, attrs in parser.tags if "id" in attrs}
    for tag, attrs in parser.tags:
        assert tag not in ("script", "link", "iframe", "object")
        for key in ("src", "href"):
            if key in attrs:
                # embedded data, or a jump to a section of the page itself (the contents line)
                target = attrs[key]
                assert target.startswith("data:") or (target.startswith("#") and target[1:] in ids), (
                    tag, target[:60])
    assert "http://" not in text.replace('xmlns="http://www.w3.org/1999/xhtml"', "")
    assert "https://" not in text
    assert "@import" not in text and "url(" not in text
    return root, parser


def _images(parser):
    out = []
    for tag, attrs in parser.tags:
        if tag == "img":
            src = attrs["src"]
            assert src.startswith("data:image/png;base64,")
            png = base64.b64decode(src.split(",", 1)[1])
            assert png[:8] == b"\x89PNG\r\n\x1a\n"
            out.append(attrs.get("alt", ""))
    return out


def test_validation_report_html(scenario, tmp_path):
    d, reports, preds = scenario
    rep = reports["rigid"]
    path = write_report(rep, tmp_path / "val.html", tau_meas=d.validation.tau_meas, tau_pred=preds["rigid"])
    text = (tmp_path / "val.html").read_text(encoding="utf-8")
    assert path.endswith("val.html")
    _root, parser = _check_self_contained(text)
    assert "dynval validation report" in text
    # per-joint table: one row per joint + pooled, with the report's numbers
    for _j, name in enumerate(d.joint_names):
        assert f'<td class="text">{name}</td>' in text
    assert f"{rep.per_joint['rmse'][0]:.4g}" in text
    # findings of the report are all there
    for f in rep.findings:
        assert f.message.split(":")[0] in text
    # figures: prediction, residuals, ACF, cross-correlation (+ spectrum when the report has one)
    alts = _images(parser)
    expected = 4 + (rep.spectrum is not None)
    assert len(alts) == expected
    assert "Provenance" in text and "Full report as JSON" in text


def test_validation_report_without_torques_has_report_figures_only(scenario):
    _d, reports, _preds = scenario
    text = render_report(reports["friction"])
    _, parser = _check_self_contained(text)
    alts = _images(parser)
    assert not any("Measured and predicted" in a for a in alts)
    assert any("autocorrelation" in a for a in alts)


def test_comparison_report_html_from_a_comparison_shaped_object(scenario, tmp_path):
    # The renderer reads a ComparisonReport through its documented attributes; this object has
    # exactly those, filled from real validation reports.
    d, reports, preds = scenario
    names = list(d.candidates)
    pooled = {n: {"rmse": reports[n].pooled["rmse_per_element"], "vaf": reports[n].pooled["vaf"],
                  "aic": reports[n].information_criteria["aic"]} for n in names}
    cmp = SimpleNamespace(
        names=names, ranking=["friction", "friction+offset", "rigid"], reports=reports,
        table={"pooled": pooled, "per_joint": {}},
        verdict=SimpleNamespace(decision="accept", model="friction", reasons=["lowest AIC", "white residuals"]),
        to_dict=lambda: {"names": names},
    )
    write_report(cmp, tmp_path / "cmp.html", tau_meas=d.validation.tau_meas, tau_pred=preds)
    text = (tmp_path / "cmp.html").read_text(encoding="utf-8")
    _root, parser = _check_self_contained(text)
    assert 'class="verdict accept"' in text and "lowest AIC" in text
    # decision table: ranked rows, the chosen one highlighted
    rows = re.findall(r'<tr(?: class="(\w*)")?><td class="text">([^<]+)</td><td>(\d)</td>', text)
    assert [(r[1], r[2]) for r in rows] == [("friction", "1"), ("friction+offset", "2"), ("rigid", "3")]
    assert rows[0][0] == "chosen"
    for n in names:
        assert f"Model '{n}'" in text
    alts = _images(parser)
    assert any("VAF" in a for a in alts)                     # the bars of every candidate
    assert any("Measured and predicted" in a and "friction" in a for a in alts)


@pytest.mark.skipif(not hasattr(dynval, "compare"), reason="dynval.compare is not in this build yet")
def test_comparison_report_html_from_dynval_compare(scenario, tmp_path):
    d, reports, preds = scenario
    cands = {n: (preds[n], reports[n].provenance["n_params"], d.validation.full_regressor) for n in d.candidates}
    cmp = dynval.compare(d.validation.tau_meas, cands, sample_rate=d.sample_rate,
                         joint_names=list(d.joint_names), column_names=list(d.full_column_names))
    write_report(cmp, tmp_path / "c.html")
    text = (tmp_path / "c.html").read_text(encoding="utf-8")
    _check_self_contained(text)
    assert cmp.verdict.decision in text


@pytest.mark.skipif(not hasattr(dynval, "compare"), reason="dynval.compare is not in this build yet")
def test_every_section_of_a_comparison_says_whose_it_is(scenario, tmp_path):
    """The page ended with a 'Provenance' that was one candidate's, unlabelled, after the last one's."""
    from dynval import plot

    d, reports, preds = scenario
    cands = {n: (preds[n], reports[n].provenance["n_params"], d.validation.full_regressor) for n in d.candidates}
    cmp = dynval.compare(d.validation.tau_meas, cands, sample_rate=d.sample_rate,
                         joint_names=list(d.joint_names), column_names=list(d.full_column_names))
    write_report(cmp, tmp_path / "c.html", tau_meas=d.validation.tau_meas, tau_pred=preds,
                 figures=[(plot.metrics(cmp), "a figure of the caller's")])
    text = (tmp_path / "c.html").read_text(encoding="utf-8")
    headings = [h for _, h in re.findall(r"<(h[23])(?: id=\"[^\"]*\")?>(.*?)</\1>", text)]  # h2s have anchors
    whose = ("every candidate", "per candidate", "not of one candidate", *(f"odel '{n}'" for n in d.candidates))
    for h in headings:
        assert any(w in h for w in whose), h
    # the closing provenance holds the fields every candidate shares, each model's section its own
    closing = re.split(r"<h2[^>]*>Provenance shared by every candidate", text, maxsplit=1)[1]
    assert "<td class=\"text\">n_params</td>" not in closing and "<td class=\"text\">profile</td>" in closing
    for n in d.candidates:
        own = text.split(f"<h3>Provenance of model '{n}' (its own fields)</h3>", 1)[1].split("<h", 1)[0]
        assert f"<td class=\"text\">{reports[n].provenance['n_params']}</td>" in own
    assert "Full comparison as JSON (every candidate)" in text


def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


@pytest.mark.skipif(_chromium() is None, reason="no headless Chromium installed")
def test_opens_in_headless_chromium(scenario, tmp_path):
    d, reports, preds = scenario
    page = tmp_path / "report.html"
    write_report(reports["rigid"], page, tau_meas=d.validation.tau_meas, tau_pred=preds["rigid"])
    shot = tmp_path / "shot.png"
    proc = subprocess.run([_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                           f"--screenshot={shot}", "--window-size=1200,3000", page.as_uri()],
                          capture_output=True, text=True, timeout=120)
    assert shot.is_file(), proc.stderr[-2000:]
    data = shot.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    matplotlib = pytest.importorskip("matplotlib.image")
    img = matplotlib.imread(str(shot))
    assert img.shape[:2] == (3000, 1200)
    # Rendered content, not a blank page: many distinct colours (tables, text, figures).
    flat = (img[:, :, :3] * 255).astype(np.uint8).reshape(-1, 3)
    assert len(np.unique(flat[::37], axis=0)) > 50


_MEASURE = """<script>
document.addEventListener('DOMContentLoaded', () => {
  const wide = [...document.querySelectorAll('div.scroll')].filter(d => d.scrollWidth > d.clientWidth + 1);
  document.body.setAttribute('data-overflowing', wide.length + ':' + wide.map(
      d => d.querySelector('th') ? d.querySelector('tr').innerText.slice(0, 60) : '').join('|'));
});
</script></body>"""


@pytest.mark.skipif(_chromium() is None, reason="no headless Chromium installed")
def test_every_table_of_a_comparison_fits_a_1280_px_window(tmp_path):
    """The decision table (and every other) of the demo's comparison shows whole at 1280 px: no
    horizontal scrollbar (the criteria in fixed notation with their Δ, units in the headers; four
    significant digits and separate Δ columns made it scroll)."""
    from dynval.demo import run_demo

    cmp = run_demo("friction", progress=None).comparison
    page = tmp_path / "cmp.html"
    page.write_text(render_report(cmp).replace("</body>", _MEASURE), encoding="utf-8")
    proc = subprocess.run([_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--window-size=1280,2000",
                           "--dump-dom", page.as_uri()], capture_output=True, text=True, timeout=120)
    found = re.search(r'data-overflowing="([^"]*)"', proc.stdout)
    assert found, proc.stderr[-2000:]
    assert found.group(1).startswith("0:"), f"tables wider than the window: {found.group(1)}"
    # two AICs 60 apart read apart: fixed notation, with the Δ to the best
    html = render_report(cmp)
    for name in cmp.ranking:
        row = cmp.table["pooled"][name]
        assert f"<td>{row['aic']:.1f} ({row['delta_aic']:+.1f})</td>" in html, name
        ic = cmp.reports[name].information_criteria  # each candidate's own criteria table too
        assert f"<td>{ic['aic']:.1f}</td>" in html and f"<td>{ic['bic']:.1f}</td>" in html, name


# --------------------------------------------------------------------------- names as written

NAMES = ["$\\frac$", "$x^2$ and $y$", "r\udcffb"]   # mathtext, a pair of $, a byte that was not UTF-8
SHOWN = ["$\\frac$", "$x^2$ and $y$", "r\\xffb"]


def _svg_text(fig):
    """The text a figure draws, as an SVG that keeps text as text (mathtext would be drawn as paths)."""
    import io

    import matplotlib

    out = io.StringIO()
    with matplotlib.rc_context({"svg.fonttype": "none"}):
        fig.savefig(out, format="svg")
    import matplotlib.pyplot as plt

    plt.close(fig)
    return out.getvalue().replace("&amp;", "&")


def test_fleet_names_are_drawn_and_written_literally(tmp_path):
    """A robot named '$\\frac$' stopped write_fleet_report with matplotlib's mathtext error."""
    from dynval import fleet, plot
    from dynval.html import write_fleet_report

    files = fleet.write_fleet(fleet.simulate_fleet(n_robots=1, n_logs=6, n_samples=200), tmp_path)
    specs = [fleet.LogSpec(NAMES[i % 3], str(i), s.tau_meas, s.tau_pred, 3, log=f"log{i}") for i, s in enumerate(files)]
    rep = fleet.validate_many(specs, scheduler="single", max_lag=5, progress=False)
    write_fleet_report(rep, tmp_path / "fleet.html")
    page = (tmp_path / "fleet.html").read_text(encoding="utf-8")
    metrics, drift = _svg_text(plot.fleet_metrics(rep)), _svg_text(plot.fleet_drift(rep))
    for shown in SHOWN:
        assert shown in page and shown in metrics and shown in drift


def test_joint_and_model_names_are_drawn_and_written_literally(tmp_path):
    """A joint name holding a lone surrogate (byte 0xff on the command line) stopped --html."""
    from dynval import plot

    rng = np.random.default_rng(0)
    tau = rng.normal(size=(400, 3))
    pred = tau + 0.1 * rng.normal(size=tau.shape)
    report = dynval.validate(tau, pred, n_params=1, joint_names=NAMES)
    write_report(report, tmp_path / "r.html", tau_meas=tau, tau_pred=pred)
    page = (tmp_path / "r.html").read_text(encoding="utf-8")
    for shown in SHOWN:
        assert shown in page
    for fig in (plot.autocorrelation(report), plot.residuals(tau, pred, report=report),
                plot.prediction(tau, pred, report=report, model_name=NAMES[0])):
        drawn = _svg_text(fig)
        for shown in SHOWN:
            assert shown in drawn


def test_names_with_characters_xml_does_not_allow_keep_the_page_well_formed(tmp_path):
    """A joint named 'a\\x01b' (a control character) or holding U+FFFE left the page not well-formed
    XML; such a character is written as its escape."""
    rng = np.random.default_rng(1)
    tau = rng.normal(size=(200, 3))
    report = dynval.validate(tau, tau + 0.1 * rng.normal(size=tau.shape), n_params=1,
                             joint_names=["a\x01b", "c\x1bd", "e\ufffef"])
    page = render_report(report, title="t\x00")
    _check_self_contained(page)
    for shown in ("a\\x01b", "c\\x1bd", "e\\ufffef", "t\\x00"):
        assert shown in page


def test_names_the_fonts_cannot_draw_are_drawn_as_escapes():
    """A joint named with a control character or a script the figures' fonts lack drew boxes with
    matplotlib's 'Glyph ... missing from font(s)' warning on standard error."""
    from dynval import plot

    rng = np.random.default_rng(2)
    tau = rng.normal(size=(200, 2))
    pred = tau + 0.1 * rng.normal(size=tau.shape)
    names = ["a\x1fb", "j\U000f0000"]  # a control character, a private-use character no font has
    report = dynval.validate(tau, pred, n_params=1, joint_names=names)
    drawn = _svg_text(plot.residuals(tau, pred, report=report))  # warnings are errors in this suite
    assert "a\\x1fb" in drawn and "j\\U000f0000" in drawn


def test_the_headline_says_on_how_many_joints_the_model_is_deficient_not_how_many_findings():
    """A bias on one joint of three makes findings of several kinds there; the headline counts the
    joints (one of three), and the number of findings is said beside it, not as the headline.
    Kills: the headline back to the count of findings ("3 deficiencies found"), the joints counted
    from every finding (notes included), the accepting box saying a count."""
    rng = np.random.default_rng(0)
    tau = rng.normal(size=(2000, 3))
    pred = tau + 0.05 * rng.normal(size=tau.shape)
    pred[:, 1] += 0.5  # the elbow's prediction is off by a constant: its residual has a mean
    report = dynval.validate(tau, pred, n_params=3)
    defic = [f for f in report.findings if f.severity == "deficiency"]
    assert defic and {j for f in defic for j in f.joints} == {1}
    page = render_report(report)
    headline = re.search(r'<div class="decision">(.*?)</div>', page).group(1)
    assert headline == "deficient on 1 of 3 joints"
    n = len(defic)
    assert f"{n} deficienc{'y' if n == 1 else 'ies'}, the strongest first below" in page
    right = dynval.validate(tau, tau + 0.05 * rng.normal(size=tau.shape), n_params=3)
    assert not right.deficiencies
    assert re.search(r'<div class="decision">(.*?)</div>', render_report(right)).group(1) == "no deficiency found"
