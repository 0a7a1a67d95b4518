"""Figures of a validation: one function per figure, each returning a matplotlib ``Figure``.

matplotlib is an optional dependency (``pip install dynval[plot]``) and is imported only when
a figure is made. The figures are built on ``matplotlib.figure.Figure`` directly, never through
``pyplot``: no display, no global state, and nothing to close; save one with
``fig.savefig("name.png", dpi=120)`` (the Agg renderer).

==================================  ==============================================================
:func:`residuals`                   residual over time per joint, segment boundaries marked
:func:`autocorrelation`             residual autocorrelation per joint with its band (lesson §4.2)
:func:`autocorrelation_by_model`    one joint's residual autocorrelation for each candidate
:func:`spectrum`                    residual spectrum per joint (log–log), found oscillations marked
:func:`cross_correlation`           joints × regressor columns heatmap of ``max |ρ|`` / colour-aware band
:func:`metrics`                     per-joint VAF / fit / R² bars for each candidate of a comparison
:func:`prediction`                  measured and predicted torque per joint
==================================  ==============================================================

Every function takes the names it can use (``joint_names``, ``column_names``) and otherwise
falls back to the names and sample rate recorded in a report's provenance.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping

import numpy as np

__all__ = ["residuals", "autocorrelation", "autocorrelation_by_model", "spectrum", "cross_correlation",
           "cross_correlation_ratio", "metrics", "prediction", "save", "welch", "fleet_metrics", "fleet_drift"]

_MEASURED = "#4d4d4d"
_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf")


def _figure(width, height):
    try:
        from matplotlib.figure import Figure
    except ImportError as exc:  # pragma: no cover - exercised where matplotlib is absent
        raise ImportError("dynval.plot needs matplotlib: pip install 'dynval[plot]'") from exc
    return Figure(figsize=(width, height), layout="constrained")


def save(fig, path, *, dpi: int = 120) -> str:
    """Write a figure to ``path`` (format from the suffix, PNG by default); returns the path."""
    fig.savefig(str(path), dpi=dpi)
    return str(path)


def _provenance(report, key, default=None):
    prov = getattr(report, "provenance", None) or {}
    value = prov.get(key, default)
    return default if value is None else value


def _literal(text) -> str:
    """A user's name as matplotlib text: ``$`` escaped, so that it is drawn as written instead of
    parsed as mathtext (``$\\frac$`` would stop the figure with a parse error), and a byte that was
    not UTF-8 written as ``\\xff`` (a lone surrogate stops the font's text layout)."""
    from .report._text import printable

    chars = _font_chars()
    drawn = "".join(c if c == "\n" or ord(c) in chars else c.encode("unicode_escape").decode("ascii")
                    for c in printable(text))
    return drawn.replace("$", r"\$")


def _font_chars() -> frozenset:
    """The characters the figures' fonts have a glyph for: any other character of a name (a control
    character, a script the fonts lack) is written as its escape (``\\x1f``, ``\\u6f22``) rather than
    drawn as a box with a warning on standard error."""
    from matplotlib import font_manager

    props = font_manager.FontProperties()
    find = getattr(font_manager.fontManager, "_find_fonts_by_props", None)  # the fallback fonts, matplotlib >= 3.6
    paths = find(props) if find is not None else [font_manager.findfont(props)]
    return frozenset().union(*(_charmap(str(path)) for path in paths))


@functools.lru_cache(maxsize=16)
def _charmap(path: str) -> frozenset:
    from matplotlib.ft2font import FT2Font

    return frozenset(FT2Font(path).get_charmap())


def _finite_min(values, default: float) -> float:
    """The smallest finite value, or ``default`` when there is none (an exactly zero residual has an
    all-nan autocorrelation; np.nanmin would warn "All-NaN slice encountered" on standard error)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return float(v.min()) if v.size else float(default)


def _joint_names(names, m, report=None):
    if names is None and report is not None:
        names = _provenance(report, "joint_names")
    if names is None:
        return [f"joint {j + 1}" for j in range(m)]
    names = [_literal(n) for n in names]
    if len(names) != m:
        raise ValueError(f"joint_names has {len(names)} names for {m} joints")
    return names


def _column_names(names, p, report=None):
    if names is None and report is not None:
        names = _provenance(report, "column_names")
    if names is None:
        return [f"c{c}" for c in range(p)]
    names = [_literal(n) for n in names]
    if len(names) != p:
        raise ValueError(f"column_names has {len(names)} names for {p} columns")
    return names


def _signal(x, name):
    a = np.asarray(x, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise ValueError(f"{name} must be (N,) or (N, m), got shape {a.shape}")
    return a


def _time_axis(n, sample_rate):
    if sample_rate:
        return np.arange(n) / float(sample_rate), "time (s)"
    return np.arange(n, dtype=float), "sample"


def _segment_starts(segments, n):
    if segments is None:
        return []
    seg = [int(s) for s in segments]
    if seg and seg[0] == 0:
        starts = seg
    else:
        starts = list(np.cumsum([0] + seg[:-1]))
    return [s for s in starts if 0 < s < n]


def _stack_axes(fig, m):
    axes = fig.subplots(m, 1, sharex=True, squeeze=False)[:, 0]
    return list(axes)


def residuals(tau_meas, tau_pred, *, sample_rate=None, segments=None, joint_names=None, title=None,
              unit: str = "N·m", report=None):
    """Residual ``τ_meas − τ_pred`` over time, one panel per joint.

    Segment boundaries (``segments`` as lengths or starts, as in :func:`dynval.validate`) are
    drawn as dashed vertical lines; each panel's legend gives the joint's RMS residual.
    """
    meas, pred = _signal(tau_meas, "tau_meas"), _signal(tau_pred, "tau_pred")
    e = meas - pred
    n, m = e.shape
    fs = sample_rate if sample_rate is not None else _provenance(report, "sample_rate")
    names = _joint_names(joint_names, m, report)
    x, xlabel = _time_axis(n, fs)
    fig = _figure(10, 1.0 + 1.9 * m)
    axes = _stack_axes(fig, m)
    starts = _segment_starts(segments, n)
    for j, ax in enumerate(axes):
        rms = math.sqrt(float(np.mean(e[:, j] ** 2)))
        ax.plot(x, e[:, j], color=_COLOURS[j % len(_COLOURS)], lw=0.8, label=f"residual (RMS {rms:.3g} {unit})")
        ax.axhline(0.0, color="black", lw=0.6)
        for i, s in enumerate(starts):
            ax.axvline(x[s], color="grey", ls="--", lw=1.0, label="segment boundary" if i == 0 else None)
        ax.set_ylabel(f"{names[j]}\nresidual ({unit})")
        ax.legend(loc="upper right", fontsize="small")
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel(xlabel)
    fig.suptitle(title or "Residual torque τ_meas − τ_pred per joint")
    return fig


def autocorrelation(report, *, joint_names=None, sample_rate=None, title=None):
    """Residual autocorrelation per joint with the report's band (the lesson's §4.2 picture).

    Lags are in samples on the bottom axis, and in seconds on the top axis when the sample
    rate is known (argument, or the report's provenance). Lags outside the band are drawn red.
    """
    ac = report.autocorrelation if not isinstance(report, Mapping) else report
    if ac is None:
        raise ValueError("the report has no autocorrelation section (max_lag=0)")
    rho = np.asarray(ac["rho"], dtype=float)
    band = np.asarray(ac["band"], dtype=float)
    lmax, m = rho.shape[0] - 1, rho.shape[1]
    source = None if isinstance(report, Mapping) else report
    names = _joint_names(joint_names, m, source)
    fs = sample_rate if sample_rate is not None else _provenance(source, "sample_rate")
    lb = getattr(source, "ljung_box", None)
    lags = np.arange(lmax + 1)
    fig = _figure(10, 1.4 + 2.0 * m)
    axes = _stack_axes(fig, m)
    level = ac.get("level", 0.95)
    for j, ax in enumerate(axes):
        r = rho[:, j]
        b = band[:, j]
        outside = np.zeros(lmax + 1, dtype=bool)
        with np.errstate(invalid="ignore"):
            outside[1:] = np.abs(r[1:]) > b[1:]
        ax.vlines(lags[~outside], 0.0, r[~outside], color=_COLOURS[0], lw=1.5, label="ρ(ℓ) inside the band")
        ax.vlines(lags[outside], 0.0, r[outside], color="#d62728", lw=2.0, label="ρ(ℓ) outside the band")
        ax.plot(lags[1:], b[1:], color="black", ls="--", lw=1.0,
                label=f"{100 * level:g} % band ({ac.get('band_type', 'white')})")
        ax.plot(lags[1:], -b[1:], color="black", ls="--", lw=1.0)
        ax.axhline(0.0, color="black", lw=0.6)
        note = f"{int(outside.sum())} of {lmax} lags outside the band"
        if lb is not None:
            try:
                p = float(np.asarray(lb["pvalue"])[0][j])
                logp = float(np.asarray(lb["log_pvalue"])[0][j])
                note += f"; Ljung–Box up to lag {np.asarray(lb['lags'])[0]}: {_p_text(p, logp)}"
            except (KeyError, IndexError, TypeError):
                pass
        ax.text(0.99, 0.96, note, transform=ax.transAxes, ha="right", va="top", fontsize="small",
                bbox={"facecolor": "white", "alpha": 0.85, "edgecolor": "#999999"})
        ax.set_ylabel(f"{names[j]}\nautocorrelation ρ")
        ax.set_xlim(-0.5, lmax + 0.5)
        ax.set_ylim(min(-1.05, _finite_min(r, 0.0) - 0.05), 1.3)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("lag ℓ (samples)")
    if fs:
        top = axes[0].secondary_xaxis("top", functions=(lambda s: s / fs, lambda t: t * fs))
        top.set_xlabel("lag (s)")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize="small")
    rates = _two_rates_words(source, fs, lmax)
    fig.suptitle((title or "Residual autocorrelation per joint (white residual: inside the band)")
                 + (f"\n{rates}" if rates else ""), fontsize="medium" if rates else None)
    return fig


def _two_rates_words(report, fs, lmax: int) -> str:
    """Why the whiteness finding's lags differ from this figure's: the finding's Ljung–Box has its own
    largest lag, and may be counted at the information rate (every k-th sample)."""
    wh = getattr(report, "whiteness", None)
    if wh is None:
        return ""
    k, lag_d, lag = (getattr(wh, name, None) for name in ("decimation", "lag_decimated", "lag"))
    seconds = (lambda n: f" ({n / fs:.3g} s)") if fs else (lambda n: "")
    if isinstance(k, (int, np.integer)) and k > 1 and isinstance(lag_d, (int, np.integer)):
        rate = f", {fs / k:.3g} Hz" if fs else ""
        return (f"lags at the logged rate; the whiteness finding tests every {k}th sample (the information "
                f"rate{rate}),\nup to its lag {lag_d} = {lag_d * k} samples here{seconds(lag_d * k)}")
    if isinstance(lag, (int, np.integer)) and lag != lmax:
        return f"the whiteness finding's Ljung–Box runs to lag {lag}{seconds(lag)}, this figure to lag {lmax}"
    return ""


def _p_text(p, log_p):
    """``p = 0.0123`` or ``p < 1e-300``: the wording of every table and message (contract §4)."""
    from .report._text import p_clause

    return "p " + p_clause(p, log_p)


def autocorrelation_by_model(reports, *, joint: int = 0, names=None, chosen=None, title=None):
    """One joint's residual autocorrelation for each candidate, side by side, same scale.

    ``reports`` is a mapping ``{name: ValidationReport}`` (or a comparison with ``reports``).
    The picture of a comparison: the under-modelled candidate's residual leaves the band, the
    right one's stays inside.
    """
    reports = getattr(reports, "reports", reports)
    order = list(names or reports)
    first = reports[order[0]]
    m = np.asarray(first.autocorrelation["rho"]).shape[1]
    jname = _joint_names(None, m, first)[joint]
    fs = _provenance(first, "sample_rate")
    fig = _figure(max(8.0, 3.6 * len(order)), 3.6)
    axes = list(fig.subplots(1, len(order), sharey=True, squeeze=False)[0])
    for ax, name in zip(axes, order):
        ac = reports[name].autocorrelation
        r = np.asarray(ac["rho"], dtype=float)[:, joint]
        b = np.asarray(ac["band"], dtype=float)[:, joint]
        lags = np.arange(r.shape[0])
        out = np.zeros(r.shape[0], dtype=bool)
        with np.errstate(invalid="ignore"):
            out[1:] = np.abs(r[1:]) > b[1:]
        ax.vlines(lags[~out], 0.0, r[~out], color=_COLOURS[0], lw=1.5, label="inside the band")
        ax.vlines(lags[out], 0.0, r[out], color="#d62728", lw=1.8, label="outside the band")
        ax.plot(lags[1:], b[1:], "k--", lw=1.0, label=f"{100 * ac.get('level', 0.95):g} % band")
        ax.plot(lags[1:], -b[1:], "k--", lw=1.0)
        ax.axhline(0.0, color="black", lw=0.6)
        frac = int(out.sum())
        chosen_mark = " (chosen)" if name == chosen else ""
        ax.set_title(f"{_literal(name)}{chosen_mark}\n{frac} of {r.shape[0] - 1} lags outside",
                     fontsize="medium")
        ax.set_xlabel("lag ℓ (samples)" + (f", 1 sample = {1000.0 / fs:g} ms" if fs else ""))
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel(f"{jname}: autocorrelation ρ")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize="small")
    fig.suptitle(title or f"Residual autocorrelation of the {jname} joint for each candidate model")
    return fig


def welch(e, sample_rate=None, *, nperseg: int | None = None):
    """Welch power spectral density of each column (``scipy.signal.welch``, Hann, 50 % overlap)."""
    import scipy.signal

    e = _signal(e, "residuals")
    n = e.shape[0]
    seg = nperseg or min(n, max(64, 2 ** int(math.floor(math.log2(max(n // 8, 1))))))
    f, p = scipy.signal.welch(e - e.mean(axis=0), fs=sample_rate or 1.0, nperseg=seg, axis=0)
    return f, p


def _peaks(report, spec, peaks):
    """Lines to mark: given ones, else the report's oscillation and prediction_artefact findings (a
    line of the residual either way), else its peaks."""
    if peaks is None and getattr(report, "findings", None) is not None:
        found = []
        for f in report.findings:
            if getattr(f, "kind", "") in ("oscillation", "prediction_artefact") \
                    and "frequency" in (getattr(f, "details", None) or {}):
                found += [(int(j), float(f.details["frequency"])) for j in f.joints]
        return found
    out = []
    for pk in (peaks if peaks is not None else (spec or {}).get("peaks", [])) or []:
        if isinstance(pk, dict):
            out.append((int(pk["joint"]), float(pk["frequency"])))
        else:
            out.append((int(pk[0]), float(pk[1])))
    return out


def _spectrum_marks(report, funit):
    """The report's information band and input bandwidth (frequency, label, style), when it has them."""
    wh = getattr(report, "whiteness", None) if report is not None else None
    marks = []
    if wh is None:
        return marks
    try:
        band = wh.get("information_band")
        bandwidth = wh.get("bandwidth")
    except AttributeError:
        return marks
    if band is not None and np.isfinite(band) and band > 0:
        marks.append((float(band), f"information band edge ({float(band):.3g} {funit})", "#2ca02c", "--"))
    if bandwidth is not None and np.isfinite(bandwidth) and bandwidth > 0 and funit == "Hz":
        marks.append((float(bandwidth), f"input bandwidth ({float(bandwidth):.3g} Hz)", "#9467bd", "-."))
    return marks


