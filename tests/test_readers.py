"""Streaming readers (dynval.io._readers) and ``dynval validate --stream`` on files larger than memory."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from dynval import cli
from dynval.io import _readers
from dynval.io._files import FileInputError, load_array
from peak_memory import PEAK_LAUNCHER


@pytest.fixture
def arrays(tmp_path):
    rng = np.random.default_rng(11)
    regressor = rng.standard_normal((5003, 3, 4))
    pred = regressor @ rng.standard_normal(4)
    meas = pred + 0.1 * rng.standard_normal((5003, 3))
    return tmp_path, meas, pred, regressor


def _need(module):
    """The optional library, or a skip outside CI (the test extra installs both; in CI, where
    scripts/test.sh sets CI, a missing one fails instead of silently dropping the tests)."""
    if os.environ.get("CI"):
        import importlib

        return importlib.import_module(module)
    return pytest.importorskip(module)


def _write_parquet(path, data, names=None, row_group_size=None):
    pa = _need("pyarrow")
    pq = _need("pyarrow.parquet")
    names = names or [f"j{k}" for k in range(data.shape[1])]
    pq.write_table(pa.table({n: data[:, k] for k, n in enumerate(names)}), path, row_group_size=row_group_size)


def _write_hdf5(path, **datasets):
    h5py = _need("h5py")
    with h5py.File(path, "w") as handle:
        for name, data in datasets.items():
            handle.create_dataset(name.replace("__", "/"), data=data)


LAYOUTS = ["npy", "npy-fortran", "npz-stored", "npz-compressed", "npz-compressed-fortran", "csv", "npy-3d",
           "parquet", "hdf5", "hdf5-3d"]
# a compressed Fortran-ordered member is read whole: its rows are not consecutive in the deflate stream
STREAMED = {"npy", "npy-fortran", "npz-stored", "npz-compressed", "npy-3d", "csv", "parquet", "hdf5", "hdf5-3d"}


@pytest.mark.parametrize("layout", LAYOUTS)
def test_blocks_join_to_the_whole_file(arrays, layout):
    tmp, meas, _, regressor = arrays
    data = regressor if layout.endswith("-3d") else meas
    if layout == "parquet":
        path = tmp / "a.parquet"
        _write_parquet(path, data, row_group_size=1000)  # row groups that do not align with the blocks
        spec = str(path)
    elif layout.startswith("hdf5"):
        path = tmp / "a.h5"
        _write_hdf5(path, other=np.zeros(3), logs__tau=data)
        spec = f"{path}:/logs/tau"
    elif layout.startswith("npy"):
        path = tmp / "a.npy"
        np.save(path, np.asfortranarray(data) if layout == "npy-fortran" else data)
        spec = str(path)
    elif layout.startswith("npz"):
        path = tmp / "a.npz"
        (np.savez if layout == "npz-stored" else np.savez_compressed)(
            path, other=np.zeros(3), tau=np.asfortranarray(data) if layout.endswith("fortran") else data)
        spec = f"{path}:tau"
    else:
        path = tmp / "a.csv"
        np.savetxt(path, data, delimiter=",", fmt="%.17g")
        spec = str(path)
    source = _readers.open_rows(spec)
    assert source.shape == data.shape
    assert source.streamed == (layout in STREAMED)
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


# --------------------------------------------------------------------------- CSV in blocks


def _csv(tmp, name, text):
    path = tmp / name
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize(("text", "message"), [
    ("a,b\n1,2\n3,4\n" + "5,6\n" * 3000 + "7,x\n8,9\n", r"line 3004, column 2: 'x' is not a number"),
    ("1,2\n" * 2500 + "3,4,5\n", "line 2501 has 3 values, line 1 has 2"),
    ("1,2\n" * 20000 + "3,\x004\n", "line 20001 holds a NUL byte"),  # beyond the first 64 KiB
    ("# comment\n\n" + "1;2\n" * 2100 + "1;\n" + "1;2\n" * 5, r"line 2103 has 1 values, line 3 has 2"),
], ids=["bad-cell", "wide-row", "late-nul", "short-row-after-comments"])
def test_csv_errors_far_into_the_file_are_those_of_the_whole_file_loader(tmp_path, text, message):
    path = _csv(tmp_path, "bad.csv", text)
    with pytest.raises(FileInputError, match=message) as whole:
        load_array(path)
    with pytest.raises(FileInputError) as streamed:
        for _ in _readers.open_rows(path).chunks(1000):
            pass
    assert str(streamed.value) == str(whole.value)


def test_csv_rows_are_counted_without_comments_blanks_or_header(tmp_path):
    path = _csv(tmp_path, "c.csv", "# logged at 1 kHz\n\nt1 t2\n1 2\n\n# pause\n3 4\n5 6\n")
    source = _readers.open_rows(path)
    assert source.shape == (3, 2) and source.streamed
    np.testing.assert_array_equal(np.concatenate(list(source.chunks(2))), [[1, 2], [3, 4], [5, 6]])
    one = _readers.open_rows(_csv(tmp_path, "one.csv", "tau\n1\n2\n3\n"))
    assert one.shape == (3,) and [b.tolist() for b in one.chunks(2)] == [[1.0, 2.0], [3.0]]
    with pytest.raises(FileInputError, match="no data rows after the header"):
        _readers.open_rows(_csv(tmp_path, "h.csv", "a,b\n"))


# --------------------------------------------------------------------------- Parquet and HDF5


def test_parquet_columns_by_name_nulls_and_refusals(tmp_path):
    pa = _need("pyarrow")
    pq = _need("pyarrow.parquet")
    path = tmp_path / "log.parquet"
    pq.write_table(pa.table({"t": [0.0, 0.1, 0.2], "q1": [1, 2, None], "tau1": [1.5, 2.5, 3.5],
                             "note": ["a", "b", "c"]}), path)
    np.testing.assert_array_equal(load_array(f"{path}:tau1,q1"), [[1.5, 1.0], [2.5, 2.0], [3.5, np.nan]])
    assert load_array(f"{path}:tau1").shape == (3,)
    with pytest.raises(FileInputError, match=r"column 'note' holds string values"):
        load_array(str(path))
    with pytest.raises(FileInputError, match=r"no column named 'tau9'; the file holds 't', 'q1', 'tau1', 'note'"):
        load_array(f"{path}:tau9")
    garbage = tmp_path / "g.parquet"
    garbage.write_bytes(b"not parquet at all")
    with pytest.raises(FileInputError, match="not a readable Parquet file"):
        load_array(str(garbage))


def test_hdf5_datasets_by_name_and_refusals(tmp_path):
    path = tmp_path / "log.h5"
    _write_hdf5(path, a=np.arange(6.0).reshape(3, 2), b__c=np.arange(4, dtype=np.int32),
                text=np.array([b"x", b"y"]), cube=np.zeros((2, 2, 2, 2)))
    np.testing.assert_array_equal(load_array(f"{path}:/a"), [[0, 1], [2, 3], [4, 5]])
    assert load_array(f"{path}:b/c").dtype == np.float64
    with pytest.raises(FileInputError, match=r"name the dataset as file\.h5:/name; the file holds /a, /b/c"):
        load_array(str(path))
    with pytest.raises(FileInputError, match="dataset '/text' holds"):
        load_array(f"{path}:/text")
    with pytest.raises(FileInputError, match=r"dataset '/cube' has shape \(2, 2, 2, 2\)"):
        load_array(f"{path}:/cube")
    with pytest.raises(FileInputError, match="no dataset '/zz'"):
        load_array(f"{path}:/zz")
    single = tmp_path / "single.hdf5"
    _write_hdf5(single, tau=np.ones((4, 2)))
    assert load_array(str(single)).shape == (4, 2)


@pytest.mark.parametrize(("module", "extra", "suffix"), [("pyarrow.parquet", "parquet", "parquet"),
                                                         ("h5py", "hdf5", "h5")])
def test_a_missing_extra_is_named(tmp_path, monkeypatch, module, extra, suffix):
    import importlib

    path = tmp_path / f"x.{suffix}"
    path.write_bytes(b"anything")
    real = importlib.import_module

    def refuse(name, *args, **kwargs):
        if name == module:
            raise ImportError(f"No module named {name!r}")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(importlib, "import_module", refuse)
    with pytest.raises(FileInputError, match=rf"pip install 'dynval\[{extra}\]'"):
        load_array(str(path))


def test_a_fifo_is_refused_before_the_libraries_open_it(tmp_path):
    fifo = tmp_path / "pipe.parquet"
    os.mkfifo(fifo)
    with pytest.raises(FileInputError, match="is not a regular file"):
        load_array(str(fifo))


@pytest.mark.parametrize("layout", ["csv", "parquet", "hdf5"])
def test_streamed_cli_on_other_formats_equals_the_in_memory_report(arrays, layout):
    tmp, meas, pred, _ = arrays
    specs = []
    for name, a in (("meas", meas), ("pred", pred)):
        if layout == "csv":
            np.savetxt(tmp / f"{name}.csv", a, delimiter=",", fmt="%.17g")
            specs.append(str(tmp / f"{name}.csv"))
        elif layout == "parquet":
            _write_parquet(tmp / f"{name}.parquet", a, row_group_size=1500)
            specs.append(str(tmp / f"{name}.parquet"))
        else:
            _write_hdf5(tmp / f"{name}.h5", torque=a)
            specs.append(f"{tmp / f'{name}.h5'}:/torque")
    common = [*specs, "--n-params", "4", "--max-lag", "12"]
    whole = _cli_json(common)
    streamed = _cli_json([*common, "--stream", "--chunk-rows", "700"])
    assert streamed["provenance"]["streaming"] is True and "streaming" not in whole["provenance"]
    for section in ("per_joint", "pooled"):
        for key, value in whole[section].items():
            np.testing.assert_allclose(np.asarray(streamed[section][key], dtype=float),
                                       np.asarray(value, dtype=float), rtol=1e-13, atol=1e-13, err_msg=key)
    np.testing.assert_allclose(streamed["autocorrelation"]["rho"], whole["autocorrelation"]["rho"], atol=1e-14)


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
    monkeypatch.setattr(cli, "physical_memory", lambda: 4 * (meas.nbytes + pred.nbytes) - 4096)
    assert cli.main(["validate", str(tmp / "meas.npy"), str(tmp / "pred.npy"), "--n-params", "2"]) == 0
    out = capsys.readouterr().out
    assert "Streamed from the files in blocks" in out
    monkeypatch.setattr(cli, "physical_memory", lambda: 4 * (meas.nbytes + pred.nbytes) + 4096)
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
    proc = subprocess.run([sys.executable, "-c", PEAK_LAUNCHER, "validate", str(tmp_path / "meas.npy"),
                           str(tmp_path / "pred.npy"), "--n-params", "3", "--stream", "--max-lag", "5",
                           "--no-progress"], capture_output=True, text=True, env={**os.environ,
                                                                                  "OMP_NUM_THREADS": "1"})
    assert proc.returncode == 0, proc.stderr
    assert "Streamed from the files" in proc.stdout
    peak = int(proc.stderr.split("VmHWM ")[-1].split()[0]) * 1024
    assert peak < 0.4 * size, f"peak RSS {peak / 1e6:.0f} MB for {size / 1e6:.0f} MB of input"


@pytest.mark.parametrize("layout", ["csv", "parquet", "hdf5"])
def test_streamed_reading_holds_one_block(tmp_path, layout):
    # numpy reports its buffers to tracemalloc (Arrow's and HDF5's own buffers are not seen):
    # reading 2.4 MB of values in blocks of 2,000 rows must never hold much more than a block.
    import tracemalloc

    data = np.random.default_rng(5).standard_normal((50_000, 6))
    if layout == "csv":
        spec = str(tmp_path / "big.csv")
        np.savetxt(spec, data, delimiter=",", fmt="%.17g")
    elif layout == "parquet":
        spec = str(tmp_path / "big.parquet")
        _write_parquet(spec, data, row_group_size=10_000)
    else:
        spec = f"{tmp_path / 'big.h5'}:/tau"
        _write_hdf5(tmp_path / "big.h5", tau=data)
    source = _readers.open_rows(spec)
    tracemalloc.start()
    try:
        total = 0.0
        for block in source.chunks(2_000):
            total += float(block.sum())
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert total == pytest.approx(float(data.sum()), rel=1e-9, abs=1e-6)
    assert peak < 0.25 * data.nbytes, f"peak {peak / 1e6:.2f} MB for {data.nbytes / 1e6:.1f} MB of data"
