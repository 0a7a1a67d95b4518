"""Row sources that read a data file a block of rows at a time (contract §7.1).

``open_rows(spec)`` checks a file as :func:`dynval.io._files.read_table` does (regular files only,
no pickles, a header that fits the bytes) and returns a :class:`RowSource` whose ``chunks(rows)``
yields consecutive blocks of rows as float64 arrays. Only the block in hand is in memory:

* ``.npy``, and ``.npz`` members stored without compression (``numpy.savez``): read with ``seek``
  and ``readinto`` at the block's offset, C or Fortran order (a Fortran-ordered block is read
  column by column);
* CSV text: a first pass counts the data rows (its first lines go through the loader's checks up
  to the first data row), then the rows are parsed and checked a block at a time by the loader's
  own code, so errors and their line numbers are those of the whole-file loader;
* Parquet (row groups, in batches) and HDF5 (hyperslabs of rows): ``dynval.io._columnar``;
* compressed ``.npz`` members (``numpy.savez_compressed``): a deflate stream allows no seek to a
  row, so the member is inflated from its start, one block after the other (rows are consecutive in
  C order); a Fortran-ordered member with several columns is read whole by ``read_table`` (within
  its decoded-size limit) and then handed out in blocks.
"""

from __future__ import annotations

import math
import zipfile
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import BinaryIO, cast

import numpy as np

from ._fileopen import PARQUET_SUFFIXES, open_regular
from ._files import (
    _COLUMNAR_SUFFIXES,
    _NPY_MAGIC,
    FileInputError,
    _content_hint,
    _csv_blocks,
    _read_exact,
    _read_npy_header,
    _split_key,
    column_index,
    csv_layout,
    read_table,
    split_column,
)
from ._limits import decoded_bytes

# Rows per block of the command line's streamed validation (about 8 MB per array at m = 7).
DEFAULT_CHUNK_ROWS = 1 << 17


@dataclass
class RowSource:
    """A file's array, read on demand. ``shape`` is the whole array's; ``streamed`` says whether
    blocks come from the file (True) or from an array already in memory (False)."""

    path: str
    shape: tuple[int, ...]
    streamed: bool
    _dtype: np.dtype | None = None
    _offset: int = 0
    _fortran: bool = False
    _data: np.ndarray | None = None
    _csv: bool = False
    _blocks: Callable[[int], Iterator[np.ndarray]] | None = None

    @property
    def n_rows(self) -> int:
        return int(self.shape[0]) if self.shape else 1

    @property
    def nbytes(self) -> int:
        """Bytes of the whole array decoded as float64 (wider types keep their size)."""
        return decoded_bytes(self.shape, 8 if self._dtype is None else self._dtype.itemsize)

    def chunks(self, rows: int = DEFAULT_CHUNK_ROWS) -> Iterator[np.ndarray]:
        """Consecutive blocks of at most ``rows`` rows (the last may be shorter), as float64."""
        if self._data is not None:
            for start in range(0, max(self.n_rows, 1), rows):
                yield np.asarray(self._data[start:start + rows], dtype=np.float64)
            return
        if self._blocks is not None:
            yield from self._blocks(rows)
            return
        if self._csv:
            handle, _ = open_regular(self.path)
            with handle:
                for block, _lines in _csv_blocks(handle, self.path, rows):
                    yield block[:, 0] if len(self.shape) == 1 else block
            return
        assert self._dtype is not None
        inner = math.prod(self.shape[1:])
        handle, _ = open_regular(self.path)
        with handle:
            for start in range(0, self.n_rows, rows):
                count = min(rows, self.n_rows - start)
                yield self._block(handle, start, count, inner)

    def _block(self, handle: BinaryIO, start: int, count: int, inner: int) -> np.ndarray:
        assert self._dtype is not None
        item = self._dtype.itemsize
        if not self._fortran or inner <= 1:
            handle.seek(self._offset + start * inner * item)
            raw = _read_exact(handle, count * inner * item, self.path)
            block = np.frombuffer(raw, dtype=self._dtype).reshape((count, *self.shape[1:]))
        else:
            # Fortran order: each column's rows [start, start + count) are contiguous.
            block = np.empty((count, inner), dtype=self._dtype)
            for j in range(inner):
                handle.seek(self._offset + (j * self.n_rows + start) * item)
                block[:, j] = np.frombuffer(_read_exact(handle, count * item, self.path), dtype=self._dtype)
            block = block.reshape((count, *self.shape[1:]), order="F")
        return np.asarray(block, dtype=np.float64)


