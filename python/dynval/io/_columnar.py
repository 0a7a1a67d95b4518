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
  Integers beyond ±2**53, which float64 cannot hold exactly, are refused with their column and
  row, as are column names that appear twice.
* HDF5: ``log.h5:/group/dataset`` names a dataset (the name may be given without the leading
  ``/``); ``log.h5`` alone takes the file's only dataset. Its dtype must be numeric and its
  shape 1-D to 3-D (a 3-D dataset is an (N, m, p) regressor); rows are its first axis. Only bytes
  inside the named file are read: external links, external raw storage and virtual datasets
  (which read other files, FIFOs or devices) are refused before any data is read.

Both check the decoded size against the limit of :mod:`dynval.io._limits` before decoding: the
whole array for a whole read, a row group (Parquet) or a block (HDF5) when streaming.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._fileopen import HDF5_SUFFIXES, PARQUET_SUFFIXES, FileInputError, open_regular
from ._limits import check_decoded

__all__ = ["Columnar", "HDF5_SUFFIXES", "PARQUET_SUFFIXES", "hdf5_dataset", "parquet_table"]


@dataclass
class Columnar:
    """A file's array: its shape, a reader of rows [start, stop) and of consecutive blocks, as float64."""

    shape: tuple[int, ...]
    read: Callable[[int, int], np.ndarray]
    blocks: Callable[[int], Iterator[np.ndarray]]
    where: str = ""

    def all(self) -> np.ndarray:
        check_decoded(self.where, self.shape)
        return self.read(0, self.shape[0])


def _needs(module: str, extra: str, path: str, what: str) -> Any:
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise FileInputError(f"{path}: reading {what} needs {module.split('.')[0]}, which is not installed "
                             f"(pip install 'dynval[{extra}]')") from None


@contextmanager
def _corrupt_as_input_error(what: str) -> Iterator[None]:
    """The libraries report a corrupt file in many exception types (OSError, RuntimeError,
    KeyError, ValueError, ArrowInvalid, ...): each becomes a FileInputError starting with ``what``;
    dynval's own refusals pass through."""
    try:
        yield
    except FileInputError:
        raise
    except MemoryError:
        raise
    except Exception as exc:
        raise FileInputError(f"{what} ({type(exc).__name__}: {exc})") from None


def _check_regular(path: str) -> None:
    # The libraries open the path themselves: refuse FIFOs and devices first, as for every file.
    handle, _ = open_regular(path)
    handle.close()


# Every integer of magnitude up to 2**53 is a float64; beyond, neighbours merge.
_EXACT_INTEGER = 2**53


def parquet_table(path: str, key: str | None) -> Columnar:
    """The numeric columns of a Parquet file (all, or those named in ``key``, comma-separated)."""
    _check_regular(path)
    pq = _needs("pyarrow.parquet", "parquet", path, "Parquet")
    pa = _needs("pyarrow", "parquet", path, "Parquet")
    try:
        handle = pq.ParquetFile(path)
        groups = [handle.metadata.row_group(i).num_rows for i in range(handle.metadata.num_row_groups)]
    except Exception as exc:  # pyarrow reports a corrupt file in several exception types
        raise FileInputError(f"{path}: not a readable Parquet file ({exc})") from None
    schema = handle.schema_arrow
    names = list(schema.names)
    wanted = names if key is None else [c.strip() for c in key.split(",")]
    if not wanted or any(not c for c in wanted):
        raise FileInputError(f"{path}: no column named; give them as file.parquet:a,b,c")
    for column in wanted:
        _check_parquet_column(pa, path, schema, names, column)
    n = int(handle.metadata.num_rows)
    if n < 0 or any(g < 0 for g in groups):
        raise FileInputError(f"{path}: not a readable Parquet file (its footer declares a negative row count)")
    shape = (n,) if len(wanted) == 1 else (n, len(wanted))

    def as_array(batch: Any, first_row: int) -> np.ndarray:
        out = np.empty((batch.num_rows, len(wanted)), dtype=np.float64)
        for j, column in enumerate(wanted):
            # a null becomes NaN: nan_policy decides about it
            out[:, j] = _as_float(pa, path, column, batch.column(column), first_row)
        return out[:, 0] if len(wanted) == 1 else out

    unreadable = f"{path}: not a readable Parquet file"

    def read(start: int, stop: int) -> np.ndarray:
        with _corrupt_as_input_error(unreadable):
            return as_array(handle.read(columns=wanted).slice(start, stop - start), start)

    def blocks(rows: int) -> Iterator[np.ndarray]:
        # batches of at most `rows` rows, decoded one row group at a time: the largest must fit
        check_decoded(f"{path}: a row group of", (max(groups, default=0), len(wanted)),
                      hint="write the file with a smaller row_group_size")
        start = 0
        with _corrupt_as_input_error(unreadable):
            batches = handle.iter_batches(batch_size=rows, columns=wanted)
            for batch in batches:
                block = as_array(batch, start)
                start += batch.num_rows
                yield block

    return Columnar(shape, read, blocks, where=path)


