"""How a notebook shows a report: the HTML renderer, given from above.

The page is drawn by :mod:`dynval.html`, a layer above the report and the comparison; the package
root hands its renderer down here (:func:`use`), so the records' ``_repr_html_`` need not import it."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["use", "render"]

_renderer: list[Callable[[Any], str]] = []


def use(renderer: Callable[[Any], str]) -> None:
    """Draw reports with ``renderer`` from now on (the package root gives dynval.html's)."""
    _renderer[:] = [renderer]


def render(obj: Any) -> str | None:
    """``obj``'s HTML fragment, or None while no renderer was given (the notebook shows the text)."""
    return _renderer[0](obj) if _renderer else None