def spectrum(report=None, *, residuals=None, sample_rate=None, joint_names=None, peaks=None,
             reference=None, reference_label: str = "expected mode", title=None, unit: str = "N·m"):
    """Residual power spectrum per joint, both axes logarithmic, found oscillations marked.

    The spectrum is the report's (``report.spectrum``: frequency, power, peaks) when it has one,
    else a Welch estimate of ``residuals``. ``peaks`` overrides the report's peaks: a list of
    ``(joint, frequency, ...)`` tuples or dicts with ``joint`` and ``frequency``. ``reference``
    draws a dotted vertical line at a known frequency (for instance a simulated mode). The
    frequency axis is logarithmic (the 0 bin is left out): the low frequencies where a robot's
    motion lives get their share of the width. The report's information band and input
    bandwidth, when it has them, are drawn as vertical lines.
    """
    spec = getattr(report, "spectrum", None) if report is not None else None
    fs = sample_rate if sample_rate is not None else _provenance(report, "sample_rate")
    if spec is not None:
        freq = np.asarray(spec["frequency"], dtype=float)
        power = _signal(spec["power"], "power")
        funit = spec.get("frequency_unit", "Hz" if fs else "cycles/sample")
    elif residuals is not None:
        freq, power = welch(residuals, fs)
        funit = "Hz" if fs else "cycles/sample"
    else:
        raise ValueError("give a report with a spectrum section, or the residuals")
    m = power.shape[1]
    names = _joint_names(joint_names, m, report)
    found = _peaks(report, spec, peaks)
    marks = _spectrum_marks(report, funit)
    fig = _figure(10, 1.4 + 2.0 * m)
    axes = _stack_axes(fig, m)
    punit = f"({unit})²/Hz" if funit == "Hz" else f"({unit})²·sample"
    positive = freq > 0
    fpos = freq[positive]
    if not fpos.size:
        raise ValueError("the spectrum has no positive frequency")
    for j, ax in enumerate(axes):
        pos = positive & (power[:, j] > 0)
        ax.loglog(freq[pos], power[pos, j], color=_COLOURS[j % len(_COLOURS)], lw=1.2, label="residual PSD")
        marked = [f for (jj, f) in found if jj == j and f > 0]
        for i, f in enumerate(marked):
            k = int(np.argmin(np.abs(freq - f)))
            ax.plot([freq[k]], [power[k, j]], "v", color="#d62728", ms=9,
                    label="oscillation found" if i == 0 else None)
            ax.annotate(f"{f:.3g} {funit}", (freq[k], power[k, j]), textcoords="offset points",
                        xytext=(6, 6), color="#d62728", fontsize="small")
        for f, label, colour, ls in marks:
            if fpos[0] <= f <= fpos[-1]:
                ax.axvline(f, color=colour, ls=ls, lw=1.3, label=label)
        if reference is not None and reference > 0:
            ax.axvline(reference, color="black", ls=":", lw=1.2, label=f"{reference_label} ({reference:.3g} {funit})")
        lo, hi = ax.get_ylim()
        ax.set_ylim(lo, hi * 4.0)  # room for the peak labels
        ax.set_ylabel(f"{names[j]}\nPSD {punit}")
        ax.legend(loc="upper right", fontsize="small", framealpha=0.85)
        ax.grid(True, which="both", alpha=0.3)
    axes[-1].set_xlabel(f"frequency ({funit})")
    axes[-1].set_xlim(fpos[0], fpos[-1])
    fig.suptitle(title or "Residual spectrum per joint (Welch)")
    return fig


