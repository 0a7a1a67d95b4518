"""How numbers reach a person: p-values, and an effect printed next to its threshold.

One place for the wording of every text the package writes (``report.summary()``, the findings'
messages, the HTML report, a comparison's reasons, the figures' notes), contract §4:

* a p-value has three significant digits (``0.0123``, ``4.56e-7``, ``1``); one below 1e-300, a p
  that underflowed to 0 included, is written ``< 1e-300`` (the report's ``log_pvalue`` keeps its
  size); a p known only from its (natural) log is written from the log; NaN is ``n/a``;
* an effect printed next to its threshold has as many digits as it takes for the two printed
  numbers to stand in the order the rule found (``24.96 %`` next to ``25 %``, never ``25 %``).
"""

from __future__ import annotations

import math
import re
from typing import SupportsFloat

Number = SupportsFloat | None

__all__ = ["P_FLOOR", "P_DIGITS", "pvalue_text", "p_clause", "number_text", "versus"]

P_FLOOR = 1e-300
"""Below this a p-value is written ``< 1e-300``: just above the smallest normal double (2.2e-308),
and far beyond the accuracy of any test's tail approximation."""

P_DIGITS = 3
"""Significant digits of a p-value."""

_LN10 = math.log(10.0)
_SPEC = re.compile(r"^([+ ]?)\.(\d+)([fg])$")
_EXPONENT = re.compile(r"e([+-])0*(\d)")


def counted(k: int, what: str, plural: str | None = None) -> str:
    """``"1 candidate"``, ``"3 candidates"``: a count with its noun in the right number."""
    return f"{k} {what if k == 1 else (plural or what + 's')}"


def _tidy_exponent(text: str) -> str:
    """``1.23e-05`` → ``1.23e-5``, ``1e+03`` → ``1e3``."""
    return _EXPONENT.sub(lambda m: "e" + ("-" if m.group(1) == "-" else "") + m.group(2), text)


def _as_float(x: Number) -> float:
    if x is None:
        return math.nan
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def pvalue_text(p: Number, log_p: Number = None) -> str:
    """A p-value as a person reads it, the same in every table and message.

    Parameters
    ----------
    p : float or None
        The p-value (0 when it underflowed).
    log_p : float, optional
        Its natural logarithm (``log_pvalue`` of the portmanteau tests), used when ``p`` is 0,
        subnormal or unknown.

    Returns
    -------
    str
        ``"0.0123"``, ``"4.56e-7"``, ``"1"``, ``"< 1e-300"`` or ``"n/a"``.

    Examples
    --------
    >>> pvalue_text(0.012345), pvalue_text(4.5678e-7), pvalue_text(1.0)
    ('0.0123', '4.57e-7', '1')
    >>> pvalue_text(0.0, log_p=-106511.0), pvalue_text(0.0, log_p=-600.0), pvalue_text(float("nan"))
    ('< 1e-300', '2.65e-261', 'n/a')
    """
    p, lp = _as_float(p), _as_float(log_p)
    if not (math.isfinite(p) and p >= P_FLOOR) and not math.isnan(lp):
        # the log is the better record: p underflowed (0 or subnormal) or was not given
        if lp / _LN10 < math.log10(P_FLOOR):
            return f"< {P_FLOOR:g}"
        p = math.exp(lp)
    if math.isnan(p) or p < 0 or math.isinf(p):
        return "n/a"
    if p < P_FLOOR:
        return f"< {P_FLOOR:g}"
    return _tidy_exponent(format(p, f".{P_DIGITS}g"))


def p_clause(p: Number, log_p: Number = None) -> str:
    """What follows "p" in a sentence: ``"= 0.0123"``, ``"< 1e-300"`` or ``"= n/a"``.

    >>> "Holm-adjusted p " + p_clause(0.0)
    'Holm-adjusted p < 1e-300'
    """
    text = pvalue_text(p, log_p)
    return text if text.startswith("<") else "= " + text


def number_text(x: Number, spec: str = ".3g") -> str:
    """A number with a format spec; None as ``n/a``, NaN and infinities as words.

    >>> number_text(1234.5), number_text(None), number_text(float("inf"))
    ('1.23e3', 'n/a', 'inf')
    """
    v = _as_float(x)
    if x is None:
        return "n/a"
    if math.isnan(v):
        return "nan"
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return _tidy_exponent(format(v, spec))


