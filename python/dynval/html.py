"""One self-contained HTML file for a validation or a comparison: what a person reads.

:func:`write_report` writes the verdict (for a comparison), the tables, the findings with
what to do about them, the figures (PNG embedded as base64 ``data:`` URIs) and the provenance,
in a single file with its CSS inline: no network, no external CSS or JavaScript. The markup is
well-formed XML (every element closed), so it can also be checked or processed as XHTML.

Figures need matplotlib (the ``plot`` extra); without it the report says so and keeps the
tables. The residual figures need the torques themselves, which a report does not keep: pass
``tau_meas`` and ``tau_pred`` to have them.
"""

from __future__ import annotations

import base64
import datetime as _dt
import html as _html
import io
import json
import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .checks._json import to_jsonable
from .report._text import printable, pvalue_text

__all__ = ["write_report", "render_report", "render_fragment", "write_fleet_report", "render_fleet_report"]

_CSS = """
body { font-family: system-ui, -apple-system, 'Segoe UI', Roboto, Helvetica, Arial, sans-serif;
       margin: 0 auto; max-width: 1180px; padding: 1.5em 2em; color: #1a1a1a; line-height: 1.45; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; }
h2 { font-size: 1.25em; border-bottom: 2px solid #ddd; padding-bottom: 0.2em; margin-top: 2em; }
h3 { font-size: 1.05em; margin-top: 1.4em; }
.sub { color: #555; margin-top: 0; }
table { border-collapse: collapse; margin: 0.6em 0 1em 0; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.3em 0.6em; text-align: right; vertical-align: top; }
th { background: #f2f2f2; }
td.text, th.text { text-align: left; }
tr.chosen td { background: #eef6ee; font-weight: 600; }
td ul { margin: 0; padding-left: 1.2em; }
td li { font-weight: normal; }
.verdict { border-radius: 6px; padding: 0.8em 1.2em; margin: 1em 0; border: 2px solid; }
.verdict.accept { background: #eef8ee; border-color: #2e7d32; }
.verdict.refine { background: #fff7e6; border-color: #e08a00; }
.verdict.redesign { background: #fdecea; border-color: #c62828; }
.verdict .decision { font-size: 1.3em; font-weight: 700; text-transform: uppercase; }
.sev { font-weight: 700; padding: 0.05em 0.4em; border-radius: 3px; color: white; }
.sev.deficiency { background: #c62828; }
.sev.design { background: #e08a00; }
.sev.note { background: #607d8b; }
figure { margin: 1.2em 0; }
figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { color: #444; font-size: 0.92em; margin-top: 0.3em; }
details pre { background: #f7f7f7; padding: 0.8em; overflow-x: auto; font-size: 0.8em; max-height: 40em; }
.muted { color: #666; }
.scroll { overflow-x: auto; }
.num { white-space: nowrap; }
nav.toc { font-size: 0.9em; color: #444; margin: 0.4em 0 0.2em 0; }
nav.toc a { color: #1f5fa8; text-decoration: none; margin-right: 0.2em; }
nav.toc a:hover { text-decoration: underline; }
.verdict p { margin: 0.35em 0; }
.verdict details { margin-top: 0.4em; }
details.finding { border-left: 4px solid #ccc; padding: 0.15em 0.6em; margin: 0.25em 0; }
details.finding.deficiency { border-left-color: #c62828; }
details.finding.design { border-left-color: #e08a00; }
details.finding.note { border-left-color: #607d8b; }
details.finding summary { cursor: pointer; }
details.finding p { margin: 0.3em 0 0.3em 1.2em; }
h4.joint { margin: 0.9em 0 0.2em 0; font-size: 0.98em; }
@media (max-width: 900px) { body { padding: 0.8em 0.8em; } table { font-size: 0.85em; } }
"""


# Characters XML 1.0 does not allow (C0 controls but tab, newline and carriage return; U+FFFE, U+FFFF):
# a name holding one would leave the page not well-formed, so it is written as its escape (``\x01``).
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ufffe\uffff]")


def _xml_text(text) -> str:
    return _NOT_XML.sub(lambda m: m.group(0).encode("unicode_escape").decode("ascii"), printable(text))


def _e(text) -> str:
    """Escape text content (quotes may stay: they need escaping in attributes only); a byte that was
    not UTF-8 (a lone surrogate) is written as ``\\xff``, so that the page can be written as UTF-8, and a
    character XML does not allow (``\\x01``) as its escape."""
    return _html.escape(_xml_text(text), quote=False)


_SCI = re.compile(r"[-+−]?\d+(?:\.\d+)?e[-+−]?\d+|[-+−]?\d+(?:\.\d+)?\s?%")


def _t(text) -> str:
    """Escaped prose whose numbers never break across lines ("2.81e-" / "241" is two numbers to a reader)."""
    return _SCI.sub(lambda m: f'<span class="num">{m.group(0)}</span>', _e(text))


def _whole_numbers(cell: str) -> str:
    """A table cell's numbers in scientific notation kept on one line (cells with markup unchanged)."""
    return cell if "<" in cell else _SCI.sub(lambda m: f'<span class="num">{m.group(0)}</span>', cell)


def _a(text) -> str:
    """Escape an attribute value (lone surrogates and characters XML does not allow as :func:`_e`)."""
    return _html.escape(_xml_text(text), quote=True)


