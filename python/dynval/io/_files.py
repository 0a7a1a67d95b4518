"""Reading the command line's data files: ``.npy``, ``.npz`` and CSV text (contract §7).

Files come from other programs and from users, so reading is bounded and refuses surprises before
allocating memory: only regular files are opened (a FIFO blocks forever, ``/dev/zero`` never
ends), a ``.npy`` header is checked against the bytes that follow it, and CSV text is read line
by line with a length limit and refused at the first NUL byte. No array read whole may decode to
more than the limit of :mod:`dynval.io._limits` (1 GiB, ``DYNVAL_MAX_DECODED_BYTES``), computed from
the ``.npy`` header itself (inside the archive for a ``.npz`` member), never from a size on disk. Every refusal is a
:class:`FileInputError` whose message starts with the path; positions are 1-based lines and
columns, as an editor shows them.
"""

from __future__ import annotations

import array
import csv
import math
import os
import stat
import struct
import zipfile
import zlib
from dataclasses import dataclass

import numpy as np

from ._fileopen import HDF5_SUFFIXES, PARQUET_SUFFIXES, FileInputError, _not_regular, open_regular
from ._limits import check_decoded

__all__ = ["FileInputError", "Table", "load_array", "read_table", "MAX_LINE_BYTES", "SNIFF_BYTES"]

# Longest CSV line (bytes, without its end of line): about 40,000 columns of full-precision
# numbers. It bounds the memory one line can take, e.g. a hole in a sparse file with no newline.
MAX_LINE_BYTES = 1 << 20
# The first block of a CSV file is searched for NUL bytes: text never holds one, binary data and
# the holes of sparse files are full of them.
SNIFF_BYTES = 1 << 16
# Longest value quoted in a message.
_SHOWN_CHARS = 40

_NPY_MAGIC = b"\x93NUMPY"
_ZIP_MAGICS = (b"PK\x03\x04", b"PK\x05\x06")  # an archive with members, an empty archive
_DELIMITERS = ("\t", ";", ",")
_COLUMNAR_SUFFIXES = PARQUET_SUFFIXES + HDF5_SUFFIXES


@dataclass(frozen=True)
class Table:
    """An array read from a file, with the 1-based file line of each row (CSV only, else None)."""

    data: np.ndarray
    lines: np.ndarray | None = None


# --------------------------------------------------------------------------- entry points


def load_array(spec: str) -> np.ndarray:
    """Load one numeric array from ``.npy``, ``.npz`` (``file.npz:key``, else the first array),
    CSV text (``.csv``, ``.tsv``, ``.txt``), Parquet (``file.parquet[:a,b,c]``, extra
    ``dynval[parquet]``) or HDF5 (``file.h5[:/dataset]``, extra ``dynval[hdf5]``); contract §7 has
    the rules and limits.

    Pickled objects are refused. Raises :class:`FileInputError` with a message naming the file.

    Examples
    --------
    >>> import numpy as np, tempfile, os
    >>> path = os.path.join(tempfile.mkdtemp(), "tau.csv")
    >>> with open(path, "w") as handle:
    ...     _ = handle.write("j1,j2\\n1,2\\n3,4\\n")
    >>> load_array(path).tolist()
    [[1.0, 2.0], [3.0, 4.0]]
    """
    return read_table(spec).data


