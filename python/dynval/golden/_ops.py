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
