"""Locate and read the golden corpus (no dependency beyond numpy and the standard library)."""

from __future__ import annotations

import json
import math
import pathlib
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: The corpus families, in the one order used everywhere (contract §6).
FAMILIES: tuple[str, ...] = (
    "norms",
    "normalized_fit",
    "residual_statistics",
    "autocorrelation",
    "portmanteau",
    "cross_correlation",
    "information_criteria",
    "errors",
    "streaming",
)

#: Families a port may leave out: one in which it declares no operation is not asked for
#: unless named explicitly (golden/PROTOCOL.md §6). ``streaming`` proves mergeable accumulators.
OPTIONAL_FAMILIES: tuple[str, ...] = ("streaming",)

#: Name of the JSON Schema every corpus file declares in its ``schema`` field.
SCHEMA_NAME = "corpus_v1.schema.json"

_NONFINITE = {"NaN": math.nan, "Infinity": math.inf, "-Infinity": -math.inf}


def golden_root() -> pathlib.Path:
    """Directory holding ``vectors/``, ``schema/``, ``data/``, ``operations.json`` and ``PROTOCOL.md``.

    The wheel merges the source tree's ``golden/`` into this package
    (``dynval/golden/vectors``, ...: scikit-build-core ``wheel.packages``), without the
    corpus generator (``generate.py``, ``corpus_generator/``: ``wheel.exclude``, see
    ``_lint.generator_dir``); in a development checkout the source tree's ``golden/`` is
    used instead.
    """
    here = pathlib.Path(__file__).resolve().parent
    if (here / "vectors").is_dir():
        return here
    source = here.parent.parent.parent / "golden"
    if (source / "vectors").is_dir():
        return source
    msg = f"golden corpus not found (looked in {here} and {source})"
    raise FileNotFoundError(msg)


def corpus_dir() -> pathlib.Path:
    """Directory of the corpus files ``<family>.json`` shipped with dynval.

    Returns
    -------
    pathlib.Path
        ``dynval/golden/vectors`` in an installed package, or ``golden/vectors``
        of the source tree in development.

    Examples
    --------
    >>> from dynval.golden import corpus_dir
    >>> (corpus_dir() / "norms.json").is_file()
    True
    """
    return golden_root() / "vectors"


def schema_path() -> pathlib.Path:
    """Path of dynval's corpus JSON Schema (in the package, or in the source tree).

    A schema file beside a corpus is deliberately not looked for: a copy of the
    corpus must be checked against dynval's schema, not against one it brings along.
    """
    return golden_root() / "schema" / SCHEMA_NAME


def load_family(family: str, corpus_dir: pathlib.Path | str | None = None) -> dict:
    """Read one corpus file as plain JSON (non-finite numbers stay strings).

    Parameters
    ----------
    family : str
        One of :data:`FAMILIES`.
    corpus_dir : path, optional
        Directory holding ``<family>.json``; default :func:`corpus_dir`.

    Examples
    --------
    >>> from dynval.golden import load_family
    >>> load_family("norms")["family"]
    'norms'
    """
    if family not in FAMILIES:
        msg = f"family must be one of {', '.join(FAMILIES)}, got {family!r}"
        raise ValueError(msg)
    directory = pathlib.Path(corpus_dir) if corpus_dir is not None else globals()["corpus_dir"]()
    path = directory / f"{family}.json"
    with path.open(encoding="utf-8") as handle:
        return json.load(handle)


def decode_number(value: Any) -> Any:
    """Map the corpus spelling of a number to a Python number.

    ``"NaN"``, ``"Infinity"`` and ``"-Infinity"`` become floats; every other
    value is returned unchanged.
    """
    if isinstance(value, str) and value in _NONFINITE:
        return _NONFINITE[value]
    return value


def is_array(value: Any) -> bool:
    """True when ``value`` is the corpus encoding of an array (``shape`` + ``values``)."""
    return isinstance(value, dict) and set(value) == {"shape", "values"}