def read_table(spec: str) -> Table:
    """:func:`load_array`, also returning the file line of each row of a CSV file."""
    path, key = _split_key(spec)
    lower = path.lower()
    if lower.endswith((".pkl", ".pickle")):
        raise FileInputError(f"{path}: pickle files are refused (they can run arbitrary code); "
                             "use .npy, .npz or .csv")
    if lower.endswith(_COLUMNAR_SUFFIXES):
        from ._columnar import hdf5_dataset, parquet_table

        source = parquet_table(path, key) if lower.endswith(PARQUET_SUFFIXES) else hdf5_dataset(path, key)
        try:
            return Table(source.all())
        except MemoryError:
            raise FileInputError(f"{path}: not enough memory to hold its data") from None
    if not lower.endswith((".npy", ".npz", ".csv", ".txt", ".tsv")):
        if not os.path.exists(path):
            raise FileInputError(f"{path}: no such file")
        mode = os.stat(path).st_mode
        if not stat.S_ISREG(mode):  # a directory is not a file of the wrong type
            raise _not_regular(path, mode)
        raise FileInputError(f"{path}: unsupported file type; use .npy, .npz (file.npz:key), .csv, "
                             ".parquet (file.parquet:a,b,c) or .h5 (file.h5:/dataset)")
    handle, size = open_regular(path)
    with handle:
        try:
            if lower.endswith(".npy"):
                return Table(_read_npy_file(handle, path, size))
            if lower.endswith(".npz"):
                return Table(_read_npz(handle, path, key))
            return _read_csv(handle, path)
        except OSError as exc:
            raise FileInputError(f"{path}: cannot be read ({exc.strerror or exc})") from None
        except MemoryError:
            raise FileInputError(f"{path}: not enough memory to hold its data") from None


def _split_key(spec: str):
    """``file.npz:key``, ``file.parquet:a,b``, ``file.h5:/group/set`` → (file, key); else (spec, None)."""
    head, sep, tail = spec.rpartition(":")
    if sep and head.lower().endswith((".npz", *_COLUMNAR_SUFFIXES)) and tail and not os.path.exists(spec):
        return head, tail
    return spec, None


def file_path(spec: str) -> str:
    """The file of a spec (``file.npz:key`` → ``file.npz``)."""
    return _split_key(spec)[0]


# --------------------------------------------------------------------------- one column


def split_column(spec: str) -> tuple[str, str | None]:
    """``FILE[:COLUMN]`` → (the spec :func:`read_table` reads, the column or None).

    A key that :func:`read_table` takes itself (``file.npz:key``, ``file.parquet:t``,
    ``file.h5:/t``) stays in the spec; what follows the last ``:`` of a spec naming no existing
    file is a column (``log.csv:t``, ``log.csv:0``, ``arrays.npz:log:2``)."""
    if ":" not in spec or os.path.exists(_split_key(spec)[0]):
        return spec, None
    base, _, column = spec.rpartition(":")
    return base, column


def csv_header(path: str) -> list[str] | None:
    """The names of a CSV file's header line (None without a header: §7's rule, a first line
    without any number)."""
    handle, _ = open_regular(path)
    with handle:
        for number, line in _lines(handle, path):
            stripped = line.strip()
            if not stripped or stripped.startswith("#"):
                continue
            cells = _cells(stripped, _delimiter(stripped), path, number)
            return None if any(_is_number(c) for c in cells) else cells
    return None


def column_index(spec: str, column: str | None, shape: tuple[int, ...]) -> int | None:
    """The column ``column`` (a header name, or an index counted from 0) of an array of ``shape``
    read from ``spec``; None for an array that is one column already. FileInputError naming the
    file and the column otherwise."""
    path = file_path(spec)
    if len(shape) > 2:
        raise FileInputError(f"{spec}: holds an array of shape {tuple(shape)}; one column is needed")
    if not shape:
        raise FileInputError(f"{spec}: holds a single number (an array of shape ()); one column is needed")
    width = 1 if len(shape) == 1 else shape[1]
    if column is None:
        if width == 1:
            return None
        raise FileInputError(f"{spec}: holds {width} columns (shape {tuple(shape)}); name one as {spec}:COLUMN "
                             "(a header name, or an index counted from 0)")
    text = column.strip()
    if text.lstrip("+-").isdigit():
        index = int(text)
        if not 0 <= index < width:
            raise FileInputError(f"{spec}: no column {index}; it holds {width} column{'s' if width > 1 else ''} "
                                 f"(indices count from 0: 0 to {width - 1})")
        return None if len(shape) == 1 else index
    names = csv_header(path) if path.lower().endswith((".csv", ".tsv", ".txt")) else None
    if names is None:
        raise FileInputError(f"{spec}: no column named {text!r}: its columns have no names (a CSV header "
                             f"line names them); give an index from 0 to {width - 1}")
    if text not in names:
        raise FileInputError(f"{spec}: no column named {text!r}; the file holds "
                             + ", ".join(repr(n) for n in names))
    return None if len(shape) == 1 else names.index(text)