def cross_correlation_ratio(section) -> tuple[np.ndarray, bool]:
    """The heatmap's cells: ``max_ℓ |ρ(ℓ)| / band`` per joint × column, and whether the band is
    the colour-aware one.

    The colour-aware band is the one the findings use: Bartlett's variance for two coloured
    series (``z_max``, the largest ``|ρ(ℓ)|/sd(ℓ)`` over the lags, divided by the band's z), so a
    cell above 1 is one whose correlation exceeds z·sd at some lag. Without ``z_max`` (a
    streamed report) the colour factor scales the white band when it is there, else the white
    band z/√N is used, and the second value is False. Constant columns are NaN.
    """
    from .statistics._stats import z_two_sided

    xc = section
    band = float(xc["band"])
    if "max_abs_rho" in xc and xc["max_abs_rho"] is not None:
        mx = np.asarray(xc["max_abs_rho"], dtype=float)
    else:
        # fmax ignores nan without numpy's "All-NaN slice" warning: a constant column's row stays nan
        mx = np.fmax.reduce(np.abs(np.asarray(xc["rho"], dtype=float)), axis=2)
    cm = xc.get("constant_mask") if hasattr(xc, "get") else None
    mask = np.zeros_like(mx, dtype=bool) if cm is None else np.asarray(cm, dtype=bool)
    z_max = xc.get("z_max") if hasattr(xc, "get") else None
    colour = xc.get("colour_factor") if hasattr(xc, "get") else None
    with np.errstate(invalid="ignore", divide="ignore"):
        if z_max is not None:
            ratio = np.asarray(z_max, dtype=float) / z_two_sided(float(xc.get("level", 0.95)))
            aware = True
        elif colour is not None:
            ratio = mx / (band * np.asarray(colour, dtype=float))
            aware = True
        else:
            ratio = mx / band
            aware = False
    return np.where(mask, np.nan, ratio), aware


