"""Shapes from the files' headers, checked against each other before any array is decoded.

A 1 MB compressed ``.npz`` can declare (2**26, 2) float64: decoding it to find that the other file
has 10 rows took 3 GB. Every format but CSV says its shape without decoding: the ``.npy`` header
(inside the archive for a ``.npz`` member; only that header is inflated), the Parquet footer, the
HDF5 dataspace. :func:`declared_shape` reads it; :func:`check_declared` runs the contract's own
shape checks (``dynval.checks._validation``, so the messages are the ones the arrays would get) on
stand-ins of those shapes that hold no memory. CSV text has no header that counts its rows: its
row count is known only after a pass over the text, so a CSV file is checked by its column count
here and by its rows after the read (CSV text decodes to at most four times its size on disk, so
its read is bounded by the file itself).
"""

from __future__ import annotations

import math
import sys
import zipfile
from collections.abc import Mapping
from typing import BinaryIO, cast

import numpy as np

from ..checks._errors import ShapeMismatch
from ..checks._validation import format_shape, format_value, regressor_shape, torque_pair
from ._fileopen import FileInputError, open_regular
from ._files import _COLUMNAR_SUFFIXES, _csv_blocks, _split_key, column_index, split_column

__all__ = ["declared_shape", "check_declared"]

_CSV = (".csv", ".tsv", ".txt")


def declared_shape(spec: str) -> tuple[int | None, ...] | None:
    """The shape the file of ``spec`` declares, read from its header or footer only.

    CSV text: ``(None,)`` or ``(None, columns)`` (its rows are not declared anywhere). None when the
    file declares nothing that can be read this way (the reader then gives its own message).
    FileInputError for a file the reader refuses on its header (a pickle, a non-numeric dtype, a
    header that needs more bytes than the file holds, ...).
    """
    return _describable(_declared(spec))


def _declared(spec: str) -> tuple[int | None, ...] | None:
    path, key = _split_key(spec)
    lower = path.lower()
    if lower.endswith(_CSV):
        handle, _ = open_regular(path)
        with handle:
            for block, _lines in _csv_blocks(handle, path, rows=1):
                return (None,) if block.shape[1] == 1 else (None, int(block.shape[1]))
        return None
    if lower.endswith(".npz"):
        return _npz_declared(path, key)
    if lower.endswith((".npy", *_COLUMNAR_SUFFIXES)):
        from ._readers import open_rows

        return tuple(open_rows(spec).shape)
    return None


def _npz_declared(path: str, key: str | None) -> tuple[int, ...] | None:
    """The shape in the ``.npy`` header of a member (stored or compressed: only the header is
    read), or None when the archive or the member cannot be found this way."""
    from ._readers import _checked_header

    handle, _ = open_regular(path)
    with handle:
        try:
            with zipfile.ZipFile(handle) as archive:
                names = [n for n in archive.namelist() if n.endswith(".npy")]
                name = names[0] if key is None and names else f"{key}.npy"
                if name not in archive.namelist():
                    return None
                info = archive.getinfo(name)
                with archive.open(info) as member:
                    shape, _fortran, _dtype, _offset = _checked_header(cast(BinaryIO, member),
                                                                       f"{path}: array {name[:-4]!r}", info.file_size)
        except FileInputError:
            raise  # the header is refused as the reader would refuse it
        except (zipfile.BadZipFile, OSError, EOFError, ValueError, NotImplementedError, RuntimeError):
            return None  # the reader gives the archive's message
    return tuple(shape)


def _stand_in(shape: tuple[int, ...]) -> np.ndarray:
    """An array of ``shape`` that holds one value: the checks read its shape only."""
    return np.broadcast_to(np.float64(0.0), shape)


def _describable(shape: tuple[int | None, ...] | None) -> tuple[int | None, ...] | None:
    """``shape``, or None when numpy cannot even describe an array of it (a hostile header's
    (2**40, 2**40)): the reader then refuses the file by its size, with its own message."""
    if shape is None:
        return None
    known = [s for s in shape if s is not None]
    return shape if math.prod(known) * 8 < sys.maxsize else None


def check_declared(tau_meas: str, predictions: Mapping[str, str], *, regressor: str | None = None,
                   time: str | None = None, q: str | None = None, n_joints: int | None = None) -> None:
    """Check the declared shapes of the command's files against each other, before any decoding.

    ``predictions`` maps a name for messages to each prediction's spec (``{"tau_pred": spec}`` for
    validate, the candidates for compare). Raises the contract's ShapeMismatch or InvalidShape with
    the message the decoded arrays would get (a candidate's prefixed ``candidates['name']: ``), and
    FileInputError for a file refused on its header. A shape that is not fully declared (CSV rows)
    is compared where it is known, its columns.
    """
    meas = declared_shape(tau_meas)
    for name, spec in predictions.items():
        pred = declared_shape(spec)
        if meas is None or pred is None:
            continue
        if None in meas or None in pred:
            _check_columns(meas, pred, name)
            continue
        try:
            torque_pair(_stand_in(meas), _stand_in(pred))  # type: ignore[arg-type]
        except ShapeMismatch as exc:
            raise ShapeMismatch(f"{exc}{_whose(name)}") from None
    if meas is None or None in meas:
        return
    n, m = meas[0], (1 if len(meas) == 1 else meas[1])
    assert n is not None and m is not None
    if regressor is not None:
        reg = declared_shape(regressor)
        if reg is not None and None not in reg:
            regressor_shape(_stand_in(reg), "tau_meas", n, m, n_joints if len(reg) == 2 else None)  # type: ignore[arg-type]
    if time is not None:
        base, column = split_column(time)
        stamps = declared_shape(base)
        if stamps is not None and None not in stamps:
            column_index(base, column, stamps)  # type: ignore[arg-type]
            if stamps[0] != n:
                raise ShapeMismatch(f"time must have one stamp per sample, shape ({n},), got ({stamps[0]},)")
    if q is not None:
        shape = declared_shape(q)
        if shape is not None and None not in shape and (shape[0], 1 if len(shape) == 1 else shape[1]) != (n, m):
            raise ShapeMismatch(f"tau_meas and q must have the same shape, got ({n}, {m}) and "
                                f"{format_shape(shape)}")


def _shape_text(shape: tuple[int | None, ...]) -> str:
    """``(N, 3)``: a shape whose rows are not declared."""
    cells = ["N" if s is None else str(s) for s in shape]
    return "(" + ", ".join(cells) + ("," if len(cells) == 1 else "") + ")"


def _whose(name: str) -> str:
    """compare's candidates are each tau_pred in turn: the message says which one."""
    return "" if name == "tau_pred" else f" (tau_pred: the prediction of candidate {format_value(name)})"


def _check_columns(meas: tuple[int | None, ...], pred: tuple[int | None, ...], name: str) -> None:
    """A CSV file's rows are not declared: its columns are compared, as 2-D (N, m) signals."""
    width = [1 if len(s) == 1 else s[1] for s in (meas, pred)]
    if len(meas) <= 2 and len(pred) <= 2 and width[0] != width[1]:
        shown = [_shape_text(s) for s in (meas, pred)]
        raise ShapeMismatch(f"tau_meas and tau_pred must have the same shape, got {shown[0]} and {shown[1]} "
                            f"(N: the rows of a CSV file, counted when it is read){_whose(name)}")