def open_rows(spec: str) -> RowSource:
    """The :class:`RowSource` of ``spec`` (``file.npy``, ``file.npz[:key]``, CSV text,
    ``file.parquet[:a,b,c]`` or ``file.h5[:/dataset]``).

    Errors are :class:`~dynval.io._files.FileInputError` with the messages of ``read_table``.
    """
    path, key = _split_key(spec)
    lower = path.lower()
    if lower.endswith(".npy"):
        return _npy_source(path)
    if lower.endswith(".npz"):
        source = _npz_member_source(path, key) or _npz_compressed_source(path, key)
        if source is not None:
            return source
    if lower.endswith((".csv", ".txt", ".tsv")):
        handle, _ = open_regular(path)
        with handle:
            n, width = csv_layout(handle, path)
        return RowSource(path=path, shape=(n,) if width == 1 else (n, width), streamed=True, _csv=True)
    if lower.endswith(_COLUMNAR_SUFFIXES):
        from ._columnar import hdf5_dataset, parquet_table

        table = parquet_table(path, key) if lower.endswith(PARQUET_SUFFIXES) else hdf5_dataset(path, key)
        return RowSource(path=spec, shape=table.shape, streamed=True, _blocks=table.blocks)
    data = read_table(spec).data  # Fortran-ordered compressed members (and refusals): whole, then in blocks
    return RowSource(path=spec, shape=tuple(data.shape), streamed=False, _data=data)


def decoded_size(spec: str) -> int:
    """Bytes the array of ``spec`` takes once decoded as float64, from the file's own layout (the
    .npy header, inside the archive for a .npz member; the HDF5 dataspace; the Parquet footer), not
    from its size on disk, which a compressed or sparse file makes small; CSV text: its size.
    FileInputError as :func:`open_rows`."""
    path, key = _split_key(spec)
    lower = path.lower()
    if lower.endswith(".npz"):
        # a stored member is checked against its bytes; a compressed one only has its header's word
        stored = _npz_member_source(path, key)
        size = _npz_member_decoded_size(path, key) if stored is None else stored.nbytes
        if size is not None:
            return size
    if lower.endswith((".npy", *_COLUMNAR_SUFFIXES)):
        return open_rows(spec).nbytes
    # CSV text: its size (a value takes at least 2 bytes of text, so it decodes to at most 4 times that)
    handle, size = open_regular(path)
    handle.close()
    return size


def _npz_member_decoded_size(path: str, key: str | None) -> int | None:
    """The decoded size of a .npz member from the .npy header inside it (only the header is
    inflated), or None when the file is no archive or has no such member (the reader says so)."""
    handle, _ = open_regular(path)
    with handle:
        try:
            with zipfile.ZipFile(handle) as archive:
                names = [n for n in archive.namelist() if n.endswith(".npy")]
                name = names[0] if key is None and names else f"{key}.npy"
                if name not in archive.namelist():
                    return None
                with archive.open(name) as member:
                    shape, _, dtype = _read_npy_header(member, f"{path}:{name[:-4]}")
        except (zipfile.BadZipFile, OSError, EOFError, ValueError, NotImplementedError, RuntimeError):
            return None
    return decoded_bytes(tuple(max(int(s), 0) for s in shape), dtype.itemsize)


def open_column(spec: str) -> RowSource:
    """The :class:`RowSource` of one column, ``FILE[:COLUMN]`` (a header name or an index counted
    from 0; :func:`dynval.io._files.read_column` has the rules): blocks of shape (rows,)."""
    base, column = split_column(spec)
    source = open_rows(base)
    index = column_index(base, column, source.shape)
    if index is None and len(source.shape) == 1:
        return source

    def blocks(rows: int) -> Iterator[np.ndarray]:
        for block in source.chunks(rows):
            yield np.ascontiguousarray(block.reshape(-1) if index is None else block[:, index])

    return RowSource(path=source.path, shape=(source.n_rows,), streamed=source.streamed, _blocks=blocks)


def _checked_header(handle: BinaryIO, where: str, available: int) -> tuple[tuple[int, ...], bool, np.dtype, int]:
    """(shape, fortran, dtype, data offset) of a .npy stream, checked like read_table's."""
    start = handle.tell()
    shape, fortran, dtype = _read_npy_header(handle, where)
    if dtype.hasobject:
        raise FileInputError(f"{where}: holds pickled Python objects, which dynval refuses to load; "
                             "save a plain numeric array (numpy.save of a float array)")
    if dtype.kind not in "biuf":
        raise FileInputError(f"{where}: holds {dtype} values; dynval reads numbers (bool, integer or float)")
    if any(s < 0 for s in shape):
        raise FileInputError(f"{where}: its header declares an impossible shape {tuple(shape)}")
    offset = handle.tell()
    declared = math.prod(shape) * dtype.itemsize
    if declared > available - (offset - start):
        raise FileInputError(f"{where}: its header declares shape {tuple(shape)} of {dtype} ({declared} bytes), "
                             f"but it holds only {available - (offset - start)} bytes after the header "
                             "(truncated or corrupt)")
    return tuple(int(s) for s in shape), bool(fortran), dtype, offset


