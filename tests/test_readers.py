"""Streaming readers (dynval._readers) and ``dynval validate --stream`` on files larger than memory."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from dynval import _readers, cli
from dynval._files import FileInputError, load_array


@pytest.fixture
def arrays(tmp_path):
    rng = np.random.default_rng(11)
    regressor = rng.standard_normal((5003, 3, 4))
    pred = regressor @ rng.standard_normal(4)
    meas = pred + 0.1 * rng.standard_normal((5003, 3))
    return tmp_path, meas, pred, regressor


@pytest.mark.parametrize("layout", ["npy", "npy-fortran", "npz-stored", "npz-compressed", "csv", "npy-3d"])
def test_blocks_join_to_the_whole_file(arrays, layout):
    tmp, meas, _, regressor = arrays
    data = regressor if layout == "npy-3d" else meas
    if layout.startswith("npy"):
        path = tmp / "a.npy"
        np.save(path, np.asfortranarray(data) if layout == "npy-fortran" else data)
        spec = str(path)
    elif layout.startswith("npz"):
        path = tmp / "a.npz"
        (np.savez if layout == "npz-stored" else np.savez_compressed)(path, other=np.zeros(3), tau=data)
        spec = f"{path}:tau"
    else:
        path = tmp / "a.csv"
        np.savetxt(path, data, delimiter=",", fmt="%.17g")
        spec = str(path)
    source = _readers.open_rows(spec)
    assert source.shape == data.shape
    assert source.streamed == (layout in ("npy", "npy-fortran", "npz-stored", "npy-3d"))
    blocks = list(source.chunks(777))
    assert [b.shape[0] for b in blocks] == [777] * 6 + [5003 - 6 * 777]
    np.testing.assert_array_equal(np.concatenate(blocks), load_array(spec))


@pytest.mark.parametrize(("content", "message"), [
    (b"", r"is empty \(0 bytes\)"),
    (b"1,2\n3,4\n", "not a .npy file"),
])
def test_bad_npy_files_give_the_loader_messages(tmp_path, content, message):
    path = tmp_path / "bad.npy"
    path.write_bytes(content)
    with pytest.raises(FileInputError, match=message):
        _readers.open_rows(str(path))


def test_truncated_and_pickled_npy_are_refused(tmp_path):
    path = tmp_path / "t.npy"
    np.save(path, np.arange(1000.0))
    path.write_bytes(path.read_bytes()[:-80])
    with pytest.raises(FileInputError, match="truncated or corrupt"):
        _readers.open_rows(str(path))
    objects = tmp_path / "o.npy"
    np.save(objects, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(FileInputError, match="pickled Python objects"):
        _readers.open_rows(str(objects))


def _cli_json(argv):
    proc = subprocess.run([sys.executable, "-m", "dynval", "validate", *argv, "--json"], capture_output=True,
                          text=True, check=True)
    return json.loads(proc.stdout)


def test_streamed_cli_equals_the_in_memory_report(arrays):
    tmp, meas, pred, regressor = arrays
    for name, a in (("meas", meas), ("pred", pred), ("reg", regressor)):
        np.save(tmp / f"{name}.npy", a)
    common = [str(tmp / "meas.npy"), str(tmp / "pred.npy"), "--n-params", "4", "--regressor", str(tmp / "reg.npy"),
              "--max-lag", "12"]
    whole = _cli_json(common)
    streamed = _cli_json([*common, "--stream", "--chunk-rows", "333"])
    assert streamed["provenance"]["streaming"] is True
    for section in ("per_joint", "pooled"):
        for key, value in whole[section].items():
            np.testing.assert_allclose(np.asarray(streamed[section][key], dtype=float),
                                       np.asarray(value, dtype=float), rtol=1e-13, atol=1e-13, err_msg=key)
    np.testing.assert_allclose(streamed["autocorrelation"]["rho"], whole["autocorrelation"]["rho"], atol=1e-14)


def test_stream_is_chosen_when_the_inputs_exceed_a_quarter_of_memory(arrays, monkeypatch, capsys):
    tmp, meas, pred, _ = arrays
    np.save(tmp / "meas.npy", meas)
    np.save(tmp / "pred.npy", pred)
    monkeypatch.setattr(cli, "_physical_memory", lambda: 4 * (meas.nbytes + pred.nbytes) - 4096)
    assert cli.main(["validate", str(tmp / "meas.npy"), str(tmp / "pred.npy"), "--n-params", "2"]) == 0
    out = capsys.readouterr().out
    assert "Streamed from the files in blocks" in out
    monkeypatch.setattr(cli, "_physical_memory", lambda: 4 * (meas.nbytes + pred.nbytes) + 4096)
    assert cli.main(["validate", str(tmp / "meas.npy"), str(tmp / "pred.npy"), "--n-params", "2"]) == 0
    assert "Streamed from the files" not in capsys.readouterr().out


def test_stream_refuses_what_needs_the_whole_series(arrays, capsys):
    tmp, meas, pred, _ = arrays
    np.save(tmp / "meas.npy", meas)
    np.save(tmp / "pred.npy", pred)
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["validate", str(tmp / "meas.npy"), str(tmp / "pred.npy"), "--n-params", "2", "--stream",
                  "--segments", "2500,2503"])
    assert exit_info.value.code == 2
    assert "--segments cannot be used with a streamed validation" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="reads VmHWM from /proc (Linux)")
def test_the_cli_validates_files_larger_than_its_peak_memory(tmp_path):
    # 2 × 280 MB of torques; the child's peak RSS stays far below them (blocks of 131,072 rows)
    n, m = 5_000_000, 7
    rng = np.random.default_rng(12)
    for name, shift in (("meas", 0.0), ("pred", 0.05)):
        out = np.lib.format.open_memmap(tmp_path / f"{name}.npy", mode="w+", dtype=np.float64, shape=(n, m))
        for start in range(0, n, 1_000_000):
            block = rng.standard_normal((min(1_000_000, n - start), m))
            out[start:start + block.shape[0]] = block + shift
        out.flush()
        del out
    size = 2 * n * m * 8
    # The child's own high-water mark (VmHWM of its address space, reset at exec; ru_maxrss would
    # also count the pages of this process at the fork).
    launcher = ("import atexit, runpy, sys\n"
                "def hwm():\n"
                "    for line in open('/proc/self/status'):\n"
                "        if line.startswith('VmHWM:'): sys.stderr.write('VmHWM ' + line.split()[1] + '\\n')\n"
                "atexit.register(hwm)\n"
                "sys.argv = ['dynval'] + sys.argv[1:]\n"
                "runpy.run_module('dynval', run_name='__main__')\n")
    proc = subprocess.run([sys.executable, "-c", launcher, "validate", str(tmp_path / "meas.npy"),
                           str(tmp_path / "pred.npy"), "--n-params", "3", "--stream", "--max-lag", "5",
                           "--no-progress"], capture_output=True, text=True, env={**os.environ,
                                                                                  "OMP_NUM_THREADS": "1"})
    assert proc.returncode == 0, proc.stderr
    assert "Streamed from the files" in proc.stdout
    peak = int(proc.stderr.split("VmHWM ")[-1].split()[0]) * 1024
    assert peak < 0.4 * size, f"peak RSS {peak / 1e6:.0f} MB for {size / 1e6:.0f} MB of input"
