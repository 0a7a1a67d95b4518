"""The finding kinds, one module each (``<kind>.py`` declaring ``KIND``), discovered here.

A kind's module holds all of the kind: its description, its rule and the rule's place among the
rules, its words, its thresholds and its line in ``compare``'s reasons (docs/architecture.md,
"Adding a finding kind"). The report's rules (``report/_findings.py``), ``compare``'s reasons, the
vocabulary ``dynval.FINDING_KINDS`` and the ``thresholds=`` names take every kind from :data:`KINDS`.
"""

from __future__ import annotations

import importlib
import pkgutil
from types import MappingProxyType

from ._base import Kind, declare

__all__ = ["KINDS", "Kind"]


def _discover() -> dict[str, Kind]:
    """Every module of this package not starting with ``_``, by its kind's name, in rule order."""
    found: list[Kind] = []
    for info in pkgutil.iter_modules(__path__):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        kind = getattr(module, "KIND", None)
        if not isinstance(kind, Kind) or kind.name != info.name:
            raise TypeError(f"{module.__name__} must declare KIND = Kind(name={info.name!r}, ...)")
        found.append(kind)
    found.sort(key=lambda k: (k.order, k.name))
    for kind in found:
        declare(kind)
    return {k.name: k for k in found}


KINDS: MappingProxyType[str, Kind] = MappingProxyType(_discover())
"""The kinds declared by this package's modules, by name, in the order their rules run."""