def _check_parquet_column(pa: Any, path: str, schema: Any, names: list[str], column: str) -> None:
    if column not in names:
        raise FileInputError(f"{path}: no column named {column!r}; the file holds "
                             + ", ".join(repr(n) for n in names))
    if names.count(column) > 1:
        raise FileInputError(f"{path}: column name {column!r} appears {names.count(column)} times; dynval "
                             "needs distinct column names (rename the columns when writing the file)")
    kind = schema.field(column).type
    if not (pa.types.is_integer(kind) or pa.types.is_floating(kind) or pa.types.is_boolean(kind)):
        raise FileInputError(f"{path}: column {column!r} holds {kind} values; dynval reads numbers "
                             "(bool, integer or float)")


def _as_float(pa: Any, path: str, column: str, values: Any, first_row: int) -> np.ndarray:
    """A column as float64; an integer float64 cannot hold exactly is refused with its row."""
    if pa.types.is_integer(values.type) and values.type.bit_width > 32:
        import pyarrow.compute as pc

        outside = pc.greater(values, pa.scalar(_EXACT_INTEGER, type=values.type))
        if pa.types.is_signed_integer(values.type):
            outside = pc.or_(outside, pc.less(values, pa.scalar(-_EXACT_INTEGER, type=values.type)))
        row = pc.index(outside, True).as_py()
        if row is not None and row >= 0:
            raise FileInputError(f"{path}: column {column!r}, row {first_row + row} (counted from 0): the integer "
                                 f"{values[row].as_py()} is beyond ±2**53 = {_EXACT_INTEGER}, where float64 no "
                                 "longer holds every integer; store the column as float64 or rescale it")
    return np.asarray(values.cast(pa.float64()).to_numpy(zero_copy_only=False), dtype=np.float64)


def hdf5_dataset(path: str, key: str | None) -> Columnar:
    """The dataset ``key`` of an HDF5 file (or its only dataset), rows along the first axis."""
    _check_regular(path)
    h5py = _needs("h5py", "hdf5", path, "HDF5")
    try:
        handle = h5py.File(path, "r")
    except Exception as exc:  # h5py raises OSError and others for a file that is not HDF5
        raise FileInputError(f"{path}: not a readable HDF5 file ({exc})") from None
    try:
        with _corrupt_as_input_error(f"{path}: not a readable HDF5 file"):
            dataset, name = _hdf5_pick(h5py, handle, path, key)
            _check_hdf5_storage(h5py, dataset, path, name)
            shape = _hdf5_shape(dataset, path, name)
    except Exception:
        handle.close()
        raise
    inner = int(np.prod(shape[1:]))

    def read(start: int, stop: int) -> np.ndarray:
        with _corrupt_as_input_error(f"{path}: dataset {name!r} cannot be read"):
            return np.asarray(dataset[start:stop], dtype=np.float64)

    def blocks(rows: int) -> Iterator[np.ndarray]:
        # unwritten chunks cost no bytes on disk: a block's decoded size is checked too
        check_decoded(f"{path}: dataset {name!r}, a block of", (min(rows, shape[0]), inner),
                      hint="read fewer rows per block (--chunk-rows)")
        for start in range(0, shape[0], rows):
            yield read(start, min(start + rows, shape[0]))

    return Columnar(shape, read, blocks, where=f"{path}: dataset {name!r}")


