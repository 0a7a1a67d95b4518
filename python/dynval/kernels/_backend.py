"""Backend selection: the numpy/scipy reference (``python``) or the compiled core (``cpp``).

The compiled module is imported lazily, once. The default is ``cpp`` when it imports, else
``python``; ``DYNVAL_BACKEND`` is read at first use and :func:`set_backend` overrides both.
"""

from __future__ import annotations

import os
from typing import Any, TypedDict

from ..checks._typing import BackendName, Kernels
from ..checks._validation import parameter_error
from . import _reference

BACKEND_NAMES = ("python", "cpp")


class _State(TypedDict):
    current: str | None
    core: Kernels | None
    core_detail: str | None


_state: _State = {"current": None, "core": None, "core_detail": None}


def _load_core() -> Kernels | None:
    if _state["core_detail"] is None:
        try:
            from .. import _core as core
        except Exception as exc:  # any import failure means the backend is unavailable
            _state["core_detail"] = f"dynval._core could not be imported: {type(exc).__name__}: {exc}"
        else:
            _state["core"] = core
            _state["core_detail"] = f"compiled module {getattr(core, '__file__', 'dynval._core')}"
    return _state["core"]


def backends() -> dict[str, dict[str, Any]]:
    """Backends and whether they can be used.

    Takes no arguments, and never raises.

    Returns
    -------
    dict
        ``{"python": {"available": bool, "default": bool, "detail": str}, "cpp": {...}}``;
        ``default`` marks the backend used when a function gets ``backend=None``; ``detail`` says
        where the backend comes from or why it is unavailable.

    Examples
    --------
    >>> import dynval
    >>> dynval.backends()["python"]["available"]
    True
    >>> sum(b["default"] for b in dynval.backends().values())
    1

    An invalid ``DYNVAL_BACKEND`` leaves no default (calls with ``backend=None`` raise
    InvalidParameter), and ``backends()`` still answers:

    >>> import os
    >>> from unittest import mock
    >>> with mock.patch.dict(os.environ, {"DYNVAL_BACKEND": "fortran"}):
    ...     [b["default"] for b in dynval.backends().values()]
    [False, False]
    """
    core = _load_core()
    try:
        default = default_backend()
    except Exception:  # an invalid DYNVAL_BACKEND: this function is what one calls to find out why
        default = None
    return {
        "python": {"available": True, "default": default == "python",
                   "detail": "numpy/scipy reference kernels (dynval.kernels._reference)"},
        "cpp": {"available": core is not None, "default": default == "cpp", "detail": _state["core_detail"]},
    }


def available() -> tuple[str, ...]:
    """Names of the usable backends, in contract order."""
    return ("python", "cpp") if _load_core() is not None else ("python",)


def check_backend(name: object) -> str:
    """Return ``name`` if it is an available backend, else raise InvalidParameter."""
    names = available()
    if not isinstance(name, str) or name not in names:
        raise parameter_error("backend", "one of " + ", ".join(repr(n) for n in names), name)
    return name


def set_backend(name: BackendName | None) -> None:
    """Select the backend used when a function is called with ``backend=None``.

    Parameters
    ----------
    name : str or None
        ``"python"`` or ``"cpp"``; ``None`` returns to the default (``DYNVAL_BACKEND``, else
        ``cpp`` when available, else ``python``).

    Returns
    -------
    None

    Raises
    ------
    InvalidParameter
        If the backend is unknown or unavailable.

    Examples
    --------
    >>> import dynval
    >>> dynval.set_backend("python")
    >>> dynval.backends()["python"]["default"]
    True
    >>> dynval.set_backend(None)

    An unknown or unavailable backend is refused, and the current choice is kept:

    >>> dynval.set_backend("fortran")
    Traceback (most recent call last):
        ...
    dynval.checks._errors.InvalidParameter: backend must be one of 'python'..., got 'fortran'
    """
    _state["current"] = None if name is None else check_backend(name)


def default_backend() -> str:
    """The name used for ``backend=None``."""
    if _state["current"] is None:
        env = os.environ.get("DYNVAL_BACKEND")
        if env:
            names = available()
            if env not in names:
                raise parameter_error("DYNVAL_BACKEND (environment variable)",
                                      "one of " + ", ".join(repr(n) for n in names), env)
            return env
        return "cpp" if _load_core() is not None else "python"
    return _state["current"]


def resolve(name: object = None) -> tuple[BackendName, Kernels]:
    """``(name, kernel module)`` for ``name`` (``None`` = the default)."""
    chosen = default_backend() if name is None else check_backend(name)
    if chosen == "python":
        return "python", _reference
    core = _load_core()
    assert core is not None, "cpp is only chosen when dynval._core imports"
    return "cpp", core


def get_backend(name: object = None) -> Kernels:
    """The kernel module of a backend (``dynval.kernels._reference`` or ``dynval._core``)."""
    return resolve(name)[1]