def _significant_cells(xc, ratio: np.ndarray) -> np.ndarray:
    """The cells the findings call significant (Holm over every test of the report, contract §4);
    a report without ``pvalue_adjusted`` (streamed, or a mapping) has only the per-cell band."""
    padj = xc.get("pvalue_adjusted") if hasattr(xc, "get") else None
    if padj is None:
        return np.asarray(ratio > 1.0)
    with np.errstate(invalid="ignore"):
        return np.asarray(np.asarray(padj, dtype=float) <= 1.0 - float(xc.get("level", 0.95)))


def _significant_label(xc, count: int, small: bool) -> str:
    mark = "dot" if small else "*"
    if (xc.get("pvalue_adjusted") if hasattr(xc, "get") else None) is None:
        return f"{mark}: beyond the band (this report has no Holm-adjusted p-values)"
    return f"{mark}: significant over the whole report (Holm over all its tests, as the findings): {count} cells"


def cross_correlation(report, *, joint_names=None, column_names=None, title=None):
    """Heatmap joints × regressor columns of ``max_ℓ |ρ(ℓ)| / band`` (lags 0..max_lag).

    The colour is the ratio to the per-cell colour-aware band (Bartlett's variance for two
    coloured series, :func:`cross_correlation_ratio`); a report without it (streamed) falls back to
    the white band z/√N and the legend says so. A per-cell band is crossed by 5 % of cells by
    chance, so the cells the findings call significant — Holm over every test of the report, the
    report's ``pvalue_adjusted`` — are marked apart: a ``*`` after the value (cells above 1 carry
    their value), or a black dot when the columns are many. Cells of columns that the report's
    findings name are outlined; grey cells marked "–" are columns that are constant on that joint
    (no correlation defined). A legend under the heatmap explains each mark.
    """
    xc = report.cross_correlation if not isinstance(report, Mapping) else report
    if xc is None:
        raise ValueError("the report has no cross-correlation section (no regressor was given)")
    band = float(xc["band"])
    ratio, aware = cross_correlation_ratio(xc)
    m, p = ratio.shape
    source = None if isinstance(report, Mapping) else report
    jnames = _joint_names(joint_names, m, source)
    cnames = _column_names(column_names, p, source)
    named = set()
    for f in getattr(source, "findings", None) or []:
        for j in getattr(f, "joints", ()) or ():
            for c in getattr(f, "columns", ()) or ():
                named.add((int(j), int(c)))

    small = p > 24
    cell = 0.21 if small else 0.55  # inches per column: many columns get narrow cells and small labels
    longest = max(len(c) for c in cnames)
    fig = _figure(max(8.0, 2.6 + cell * p),
                  2.5 + (0.4 if small else 0.55) * m + (0.055 if small else 0.075) * longest)
    ax = fig.subplots()
    import matplotlib.colors as mcolors
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    grey = "#bdbdbd"
    cmap = mcolors.LinearSegmentedColormap.from_list(
        "dynval", ["#f7fbff", "#c6dbef", "#fdae6b", "#d62728"]).with_extremes(bad=grey)
    vmax = max(2.0, float(np.nanmax(ratio)) if np.isfinite(ratio).any() else 2.0)
    norm = mcolors.TwoSlopeNorm(vmin=0.0, vcenter=1.0, vmax=vmax)
    im = ax.imshow(np.ma.masked_invalid(ratio), cmap=cmap, norm=norm, aspect="auto")
    ax.set_xticks(range(p), cnames, rotation=60 if p > 6 else 0, ha="right" if p > 6 else "center",
                  rotation_mode="anchor", fontsize="x-small" if small else None)
    ax.set_yticks(range(m), jnames, fontsize="small" if small else None)
    ax.set_xlabel("regressor column")
    ax.set_ylabel("joint (residual)")
    significant = _significant_cells(xc, ratio)
    beyond = ratio > 1.0
    for j in range(m):
        for c in range(p):
            r = ratio[j, c]
            if np.isnan(r):
                if not small:
                    ax.text(c, j, "–", ha="center", va="center", color="#555555", fontsize="small")
            elif small and significant[j, c]:
                ax.plot(c, j, "o", color="black", ms=3)
            elif not small and r > 1.0:
                ax.text(c, j, f"{r:.1f}" + ("*" if significant[j, c] else ""), ha="center", va="center",
                        fontsize="small", color="white" if r > 0.6 * vmax else "black",
                        fontweight="bold" if significant[j, c] else "normal")
            if (j, c) in named:
                ax.add_patch(_rectangle(c, j))
    which = ("per-cell colour-aware band (Bartlett, both series' colour)" if aware
             else "per-cell white-noise band z/√N (this report has no colour-aware fields, e.g. a streamed report)")
    handles = [Patch(facecolor="#d62728", edgecolor="none",
                     label=f"beyond the per-cell band (> 1): {int(np.sum(beyond))} of {int(np.isfinite(ratio).sum())} "
                           "cells" + ("" if small else ", value printed")),
               Patch(facecolor="#f7fbff", edgecolor="#999999", label="inside the band (≤ 1)")]
    handles.append(Line2D([], [], ls="none", marker="o" if small else "$*$", color="black", ms=4 if small else 7,
                          label=_significant_label(xc, int(significant.sum()), small)))
    if np.isnan(ratio).any():
        handles.append(Patch(facecolor=grey, edgecolor="none",
                             label="grey" + ("" if small else " “–”") + ": column constant on that joint, "
                                   "no correlation defined"))
    if named:
        handles.append(Patch(facecolor="none", edgecolor="black", lw=2.0, label="outlined: column named by a finding"))
    fig.legend(handles=handles, loc="outside lower center", ncol=2 if fig.get_figwidth() >= 14 else 1,
               fontsize="small",
               title=f"{100 * float(xc.get('level', 0.95)):g} % {which}", title_fontsize="small")
    cb = fig.colorbar(im, ax=ax, shrink=0.9)
    cb.set_label("max |ρ| / " + ("colour-aware band" if aware else "white band"))
    lag_text = f"lags 0..{xc.get('max_lag', '?')}"
    band_text = ("colour-aware band" if aware else f"white band z/√N = {band:.3g}")
    fig.suptitle(title or f"Residual × regressor cross-correlation ({lag_text}; {band_text}; "
                          f"> 1 is beyond the per-cell band)")
    return fig