def decode_array(value: dict) -> np.ndarray:
    """Decode ``{"shape": [...], "values": [...]}`` (row-major) into an ndarray.

    Booleans give a bool array, integers an int64 array, anything else float64.
    """
    values = [decode_number(v) for v in value["values"]]
    shape = tuple(value["shape"])
    if values and all(isinstance(v, bool) for v in values):
        dtype: type = np.bool_
    elif values and all(isinstance(v, int) and not isinstance(v, bool) for v in values):
        dtype = np.int64
    else:
        dtype = np.float64
    return np.asarray(values, dtype=dtype).reshape(shape)


def decode_value(value: Any) -> Any:
    """Decode an input or expected value: arrays to ndarrays, numbers as numbers."""
    if is_array(value):
        return decode_array(value)
    return decode_number(value)


@dataclass(frozen=True)
class Case:
    """One test vector, decoded.

    Attributes
    ----------
    family, tc_id, operation : str, int, str
        Where the vector lives and the contract operation it exercises.
    conventions : dict
        Every convention the vector assumes (contract names and values).
    inputs : dict
        Argument name → ndarray or scalar (``None`` for a JSON ``null``).
    expected : dict
        Output name → ndarray or scalar; ``{"error": kind}`` for invalid
        vectors; ``acceptable`` vectors may hold both.
    result : str
        ``"valid"``, ``"invalid"`` or ``"acceptable"``.
    tolerance : dict
        Output name → absolute tolerance (float or ndarray of the output's shape).
    flags : tuple of str
        Reasons the vector exists, explained in the file's ``notes``.
    comment : str
        One line about the vector.
    source : dict
        Provenance of the group's expected values.
    """

    family: str
    tc_id: int
    operation: str
    conventions: dict
    inputs: dict
    expected: dict
    result: str
    tolerance: dict
    flags: tuple[str, ...]
    comment: str
    source: dict = field(default_factory=dict)

    @property
    def id(self) -> str:
        """Readable identifier ``"<family>-<tcId>"`` (pytest ids, reports)."""
        return f"{self.family}-{self.tc_id}"

    @property
    def error(self) -> str | None:
        """The expected error kind, if any."""
        return self.expected.get("error")


def _decode_mapping(mapping: dict) -> dict:
    return {name: (value if name == "error" else decode_value(value)) for name, value in mapping.items()}


def iter_cases(
    corpus_dir: pathlib.Path | str | None = None,
    families: Sequence[str] | None = None,
) -> Iterator[Case]:
    """Iterate over every test vector of the corpus, family by family, in file order.

    Parameters
    ----------
    corpus_dir : path, optional
        Directory holding the ``<family>.json`` files; default :func:`corpus_dir`.
    families : sequence of str, optional
        Restrict to these families (default: all of :data:`FAMILIES`; an optional family whose
        file a corpus directory of one's own lacks is left out).

    Examples
    --------
    >>> from dynval.golden import iter_cases
    >>> case = next(iter_cases(families=["norms"]))
    >>> case.id.startswith("norms-")
    True
    """
    selected = FAMILIES if families is None else tuple(families)
    for family in selected:
        if families is None and corpus_dir is not None and family in OPTIONAL_FAMILIES \
                and not (pathlib.Path(corpus_dir) / f"{family}.json").is_file():
            continue
        data = load_family(family, corpus_dir)
        for group in data["testGroups"]:
            for test in group["tests"]:
                yield Case(
                    family=family,
                    tc_id=test["tcId"],
                    operation=group["operation"],
                    conventions=dict(group["conventions"]),
                    inputs=_decode_mapping(test["inputs"]),
                    expected=_decode_mapping(test["expected"]),
                    result=test["result"],
                    tolerance=_decode_mapping(test.get("tolerance", {})),
                    flags=tuple(test["flags"]),
                    comment=test["comment"],
                    source=dict(group["source"]),
                )