def _shortest(x: float) -> str:
    """The shortest text (at most 15 significant digits) that reads back as ``x``."""
    for digits in range(1, 16):
        value = float(format(x, f".{digits}g"))
        if math.isclose(value, x, rel_tol=1e-12, abs_tol=0.0):
            break
    text = repr(value)  # positional from 1e-4 to 1e16: "1000", not "1e3"
    return _tidy_exponent(text[:-2] if text.endswith(".0") else text)


def _sign(x: float) -> int:
    return (x > 0) - (x < 0)


def versus(effect: Number, threshold: Number, spec: str = ".3g", *, scale: float = 1.0,
           absolute: bool = False) -> tuple[str, str]:
    """An effect and its threshold as two texts that compare the way the numbers do.

    The threshold is written as briefly as it reads back exactly; the effect starts at ``spec``
    (``".0f"``, ``"+.3f"``, ``".3g"``, ...) and gains digits (up to 17 significant ones) until the
    two printed numbers stand in the same order as ``effect`` and ``threshold`` (equal only when
    they are equal). Both are multiplied by ``scale`` first (100 for a percentage). With
    ``absolute`` the rule compared ``abs(effect)`` with the threshold: the digits follow it, and
    the text keeps the effect's sign (``"+0.0999"`` or ``"-0.0999"`` next to ``0.1``).

    Returns
    -------
    (str, str)
        The effect's text and the threshold's.

    Examples
    --------
    >>> versus(0.2496, 0.25, ".0f", scale=100)
    ('24.96', '25')
    >>> versus(0.31, 0.25, ".0f", scale=100)
    ('31', '25')
    >>> versus(1000.4, 1000.0)
    ('1000.4', '1000')
    >>> versus(-0.09996, 0.1, "+.3f", absolute=True)
    ('-0.09996', '0.1')
    """
    m = _SPEC.match(spec)
    if m is None:
        raise ValueError(f"spec must look like '.3g', '+.2f' or '.0f', got {spec!r}")
    sign, start, kind = m.group(1), int(m.group(2)), m.group(3)
    e, t = _as_float(effect), _as_float(threshold)
    t_text = _shortest(t * scale) if math.isfinite(t) else number_text(None if threshold is None else t)
    if not math.isfinite(e):
        return number_text(None if effect is None else e), t_text
    e_scaled = e * scale
    text = number_text(e_scaled, spec)
    if not math.isfinite(t):
        return text, t_text
    want = _sign((abs(e) if absolute else e) - t)
    t_read = float(t_text)
    # 17 significant digits tell any two doubles apart
    last = 17 if kind == "g" else max(start, 16 - math.floor(math.log10(abs(e_scaled)))) if e_scaled else start + 17
    for digits in range(max(start, 1 if kind == "g" else 0), last + 1):
        text = number_text(e_scaled, f"{sign}.{digits}{kind}")
        read = float(text)
        if _sign((abs(read) if absolute else read) - t_read) == want:
            break
    return text, t_text


def printable(text: object) -> str:
    """``str(text)`` that any UTF-8 writer and any font can take: a byte that was not UTF-8 (a command
    line's ``\\xff``, kept by Python as the lone surrogate ``\\udcff``) is written as ``\\xff``, any
    other lone surrogate as ``\\udXXX``; everything else unchanged.

    Examples
    --------
    >>> printable("jo\\udcffnt"), printable("Δq"), printable("\\ud800")
    ('jo\\\\xffnt', 'Δq', '\\\\ud800')
    """
    text = str(text)
    try:
        raw = text.encode("utf-8", "surrogateescape")
    except UnicodeEncodeError:
        return text.encode("utf-8", "backslashreplace").decode("utf-8")
    return raw.decode("utf-8", "backslashreplace")


def source_text(source: str) -> str:
    """The derivative source in words (the provenance's and the findings')."""
    return ("the user's q̇, q̈ on both runs" if source == "given"
            else "Savitzky–Golay derivatives of q on both runs (0.1 s window, degree 4)")
