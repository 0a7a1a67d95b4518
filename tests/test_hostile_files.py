"""Hostile data files (contract §7): HDF5 data outside the named file, small files that decode to
gigabytes, Parquet values float64 cannot hold, and the command line's failures of standard output
and of Ctrl-C at start-up. Each is refused with a message naming the file, never an internal error."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import zipfile

import numpy as np
import pytest

from dynval import cli
from dynval.io import _readers
from dynval.io._files import FileInputError, load_array
from dynval.io._limits import DEFAULT_MAX_DECODED_BYTES, LIMIT_ENV
from peak_memory import PEAK_LAUNCHER

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LINUX = os.path.exists("/proc/self/status")


def _need(module):
    """The optional library; in CI (scripts/test.sh sets CI) a missing one fails instead of skipping."""
    if os.environ.get("CI"):
        import importlib

        return importlib.import_module(module)
    return pytest.importorskip(module)


def _env(**extra):
    path = os.pathsep.join([os.path.join(ROOT, "python")]
                           + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])
    return {**os.environ, "PYTHONPATH": path, "OMP_NUM_THREADS": "1", **extra}


PEAK_LIMIT = 500 * 2**20


def _validate_with_peak(spec, *extra, timeout=120):
    """(exit code, stderr, peak RSS in bytes) of `dynval validate SPEC SPEC --n-params 1` in a child."""
    proc = subprocess.run([sys.executable, "-c", PEAK_LAUNCHER, "validate", str(spec), str(spec), "--n-params",
                           "1", "--no-progress", *extra], capture_output=True, text=True, env=_env(),
                          timeout=timeout)
    peak = int(proc.stderr.split("VmHWM ")[-1].split()[0]) * 1024
    return proc.returncode, proc.stderr, peak


def _refused(spec, *needles):
    with pytest.raises(FileInputError) as info:
        load_array(str(spec))
    for needle in needles:
        assert needle in str(info.value), str(info.value)
    return str(info.value)


# --------------------------------------------------------------------------- HDF5: only the named file


def test_hdf5_external_raw_storage_is_refused_before_reading(tmp_path, capsys):
    h5py = _need("h5py")
    secret = tmp_path / "secret.txt"
    secret.write_bytes(b"root:x:0:0:root:/root:/bin/bash\n" * 8)
    path = tmp_path / "ext.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("d", shape=(64,), dtype="u1", external=[(str(secret), 0, 64)])
    _refused(path, f"{path}: dataset '/d' keeps its data in an external file", "secret.txt")
    assert cli.main(["validate", str(path), str(path), "--n-params", "1"]) == 1
    assert "external file" in capsys.readouterr().err


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_hdf5_external_storage_on_a_fifo_does_not_block(tmp_path):
    h5py = _need("h5py")
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    path = tmp_path / "fifo.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("d", shape=(64,), dtype="u1", external=[(str(fifo), 0, 64)])
    proc = subprocess.run([sys.executable, "-m", "dynval", "validate", str(path), str(path), "--n-params", "1"],
                          capture_output=True, text=True, env=_env(), timeout=60)
    assert proc.returncode == 1 and "external file" in proc.stderr, proc.stderr


def test_hdf5_virtual_datasets_are_refused(tmp_path):
    h5py = _need("h5py")
    with h5py.File(tmp_path / "source.h5", "w") as f:
        f["s"] = np.arange(100.0)
    path = tmp_path / "virtual.h5"
    with h5py.File(path, "w") as f:
        layout = h5py.VirtualLayout(shape=(100,), dtype="f8")
        layout[:] = h5py.VirtualSource(str(tmp_path / "source.h5"), "s", shape=(100,))
        f.create_virtual_dataset("v", layout)
    _refused(path, "dataset '/v' is a virtual dataset")
    with pytest.raises(FileInputError, match="virtual dataset"):
        _readers.open_rows(str(path))


def test_hdf5_external_links_are_refused_soft_links_inside_are_followed(tmp_path):
    h5py = _need("h5py")
    with h5py.File(tmp_path / "other.h5", "w") as f:
        f["s"] = np.arange(10.0)
    path = tmp_path / "links.h5"
    with h5py.File(path, "w") as f:
        f["data/tau"] = np.arange(6.0)
        f["ext"] = h5py.ExternalLink(str(tmp_path / "other.h5"), "/s")
        f["group"] = h5py.ExternalLink(str(tmp_path / "other.h5"), "/")
        f["alias"] = h5py.SoftLink("/data/tau")
        f["data/relative"] = h5py.SoftLink("tau")
        f["via"] = h5py.SoftLink("/ext")
    _refused(f"{path}:/ext", "'/ext' is an external link to", "other.h5:/s")
    _refused(f"{path}:/group/s", "'/group' is an external link")
    _refused(f"{path}:/via", "'/ext' is an external link")
    np.testing.assert_array_equal(load_array(f"{path}:/alias"), np.arange(6.0))
    np.testing.assert_array_equal(load_array(f"{path}:/data/relative"), np.arange(6.0))


def test_an_empty_hdf5_dataset_is_an_input_error(tmp_path, capsys):
    h5py = _need("h5py")
    path = tmp_path / "empty.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("d", data=h5py.Empty("f8"))
    _refused(path, "dataset '/d' is empty")
    assert cli.main(["validate", str(path), str(path), "--n-params", "1"]) == 1
    assert "internal error" not in capsys.readouterr().err


# --------------------------------------------------------------------------- decoded size


def _compressed_zeros_npz(path, n):
    """A .npz holding n float64 zeros, deflated (about 4 KB of file per MB of array)."""
    header = {"descr": "<f8", "fortran_order": False, "shape": (n,)}
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=1) as archive, \
            archive.open("a.npy", "w", force_zip64=True) as member:
        np.lib.format.write_array_header_1_0(member, header)
        block = bytes(8 << 20)
        for start in range(0, n * 8, len(block)):
            member.write(block[:min(len(block), n * 8 - start)])


def test_the_limit_is_a_gibibyte_and_is_read_from_the_environment(tmp_path, monkeypatch):
    assert DEFAULT_MAX_DECODED_BYTES == 2**30
    np.save(tmp_path / "a.npy", np.zeros((100, 3)))
    monkeypatch.setenv(LIMIT_ENV, "2399")
    message = _refused(tmp_path / "a.npy", "shape (100, 3) decodes to 2400 bytes as float64",
                       "limit of 2399 bytes", f"{LIMIT_ENV}=BYTES", "--stream")
    assert message.startswith(f"{tmp_path / 'a.npy'}: ")
    monkeypatch.setenv(LIMIT_ENV, "2400")
    assert load_array(str(tmp_path / "a.npy")).shape == (100, 3)
    monkeypatch.setenv(LIMIT_ENV, "lots")
    _refused(tmp_path / "a.npy", f"{LIMIT_ENV}='lots': expected a positive integer number of bytes")


def test_a_compressed_npz_member_is_limited_by_its_own_header_not_the_archive(tmp_path, monkeypatch):
    path = tmp_path / "zeros.npz"
    np.savez_compressed(path, a=np.zeros(10_000))
    assert os.path.getsize(path) < 2_000
    monkeypatch.setenv(LIMIT_ENV, "50000")
    _refused(path, "array 'a': shape (10000,) decodes to 80000 bytes", "--stream")


def test_a_compressed_npz_member_streams_in_blocks_beyond_the_limit(tmp_path, monkeypatch):
    data = np.arange(3000.0).reshape(1000, 3)
    np.savez_compressed(tmp_path / "c.npz", tau=data, f=np.asfortranarray(data))
    monkeypatch.setenv(LIMIT_ENV, str(data.nbytes // 2))
    _refused(f"{tmp_path / 'c.npz'}:tau", "decodes to 24000 bytes", "--stream")
    source = _readers.open_rows(f"{tmp_path / 'c.npz'}:tau")
    assert source.streamed
    np.testing.assert_array_equal(np.concatenate(list(source.chunks(128))), data)
    _refused(f"{tmp_path / 'c.npz'}:f", "save it in C order or without compression")
    with pytest.raises(FileInputError, match="save it in C order"):
        _readers.open_rows(f"{tmp_path / 'c.npz'}:f")


@pytest.mark.slow
@pytest.mark.skipif(not LINUX, reason="reads VmHWM from /proc (Linux)")
def test_a_compressed_npz_bomb_is_refused_in_bounded_memory(tmp_path):
    path = tmp_path / "bomb.npz"
    _compressed_zeros_npz(path, 150_000_000)  # 1.2 GB of zeros in about 5 MB
    assert os.path.getsize(path) < 8 * 2**20
    code, err, peak = _validate_with_peak(path)
    assert code == 1 and "decodes to 1200000000 bytes" in err and "Traceback" not in err, err
    assert peak < PEAK_LIMIT, f"peak RSS {peak / 1e6:.0f} MB"


@pytest.mark.slow
@pytest.mark.skipif(not LINUX, reason="reads VmHWM from /proc (Linux)")
def test_an_hdf5_dataset_of_unwritten_chunks_is_refused_in_bounded_memory(tmp_path):
    h5py = _need("h5py")
    path = tmp_path / "bomb.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("d", shape=(50_000_000, 3), dtype="f8", chunks=(65_536, 3))  # 1.2 GB, no chunk written
    assert os.path.getsize(path) < 10_000
    code, err, peak = _validate_with_peak(path)
    assert code == 1 and "dataset '/d': shape (50000000, 3) decodes to 1200000000 bytes" in err, err
    assert peak < PEAK_LIMIT, f"peak RSS {peak / 1e6:.0f} MB"


@pytest.mark.slow
@pytest.mark.skipif(not LINUX, reason="reads VmHWM from /proc (Linux)")
def test_a_parquet_file_of_repeated_values_is_refused_in_bounded_memory(tmp_path):
    pa = _need("pyarrow")
    pq = _need("pyarrow.parquet")
    path = tmp_path / "bomb.parquet"
    pq.write_table(pa.table({"a": pa.array(np.zeros(140_000_000, dtype=np.int8))}), path,
                   row_group_size=140_000_000)  # 1.12 GB as float64
    assert os.path.getsize(path) < 3 * 2**20
    code, err, peak = _validate_with_peak(path)
    assert code == 1 and "shape (140000000,) decodes to 1120000000 bytes" in err, err
    assert peak < PEAK_LIMIT, f"peak RSS {peak / 1e6:.0f} MB"


def test_a_streamed_parquet_row_group_is_limited_too(tmp_path, monkeypatch):
    pa = _need("pyarrow")
    pq = _need("pyarrow.parquet")
    table = pa.table({"a": pa.array(np.zeros(10_000)), "b": pa.array(np.ones(10_000))})
    pq.write_table(table, tmp_path / "one.parquet", row_group_size=10_000)
    pq.write_table(table, tmp_path / "many.parquet", row_group_size=1_000)
    monkeypatch.setenv(LIMIT_ENV, str(8 * 2 * 5_000))
    with pytest.raises(FileInputError, match=r"one.parquet: a row group of: shape \(10000, 2\).*row_group_size"):
        next(_readers.open_rows(str(tmp_path / "one.parquet")).chunks(100))
    assert sum(b.shape[0] for b in _readers.open_rows(str(tmp_path / "many.parquet")).chunks(100)) == 10_000


def test_a_streamed_hdf5_block_is_limited_too(tmp_path, monkeypatch):
    h5py = _need("h5py")
    path = tmp_path / "wide.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("d", shape=(1000, 50), dtype="f8", chunks=(100, 50))
    monkeypatch.setenv(LIMIT_ENV, str(8 * 50 * 100))
    assert sum(b.shape[0] for b in _readers.open_rows(str(path)).chunks(100)) == 1000
    with pytest.raises(FileInputError, match=r"a block of: shape \(101, 50\).*--chunk-rows"):
        next(_readers.open_rows(str(path)).chunks(101))


def test_an_hdf5_chunk_larger_than_the_limit_is_refused(tmp_path, monkeypatch):
    # a chunk may be far larger than the data (maxshape): HDF5 inflates it whole to read one row
    h5py = _need("h5py")
    path = tmp_path / "chunk.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("d", data=np.ones((10, 3)), maxshape=(None, 3), chunks=(100_000, 3), compression="gzip")
    monkeypatch.setenv(LIMIT_ENV, str(1 << 20))
    _refused(path, "dataset '/d', a chunk of: shape (100000, 3) decodes to 2400000 bytes", "smaller chunks")
    monkeypatch.setenv(LIMIT_ENV, str(3 << 20))
    np.testing.assert_array_equal(load_array(str(path)), np.ones((10, 3)))


def test_automatic_streaming_looks_at_the_decoded_size_not_the_size_on_disk(tmp_path, monkeypatch, capsys):
    rng = np.random.default_rng(3)
    meas = np.round(rng.standard_normal((20_000, 2)), 1)  # compresses well
    np.savez_compressed(tmp_path / "meas.npz", tau=meas)
    np.savez_compressed(tmp_path / "pred.npz", tau=meas + 0.1)
    decoded = 2 * meas.nbytes
    assert 4 * os.path.getsize(tmp_path / "meas.npz") < meas.nbytes
    assert _readers.decoded_size(str(tmp_path / "meas.npz")) == meas.nbytes
    argv = ["validate", str(tmp_path / "meas.npz"), str(tmp_path / "pred.npz"), "--n-params", "2"]
    monkeypatch.setattr(cli, "physical_memory", lambda: 4 * decoded - 4096)
    assert cli.main(argv) == 0
    assert "Streamed from the files in blocks" in capsys.readouterr().out
    monkeypatch.setattr(cli, "physical_memory", lambda: 4 * decoded + 4096)
    assert cli.main(argv) == 0
    assert "Streamed from the files" not in capsys.readouterr().out


# --------------------------------------------------------------------------- Parquet values


def test_parquet_integers_beyond_2_53_are_refused_with_column_and_row(tmp_path, capsys):
    pa = _need("pyarrow")
    pq = _need("pyarrow.parquet")
    path = tmp_path / "ids.parquet"
    values = [1, 2, 2**53, -(2**53), 2**53 + 1, 5]
    pq.write_table(pa.table({"t": pa.array(np.arange(6.0)), "big": pa.array(values, type=pa.int64()),
                             "u": pa.array([0, 1, 2, 3, 4, 2**63], type=pa.uint64())}), path)
    np.testing.assert_array_equal(load_array(f"{path}:t"), np.arange(6.0))
    _refused(f"{path}:t,big", "column 'big', row 4 (counted from 0): the integer 9007199254740993",
             "beyond ±2**53")
    _refused(f"{path}:u", "column 'u', row 5", str(2**63))
    with pytest.raises(FileInputError, match="column 'big', row 4"):
        list(_readers.open_rows(f"{path}:big").chunks(3))
    assert cli.main(["validate", f"{path}:big", f"{path}:big", "--n-params", "1"]) == 1
    assert "row 4" in capsys.readouterr().err


def test_duplicate_parquet_column_names_are_refused(tmp_path, capsys):
    pa = _need("pyarrow")
    pq = _need("pyarrow.parquet")
    path = tmp_path / "dup.parquet"
    table = pa.Table.from_arrays([pa.array(np.arange(5.0)), pa.array(np.arange(5.0)), pa.array(np.ones(5))],
                                 names=["a", "a", "b"])
    pq.write_table(table, path)
    _refused(path, "column name 'a' appears 2 times")
    np.testing.assert_array_equal(load_array(f"{path}:b"), np.ones(5))
    assert cli.main(["validate", str(path), str(path), "--n-params", "1"]) == 1
    assert "appears 2 times" in capsys.readouterr().err


# --------------------------------------------------------------------------- the command line


@pytest.fixture
def pair(tmp_path):
    rng = np.random.default_rng(8)
    meas = rng.standard_normal((300, 2))
    np.save(tmp_path / "meas.npy", meas)
    np.save(tmp_path / "pred.npy", meas + 0.3 * rng.standard_normal((300, 2)))
    return str(tmp_path / "meas.npy"), str(tmp_path / "pred.npy")


def test_names_that_look_like_mathtext_are_drawn_as_written(pair, tmp_path, capsys):
    _need("matplotlib")
    html = tmp_path / "report.html"
    code = cli.main(["validate", *pair, "--n-params", "1", "--joint-names", r"$\frac$,b$", "--html", str(html)])
    assert code == 0, capsys.readouterr().err
    assert html.stat().st_size > 10_000


def test_a_sample_rate_too_small_to_draw_is_an_input_error(pair, tmp_path):
    _need("matplotlib")
    # in a child, as a user runs it: no warning may reach standard error before the message
    proc = subprocess.run([sys.executable, "-m", "dynval", "validate", *pair, "--n-params", "1", "--sample-rate",
                           "1e-308", "--html", str(tmp_path / "r.html")], capture_output=True, text=True,
                          env=_env(), timeout=120)
    assert proc.returncode == 1, proc.stderr
    assert "error: --html: the sample rate 1e-308 Hz is too small to draw the figures: " in proc.stderr
    assert "Traceback" not in proc.stderr and "internal error" not in proc.stderr
    assert "Warning" not in proc.stderr, proc.stderr


@pytest.mark.parametrize(("rate", "n", "words"), [
    (1e-308, 500, "too small"), (1e-288, 500, "too small"), (1e292, 500, "too large"), (1e300, 500, "too large"),
    (1e-280, 500, None), (200.0, 500, None), (1e280, 500, None)])
def test_the_rates_the_figures_can_draw(rate, n, words):
    problem = cli._undrawable_rate(rate, n)
    assert (problem is None) if words is None else problem.startswith(words)


def test_a_full_standard_output_is_an_error_without_traceback(pair):
    with open(os.devnull if not os.path.exists("/dev/full") else "/dev/full", "w") as full:
        proc = subprocess.run([sys.executable, "-m", "dynval", "validate", *pair, "--n-params", "1"],
                              stdout=full, stderr=subprocess.PIPE, text=True, env=_env(), timeout=120)
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    assert proc.returncode == 1, proc.stderr
    assert proc.stderr == "dynval validate: error: standard output cannot be written (No space left on device)\n"


@pytest.mark.skipif(os.name != "posix", reason="closes a file descriptor in the child")
def test_a_closed_standard_output_is_an_error_without_traceback(pair):
    proc = subprocess.run([sys.executable, "-m", "dynval", "validate", *pair, "--n-params", "1"],
                          stderr=subprocess.PIPE, text=True, env=_env(), timeout=120,
                          preexec_fn=lambda: os.close(1))
    assert proc.returncode == 1, proc.stderr
    assert "standard output is closed" in proc.stderr and "Traceback" not in proc.stderr, proc.stderr


@pytest.mark.skipif(not LINUX, reason="watches the child's mapped libraries in /proc")
def test_ctrl_c_while_starting_exits_130_quietly(pair):
    proc = subprocess.Popen([sys.executable, "-m", "dynval", "validate", *pair, "--n-params", "1"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env())
    # numpy's extension is mapped early in the package's imports: interrupt the start-up there
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        try:
            with open(f"/proc/{proc.pid}/maps") as maps:
                if "_multiarray_umath" in maps.read():
                    break
        except OSError:
            pass
        time.sleep(0.005)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and err.strip().endswith("interrupted"), err


def test_importing_dynval_leaves_sigint_alone():
    code = "import signal, dynval; print(signal.getsignal(signal.SIGINT) is signal.default_int_handler)"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=_env(), timeout=120)
    assert proc.stdout.strip() == "True", proc.stderr


@pytest.mark.parametrize("filename", [None, "out/figure.png"])
def test_a_write_that_fails_mid_command_is_an_error_not_a_bug(monkeypatch, capsys, filename):
    # The demo prints and writes figures as it goes: a full disk (or /dev/full) can stop it anywhere.
    import errno

    def full(argv):
        raise OSError(errno.ENOSPC, "No space left on device", filename)

    monkeypatch.setattr(cli, "_dispatch", full)
    assert cli.main(["demo"]) == 1
    where = f" {filename}" if filename else ""
    assert capsys.readouterr().err == f"dynval demo: error: cannot write the output{where} (No space left on device)\n"


def test_another_os_error_is_still_reported_as_a_bug(monkeypatch, capsys):
    import errno

    def missing(argv):
        raise OSError(errno.ENOENT, "No such file or directory", "x")

    monkeypatch.setattr(cli, "_dispatch", missing)
    assert cli.main(["demo"]) == 3
    assert "internal error" in capsys.readouterr().err
