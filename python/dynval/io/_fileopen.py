"""Opening a data file safely, and the error every file reader raises (contract §7).

Shared by the whole-file readers (:mod:`dynval.io._files`), the columnar formats
(:mod:`dynval.io._columnar`) and the block readers (:mod:`dynval.io._readers`).
"""

from __future__ import annotations

import os
import stat
from typing import BinaryIO, cast

from ..checks._errors import InputError

__all__ = ["FileInputError", "PARQUET_SUFFIXES", "HDF5_SUFFIXES"]

# Parquet and HDF5 (dynval.io._columnar), optional extras
PARQUET_SUFFIXES = (".parquet", ".pq")
HDF5_SUFFIXES = (".h5", ".hdf5", ".hdf")


class FileInputError(InputError):
    """A data file cannot be read as a numeric array (the command line exits with code 1).

    Not one of the contract's language-neutral kinds: only this reader raises it.
    """

    kind = "InvalidFile"


def _describe_mode(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def _not_regular(path: str, mode: int) -> FileInputError:
    return FileInputError(f"{path}: is not a regular file ({_describe_mode(mode)}); "
                          "dynval reads only regular files")


def open_regular(path: str) -> tuple[BinaryIO, int]:
    """Open ``path`` for binary reading if it is a regular file; returns (file, size).

    ``stat`` first, so that a FIFO or a device is refused without opening it; then open without
    blocking (opening a FIFO waits for a writer) and check the opened file again, in case the
    path changed in between.
    """
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        raise FileInputError(f"{path}: no such file") from None
    except OSError as exc:
        raise FileInputError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    if not stat.S_ISREG(mode):
        raise _not_regular(path, mode)
    nonblock = getattr(os, "O_NONBLOCK", 0)
    try:
        fd = os.open(path, os.O_RDONLY | nonblock | getattr(os, "O_BINARY", 0))
    except OSError as exc:
        raise FileInputError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    info = os.fstat(fd)
    if not stat.S_ISREG(info.st_mode):
        os.close(fd)
        raise _not_regular(path, info.st_mode)
    if nonblock:
        os.set_blocking(fd, True)
    return cast(BinaryIO, os.fdopen(fd, "rb")), info.st_size