def _rectangle(c, j):
    from matplotlib.patches import Rectangle

    return Rectangle((c - 0.5, j - 0.5), 1.0, 1.0, fill=False, edgecolor="black", lw=2.5)


_METRIC_LABELS = {"vaf": "VAF", "fit_percent": "fit", "r2": "R²", "nrmse": "NRMSE", "rmse": "RMSE"}


def metrics(comparison, *, names=None, joint_names=None, which=("vaf", "fit_percent", "r2"), title=None,
            chosen=None):
    """Per-joint bars of VAF, fit and R² (one panel each, stacked) for every candidate.

    ``comparison`` is a :class:`dynval.ComparisonReport` (its ``reports``, ``names`` and
    verdict) or a mapping ``{name: ValidationReport}``. The chosen model's bars are outlined and
    its legend entry says "(chosen)". The axis stops at −100 % (−1 for fractions): a bar below
    is cut there and carries its value, so one bad joint does not flatten the others.
    """
    reports = getattr(comparison, "reports", comparison)
    order = list(names or getattr(comparison, "names", None) or list(reports))
    if chosen is None:
        verdict = getattr(comparison, "verdict", None)
        chosen = getattr(verdict, "model", None)
    first = reports[order[0]]
    m = len(np.atleast_1d(first.per_joint["rmse"]))
    jnames = _joint_names(joint_names, m, first)
    units = _provenance(first, "units", {}) or {}
    fig = _figure(max(8.0, 2.0 + 0.32 * m * len(order)), 0.9 + 2.4 * len(which))
    axes = list(fig.subplots(len(which), 1, sharex=True, squeeze=False)[:, 0])
    width = 0.8 / len(order)
    x = np.arange(m)
    for k, metric in enumerate(which):
        ax = axes[k]
        unit = units.get(metric, "")
        label_unit = "%" if unit == "percent" else ("fraction" if unit == "fraction" else unit)
        top = 100.0 if unit == "percent" else 1.0
        floor = -top
        lowest = 0.0
        cut = False
        for i, name in enumerate(order):
            vals = np.asarray(reports[name].per_joint[metric], dtype=float)
            shown = np.maximum(vals, floor)
            lab = _literal(f"{name} (chosen)" if name == chosen else name)
            pos = x + (i - (len(order) - 1) / 2) * width
            ax.bar(pos, shown, width, label=lab, color=_COLOURS[i % len(_COLOURS)],
                   edgecolor="black" if name == chosen else "none", linewidth=1.5 if name == chosen else 0)
            for xp, v in zip(pos, vals):
                if v < floor:
                    cut = True
                    ax.text(xp, floor, f"{v:.3g}", rotation=90, ha="center", va="bottom", fontsize="x-small",
                            color="white" if i % len(_COLOURS) in (0, 1, 3, 5) else "black")
            lowest = min(lowest, _finite_min(shown, lowest))
        ax.axhline(top, color="black", lw=0.8, ls=":")
        # at the left end of the line: the right end is where the note on cut bars goes
        ax.annotate("perfect", (0.0, top), xycoords=("axes fraction", "data"), xytext=(3, 2),
                    textcoords="offset points", ha="left", va="bottom", fontsize="x-small")
        ax.axhline(0.0, color="black", lw=0.6)
        if cut:
            ax.set_title(f"bars below {floor:g} are cut there, their value printed on them", loc="right",
                         fontsize="x-small")
        ax.set_ylabel(f"{_METRIC_LABELS.get(metric, metric)} ({label_unit})" if label_unit else metric)
        ax.grid(True, axis="y", alpha=0.3)
        ax.set_ylim(lowest * 1.05 if lowest < 0 else 0.0, top * 1.12)
    axes[-1].set_xticks(x, jnames, rotation=30 if m > 4 else 0, ha="right" if m > 4 else "center")
    axes[-1].set_xlabel("joint")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(order), 5), fontsize="small",
               title="candidate model")
    fig.suptitle(title or "Goodness of fit per joint on the validation data (higher is better; 100 % is perfect)")
    return fig


