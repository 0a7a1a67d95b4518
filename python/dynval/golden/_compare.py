"""The one comparison routine of the corpus: expected vs got, with the vector's tolerance."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ._loader import Case


def _fmt(value: Any) -> str:
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    return repr(float(value))


def _compare_output(name: str, expected: Any, got: Any, tol: Any) -> str | None:
    """Return None when ``got`` matches ``expected``, else a readable reason."""
    try:
        got_arr = np.asarray(got)
    except Exception as exc:  # a port may hand back anything
        return f"{name}: cannot read the value ({exc})"
    exp_arr = np.asarray(expected)
    if got_arr.shape != exp_arr.shape:
        return f"{name}: shape {tuple(got_arr.shape)} expected {tuple(exp_arr.shape)}"
    if exp_arr.dtype == np.bool_:
        if got_arr.dtype.kind not in "biuf":
            return f"{name}: expected booleans, got dtype {got_arr.dtype}"
        bad = np.flatnonzero((got_arr.astype(np.float64) != 0).ravel() != exp_arr.ravel())
        if bad.size:
            i = int(bad[0])
            return (f"{name}[{_index(exp_arr.shape, i)}]: expected {_fmt(exp_arr.ravel()[i])}, "
                    f"got {_fmt(got_arr.ravel()[i])} ({bad.size} differ)")
        return None
    if got_arr.dtype.kind not in "biuf":
        return f"{name}: expected numbers, got dtype {got_arr.dtype}"
    e = exp_arr.astype(np.float64).ravel()
    g = got_arr.astype(np.float64).ravel()
    try:
        t = np.broadcast_to(np.asarray(tol, dtype=np.float64), exp_arr.shape).ravel()
    except ValueError:
        return f"{name}: tolerance of shape {np.shape(tol)} does not fit the value's shape {exp_arr.shape}"
    with np.errstate(invalid="ignore", over="ignore"):
        e_nan, g_nan = np.isnan(e), np.isnan(g)
        e_inf = np.isinf(e)
        finite = ~e_nan & ~e_inf
        ok = np.where(e_nan, g_nan, np.where(e_inf, g == e, False))
        diff = np.full(e.shape, np.inf)
        usable = finite & np.isfinite(g)
        diff[usable] = np.abs(g[usable] - e[usable])
        ok = np.where(finite, diff <= t, ok)
    bad = np.flatnonzero(~ok)
    if bad.size:
        i = int(bad[0])
        detail = (f"{name}[{_index(exp_arr.shape, i)}]: expected {_fmt(e[i])}, got {_fmt(g[i])}")
        if finite[i]:
            detail += f", |diff| = {diff[i]:.3g} > tol {t[i]:.3g}"
        return detail + f" ({bad.size} of {e.size} differ)"
    return None


def _index(shape: tuple, flat: int) -> str:
    if not shape:
        return ""
    return ", ".join(str(int(k)) for k in np.unravel_index(flat, shape))


def check_case(
    case: Case,
    outputs: Mapping[str, Any] | None = None,
    error_kind: str | None = None,
) -> tuple[bool, str]:
    """Compare what an implementation produced for ``case`` with the vector.

    Parameters
    ----------
    case : Case
        The vector.
    outputs : mapping, optional
        Output name → value, when the implementation returned normally.
    error_kind : str, optional
        The contract error kind, when the implementation raised.

    Returns
    -------
    (ok, detail) : (bool, str)
        ``detail`` says what differs (empty when ok). Rules: shapes must match
        exactly; finite values within the absolute tolerance; NaN matches NaN
        only; ±inf exactly; every expected output must be present; ``invalid``
        vectors need the expected error kind; ``acceptable`` vectors take the
        values or the listed error.

    Examples
    --------
    >>> from dynval.golden import iter_cases, check_case
    >>> case = next(c for c in iter_cases(families=["errors"]) if c.result == "invalid")
    >>> check_case(case, error_kind=case.error)
    (True, '')
    """
    expected_error = case.expected.get("error")
    values = {k: v for k, v in case.expected.items() if k != "error"}
    if error_kind is not None:
        if expected_error is not None and error_kind == expected_error:
            return True, ""
        if expected_error is None:
            return False, f"raised {error_kind}, expected values"
        return False, f"raised {error_kind}, expected {expected_error}"
    if outputs is None:
        return False, "no outputs and no error"
    if case.result == "invalid":
        return False, f"returned values, expected error {expected_error}"
    problems = []
    for name, exp in values.items():
        if name not in outputs:
            problems.append(f"{name}: missing")
            continue
        reason = _compare_output(name, exp, outputs[name], case.tolerance.get(name, 0.0))
        if reason:
            problems.append(reason)
    if problems:
        return False, "; ".join(problems)
    return True, ""
