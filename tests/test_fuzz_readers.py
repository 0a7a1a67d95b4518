"""Fuzzing the file readers with mutated valid files (contract §7).

Each example takes a valid file (CSV, .npy in C and Fortran order, .npz stored and compressed,
HDF5 contiguous and chunked with compression, Parquet with several row groups), changes a few of
its bytes (flip, overwrite, insert, delete, truncate) and reads it whole (``load_array``) and in
blocks (``open_rows(...).chunks``). The outcome must be an array or a ``dynval.InputError``
(a ``FileInputError`` naming the file): never another exception, never a hang (a timer fails an
example that takes over 20 s; a stuck library call ends the run through ``faulthandler``).

``DYNVAL_FUZZ_EXAMPLES`` sets the examples per file kind (scripts/sanitize.sh runs this file too).
"""

from __future__ import annotations

import contextlib
import faulthandler
import os
import signal
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import dynval
from dynval.io import _readers
from dynval.io._files import load_array
from dynval.io._limits import LIMIT_ENV

EXAMPLES = int(os.environ.get("DYNVAL_FUZZ_EXAMPLES", "40"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, database=None, suppress_health_check=list(HealthCheck))
# A mutated header may declare a large array: the limit keeps every example small and fast.
FUZZ_LIMIT = 4 << 20
EXAMPLE_SECONDS = 20
MAX_BLOCKS = 64


def _seeds() -> dict[str, tuple[str, bytes]]:
    """(suffix and key, bytes) of one valid file of each kind, built in memory."""
    import io
    import tempfile

    rng = np.random.default_rng(4)
    data = np.round(rng.standard_normal((40, 3)), 3)
    seeds: dict[str, tuple[str, bytes]] = {}
    text = "a,b,c\n" + "".join(f"{x},{y},{z}\n" for x, y, z in data)
    seeds["csv"] = (".csv", text.encode())
    for name, array in (("npy", data), ("npy-fortran", np.asfortranarray(data))):
        buf = io.BytesIO()
        np.save(buf, array)
        seeds[name] = (".npy", buf.getvalue())
    for name, save in (("npz", np.savez), ("npz-compressed", np.savez_compressed)):
        buf = io.BytesIO()
        save(buf, tau=data, other=np.arange(5))
        seeds[name] = (".npz:tau", buf.getvalue())
    with tempfile.TemporaryDirectory() as tmp:
        try:
            import h5py

            for name, options in (("hdf5", {}), ("hdf5-chunked", {"chunks": (8, 3), "compression": "gzip"})):
                path = os.path.join(tmp, f"{name}.h5")
                with h5py.File(path, "w") as f:
                    f.create_dataset("tau", data=data, **options)
                with open(path, "rb") as handle:
                    seeds[name] = (".h5:/tau", handle.read())
        except ImportError:
            pass
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq

            path = os.path.join(tmp, "t.parquet")
            pq.write_table(pa.table({c: pa.array(data[:, j]) for j, c in enumerate("abc")}), path,
                           row_group_size=16)
            with open(path, "rb") as handle:
                seeds["parquet"] = (".parquet", handle.read())
        except ImportError:
            pass
    return seeds


SEEDS = _seeds()
KINDS = ["csv", "npy", "npy-fortran", "npz", "npz-compressed", "hdf5", "hdf5-chunked", "parquet"]

EDIT = st.tuples(st.sampled_from(["flip", "set", "insert", "delete", "truncate"]), st.floats(0.0, 1.0),
                 st.integers(0, 255))


def _mutated(raw: bytes, edits) -> bytes:
    out = bytearray(raw)
    for kind, where, value in edits:
        if not out:
            break
        at = min(int(where * len(out)), len(out) - 1)
        if kind == "flip":
            out[at] ^= 1 << (value % 8)
        elif kind == "set":
            out[at] = value
        elif kind == "insert":
            out[at:at] = bytes([value]) * (1 + value % 4)
        elif kind == "delete":
            del out[at:at + 1 + value % 8]
        else:
            del out[at:]
    return bytes(out)


class _Hang(Exception):
    pass


@contextlib.contextmanager
def _time_limit(seconds: int):
    """A Python-level hang raises _Hang; a hang inside a library call ends the process with its
    traceback (faulthandler), so that the run fails either way."""
    def expired(signum, frame):
        raise _Hang(f"no outcome after {seconds} s")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.alarm(seconds)
    faulthandler.dump_traceback_later(3 * seconds, exit=True, file=sys.stderr)
    try:
        yield
    finally:
        faulthandler.cancel_dump_traceback_later()
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def _outcome(read) -> str:
    try:
        result = read()
    except dynval.InputError as exc:
        assert str(exc), "an error without a message"
        return "refused"
    assert isinstance(result, np.ndarray) and result.dtype.kind in "biuf", type(result)
    return "read"


def _streamed(spec: str) -> np.ndarray:
    blocks = []
    for i, block in enumerate(_readers.open_rows(spec).chunks(7)):
        blocks.append(block)
        if i >= MAX_BLOCKS:
            break
    return np.concatenate(blocks) if blocks else np.empty(0)


@pytest.fixture(autouse=True)
def _small_limit(monkeypatch):
    monkeypatch.setenv(LIMIT_ENV, str(FUZZ_LIMIT))


@pytest.mark.skipif(not hasattr(signal, "SIGALRM"), reason="times examples with SIGALRM")
@pytest.mark.parametrize("kind", KINDS)
@FUZZ
@given(edits=st.lists(EDIT, min_size=1, max_size=4))
def test_mutated_files_are_read_or_refused(kind, edits, tmp_path_factory):
    if kind not in SEEDS:
        pytest.skip(f"{kind} needs an optional library")
    suffix, raw = SEEDS[kind]
    ext, _, key = suffix.partition(":")
    path = tmp_path_factory.mktemp("fuzz") / f"f{ext}"
    path.write_bytes(_mutated(raw, edits))
    spec = f"{path}:{key}" if key else str(path)
    with _time_limit(EXAMPLE_SECONDS):
        _outcome(lambda: load_array(spec))
        _outcome(lambda: _streamed(spec))


@pytest.mark.parametrize("kind", KINDS)
def test_the_unmutated_seeds_are_read(kind, tmp_path):
    if kind not in SEEDS:
        pytest.skip(f"{kind} needs an optional library")
    suffix, raw = SEEDS[kind]
    ext, _, key = suffix.partition(":")
    path = tmp_path / f"f{ext}"
    path.write_bytes(raw)
    spec = f"{path}:{key}" if key else str(path)
    whole = load_array(spec)
    assert whole.shape == (40, 3)
    np.testing.assert_array_equal(_streamed(spec), whole)
