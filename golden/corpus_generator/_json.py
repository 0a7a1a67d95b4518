"""Corpus encoding of numbers and arrays, and the fixed JSON layout of the files."""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

from ._exact import f64


def num(x: Any) -> Any:
    """Corpus encoding of one number (floats shortest round-trip, non-finite as strings)."""
    if isinstance(x, (bool, int)):
        return x
    v = f64(x)
    if v != v:
        return "NaN"
    if v == float("inf"):
        return "Infinity"
    if v == float("-inf"):
        return "-Infinity"
    return v


def arr(values: Sequence, shape: Sequence[int]) -> dict:
    return {"shape": list(shape), "values": [num(v) for v in values]}


def mat(rows: Sequence[Sequence]) -> dict:
    """(N, m) matrix given as rows."""
    n = len(rows)
    m = len(rows[0]) if n else 0
    return arr([v for r in rows for v in r], [n, m])


def _dump(value: Any, indent: int, level: int) -> str:
    pad = " " * (indent * (level + 1))
    end = " " * (indent * level)
    if isinstance(value, dict):
        if not value:
            return "{}"
        if set(value) == {"shape", "values"}:  # arrays on one line
            return json.dumps(value, allow_nan=False, separators=(", ", ": "))
        items = [f"{pad}{json.dumps(k)}: {_dump(v, indent, level + 1)}" for k, v in value.items()]
        return "{\n" + ",\n".join(items) + "\n" + end + "}"
    if isinstance(value, list):
        if all(not isinstance(v, (dict, list)) for v in value):
            return json.dumps(value, allow_nan=False, separators=(", ", ": "))
        items = [pad + _dump(v, indent, level + 1) for v in value]
        return "[\n" + ",\n".join(items) + "\n" + end + "]"
    return json.dumps(value, allow_nan=False)


def dumps(doc: dict) -> str:
    """The fixed JSON layout of corpus files (2-space indent, arrays and lists on one line)."""
    return _dump(doc, 2, 0) + "\n"
