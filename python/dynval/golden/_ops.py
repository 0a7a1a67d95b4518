"""Run one corpus operation through the public dynval API (never a kernel directly)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

#: Positional (data) arguments of each operation, in the contract's order.
#: Every other input and every convention is passed by keyword.
POSITIONAL: dict[str, tuple[str, ...]] = {
    "residuals": ("tau_meas", "tau_pred"),
    "sse": ("tau_meas", "tau_pred"),
    "rmse": ("tau_meas", "tau_pred"),
    "max_abs_error": ("tau_meas", "tau_pred"),
    "vaf": ("tau_meas", "tau_pred"),
    "fit_percent": ("tau_meas", "tau_pred"),
    "r2": ("tau_meas", "tau_pred"),
    "residual_mean": ("e",),
    "residual_variance": ("e",),
    "zero_mean_test": ("e",),
    "autocorrelation": ("e", "max_lag"),
    "confidence_band": ("n",),
    "ljung_box": ("e", "lags"),
    "box_pierce": ("e", "lags"),
    "cross_correlation": ("e", "regressor", "max_lag"),
    "information_criteria": ("rss", "n_obs", "n_params"),
    "criteria": ("tau_meas", "tau_pred"),
    "aic": ("tau_meas", "tau_pred"),
    "bic": ("tau_meas", "tau_pred"),
    "accumulate": ("tau_meas", "tau_pred"),
}

#: Named outputs of the operations that return a result object (contract field names).
FIELDS: dict[str, tuple[str, ...]] = {
    "zero_mean_test": (
        "mean", "std", "n_samples", "statistic_iid", "pvalue_iid", "df_iid",
        "statistic_eff", "pvalue_eff", "df_eff", "n_eff", "bandwidth",
    ),
    "ljung_box": ("lags", "statistic", "pvalue", "log_pvalue", "df"),
    "box_pierce": ("lags", "statistic", "pvalue", "log_pvalue", "df"),
    "cross_correlation": ("rho", "constant_mask", "band"),
    "information_criteria": ("aic", "bic", "aicc", "fpe", "naic"),
    "criteria": ("aic", "bic", "aicc", "fpe", "naic", "n_obs"),
}

OPERATIONS: tuple[str, ...] = tuple(POSITIONAL)

#: Outputs of ``accumulate``: (report section, field, column of a per-joint table or None).
_ACCUMULATED = {
    "sse": ("per_joint", "sse"), "rmse": ("per_joint", "rmse"), "max_abs_error": ("per_joint", "max_abs_error"),
    "vaf": ("per_joint", "vaf"), "fit_percent": ("per_joint", "fit_percent"), "r2": ("per_joint", "r2"),
    "residual_mean": ("residuals", "mean"), "residual_variance": ("residuals", "variance"),
    "autocorrelation": ("autocorrelation", "rho"), "aic": ("information_criteria", "aic"),
    "bic": ("information_criteria", "bic"), "aicc": ("information_criteria", "aicc"),
    "fpe": ("information_criteria", "fpe"), "naic": ("information_criteria", "naic"),
}


def _field(result: Any, name: str) -> Any:
    if isinstance(result, Mapping):
        return result[name]
    return getattr(result, name)


def run_operation(
    operation: str,
    inputs: Mapping[str, Any],
    conventions: Mapping[str, Any],
    backend: str | None = None,
) -> dict[str, np.ndarray]:
    """Evaluate one corpus operation with the public dynval API.

    Parameters
    ----------
    operation : str
        Contract operation name (``"r2"``, ``"ljung_box"``, ...).
    inputs : mapping
        Decoded inputs of a vector (arrays and per-test parameters).
    conventions : mapping
        The group's conventions, passed as keywords under their contract names.
    backend : str, optional
        ``"python"`` or ``"cpp"``; default: dynval's default backend.

    Returns
    -------
    dict
        Output name → ndarray (0-d for scalars): ``value`` for single-valued
        operations, the result fields otherwise.

    Raises
    ------
    dynval.InputError
        Whatever the API raises for the inputs (the corpus names its kind).

    Examples
    --------
    >>> from dynval.golden import run_operation
    >>> out = run_operation("sse", {"tau_meas": [[1.0], [2.0]], "tau_pred": [[0.0], [0.0]]},
    ...                     {"multioutput": "pooled"})
    >>> float(out["value"])
    5.0
    """
    import dynval  # late import: the loader must work while the API is imported elsewhere

    if operation not in POSITIONAL:
        msg = f"operation must be one of {', '.join(OPERATIONS)}, got {operation!r}"
        raise ValueError(msg)
    if operation == "accumulate":
        return _accumulate(inputs, conventions, backend)
    function = getattr(dynval, operation)
    positional = [inputs[name] for name in POSITIONAL[operation]]
    keywords = {k: v for k, v in inputs.items() if k not in POSITIONAL[operation]}
    keywords.update(conventions)
    if backend is not None:
        keywords["backend"] = backend
    result = function(*positional, **keywords)
    if operation not in FIELDS:
        return {"value": np.asarray(result)}
    out = {}
    for name in FIELDS[operation]:
        try:
            out[name] = np.asarray(_field(result, name))
        except (AttributeError, KeyError):
            continue  # absent fields are reported as missing by check_case when expected
    return out


def _blocks(n: int, chunks: Any) -> list[tuple[int, int]]:
    """Row ranges of the blocks of ``chunks`` (positive lengths summing to N)."""
    from ..checks._validation import is_integer, parameter_error

    if not isinstance(chunks, (list, tuple)) or not chunks or not all(is_integer(c) and c >= 1 for c in chunks) \
            or sum(int(c) for c in chunks) != n:
        raise parameter_error("chunks", f"a non-empty list of positive lengths summing to N={n}", chunks)
    ends = np.cumsum([int(c) for c in chunks])
    return list(zip([0, *ends[:-1].tolist()], ends.tolist()))


def _merged(accumulators: list, merge: str):
    """One accumulator from the blocks' own, combined in the order ``merge`` names."""
    if merge == "left":
        out = accumulators[0]
        for acc in accumulators[1:]:
            out = out.merge(acc)
        return out
    if merge == "right":
        out = accumulators[-1]
        for acc in reversed(accumulators[:-1]):
            out = acc.merge(out)
        return out
    level = accumulators
    while len(level) > 1:  # tree: adjacent pairs, an odd last one passed up unchanged
        level = [level[k].merge(level[k + 1]) if k + 1 < len(level) else level[k] for k in range(0, len(level), 2)]
    return level[0]