def read_column(spec: str) -> tuple[Table, int]:
    """One column of a file, ``FILE[:COLUMN]`` (:func:`split_column`, :func:`column_index`): the
    (N,) array with the file line of each row (CSV only), and the column's index in the file."""
    base, column = split_column(spec)
    table = read_table(base)
    index = column_index(base, column, tuple(table.data.shape))
    data = table.data if index is None else table.data[:, index]
    return Table(np.ascontiguousarray(data.reshape(-1)), table.lines), index or 0


# --------------------------------------------------------------------------- opening


def _content_hint(head: bytes) -> str:
    """What the first bytes of a file look like, for a message about the wrong format."""
    if head.startswith(_NPY_MAGIC):
        return "it is a .npy file"
    if head.startswith(_ZIP_MAGICS):
        return "it is a ZIP archive (.npz)"
    if b"\x00" not in head:
        try:
            head.decode("utf-8")
            return "it holds text; name a CSV file .csv"
        except UnicodeDecodeError as exc:
            if exc.start >= len(head) - 3:  # a character cut by the end of the block
                return "it holds text; name a CSV file .csv"
    return "it holds other binary data"


def _binary_hint(head: bytes) -> str:
    """For a CSV that is binary: say so when it is in fact one of the binary formats."""
    hint = _content_hint(head)
    return f"; {hint}" if hint.startswith("it is") else ""


# --------------------------------------------------------------------------- .npy and .npz


def physical_memory() -> int | None:
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, OSError, ValueError):
        return None


def _read_npy_header(handle, where: str):
    """Parse a .npy header without executing anything; returns (shape, fortran_order, dtype)."""
    from numpy.lib import format as npy_format

    try:
        version = npy_format.read_magic(handle)
        if version == (1, 0):
            return npy_format.read_array_header_1_0(handle)
        return npy_format.read_array_header_2_0(handle)
    except Exception as exc:  # numpy parses hostile bytes with ast and tokenize: any error can come out
        raise FileInputError(f"{where}: not a readable .npy header ({type(exc).__name__}: {exc})") from None


def _read_exact(handle, n_bytes: int, where: str) -> bytearray:
    """Read exactly ``n_bytes`` into one buffer (file objects may return less per call)."""
    buf = bytearray(n_bytes)
    view = memoryview(buf)
    done = 0
    while done < n_bytes:
        got = handle.readinto(view[done:])
        if not got:
            raise FileInputError(f"{where}: ends after {done} of the {n_bytes} bytes its header declares")
        done += got
    return buf


def _read_npy(handle, where: str, size: int, streamable: bool = True) -> np.ndarray:
    """Read one .npy stream of ``size`` bytes (a file, or a member of a .npz archive).

    The shape in the header is checked against the bytes that follow it, the decoded-size limit
    and the machine's memory before anything is allocated or decompressed: a header can declare
    any shape, and an archive any size. ``streamable``: whether the streamed reader reads it in
    blocks even when Fortran-ordered (a compressed member must be inflated from its start).
    """
    start = handle.tell()
    shape, fortran, dtype = _read_npy_header(handle, where)
    if dtype.hasobject:
        raise FileInputError(f"{where}: holds pickled Python objects, which dynval refuses to load; "
                             "save a plain numeric array (numpy.save of a float array)")
    if any(s < 0 for s in shape):
        raise FileInputError(f"{where}: its header declares an impossible shape {tuple(shape)}")
    count = math.prod(shape)
    declared = count * dtype.itemsize
    available = size - (handle.tell() - start)
    if declared > available:
        raise FileInputError(f"{where}: its header declares shape {tuple(shape)} of {dtype} ({declared} bytes), "
                             f"but it holds only {available} bytes after the header (truncated or corrupt)")
    rows_scattered = not streamable and fortran and math.prod(shape[1:]) > 1
    check_decoded(where, tuple(shape), dtype.itemsize, hint="save it in C order or without compression "
                  "(numpy.savez), then read it in blocks with dynval validate --stream" if rows_scattered else None)
    memory = physical_memory()
    if memory is not None and declared > memory:
        raise FileInputError(f"{where}: shape {tuple(shape)} of {dtype} needs {declared} bytes, more than this "
                             f"machine's memory ({memory} bytes)")
    data = np.frombuffer(_read_exact(handle, declared, where), dtype=dtype, count=count)
    return data.reshape(shape, order="F" if fortran else "C")