def _hdf5_pick(h5py: Any, handle: Any, path: str, key: str | None) -> tuple[Any, str]:
    """The dataset named by ``key`` (or the file's only one) and its name inside the file."""
    datasets: list[str] = []
    # visititems follows hard links only: it never opens another file
    handle.visititems(lambda name, obj: datasets.append("/" + name) if isinstance(obj, h5py.Dataset) else None)
    if key is None:
        if len(datasets) != 1:
            listed = ", ".join(datasets) if datasets else "none"
            raise FileInputError(f"{path}: name the dataset as file.h5:/name; the file holds {listed}")
        key = datasets[0]
    name = key if key.startswith("/") else "/" + key
    resolved = _hdf5_resolve(h5py, handle, path, name, 0)
    if resolved is None or not isinstance(handle.get(resolved), h5py.Dataset):
        raise FileInputError(f"{path}: no dataset {name!r}; the file holds "
                             + (", ".join(repr(d) for d in datasets) or "none"))
    return handle[resolved], name


# Soft links that point to soft links: a chain this long is a loop.
_MAX_SOFT_LINKS = 32


def _hdf5_resolve(h5py: Any, handle: Any, path: str, name: str, depth: int) -> str | None:
    """``name`` with its soft links replaced by their targets, refusing any link to another file
    before it is followed (following it would open that file); None when nothing has that name."""
    if depth > _MAX_SOFT_LINKS:
        raise FileInputError(f"{path}: the soft links to {name!r} form a loop")
    resolved = ""
    for part in (p for p in name.split("/") if p):
        current = f"{resolved}/{part}"
        try:
            link = handle.get(current, getlink=True)
        except (KeyError, RuntimeError, ValueError):
            return None
        if link is None:
            return None
        if isinstance(link, h5py.SoftLink):
            target = link.path if link.path.startswith("/") else f"{resolved}/{link.path}"
            followed = _hdf5_resolve(h5py, handle, path, target, depth + 1)
            if followed is None:
                return None
            current = followed
        elif not isinstance(link, h5py.HardLink):
            target = f" to {link.filename}:{link.path}" if isinstance(link, h5py.ExternalLink) else ""
            raise FileInputError(f"{path}: {current!r} is an external link{target}; dynval reads only data "
                                 "stored inside the named file")
        resolved = current
    return resolved or "/"


def _check_hdf5_storage(h5py: Any, dataset: Any, path: str, name: str) -> None:
    """Refuse a dataset whose bytes live outside the file (read before any of its data)."""
    plist = dataset.id.get_create_plist()
    if plist.get_layout() == h5py.h5d.VIRTUAL:
        raise FileInputError(f"{path}: dataset {name!r} is a virtual dataset (its data are read from other "
                             "files); dynval reads only data stored inside the named file")
    if plist.get_external_count() > 0:
        other = plist.get_external(0)[0].decode(errors="replace")
        raise FileInputError(f"{path}: dataset {name!r} keeps its data in an external file ({other!r}); dynval "
                             "reads only data stored inside the named file")
    if dataset.chunks:  # HDF5 decodes a whole chunk to read any of its rows
        check_decoded(f"{path}: dataset {name!r}, a chunk of", tuple(dataset.chunks), dataset.dtype.itemsize,
                      hint="write the file with smaller chunks")


def _hdf5_shape(dataset: Any, path: str, name: str) -> tuple[int, ...]:
    """The dataset's shape, checked: numeric, 1-D to 3-D, with a dataspace."""
    dtype = dataset.dtype
    if dtype.kind not in "biuf":
        raise FileInputError(f"{path}: dataset {name!r} holds {dtype} values; dynval reads numbers "
                             "(bool, integer or float)")
    if dataset.shape is None:  # an HDF5 null dataspace (h5py.Empty)
        raise FileInputError(f"{path}: dataset {name!r} is empty (a null dataspace: no values at all)")
    shape = tuple(int(s) for s in dataset.shape)
    if not 1 <= len(shape) <= 3:
        raise FileInputError(f"{path}: dataset {name!r} has shape {shape}; dynval reads 1-D to 3-D arrays "
                             "(samples along the first axis)")
    return shape