def _npy_source(path: str) -> RowSource:
    handle, size = open_regular(path)
    with handle:
        head = handle.read(len(_NPY_MAGIC))
        if not head:
            raise FileInputError(f"{path}: is empty (0 bytes)")
        if head != _NPY_MAGIC:
            raise FileInputError(f"{path}: not a .npy file (no NumPy magic string at its start; "
                                 f"{_content_hint(head + handle.read(1 << 16))})")
        handle.seek(0)
        shape, fortran, dtype, offset = _checked_header(handle, path, size)
    return RowSource(path=path, shape=shape, streamed=True, _dtype=dtype, _offset=offset, _fortran=fortran)


def _npz_member_source(path: str, key: str | None) -> RowSource | None:
    """A source on an uncompressed member, or None when the member is compressed (or the file is
    not a zip archive: read_table then gives its message)."""
    handle, _ = open_regular(path)
    with handle:
        try:
            archive = zipfile.ZipFile(handle)
        except (zipfile.BadZipFile, OSError, EOFError, ValueError, NotImplementedError, RuntimeError):
            return None  # read_table gives the archive's message
        with archive:
            if any(info.header_offset < 0 for info in archive.infolist()):
                return None  # a corrupt central directory
            names = [n for n in archive.namelist() if n.endswith(".npy")]
            name = names[0] if key is None and names else f"{key}.npy"
            if name not in archive.namelist():
                return None  # read_table names the keys there are
            info = archive.getinfo(name)
            if info.compress_type != zipfile.ZIP_STORED:
                return None
            # The member's bytes start after its local header (fixed 30 bytes, name, extra field).
            handle.seek(info.header_offset)
            local = handle.read(30)
            if len(local) < 30 or local[:4] != b"PK\x03\x04":
                return None
            data_start = info.header_offset + 30 + int.from_bytes(local[26:28], "little") \
                + int.from_bytes(local[28:30], "little")
            handle.seek(data_start)
            where = f"{path}:{name[:-4]}"
            shape, fortran, dtype, offset = _checked_header(handle, where, info.file_size)
    return RowSource(path=path, shape=shape, streamed=True, _dtype=dtype, _offset=offset, _fortran=fortran)


def _npz_compressed_source(path: str, key: str | None) -> RowSource | None:
    """A source inflating a compressed member from its start, one block after the other (a
    deflate stream allows no seek), so that only a block is in memory; None when the member is
    Fortran-ordered with several columns (its rows are not consecutive: read whole) or the archive
    cannot be read this way (read_table then gives its message)."""
    opened = _open_member(path, key)
    if opened is None:
        return None
    handle, archive, member, info, where = opened
    with handle, archive, member:
        try:
            shape, fortran, dtype, _ = _checked_header(member, where, info.file_size)
        except FileInputError:
            return None  # read_table gives the message of a whole read
    inner = math.prod(shape[1:])
    if fortran and inner > 1:
        return None
    n_rows = shape[0] if shape else 1

    def blocks(rows: int) -> Iterator[np.ndarray]:
        reopened = _open_member(path, key)
        if reopened is None:
            raise FileInputError(f"{where}: the archive changed while it was read")
        handle, archive, member, _, _ = reopened
        with handle, archive, member:
            _checked_header(member, where, info.file_size)
            for start in range(0, n_rows, rows):
                count = min(rows, n_rows - start)
                try:
                    raw = _read_exact(member, count * inner * dtype.itemsize, where)
                except (zipfile.BadZipFile, zlib.error, EOFError, OSError) as exc:
                    raise FileInputError(f"{where}: not a readable .npz member ({exc})") from None
                block = np.frombuffer(raw, dtype=dtype).reshape((count, *shape[1:]))
                yield np.asarray(block, dtype=np.float64)

    return RowSource(path=path, shape=shape, streamed=True, _blocks=blocks, _dtype=dtype)


def _open_member(path: str, key: str | None) -> tuple[BinaryIO, zipfile.ZipFile, BinaryIO, zipfile.ZipInfo, str] | None:
    """(file, archive, member stream, ZipInfo, name for messages) of a compressed .npz member, or None."""
    handle, _ = open_regular(path)
    try:
        archive = zipfile.ZipFile(handle)
        names = [n for n in archive.namelist() if n.endswith(".npy")]
        name = names[0] if key is None and names else f"{key}.npy"
        if name not in archive.namelist() or archive.getinfo(name).compress_type == zipfile.ZIP_STORED:
            handle.close()
            return None
        info = archive.getinfo(name)
        member = cast(BinaryIO, archive.open(info))
        return handle, archive, member, info, f"{path}: array {name[:-4]!r}"
    except (zipfile.BadZipFile, zlib.error, OSError, EOFError, ValueError, NotImplementedError, RuntimeError):
        handle.close()
        return None