def _num(x, digits=4) -> str:
    if x is None:
        return "—"
    if isinstance(x, str):
        return _e(x)
    try:
        v = float(x)
    except (TypeError, ValueError):
        return _e(x)
    if math.isnan(v):
        return "nan"
    if math.isinf(v):
        return "∞" if v > 0 else "−∞"
    if v != 0 and (abs(v) >= 1e6 or abs(v) < 1e-3):
        return f"{v:.{digits - 1}e}"
    return f"{v:.{digits}g}"


def _table(header, rows, *, text_cols=(0,), row_classes=None) -> str:
    out = ['<div class="scroll"><table>', "<tr>"]
    for i, h in enumerate(header):
        out.append(f'<th class="text">{_e(h)}</th>' if i in text_cols else f"<th>{_e(h)}</th>")
    out.append("</tr>")
    for r, row in enumerate(rows):
        cls = f' class="{row_classes[r]}"' if row_classes and row_classes[r] else ""
        out.append(f"<tr{cls}>")
        for i, cell in enumerate(row):
            out.append(f'<td class="text">{cell}</td>' if i in text_cols else f"<td>{_whole_numbers(cell)}</td>")
        out.append("</tr>")
    out.append("</table></div>")
    return "".join(out)


def _png(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _figure_html(fig_or_png, caption) -> str:
    if isinstance(fig_or_png, (bytes, bytearray)):
        data = base64.b64encode(bytes(fig_or_png)).decode("ascii")
    elif isinstance(fig_or_png, (str, Path)):
        data = base64.b64encode(Path(fig_or_png).read_bytes()).decode("ascii")
    else:
        data = _png(fig_or_png)
    return (f'<figure><img alt="{_a(caption)}" src="data:image/png;base64,{data}"/>'
            f"<figcaption>{_e(caption)}</figcaption></figure>")


def _names(report, key, n, default):
    prov = getattr(report, "provenance", None) or {}
    names = prov.get(key)
    if names is None or len(names) != n:
        return [default(i) for i in range(n)]
    return [str(s) for s in names]


def _joint_names(report):
    m = len(np.atleast_1d(report.per_joint["rmse"]))
    return _names(report, "joint_names", m, lambda j: f"joint {j + 1}")


def _column_names(report):
    prov = getattr(report, "provenance", None) or {}
    p = prov.get("n_regressor_columns") or 0
    return _names(report, "column_names", int(p), lambda c: f"c{c}")


def _per_joint_table(report) -> str:
    units = (getattr(report, "provenance", None) or {}).get("units", {}) or {}
    pct = lambda k: " (%)" if units.get(k) == "percent" else ""  # noqa: E731
    keys = [("rmse", "RMSE"), ("max_abs_error", "max |e|"), ("vaf", "VAF" + pct("vaf")),
            ("fit_percent", "fit" + pct("fit_percent")), ("r2", "R²"), ("nrmse", "NRMSE")]
    keys = [(k, label) for k, label in keys if k in report.per_joint]
    lb = getattr(report, "ljung_box", None)
    lb_p = None
    if lb is not None and "pvalue" in lb:
        lb_p = (np.atleast_2d(np.asarray(lb["pvalue"], dtype=float)),
                np.atleast_2d(np.asarray(lb.get("log_pvalue", np.full(np.shape(lb["pvalue"]), np.nan)), dtype=float)))
    rows = []
    for j, name in enumerate(_joint_names(report)):
        rows.append([_e(name)] + [_num(np.atleast_1d(report.per_joint[k])[j]) for k, _ in keys]
                    + ([_e(pvalue_text(lb_p[0][0][j], lb_p[1][0][j]))] if lb_p is not None else []))
    pooled = report.pooled
    pooled_map = {"rmse": "rmse_per_element", "max_abs_error": "max_abs_error", "vaf": "vaf",
                  "fit_percent": "fit_percent", "r2": "r2"}
    rows.append(["<b>pooled</b>"] + [_num(pooled.get(pooled_map.get(k, ""), None)) if k in pooled_map else "—"
                                     for k, _ in keys] + (["—"] if lb_p is not None else []))
    lb_head = []
    if lb_p is not None:
        lags = lb.get("lags")
        lb_head = [f"Ljung–Box p (h = {int(np.atleast_1d(lags)[0])})" if lags is not None else "Ljung–Box p"]
    return _table(["joint"] + [label for _, label in keys] + lb_head, rows)


def _findings_html(report) -> str:
    """The findings grouped by the joint they concern most (the whole run last), one collapsed line each:
    severity, kind and the message's first sentence; a click shows the message, what to do and the columns."""
    findings = getattr(report, "findings", None)
    if findings is None:
        texts = getattr(report, "warnings_text", None) or []
        if not texts:
            return '<p class="muted">No findings.</p>'
        return "<ul>" + "".join(f"<li>{_t(t)}</li>" for t in texts) + "</ul>"
    left_out = _not_tested_html(report)
    if not findings:
        if left_out:
            return '<p class="muted">No findings from the tests this report ran.</p>' + left_out
        return '<p class="muted">No findings: nothing in the residuals calls for a change.</p>'
    jn = _joint_names(report)
    cn = _column_names(report)
    groups: dict[int, list[str]] = {}
    for f in findings:
        joints = tuple(getattr(f, "joints", ()) or ())
        groups.setdefault(joints[0] if joints else -1, []).append(_finding_html(f, jn, cn))
    out = []
    for j in sorted(groups, key=lambda k: (k < 0, k)):
        title = (jn[j] if 0 <= j < len(jn) else f"joint {j}") if j >= 0 else "the whole run"
        out.append(f'<h4 class="joint">{_e(title)} <span class="muted">({len(groups[j])})</span></h4>'
                   + "".join(groups[j]))
    return '<div class="findings">' + "".join(out) + "</div>" + left_out


def _not_tested_html(report) -> str:
    """The tests a streamed report left out (``provenance["not_tested"]``, contract §4.1): a report
    that tested less must not read as a clean bill."""
    prov = getattr(report, "provenance", None)
    left_out = (prov.get("not_tested") if prov is not None else None) or []
    if not left_out:
        return ""
    items = "".join(f"<li><b>{_e(t['test'])}</b> ({_e(', '.join(t['kinds']))}): {_e(t['why'])}</li>" for t in left_out)
    return (f'<p class="not-tested">Not tested ({len(left_out)}; a finding of these kinds cannot show here):</p>'
            f"<ul>{items}</ul>")


def _finding_html(f, jn, cn) -> str:
    sev = getattr(f, "severity", "note")
    message = str(getattr(f, "message", ""))
    first = message.split(": ", 1)[-1] if message.count(": ") and len(message.split(": ", 1)[0]) < 40 else message
    first = first if len(first) <= 110 else first[:109].rsplit(" ", 1)[0] + " …"
    joints = ", ".join(jn[j] if 0 <= j < len(jn) else str(j) for j in getattr(f, "joints", ()) or ())
    cols = ", ".join(cn[c] if 0 <= c < len(cn) else str(c) for c in getattr(f, "columns", ()) or ())
    action = str(getattr(f, "action", ""))
    where = "".join(f"<p class=\"muted\">{label}: {_e(v)}</p>" for label, v in (("joints", joints),
                                                                             ("columns", cols)) if v)
    return (f'<details class="finding {_a(sev)}"><summary><span class="sev {_a(sev)}">{_e(sev)}</span> '
            f"<b>{_e(getattr(f, 'kind', ''))}</b> — {_t(first)}</summary><p>{_t(message)}</p>"
            + (f"<p>What to do: <b>{_t(action)}</b></p>" if action else "") + where + "</details>")


def _criteria_html(report) -> str:
    ic = getattr(report, "information_criteria", None)
    if not ic:
        return ""
    keys = [k for k in ("n_obs", "n_params", "noise_model", "aic", "bic", "aicc", "fpe") if k in ic]

    def cell(k: str) -> str:
        if isinstance(ic[k], str):
            return _e(ic[k])
        return _fixed(ic[k], ".1f") if k in ("aic", "bic", "aicc") else _num(ic[k])  # criteria differ in units

    return _table(keys, [[cell(k) for k in keys]], text_cols=())


def _provenance_html(report, fields=None) -> str:
    """The report's provenance as a table: every field, or those named in ``fields``."""
    prov = getattr(report, "provenance", None) or {}
    rows = []
    for k, v in prov.items():
        if fields is not None and k not in fields:
            continue
        if isinstance(v, dict):
            v = json.dumps(to_jsonable(v), ensure_ascii=False, allow_nan=False)
        elif isinstance(v, (list, tuple)):
            v = ", ".join(str(x) for x in v)
        rows.append([_e(k), _e(v)])
    return _table(["field", "value"], rows, text_cols=(0, 1))


def _provenance_split(cmp, names) -> tuple[list[str], dict[str, list[str]]]:
    """The provenance fields every candidate has with the same value, and each candidate's own: a
    comparison's page shows the shared ones once, for all, and the others in each model's section."""
    provs = {n: dict(getattr(cmp.reports[n], "provenance", None) or {}) for n in names}

    def same(k: str) -> bool:
        values = [json.dumps(to_jsonable(p.get(k)), sort_keys=True, default=str) for p in provs.values()]
        return all(k in p for p in provs.values()) and len(set(values)) == 1

    keys = list(dict.fromkeys(k for p in provs.values() for k in p))
    shared = [k for k in keys if same(k)]
    return shared, {n: [k for k in provs[n] if k not in shared] for n in names}


def _report_figures(report, tau_meas, tau_pred, sample_rate, model_name, reference, reference_label,
                    interval=None) -> list:
    try:
        from . import plot
    except ImportError:  # pragma: no cover
        return []
    figs = []
    if tau_meas is not None and tau_pred is not None:
        meas = np.asarray(tau_meas, dtype=float)
        n = meas.shape[0]
        fs = sample_rate or (getattr(report, "provenance", None) or {}).get("sample_rate")
        window = (0.0, min(n / fs, 10.0)) if fs else (0.0, min(n, 1000))
        band = ""
        if interval is not None:
            inside = ", ".join(f"{100 * s:.1f} %" for s in interval.share_inside(meas))
            band = (f" Shaded: the {100 * interval.level:g} % prediction interval (estimation run's parameter "
                    f"covariance and noise level); share of samples inside it per joint: {inside}.")
        figs.append((plot.prediction(tau_meas, tau_pred, sample_rate=fs, report=report, model_name=model_name,
                                     window=window, interval=interval),
                     f"Measured and predicted torque of '{model_name}', first "
                     f"{window[1]:g} {'s' if fs else 'samples'} of the validation data.{band}"))
        segments = (getattr(report, "provenance", None) or {}).get("segments")
        figs.append((plot.residuals(tau_meas, tau_pred, sample_rate=fs, report=report,
                                    segments=segments if segments and len(segments) > 1 else None),
                     "Residual over time per joint (segment boundaries dashed)."))
    if getattr(report, "autocorrelation", None) is not None:
        figs.append((plot.autocorrelation(report),
                     "Residual autocorrelation with its band: a white residual stays inside (lesson §4.2)."))
    if getattr(report, "spectrum", None) is not None:
        figs.append((plot.spectrum(report, reference=reference, reference_label=reference_label),
                     "Residual spectrum per joint; oscillations found by the report are marked."))
    if getattr(report, "cross_correlation", None) is not None:
        figs.append((plot.cross_correlation(report),
                     "Residual × regressor-column cross-correlation, max |ρ| over lags divided by each cell's "
                     "band (colour-aware when the report has it); cells above 1 are beyond it, * or a dot marks "
                     "the cells significant over the whole report (Holm, as the findings test), grey cells are "
                     "constant columns, outlined cells are named by a finding."))
    return figs


def _decided_html(verdict, chosen, cmp) -> str:
    """The verdict's "do first" and "decided by" lines (nothing for an object without them): the
    deciding findings grouped by kind, one line, so that the box fits the first screen."""
    decided = tuple(getattr(verdict, "decided_by", ()) or ())
    out = ""
    first = getattr(verdict, "first_step", "")
    if first:
        out += f'<p class="first-step">Do first: <b>{_t(first)}</b></p>'
    if decided:
        by_kind: dict[tuple[str, str], list[str]] = {}
        for d in decided:
            owner = f"{d.severity} of {d.model}" if d.model else f"{d.severity} of the comparison"
            by_kind.setdefault((d.kind, owner), []).extend(str(x) for x in tuple(d.joints) + tuple(d.columns))
        items = []
        for (kind, owner), where in by_kind.items():
            shown = ", ".join(where[:4]) + (f" and {len(where) - 4} more" if len(where) > 4 else "")
            items.append(f"<b>{_e(kind)}</b>{' on ' + _e(shown) if where else ''} ({_e(owner)})")
        out += "<p>Decided by: " + "; ".join(items) + "</p>"
    elif hasattr(verdict, "decided_by") and getattr(verdict, "decision", "") == "accept":
        crit = getattr(cmp, "criterion", None) or "the criterion"
        out += (f"<p>Decided by: the criterion — no finding stands against <b>{_e(chosen)}</b> (no deficiency in "
                f"its report, no design finding in any) and {_e(crit)} ranks it first.</p>")
    return out


def _candidate_reasons_html(cmp, ranking, chosen) -> str:
    """Every candidate in ranking order with its reasons (``ComparisonReport.reasons``)."""
    reasons = getattr(cmp, "reasons", None) or {}
    if not reasons:
        return ""
    pooled = (getattr(cmp, "table", None) or {}).get("pooled", {})
    rows, classes = [], []
    for i, n in enumerate(ranking):
        d = pooled.get(n, {}).get("n_deficiencies")
        rows.append([str(i + 1), _e(n), _num(d),
                     "<ul>" + "".join(f"<li>{_t(r)}</li>" for r in reasons.get(n, ())) + "</ul>"])
        classes.append("chosen" if n == chosen else "")
    return ("<h2>Reasons per candidate</h2>"
            + _table(["rank", "model", "deficiencies", "reasons (one per deficiency or design finding)"], rows,
                     text_cols=(1, 3), row_classes=classes)
            + '<p class="muted">In ranking order; a candidate without a deficiency or design finding gets its '
              "rank and criterion instead.</p>")


def _is_comparison(obj) -> bool:
    return hasattr(obj, "reports") and hasattr(obj, "verdict")


def _provenance_heading(obj, tag: str = "") -> str:
    """A comparison's closing provenance is every candidate's, and says so (each model's own fields are
    in its section)."""
    text = ("Provenance shared by every candidate (each model's own fields are in its section)"
            if _is_comparison(obj) else "Provenance")
    return f"<{tag}>{text}</{tag}>" if tag else text


def render_report(obj, *, tau_meas=None, tau_pred=None, sample_rate=None, title=None, figures=(),
                  reference_frequency=None, reference_label="expected mode", intro=None, interval=None) -> str:
    """The HTML text of :func:`write_report` (same arguments, without the path)."""
    from ._version import __version__

    have_plot = _have_matplotlib()
    stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    signature = f"dynval {_e(__version__)} · {stamp}"
    plots = _FigureData(have_plot, tau_meas, tau_pred, sample_rate, reference_frequency, reference_label,
                        _checked_interval(interval, tau_meas))
    if _is_comparison(obj):
        parts, provenance = _comparison_parts(obj, title, intro, signature, plots)
    else:
        parts, provenance = _validation_parts(obj, title, intro, signature, plots), _provenance_html(obj)
    if figures and _is_comparison(obj):
        # after the last candidate's section: a heading, so that they do not read as that model's
        parts.append("<h2>Further figures (given with the page, not of one candidate)</h2>")
    parts += [_figure_html(fig, cap) for fig, cap in figures or ()]
    if not have_plot:
        parts.append('<p class="muted">Figures omitted: matplotlib is not installed (pip install dynval[plot]).</p>')
    parts.append(_provenance_heading(obj, "h2") + provenance)
    parts.append(_json_html(obj))
    body = _with_contents("\n".join(p for p in parts if p))
    head = title or ("dynval model comparison" if _is_comparison(obj) else "dynval validation report")
    return ("<!DOCTYPE html>\n"
            '<html xmlns="http://www.w3.org/1999/xhtml" lang="en">\n<head>\n<meta charset="utf-8"/>\n'
            '<meta name="viewport" content="width=device-width, initial-scale=1"/>\n'
            f"<title>{_e(head)}</title>\n<style>{_CSS}</style>\n</head>\n<body>\n{body}\n</body>\n</html>\n")


def _with_contents(body: str) -> str:
    """Every section heading given an anchor, and a line of jump links to them under the page's
    subtitle (the verdict first, when there is one)."""
    links = ['<a href="#verdict">Verdict</a>'] if 'id="verdict"' in body else []
    used: set[str] = set()

    def anchor(m: re.Match) -> str:
        text = re.sub(r"<[^>]+>", "", m.group(1))
        slug = re.sub(r"[^a-z0-9]+", "-", _html.unescape(text).lower()).strip("-") or "section"
        while slug in used:
            slug += "-"
        used.add(slug)
        links.append(f'<a href="#{slug}">{m.group(1)}</a>')
        return f'<h2 id="{slug}">{m.group(1)}</h2>'

    body = re.sub(r"<h2>(.*?)</h2>", anchor, body)
    nav = '<nav class="toc">Contents: ' + " · ".join(links) + "</nav>"
    head = re.search(r'<p class="sub">.*?</p>', body)
    return body[:head.end()] + nav + body[head.end():] if head else nav + body


def render_fragment(obj) -> str:
    """The page's parts without the page: what a notebook shows for a report (``_repr_html_``).

    The same headline, tables, findings, verdict, reasons and provenance as :func:`render_report`,
    inside one ``<div class="dynval-report">`` whose style applies to it alone (the notebook's own
    styles are left as they are); no figures (they need the torques, and a notebook draws them with
    :mod:`dynval.plot`) and no JSON dump (``obj.to_dict()`` is at hand).
    """
    from ._version import __version__

    plots = _FigureData(False, None, None, None, None, "")
    signature = f"dynval {_e(__version__)}"
    if _is_comparison(obj):
        parts, provenance = _comparison_parts(obj, None, None, signature, plots)
    else:
        parts, provenance = _validation_parts(obj, None, None, signature, plots), _provenance_html(obj)
    parts.append(f"<details><summary>{_provenance_heading(obj)}</summary>{provenance}</details>")
    body = "\n".join(p for p in parts if p)
    return f'<div class="dynval-report">\n<style>{_scoped_css()}</style>\n{body}\n</div>'


def _scoped_css() -> str:
    """The page's style with every rule confined to ``.dynval-report`` (``body`` becomes the box)."""
    rules = []
    for rule in _CSS.strip().split("}"):
        if "{" not in rule:
            continue
        selectors, declarations = rule.split("{", 1)
        scoped = [".dynval-report" if sel.strip() == "body" else f".dynval-report {sel.strip()}"
                  for sel in selectors.split(",")]
        rules.append(f"{', '.join(scoped)} {{{declarations}}}")
    return "\n".join(rules)


def _have_matplotlib() -> bool:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


@dataclass(frozen=True)
class _FigureData:
    """The caller's data for the figures of one page; ``enabled`` is false without matplotlib."""

    enabled: bool
    tau_meas: Any
    tau_pred: Any
    sample_rate: Any
    reference_frequency: Any
    reference_label: str
    interval: Any = None

    def html(self, report, tau_pred, model_name) -> list:
        """The report's figures as ``<figure>`` elements (none without matplotlib)."""
        if not self.enabled:
            return []
        band = self.interval.get(model_name) if isinstance(self.interval, dict) else self.interval
        return [_figure_html(fig, cap) for fig, cap in _report_figures(
            report, self.tau_meas, tau_pred, self.sample_rate, model_name, self.reference_frequency,
            self.reference_label, band)]


def _validation_parts(rep, title, intro, signature, plots: _FigureData) -> list:
    """The sections of one validation's page, down to its figures."""
    prov = getattr(rep, "provenance", None) or {}
    parts = [f"<h1>{_e(title or 'dynval validation report')}</h1>",
             f'<p class="sub">{_e(prov.get("n_samples", "?"))} samples × {_e(prov.get("n_joints", "?"))} '
             f"joints · {_e(prov.get('n_params', '?'))} parameters · {signature}</p>"]
    if intro:
        parts.append(f"<p>{_e(intro)}</p>")
    parts.append(_deficiency_count_html(rep))
    parts.append("<h2>Per joint</h2>" + _per_joint_table(rep))
    parts.append("<h2>Findings</h2>" + _findings_html(rep))
    parts.append("<h2>Information criteria</h2>" + _criteria_html(rep))
    if plots.enabled:
        parts.append("<h2>Figures</h2>")
        parts += plots.html(rep, plots.tau_pred, "model")
    return parts


def _deficiency_count_html(rep) -> str:
    """A verdict-coloured box saying on how many joints the model is deficient, with the step to take
    first and why ("" for an object without findings). The headline counts joints, not findings: one
    missing term makes a deficiency of several kinds on its joint, so a weak model can show fewer
    findings than a good one (conventions §5.10, "The count is not the measure")."""
    findings = getattr(rep, "findings", None)
    if findings is None:
        return ""
    defic = [f for f in findings or [] if getattr(f, "severity", "") == "deficiency"]
    state = "refine" if defic else "accept"
    # the step to take first and why, in the box: a reader who stops at the first screen acts on it
    first = getattr(rep, "first_step", "") if defic else ""
    step = (f'<p class="first-step">Do first: <b>{_t(first)}</b></p><p class="muted">{_t(rep.first_reason)}</p>'
            if first else "")
    if not defic:
        return f'<div class="verdict {state}"><div class="decision">no deficiency found</div></div>'
    joints = sorted({j for f in defic for j in (getattr(f, "joints", None) or ())})
    m = (getattr(rep, "provenance", None) or {}).get("n_joints")
    where = (f"deficient on {len(joints)} of {m} joint{'' if m == 1 else 's'}" if joints and m
             else "deficient")
    count = f"{len(defic)} deficienc{'y' if len(defic) == 1 else 'ies'}, the strongest first below"
    return (f'<div class="verdict {state}"><div class="decision">{_e(where)}</div>'
            f'<p class="muted">{_e(count)}</p>{step}</div>')


def _comparison_parts(cmp, title, intro, signature, plots: _FigureData) -> tuple[list, str]:
    """The sections of a comparison's page, each naming the model it belongs to (or "every
    candidate"), and the provenance every candidate shares, as HTML."""
    names = list(getattr(cmp, "names", None) or list(cmp.reports))
    verdict = cmp.verdict
    chosen = getattr(verdict, "model", None) or (list(getattr(cmp, "ranking", names)) or names)[0]
    ranking = list(getattr(cmp, "ranking", names))
    parts = [f"<h1>{_e(title or 'dynval model comparison')}</h1>",
             f'<p class="sub">{len(names)} candidate models validated on the same data · {signature}</p>']
    if intro:
        parts.append(f"<p>{_e(intro)}</p>")
    parts.append(_verdict_html(verdict, chosen, cmp))
    parts.append("<h2>Decision table: every candidate</h2>")
    parts.append(_decision_table_html(cmp, names, ranking, chosen))
    parts.append('<p class="muted">Pooled over joints on the validation data; rank from the comparison '
                 "(best first); the chosen model is highlighted.</p>")
    parts.append(_candidate_reasons_html(cmp, ranking, chosen))
    if plots.enabled:
        from . import plot

        parts.append(_figure_html(plot.metrics(cmp), "Per-joint VAF, fit and R² of every candidate "
                                                     "(the chosen model outlined)."))
    shared, own = _provenance_split(cmp, names)
    for n in [chosen] + [x for x in ranking if x != chosen]:
        parts += _candidate_parts(cmp.reports[n], n, n == chosen, plots, own.get(n, []))
    return parts, _provenance_html(cmp.reports[names[0]], fields=shared)


def _verdict_html(verdict, chosen, cmp) -> str:
    """The verdict box: the decision, the chosen model, what to do first and what decided it; the
    reasons, one per finding, collapsed under them (the reasons per candidate follow the table)."""
    decision = str(getattr(verdict, "decision", ""))
    reasons = list(getattr(verdict, "reasons", []) or [])
    shown = reasons if len(reasons) <= 3 else []
    more = (f"<details><summary>{len(reasons)} reasons</summary><ul>"
            + "".join(f"<li>{_t(r)}</li>" for r in reasons) + "</ul></details>") if not shown and reasons else ""
    return (f'<div class="verdict {_a(decision)}" id="verdict"><div class="decision">Verdict: {_e(decision)}</div>'
            f"<p>Model: <b>{_e(chosen)}</b></p>" + _decided_html(verdict, chosen, cmp)
            + ("<ul>" + "".join(f"<li>{_t(r)}</li>" for r in shown) + "</ul>" if shown else "") + more
            + "</div>")


def _fixed(x, fmt: str) -> str:
    """A criterion or a share in fixed notation (``-12808.2``): two AICs 4 apart must read apart,
    which four significant digits (``-1.281e+04``) do not show."""
    if x is None or isinstance(x, str):
        return _num(x)
    v = float(x)
    return _num(v) if not math.isfinite(v) else f"{v:{fmt}}"


def _decision_columns(cmp, names) -> list[tuple[str, Callable[[dict], str]]]:
    """The decision table's columns: header (with its unit) and how a candidate's pooled row fills it."""
    pooled = (getattr(cmp, "table", None) or {}).get("pooled", {})
    first = next(iter(cmp.reports.values()), None)
    units = (getattr(first, "provenance", None) or {}).get("units", {}) or {}
    pct = " (%)" if units.get("vaf") == "percent" else ""

    def has(key: str) -> bool:
        return any(key in pooled.get(n, {}) for n in names)

    def criterion(key: str) -> Callable[[dict], str]:
        return lambda row: (_fixed(row.get(key), ".1f")
                            + (f" ({_fixed(row.get('delta_' + key), '+.1f')})" if ("delta_" + key) in row else ""))

    # the columns that decide come first: at 800 px they are what the reader sees without scrolling
    cols: list[tuple[str, Callable[[dict], str]]] = [
        ("deficiencies", lambda row: _num(row.get("n_deficiencies"))),
        ("whiteness", lambda row: _num(row.get("whiteness"))),
        ("bias", lambda row: _num(row.get("bias"))),
        ("parameters", lambda row: _num(row.get("n_params"))),
        ("RMSE (τ units)", lambda row: _num(row.get("rmse"))),
        ("VAF" + pct, lambda row: _num(row.get("vaf"))),
        ("fit" + pct, lambda row: _num(row.get("fit_percent"))),
        ("R²", lambda row: _fixed(row.get("r2"), ".4f")),
        ("AIC (Δ)", criterion("aic")),
        ("BIC (Δ)", criterion("bic")),
        ("Akaike weight", lambda row: _num(row.get("akaike_weight"), 3)),
    ]
    keys = ("n_deficiencies", "whiteness", "bias", "n_params", "rmse", "vaf", "fit_percent", "r2", "aic", "bic",
            "akaike_weight")
    return [col for col, key in zip(cols, keys) if has(key)]


def _decision_table_html(cmp, names, ranking, chosen) -> str:
    """One row per candidate in ranking order: its pooled metrics and criteria (with units, and the
    criteria in fixed notation with their Δ to the best), the chosen one highlighted."""
    pooled = (getattr(cmp, "table", None) or {}).get("pooled", {})
    cols = _decision_columns(cmp, names)
    rows = [[_e(n), str(ranking.index(n) + 1)] + [fill(pooled.get(n, {})) for _, fill in cols] for n in ranking]
    classes = ["chosen" if n == chosen else "" for n in ranking]
    text = (0,) + tuple(i + 2 for i, (h, _) in enumerate(cols) if h in ("whiteness", "bias"))
    return _table(["model", "rank"] + [h for h, _ in cols], rows, row_classes=classes, text_cols=text)


def _candidate_parts(rep, name, chosen, plots: _FigureData, own_fields=()) -> list:
    """One candidate's section, every heading naming the model: its tables, its own provenance
    fields (those not shared by every candidate), and the figures for the chosen one."""
    whose = f"model '{_e(name)}'"
    own = (_provenance_html(rep, fields=set(own_fields)) if own_fields else
           '<p class="muted">None: every provenance field is shared by all candidates (at the end of the '
           "page).</p>")
    parts = [f"<h2>Model '{_e(name)}'{' — chosen' if chosen else ''}</h2>",
             f"<h3>Per joint: {whose}</h3>" + _per_joint_table(rep),
             f"<h3>Findings: {whose}</h3>" + _findings_html(rep),
             f"<h3>Information criteria: {whose}</h3>" + _criteria_html(rep),
             f"<h3>Provenance of {whose} (its own fields)</h3>" + own]
    if chosen and plots.enabled:
        pred = plots.tau_pred.get(name) if isinstance(plots.tau_pred, dict) else None
        figures = plots.html(rep, pred, name)
        if figures:
            parts += [f"<h3>Figures: {whose}</h3>"] + figures
    return parts


def _json_html(obj) -> str:
    """The whole report as JSON in a collapsed block, or why it could not be included."""
    try:
        full = json.dumps(obj.to_dict(), indent=1, allow_nan=False, ensure_ascii=False)
    except Exception as exc:
        return f'<p class="muted">JSON not included: {_e(type(exc).__name__)}: {_e(exc)}</p>'
    whose = "Full comparison as JSON (every candidate)" if _is_comparison(obj) else "Full report as JSON"
    return f"<details><summary>{whose}</summary><pre>{_e(full)}</pre></details>"


def _checked_interval(interval, tau_meas):
    """The prediction interval(s) of ``interval=``, refused when they cannot be drawn."""
    if interval is None:
        return None
    bands = interval.values() if isinstance(interval, dict) else [interval]
    for band in bands:
        if not hasattr(band, "share_inside"):
            raise TypeError("interval must be a PredictionInterval (IdentificationResult.prediction_interval) "
                            f"or a dict of them by model name, got {type(band).__name__}")
        if tau_meas is None:
            raise ValueError("interval needs tau_meas (the band is drawn over the measured torque)")
        if band.lower.shape != np.shape(tau_meas):
            raise ValueError(f"interval has shape {band.lower.shape}, tau_meas {np.shape(tau_meas)}: "
                             "the band must be of the validation data")
    return interval


def write_report(obj, path, *, tau_meas=None, tau_pred=None, sample_rate=None, title=None, figures=(),
                 reference_frequency=None, reference_label="expected mode", intro=None, interval=None) -> str:
    """Write one self-contained HTML report of a validation or a comparison.

    Parameters
    ----------
    obj : ValidationReport or ComparisonReport
        What :func:`dynval.validate` or :func:`dynval.compare` returned.
    path : str or Path
        The file to write (UTF-8).
    tau_meas : array_like (N, m), optional
        Measured torques of the validation data: with ``tau_pred``, adds the measured-vs-predicted
        and residual figures.
    tau_pred : array_like (N, m), or dict {model name: (N, m)} for a comparison, optional
        Predicted torques (of the chosen model, for a comparison).
    sample_rate : float, optional
        Hz; default the report's provenance.
    title, intro : str, optional
        Heading and an introductory paragraph.
    figures : sequence of (Figure or PNG bytes or PNG path, caption), optional
        More figures to embed.
    reference_frequency : float, optional
        A known frequency (a simulated mode) drawn on the spectrum.
    interval : PredictionInterval, or dict {model name: PredictionInterval}, optional
        :meth:`dynval.identify.IdentificationResult.prediction_interval` on the validation data:
        drawn as a band in the measured-vs-predicted figure, whose caption gives the share of
        samples inside it per joint.

    Returns
    -------
    str
        The path written.
    """
    text = render_report(obj, tau_meas=tau_meas, tau_pred=tau_pred, sample_rate=sample_rate, title=title,
                         figures=figures, reference_frequency=reference_frequency,
                         reference_label=reference_label, intro=intro, interval=interval)
    Path(path).write_text(text, encoding="utf-8")
    return str(path)


# --------------------------------------------------------------------------- fleet page


def _fleet_drift_table(fleet) -> str:
    rows, classes = [], []
    for d, robot in zip(fleet.drift, fleet.robot_table()):
        sev = d.finding.severity if d.finding is not None else ""
        state = (f'<span class="sev {_a(sev)}">{_e(sev)}</span>' if sev
                 else ("not tested" if not d.tested else "no drift"))
        decisions = ", ".join(f"{n} {k}" for k, n in sorted(robot["decisions"].items()))
        rows.append([_e(d.robot), str(robot["n_logs"]), _num(robot["rmse"]), _e(decisions), state,
                     (_e(d.change_log) if sev else f'<span class="muted">{_e(d.change_log)}</span>') if d.tested
                     else _e(d.reason),
                     _num(d.ratio, 3) if d.tested else "—", pvalue_text(d.pvalue) if d.tested else "—",
                     pvalue_text(d.pvalue_adjusted) if d.tested else "—"])
        classes.append("flagged" if sev == "deficiency" else "")
    return _table(["robot", "logs", "median RMSE", "decisions", "drift", "change from log (most likely)",
                   "RMSE ratio after/before", "p", "Holm p"], rows, text_cols=(0, 3, 4, 5), row_classes=classes)


def _fleet_log_table(fleet) -> str:
    rows, classes = [], []
    for r in fleet.logs:
        found = _e(r.error) if r.error else (_e(f"{r.n_findings}: {', '.join(r.kinds)}") if r.n_findings else "0")
        rows.append([_e(r.robot), _e(r.time), _e(r.log), str(r.n_samples), str(r.n_joints), _num(r.rmse),
                     _fixed(r.vaf, ".2f"), f'<span class="dec {_a(r.decision)}">{_e(r.decision)}</span>', found,
                     _e(r.sees)])
        classes.append("error" if r.error else "")
    return _table(["robot", "time", "log", "N", "m", "RMSE", "VAF %", "decision", "findings", "the decision saw"],
                  rows, text_cols=(0, 1, 2, 7, 8, 9), row_classes=classes)


def _fleet_findings_html(fleet) -> str:
    if not fleet.findings:
        return '<p class="muted">No drift: no robot fits worse in its later logs than in its earlier ones.</p>'
    rows = [[f'<span class="sev {_a(f.severity)}">{_e(f.severity)}</span>', _e(f.details.get("robot", "")),
             _e(f.message), _e(f.action) or "—"] for f in fleet.findings]
    return _table(["severity", "robot", "finding", "what to do"], rows, text_cols=(0, 1, 2, 3))


_FLEET_CSS = """
tr.flagged td { background: #fdecea; }
tr.error td { background: #fff7e6; }
.dec { font-weight: 600; }
.dec.refine { color: #b36b00; }
.dec.redesign, .dec.error { color: #c62828; }
.dec.accept { color: #2e7d32; }
"""


def render_fleet_report(fleet, *, title=None) -> str:
    """The HTML fleet page of a :class:`dynval.fleet.FleetReport`: drift per robot, its findings,
    the drift figures and the table of every log."""
    prov = fleet.provenance
    decisions = {}
    for r in fleet.logs:
        decisions[r.decision] = decisions.get(r.decision, 0) + 1
    counts = ", ".join(f"{n} {d}" for d, n in sorted(decisions.items()))
    parts = [f"<h1>{_e(title or 'dynval fleet report')}</h1>",
             f'<p class="sub">{len(fleet.logs)} logs of {len(fleet.drift)} robots · decisions: {_e(counts)} · '
             f"ran on {_e(prov.get('where', 'this process'))} in {prov.get('seconds', 0.0):.1f} s · "
             f"α = {1.0 - fleet.level:g}</p>",
             "<h2>Robots and their drift</h2>",
             '<p class="muted">A change point in each robot\'s log RMSE (logs in time order): the largest '
             "two-sample t of the later logs against at least "
             f"{_e(prov.get('min_baseline', 3))} earlier ones, its p-value from shuffles of the logs' order, "
             "Holm over the robots tested. A drift is a deficiency when the later logs' RMSE is at least "
             f"{_e(prov.get('ratio_threshold', 1.1))}× the earlier logs' (geometric means).</p>",
             _fleet_drift_table(fleet), "<h2>Findings</h2>", _fleet_findings_html(fleet)]
    if fleet.notes:  # a drift beside accepted logs, explained
        parts.append("<ul>" + "".join(f"<li>{_e(note)}</li>" for note in fleet.notes) + "</ul>")
    if _have_matplotlib():
        from . import plot

        parts += ["<h2>Figures</h2>",
                  _figure_html(plot.fleet_drift(fleet), "Each robot's log RMSE and the change the drift test found"),
                  _figure_html(plot.fleet_metrics(fleet), "RMSE and VAF of every log over time, per robot")]
    else:
        parts.append('<p class="muted">Figures need matplotlib (pip install "dynval[plot]").</p>')
    parts += ["<h2>Every log</h2>", _fleet_log_table(fleet), _json_html(fleet)]
    return ("<!DOCTYPE html>\n"
            '<html xmlns="http://www.w3.org/1999/xhtml" lang="en">\n<head>\n<meta charset="utf-8"/>\n'
            '<meta name="viewport" content="width=device-width, initial-scale=1"/>\n'
            f"<title>{_e(title or 'dynval fleet report')}</title>\n<style>{_CSS}{_FLEET_CSS}</style>\n</head>\n"
            f"<body>\n{chr(10).join(parts)}\n</body>\n</html>\n")


def write_fleet_report(fleet, path, *, title=None) -> str:
    """Write :func:`render_fleet_report` to ``path`` (UTF-8); returns the path."""
    Path(path).write_text(render_fleet_report(fleet, title=title), encoding="utf-8")
    return str(path)
