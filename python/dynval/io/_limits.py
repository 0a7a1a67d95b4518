"""The decoded-size limit of the file readers (contract §7).

A few bytes on disk can decode to gigabytes: a compressed ``.npz`` member of zeros, an HDF5
dataset whose chunks were never written, a run-length-encoded Parquet column. The size on disk
says nothing, so every reader computes the decoded size from the file's own layout (the ``.npy``
header inside the member, the HDF5 dataspace, the Parquet footer) and refuses, before decoding
anything, an array that would take more than the limit as float64, the type dynval computes in.
"""

from __future__ import annotations

import math
import os

from ._fileopen import FileInputError

__all__ = ["DEFAULT_MAX_DECODED_BYTES", "LIMIT_ENV", "check_decoded", "decoded_bytes", "max_decoded_bytes"]

# 1 GiB: 134 million float64 values, a day of 7 joints at 200 Hz; larger files stream (--stream).
DEFAULT_MAX_DECODED_BYTES = 1 << 30
LIMIT_ENV = "DYNVAL_MAX_DECODED_BYTES"


def max_decoded_bytes() -> int:
    """The limit: ``$DYNVAL_MAX_DECODED_BYTES`` (a positive integer of bytes), else 1 GiB."""
    text = os.environ.get(LIMIT_ENV, "").strip()
    if not text:
        return DEFAULT_MAX_DECODED_BYTES
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise FileInputError(f"{LIMIT_ENV}={text!r}: expected a positive integer number of bytes, "
                             f"e.g. {LIMIT_ENV}={4 << 30} for 4 GiB")
    return value


def decoded_bytes(shape: tuple[int, ...], itemsize: int = 8) -> int:
    """Bytes of an array of ``shape`` once converted to float64 (wider types keep their size)."""
    return math.prod(shape) * max(int(itemsize), 8)


def check_decoded(where: str, shape: tuple[int, ...], itemsize: int = 8, *, hint: str | None = None) -> None:
    """Refuse an array of ``shape`` whose decoded size exceeds the limit; ``where`` starts the
    message (the file, and the member or dataset), ``hint`` replaces the advice to stream."""
    size = decoded_bytes(shape, itemsize)
    limit = max_decoded_bytes()
    if size > limit:
        advice = hint or "read it in blocks with dynval validate --stream"
        raise FileInputError(f"{where}: shape {tuple(shape)} decodes to {size} bytes as float64, more than the "
                             f"limit of {limit} bytes; {advice}, or raise the limit with {LIMIT_ENV}=BYTES")