def _read_npy_file(handle, path: str, size: int) -> np.ndarray:
    head = handle.read(len(_NPY_MAGIC))
    if not head:
        raise FileInputError(f"{path}: is empty (0 bytes)")
    if head != _NPY_MAGIC:
        raise FileInputError(f"{path}: not a .npy file (no NumPy magic string at its start; "
                             f"{_content_hint(head + handle.read(SNIFF_BYTES))})")
    handle.seek(0)
    return _read_npy(handle, path, size)


def _read_npz(handle, path: str, key: str | None) -> np.ndarray:
    head = handle.read(SNIFF_BYTES)
    if not head:
        raise FileInputError(f"{path}: is empty (0 bytes)")
    if not head.startswith(_ZIP_MAGICS):
        raise FileInputError(f"{path}: not a .npz archive (no ZIP signature at its start; {_content_hint(head)})")
    handle.seek(0)
    try:
        with zipfile.ZipFile(handle) as archive:
            members = {info.filename[:-4] if info.filename.endswith(".npy") else info.filename: info
                       for info in archive.infolist() if not info.is_dir()}
            if not members:
                raise FileInputError(f"{path}: the archive holds no array")
            if key is None:
                key = next(iter(members))
            elif key not in members:
                raise FileInputError(f"{path}: no array named {key!r}; the archive holds "
                                     + ", ".join(repr(n) for n in members))
            info = members[key]
            # A compressed member's size in the archive is the archive's word: the limit is checked
            # on the shape its own .npy header declares, before anything past the header is inflated.
            with archive.open(info) as member:
                return _read_npy(member, f"{path}: array {key!r}", info.file_size,
                                 streamable=info.compress_type == zipfile.ZIP_STORED)
    except FileInputError:
        raise
    except (zipfile.BadZipFile, zlib.error, EOFError, NotImplementedError, RuntimeError, ValueError,
            struct.error) as exc:
        # A corrupt or hostile archive: zipfile reports it in many ways.
        raise FileInputError(f"{path}: not a readable .npz archive ({exc})") from None


# --------------------------------------------------------------------------- CSV


def _shown(text: str) -> str:
    """``repr`` of a value for a message, cut to a readable length."""
    return repr(text if len(text) <= _SHOWN_CHARS else text[:_SHOWN_CHARS] + "...")


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _lines(handle, path: str):
    """Yield ``(line_number, text)`` for every line, bounded in length and free of NUL bytes.

    Lines are read as bytes and decoded one by one, so that a decoding error names its line.
    """
    head = handle.read(SNIFF_BYTES)
    if b"\x00" in head:
        raise FileInputError(f"{path}: holds binary data (a NUL byte in its first {SNIFF_BYTES} bytes), "
                             f"not CSV text{_binary_hint(head)}")
    handle.seek(0)
    number = 0
    while True:
        number += 1
        raw = handle.readline(MAX_LINE_BYTES + 2)
        if not raw:
            return
        raw = raw.rstrip(b"\r\n") if raw.endswith(b"\n") else raw
        if len(raw) > MAX_LINE_BYTES:
            raise FileInputError(f"{path}: line {number} is longer than {MAX_LINE_BYTES} bytes "
                                 "(the limit of a CSV line)")
        if b"\x00" in raw:
            raise FileInputError(f"{path}: line {number} holds a NUL byte: binary data, not CSV text")
        if number == 1 and raw.startswith(b"\xef\xbb\xbf"):
            raw = raw[3:]  # a UTF-8 byte-order mark
        try:
            yield number, raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise FileInputError(f"{path}: line {number} is not UTF-8 text ({exc.reason} at byte "
                                 f"{exc.start + 1} of the line)") from None


def _delimiter(line: str):
    """The first of tab, ';', ',' present in the line; None means runs of whitespace."""
    return next((d for d in _DELIMITERS if d in line), None)


