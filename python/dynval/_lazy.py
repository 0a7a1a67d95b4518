"""scipy, imported where it is first used rather than by ``import dynval``.

scipy.signal and scipy.stats alone take most of a second to import, several times numpy and the
whole of dynval; a session that only reads a report or computes an RMSE need not pay it. Modules
write ``scipy.stats.chi2.sf(...)`` as usual; the name ``scipy`` they import from here imports each
subpackage on its first attribute access and keeps it. Type checkers see the real modules (each
module imports them under ``TYPE_CHECKING``).
"""

from __future__ import annotations

import importlib
from types import ModuleType

__all__ = ["scipy"]


class _LazyScipy:
    """Stands for the ``scipy`` package: ``scipy.<sub>`` is ``importlib.import_module("scipy.<sub>")``."""

    def __getattr__(self, name: str) -> ModuleType:
        if name.startswith("__"):  # copy, pickle and introspection ask for dunders: not subpackages
            raise AttributeError(name)
        module = importlib.import_module(f"scipy.{name}")
        setattr(self, name, module)  # later accesses are plain attribute reads
        return module

    def __repr__(self) -> str:
        return "<scipy, imported on first use>"


scipy = _LazyScipy()
