"""Environment variables changed for a while and put back as they were."""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from contextlib import contextmanager


@contextmanager
def restored_environ(keys: Iterable[str]) -> Iterator[None]:
    """Put each of ``keys`` back as it was on exit (unset if it was unset), whatever the block set.

    Subprocesses started later by the caller must not inherit what the block needed for its own
    (a port's variables in the conformance matrix, the dask nannies' worker settings)."""
    saved = {key: os.environ.get(key) for key in keys}
    try:
        yield
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