def _cells(line: str, delimiter, path: str, number: int) -> list[str]:
    if delimiter is None:
        return line.split()
    if '"' in line:
        # Only headers quote their names; the csv module handles the quotes.
        try:
            cells = next(csv.reader([line], delimiter=delimiter, skipinitialspace=True))
        except csv.Error as exc:
            raise FileInputError(f"{path}: line {number}: not valid CSV ({exc})") from None
    else:
        cells = line.split(delimiter)
    cells = [c.strip() for c in cells]
    while cells and cells[-1] == "":  # a delimiter at the end of the line
        cells.pop()
    if not cells:
        raise FileInputError(f"{path}: line {number} holds delimiters but no value")
    return cells


def _numbers(cells):
    """The cells as floats, or None when one of them is not a number."""
    try:
        return [float(c) for c in cells]
    except ValueError:
        return None


def _header_or_error(cells, path: str, number: int, header_allowed: bool) -> None:
    """A line that is not all numbers: accept it as the header (no number at all), else refuse.

    A line with some numbers is data, so a bad value in the first data line is reported instead
    of silently turning the line into a header.
    """
    numeric = [_is_number(c) for c in cells]
    if header_allowed and not any(numeric):
        return
    column = numeric.index(False)
    bad = cells[column]
    if bad == "":
        raise FileInputError(f"{path}: line {number}, column {column + 1}: empty value")
    rule = " (a header line must hold no number, a data line only numbers)" if header_allowed else ""
    raise FileInputError(f"{path}: line {number}, column {column + 1}: {_shown(bad)} is not a number{rule}")


def _csv_blocks(handle, path: str, rows: int):
    """Yield ``(values, lines)`` blocks of at most ``rows`` data rows of a CSV file, checked by the
    rules of contract §7 in file order: values (k, width) float64, lines (k,) the 1-based file line
    of each row. The whole-file loader and the streamed reader both use it, so their checks and
    messages are one."""
    values = array.array("d")
    lines = array.array("q")
    delimiter = width = first = None  # first: the header line, then the first data line
    for number, line in _lines(handle, path):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        if first is None:
            delimiter = _delimiter(stripped)
        cells = _cells(stripped, delimiter, path, number)
        numbers = _numbers(cells)
        if numbers is None:
            _header_or_error(cells, path, number, header_allowed=first is None)
            first = number
            continue
        if width is None:
            width, first = len(numbers), number
        elif len(numbers) != width:
            raise FileInputError(f"{path}: line {number} has {len(numbers)} values, line {first} has {width}")
        values.extend(numbers)
        lines.append(number)
        if len(lines) == rows:
            yield np.frombuffer(values, dtype=np.float64).reshape(len(lines), width).copy(), \
                np.frombuffer(lines, dtype=np.int64).copy()
            values, lines = array.array("d"), array.array("q")
    if first is None or width is None:
        raise FileInputError(f"{path}: no data rows" if first is None else f"{path}: no data rows after the header")
    if lines:
        yield np.frombuffer(values, dtype=np.float64).reshape(len(lines), width), np.frombuffer(lines, dtype=np.int64)


def _read_csv(handle, path: str) -> Table:
    blocks = list(_csv_blocks(handle, path, rows=-1))  # -1: one block, the whole file
    data, lines = blocks[0] if len(blocks) == 1 else (np.concatenate([b[0] for b in blocks]),
                                                      np.concatenate([b[1] for b in blocks]))
    return Table(data[:, 0] if data.shape[1] == 1 else data, lines)


def csv_layout(handle, path: str) -> tuple[int, int]:
    """(data rows, values per row) of a CSV file, for a reader that streams it: the first lines
    go through :func:`_csv_blocks` up to the first data row; the others are only counted (every
    line that is neither blank nor a comment is a data row; the streaming pass checks them)."""
    width = first_line = None
    for block, lines in _csv_blocks(handle, path, rows=1):
        width, first_line = block.shape[1], int(lines[0])
        break
    assert width is not None and first_line is not None  # _csv_blocks raises when there is no data row
    handle.seek(0)
    count = 0
    for number, line in _lines(handle, path):
        if number < first_line:
            continue
        stripped = line.strip()
        if stripped and not stripped.startswith("#"):
            count += 1
    return count, width