def _checked_data(inputs: Mapping[str, Any], nan_policy: object) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """The data checks of the in-memory operations, so that the errors are those of the other
    families: the torques as ``criteria`` checks them (the checked call: ``nan_policy`` deferred,
    then finiteness), then the regressor as ``cross_correlation`` checks it against ``e``."""
    from ..checks._checks import CheckedCall
    from ..checks._validation import check_min_samples, regressor_shape, regressor_to_2d, to_float_array, torque_pair
    from ..kernels._backend import resolve

    t = torque_pair(inputs["tau_meas"], inputs["tau_pred"])
    n, m = t.meas.shape
    check_min_samples("criteria", n)
    call = CheckedCall("criteria", [("tau_meas", t.meas, None), ("tau_pred", t.pred, None)])
    call.nan_policy(nan_policy)
    call.resolve_backend(None, resolve)
    call.require_finite()
    if inputs.get("regressor") is None:
        return t.meas, t.pred, None
    y = to_float_array(inputs["regressor"], "regressor")
    p = regressor_shape(y, "e", n, m, None)
    e = t.meas - t.pred  # in range only up to 1e144, as every datum
    CheckedCall("cross_correlation", [("e", e, None), ("regressor", regressor_to_2d(y, n, m, p), p)]).require_finite()
    return t.meas, t.pred, y


def _accumulate(inputs: Mapping[str, Any], conventions: Mapping[str, Any],
                backend: str | None) -> dict[str, np.ndarray]:
    """``accumulate``: feed the rows in the blocks of ``chunks`` to accumulators and merge them (contract §4.1).

    The data are checked as ``criteria`` checks them first (type, shape, size, finiteness), the
    regressor then as ``cross_correlation`` checks it, then the driver's own parameters (``chunks``,
    ``merge``, ``segments``, ``max_lag``), so the check order is the contract's.
    """
    from ..checks._segments import longest_segment, parse_segments
    from ..checks._validation import check_choice, check_max_lag, check_n_params
    from ..stream import ValidationAccumulator

    nan_policy = conventions.get("nan_policy", "raise")
    # operations.json lists only "raise" for accumulate: "omit" is refused after the data, as the
    # other ports refuse it, so that a refused policy does not hide a non-finite value.
    meas2, pred2, reg = _checked_data(inputs, "raise" if nan_policy == "omit" else nan_policy)
    check_choice("nan_policy", nan_policy, ("raise",))
    n = meas2.shape[0]
    blocks = _blocks(n, conventions.get("chunks"))
    merge = check_choice("merge", conventions.get("merge", "none"), ("none", "left", "right", "tree"))
    starts = parse_segments(conventions.get("segments"), n)
    check_n_params(inputs["n_params"])  # operations.json's order: n_params before max_lag
    max_lag = check_max_lag(inputs["max_lag"], longest_segment(starts, n))
    record_starts = set(starts.tolist()) - {0}

    def new() -> ValidationAccumulator:
        return ValidationAccumulator(n_params=inputs["n_params"], max_lag=max_lag,
                                     noise_model=conventions.get("noise_model", "pooled"), nan_policy=nan_policy,
                                     backend=backend)

    def feed(acc: ValidationAccumulator, a: int, b: int) -> None:
        # a block is split where a record starts inside it; a record starting at the block's
        # first row is a break before it (the junction with the block before)
        cuts = sorted(k for k in record_starts if a <= k < b)
        edges = [a, *[k for k in cuts if k > a], b]
        if a in record_starts:
            acc.break_segment()
        for lo, hi in zip(edges[:-1], edges[1:]):
            if lo > a:
                acc.break_segment()
            acc.update(meas2[lo:hi], pred2[lo:hi], None if reg is None else reg[lo:hi])

    if merge == "none":
        acc = new()
        for a, b in blocks:
            feed(acc, a, b)
    else:
        parts = []
        for a, b in blocks:
            parts.append(new())
            feed(parts[-1], a, b)
        acc = _merged(parts, merge)
    report = acc.result()
    out = {name: np.asarray(getattr(report, section)[key]) for name, (section, key) in _ACCUMULATED.items()}
    if reg is not None:
        out["rho"] = np.asarray(report.cross_correlation["rho"])
    return out
