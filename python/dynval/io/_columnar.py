"""Parquet (pyarrow) and HDF5 (h5py) inputs of the command line (contract §7.2).

Both are optional extras (``dynval[parquet]``, ``dynval[hdf5]``); a missing library is a
:class:`~dynval.io._files.FileInputError` saying which extra to install. Both formats address rows
directly, so :func:`parquet_table` and :func:`hdf5_dataset` give a layout (shape) and a function
reading rows ``[start, stop)``; the in-memory loader reads every row at once, the streamed reader
a block at a time.

* Parquet: ``log.parquet`` takes every column, ``log.parquet:a,b,c`` the named columns in that
  order; each must be numeric (bool, integer or float). A null is NaN, so that ``nan_policy``
  decides about it as about any missing value. The array is (rows, columns), (rows,) for one
  column.
* HDF5: ``log.h5:/group/dataset`` names a dataset (the name may be given without the leading
  ``/``); ``log.h5`` alone takes the file's only dataset. Its dtype must be numeric and its
  shape 1-D to 3-D (a 3-D dataset is an (N, m, p) regressor); rows are its first axis.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._fileopen import HDF5_SUFFIXES, PARQUET_SUFFIXES, FileInputError, _open_regular

__all__ = ["Columnar", "HDF5_SUFFIXES", "PARQUET_SUFFIXES", "hdf5_dataset", "parquet_table"]


@dataclass
class Columnar:
    """A file's array: its shape, a reader of rows [start, stop) and of consecutive blocks, as float64."""

    shape: tuple[int, ...]
    read: Callable[[int, int], np.ndarray]
    blocks: Callable[[int], Iterator[np.ndarray]]

    def all(self) -> np.ndarray:
        return self.read(0, self.shape[0])


def _needs(module: str, extra: str, path: str, what: str) -> Any:
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise FileInputError(f"{path}: reading {what} needs {module.split('.')[0]}, which is not installed "
                             f"(pip install 'dynval[{extra}]')") from None


def _check_regular(path: str) -> None:
    # The libraries open the path themselves: refuse FIFOs and devices first, as for every file.
    handle, _ = _open_regular(path)
    handle.close()


def parquet_table(path: str, key: str | None) -> Columnar:
    """The numeric columns of a Parquet file (all, or those named in ``key``, comma-separated)."""
    _check_regular(path)
    pq = _needs("pyarrow.parquet", "parquet", path, "Parquet")
    pa = _needs("pyarrow", "parquet", path, "Parquet")
    try:
        handle = pq.ParquetFile(path)
    except Exception as exc:  # pyarrow reports a corrupt file in several exception types
        raise FileInputError(f"{path}: not a readable Parquet file ({exc})") from None
    schema = handle.schema_arrow
    names = list(schema.names)
    wanted = names if key is None else [c.strip() for c in key.split(",")]
    if not wanted or any(not c for c in wanted):
        raise FileInputError(f"{path}: no column named; give them as file.parquet:a,b,c")
    for column in wanted:
        if column not in names:
            raise FileInputError(f"{path}: no column named {column!r}; the file holds "
                                 + ", ".join(repr(n) for n in names))
        kind = schema.field(column).type
        if not (pa.types.is_integer(kind) or pa.types.is_floating(kind) or pa.types.is_boolean(kind)):
            raise FileInputError(f"{path}: column {column!r} holds {kind} values; dynval reads numbers "
                                 "(bool, integer or float)")
    n = int(handle.metadata.num_rows)
    shape = (n,) if len(wanted) == 1 else (n, len(wanted))

    def as_array(batch: Any) -> np.ndarray:
        out = np.empty((batch.num_rows, len(wanted)), dtype=np.float64)
        for j, column in enumerate(wanted):
            # a null becomes NaN: nan_policy decides about it
            out[:, j] = batch.column(column).cast(pa.float64()).to_numpy(zero_copy_only=False)
        return out[:, 0] if len(wanted) == 1 else out

    def read(start: int, stop: int) -> np.ndarray:
        return as_array(handle.read(columns=wanted).slice(start, stop - start))

    def blocks(rows: int) -> Iterator[np.ndarray]:
        # batches of at most `rows` rows, decoded one row group at a time
        for batch in handle.iter_batches(batch_size=rows, columns=wanted):
            yield as_array(batch)

    return Columnar(shape, read, blocks)


def hdf5_dataset(path: str, key: str | None) -> Columnar:
    """The dataset ``key`` of an HDF5 file (or its only dataset), rows along the first axis."""
    _check_regular(path)
    h5py = _needs("h5py", "hdf5", path, "HDF5")
    try:
        handle = h5py.File(path, "r")
    except Exception as exc:  # h5py raises OSError and others for a file that is not HDF5
        raise FileInputError(f"{path}: not a readable HDF5 file ({exc})") from None
    datasets: list[str] = []
    handle.visititems(lambda name, obj: datasets.append("/" + name) if isinstance(obj, h5py.Dataset) else None)
    if key is None:
        if len(datasets) != 1:
            handle.close()
            listed = ", ".join(datasets) if datasets else "none"
            raise FileInputError(f"{path}: name the dataset as file.h5:/name; the file holds {listed}")
        key = datasets[0]
    name = key if key.startswith("/") else "/" + key
    if name not in datasets:
        handle.close()
        raise FileInputError(f"{path}: no dataset {name!r}; the file holds "
                             + (", ".join(repr(d) for d in datasets) or "none"))
    dataset = handle[name]
    dtype, shape = dataset.dtype, tuple(int(s) for s in dataset.shape)
    if dtype.kind not in "biuf" or not 1 <= len(shape) <= 3:
        handle.close()
        if dtype.kind not in "biuf":
            raise FileInputError(f"{path}: dataset {name!r} holds {dtype} values; dynval reads numbers "
                                 "(bool, integer or float)")
        raise FileInputError(f"{path}: dataset {name!r} has shape {shape}; dynval reads 1-D to 3-D arrays "
                             "(samples along the first axis)")

    def read(start: int, stop: int) -> np.ndarray:
        return np.asarray(dataset[start:stop], dtype=np.float64)

    def blocks(rows: int) -> Iterator[np.ndarray]:
        for start in range(0, dataset.shape[0], rows):
            yield read(start, min(start + rows, dataset.shape[0]))

    return Columnar(shape, read, blocks)
