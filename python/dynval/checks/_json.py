"""Report values as plain JSON types (contract §4): the one converter every writer uses."""

from __future__ import annotations

import importlib
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["to_jsonable", "to_frame"]


def to_jsonable(value: Any) -> Any:
    """Convert a report value to plain JSON types.

    Arrays become nested lists, numpy scalars Python scalars, tuples lists, and non-finite
    floats the strings ``"NaN"``, ``"Infinity"`` and ``"-Infinity"`` (contract §4).

    Examples
    --------
    >>> to_jsonable({"a": np.array([1.0, np.nan, -np.inf]), "b": (np.int64(2), True)})
    {'a': [1.0, 'NaN', '-Infinity'], 'b': [2, True]}
    """
    if isinstance(value, Mapping):  # a dict, or a report section (a record)
        return {str(k): to_jsonable(x) for k, x in value.items()}
    if isinstance(value, np.ndarray):
        return to_jsonable(value.tolist())
    if isinstance(value, (list, tuple)):
        return [to_jsonable(x) for x in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        x = float(value)
        if math.isnan(x):
            return "NaN"
        if math.isinf(x):
            return "Infinity" if x > 0 else "-Infinity"
        return x
    return value


def to_frame(columns: dict[str, Any], index: list[str], index_name: str, what: str) -> Any:
    """A pandas DataFrame of ``columns`` (name → values in ``index`` order); pandas is optional.

    Raises ImportError naming ``what`` and the package to install when pandas is missing.
    """
    try:
        pd = importlib.import_module("pandas")
    except ImportError as exc:
        raise ImportError(f"{what} needs pandas: pip install pandas") from exc
    frame = pd.DataFrame({k: list(np.asarray(v).tolist()) if np.ndim(v) else [v] * len(index)
                          for k, v in columns.items()}, index=pd.Index(index, name=index_name))
    return frame