def prediction(tau_meas, tau_pred, *, sample_rate=None, joint_names=None, model_name=None, title=None,
               unit: str = "N·m", report=None, window=None, interval=None):
    """Measured and predicted torque per joint.

    ``window`` = (start, stop) in seconds (or samples without a rate) zooms on a stretch.
    ``interval`` (:meth:`dynval.identify.IdentificationResult.prediction_interval`) draws the
    prediction's band, labelled with the share of the measured torque inside it.
    """
    meas, pred = _signal(tau_meas, "tau_meas"), _signal(tau_pred, "tau_pred")
    n, m = meas.shape
    fs = sample_rate if sample_rate is not None else _provenance(report, "sample_rate")
    names = _joint_names(joint_names, m, report)
    x, xlabel = _time_axis(n, fs)
    sel = slice(None)
    shown = ""
    if window is not None:
        sel = (x >= window[0]) & (x <= window[1])
        shown = _window_words(x, sel, "s" if fs else "samples")
    fig = _figure(10, 1.4 + 1.9 * m)
    axes = _stack_axes(fig, m)
    label = f"predicted ({_literal(model_name)})" if model_name else "predicted"
    shares = interval.share_inside(meas) if interval is not None else None
    for j, ax in enumerate(axes):
        ax.plot(x[sel], meas[sel, j], color=_MEASURED, lw=1.6, label="measured")
        ax.plot(x[sel], pred[sel, j], color="#d62728", lw=1.1, label=label)
        if interval is not None:
            ax.fill_between(x[sel], interval.lower[sel, j], interval.upper[sel, j], color="#d62728", alpha=0.18,
                            lw=0, label=f"{100 * interval.level:g} % prediction interval")
            # the share is over the whole run, not only the window shown
            ax.set_title(f"{100 * float(shares[j]):.1f} % of the measured torque inside the band (whole run)",
                         fontsize="small", loc="right")
        ax.set_ylabel(f"{names[j]}\ntorque ({unit})")
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel(xlabel)
    # one legend below the panels: inside an axes it covers the data
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=len(labels), fontsize="small", frameon=False)
    named = f" — {_literal(model_name)}" if model_name else ""
    fig.suptitle((title or ("Measured and predicted joint torque" + named)) + (f"\n{shown}" if shown else ""))
    return fig


def _window_words(x, sel, unit: str) -> str:
    """What part of the run a zoomed figure shows (``"0–10 s of 20 s shown"``)."""
    if not np.any(sel):
        return "no sample in the window"
    lo, hi = float(x[sel][0]), float(x[sel][-1])
    step = float(x[1] - x[0]) if len(x) > 1 else 0.0
    total = float(x[-1] - x[0] + step)
    if lo <= float(x[0]) and hi >= float(x[-1]):
        return ""
    return f"{lo:.3g}–{hi + step:.3g} {unit} of {total:.3g} {unit} shown"


def _fleet_x(times):
    """The time axis of a fleet's logs: dates when every stamp is one, numbers when every stamp is one,
    else each robot's log order (None)."""
    import datetime as _dt

    from .fleet._logs import time_key

    keys = [time_key(t) for t in times]
    kinds = {k[0] for k in keys}
    if kinds == {1}:
        return [_dt.datetime.fromtimestamp(k[1], tz=_dt.timezone.utc) for k in keys], "time (UTC)"
    if kinds == {0}:
        return [k[1] for k in keys], "time"
    return None, "log (in time order)"


def _plain_log_axis(ax):
    """A log scale whose ticks read as plain numbers (0.3, 1, 3), not powers of ten."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    ax.set_yscale("log")
    ax.yaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.yaxis.set_minor_formatter(NullFormatter())


def fleet_metrics(fleet, *, which=("rmse", "vaf"), title=None):
    """Each robot's metrics over its logs (one line per robot; RMSE on a log scale), the start of
    a drift marked on its robot's line.

    ``fleet`` is a :class:`dynval.fleet.FleetReport`.
    """
    rows = [r for r in fleet.logs if r.error is None]
    xs, xlabel = _fleet_x([r.time for r in rows])
    fig = _figure(10.0, 1.2 + 2.6 * len(which))
    axes = list(fig.subplots(len(which), 1, sharex=True, squeeze=False)[:, 0])
    drift = {d.robot: d for d in fleet.drift}
    for i, robot in enumerate(fleet.robots):
        mine = [(k, r) for k, r in enumerate(rows) if r.robot == robot]
        if not mine:
            continue
        x = [xs[k] for k, _ in mine] if xs is not None else list(range(1, len(mine) + 1))
        colour = _COLOURS[i % len(_COLOURS)]
        d = drift.get(robot)
        flagged = d is not None and d.finding is not None
        for ax, metric in zip(axes, which):
            y = [getattr(r, metric) for _, r in mine]
            ax.plot(x, y, marker="o", ms=3.5, lw=2.0 if flagged else 1.0, color=colour,
                    alpha=1.0 if flagged else 0.55, label=_literal(f"{robot} (drift)" if flagged else robot))
            if flagged:
                ax.axvline(x[d.change], color=colour, ls="--", lw=1.0)
                ax.plot(x[d.change:], y[d.change:], ls="none", marker="o", ms=7, mfc="none", mec=colour)
    for ax, metric in zip(axes, which):
        ax.set_ylabel(_METRIC_LABELS.get(metric, metric) + (" (%)" if metric == "vaf" else ""))
        ax.grid(True, alpha=0.3)
    if "rmse" in which:
        _plain_log_axis(axes[list(which).index("rmse")])
    axes[-1].set_xlabel(xlabel)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside right upper", fontsize="small", title="robot")
    fig.suptitle(title or "Each robot's logs over time (a dashed line: where a drift starts; circled: the logs "
                 "after it)", fontsize="medium")
    return fig


def fleet_drift(fleet, *, title=None, max_robots: int = 24):
    """One panel per robot: its log RMSEs in time order, the geometric mean of the logs before and
    after the change the drift test found, the logs after a significant change shaded.

    ``fleet`` is a :class:`dynval.fleet.FleetReport`; at most ``max_robots`` robots, drifting ones first.
    """
    tests = sorted(fleet.drift, key=lambda d: (d.finding is None, fleet.robots.index(d.robot)))[:max_robots]
    cols = min(4, max(1, len(tests)))
    nrows = -(-len(tests) // cols)
    fig = _figure(2.9 * cols + 0.6, 0.8 + 2.1 * nrows)
    axes = fig.subplots(nrows, cols, squeeze=False).reshape(-1)
    for ax, d in zip(axes, tests):
        y = np.array([r.rmse for r in fleet.logs if r.robot == d.robot and r.error is None])
        x = np.arange(1, y.size + 1)
        flagged = d.finding is not None
        ax.plot(x, y, marker="o", ms=3.5, color=_COLOURS[1] if flagged else _COLOURS[0], lw=1.0)
        if d.tested:
            k = int(d.change)
            before, after = np.exp(np.log(y[:k]).mean()), np.exp(np.log(y[k:]).mean())
            ax.hlines([before, after], [0.7, k + 0.5], [k + 0.5, y.size + 0.3], colors="black", lw=1.0,
                      linestyles=["-", "--"])
            if flagged:
                ax.axvspan(k + 0.5, y.size + 0.5, color=_COLOURS[1], alpha=0.12)
        holm_p = "Holm " + _p_text(d.pvalue_adjusted, None)
        state = (f"DRIFT from log {d.change + 1}, ×{d.ratio:.2g}, {holm_p}" if flagged
                 else ("not tested" if not d.tested else f"no drift ({holm_p})"))
        ax.set_title(f"{_literal(d.robot)}: {state}", fontsize="small", loc="left",
                     color=_COLOURS[1] if flagged else "black")
        ax.grid(True, alpha=0.3)
        ax.tick_params(labelsize="x-small")
    for ax in axes[len(tests):]:
        ax.set_visible(False)
    fig.supxlabel("log (in each robot's time order)", fontsize="small")
    fig.supylabel("RMSE per log", fontsize="small")
    fig.suptitle(title or "Drift per robot: RMSE of each log, geometric mean before (solid) and after (dashed) "
                 "the most likely change", fontsize="medium")
    return fig
