"""Shapes read from the files' headers and checked against each other before any decoding
(contract §7, ``dynval.io._shapes``), and the peak memory of the command line around them."""

from __future__ import annotations

import os
import subprocess
import sys
import tracemalloc
import zipfile

import numpy as np
import pytest

import dynval
from dynval.io._files import FileInputError
from dynval.io._shapes import check_declared, declared_shape
from peak_memory import PEAK_LAUNCHER


def _zeros_npz(path, shape, *, fortran=False):
    """A compressed .npz whose member declares ``shape`` of float64 zeros, written a block at a time:
    a few hundred KB on disk for hundreds of MB decoded."""
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive, \
            archive.open("arr_0.npy", "w", force_zip64=True) as member:
        np.lib.format.write_array_header_1_0(member, {"descr": "<f8", "fortran_order": fortran,
                                                      "shape": tuple(shape)})
        block = np.zeros(1 << 20).tobytes()
        left = int(np.prod(shape)) * 8
        while left:
            member.write(block[:min(left, len(block))])
            left -= min(left, len(block))
    return str(path)


def _peak(*argv):
    proc = subprocess.run([sys.executable, "-c", PEAK_LAUNCHER, *argv], capture_output=True, text=True,
                          env={**os.environ, "OMP_NUM_THREADS": "1"}, timeout=600)
    return proc, int(proc.stderr.split("VmHWM ")[-1].split()[0]) * 1024


# --------------------------------------------------------------------------- the headers


def test_declared_shapes_of_every_format(tmp_path):
    a = np.arange(12.0).reshape(6, 2)
    np.save(tmp_path / "a.npy", a)
    np.savez(tmp_path / "s.npz", x=a, y=a[:, 0])
    np.savez_compressed(tmp_path / "c.npz", x=a)
    np.savez_compressed(tmp_path / "f.npz", x=np.asfortranarray(a))
    np.savetxt(tmp_path / "a.csv", a, delimiter=",", header="j1,j2", comments="")
    np.savetxt(tmp_path / "one.csv", a[:, 0])
    assert declared_shape(str(tmp_path / "a.npy")) == (6, 2)
    assert declared_shape(f"{tmp_path / 's.npz'}:y") == (6,)
    assert declared_shape(str(tmp_path / "c.npz")) == (6, 2)
    assert declared_shape(str(tmp_path / "f.npz")) == (6, 2)   # a Fortran member: its header, not read whole
    assert declared_shape(str(tmp_path / "a.csv")) == (None, 2)  # CSV: rows counted only when read
    assert declared_shape(str(tmp_path / "one.csv")) == (None,)
    assert declared_shape(f"{tmp_path / 's.npz'}:missing") is None  # the reader names the keys


def test_declared_shapes_of_columnar_files(tmp_path):
    a = np.arange(12.0).reshape(6, 2)
    pa = pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq

    pq.write_table(pa.table({"a": a[:, 0], "b": a[:, 1]}), tmp_path / "t.parquet")
    assert declared_shape(str(tmp_path / "t.parquet")) == (6, 2)
    h5py = pytest.importorskip("h5py")
    with h5py.File(tmp_path / "t.h5", "w") as handle:
        handle["d"] = np.zeros((7, 2, 3))
    assert declared_shape(f"{tmp_path / 't.h5'}:/d") == (7, 2, 3)


def test_a_refused_header_is_refused_before_decoding(tmp_path):
    np.save(tmp_path / "o.npy", np.array([{}, 1], dtype=object))
    with pytest.raises(FileInputError, match="pickled Python objects"):
        declared_shape(str(tmp_path / "o.npy"))


def test_check_declared_gives_the_messages_of_the_decoded_arrays(tmp_path):
    def save(name, shape):
        np.save(tmp_path / name, np.zeros(shape))
        return str(tmp_path / name)

    meas, pred = save("m.npy", (10, 2)), save("p.npy", (9, 2))
    with pytest.raises(dynval.ShapeMismatch) as info:
        check_declared(meas, {"tau_pred": pred})
    with pytest.raises(dynval.ShapeMismatch) as want:
        dynval.validate(np.zeros((10, 2)), np.zeros((9, 2)), n_params=1)
    assert str(info.value) == str(want.value)
    with pytest.raises(dynval.ShapeMismatch, match=r"\(tau_pred: the prediction of candidate 'fric'\)$"):
        check_declared(meas, {"fric": pred})
    with pytest.raises(dynval.ShapeMismatch, match=r"^regressor has 19 rows, which is not N\*m = 10\*2$"):
        check_declared(meas, {"tau_pred": meas}, regressor=save("y.npy", (19, 3)), n_joints=2)
    with pytest.raises(dynval.ShapeMismatch, match=r"^regressor must have shape \(N, m, p\) = \(10, 2, p\)"):
        check_declared(meas, {"tau_pred": meas}, regressor=save("y3.npy", (10, 3, 4)))
    with pytest.raises(dynval.ShapeMismatch, match=r"^time must have one stamp per sample, shape \(10,\), got \(9,\)$"):
        check_declared(meas, {"tau_pred": meas}, time=save("t.npy", (9,)))
    with pytest.raises(dynval.ShapeMismatch,
                       match=r"^tau_meas and q must have the same shape, got \(10, 2\) and \(10, 3\)$"):
        check_declared(meas, {"tau_pred": meas}, q=save("q.npy", (10, 3)))
    np.savetxt(tmp_path / "p.csv", np.zeros((10, 3)), delimiter=",")
    with pytest.raises(dynval.ShapeMismatch, match=r"got \(10, 2\) and \(N, 3\) \(N: the rows of a CSV file"):
        check_declared(meas, {"tau_pred": str(tmp_path / "p.csv")})
    # shapes that agree, and a CSV whose columns agree (its rows are checked once it is read)
    check_declared(meas, {"tau_pred": meas}, regressor=save("y2.npy", (20, 3)), time=save("t2.npy", (10,)),
                   n_joints=2)
    np.savetxt(tmp_path / "p2.csv", np.zeros((4, 2)), delimiter=",")
    check_declared(meas, {"tau_pred": str(tmp_path / "p2.csv")})


# --------------------------------------------------------------------------- memory


def test_a_mismatch_beside_a_huge_declared_array_costs_no_decoding(tmp_path):
    """A compressed .npz declaring (2**24, 2) float64 (256 MB decoded, 256 KB on disk) beside a
    10-row file: the shapes were compared only after both were decoded (3.1 GB at (2**26, 2))."""
    big = _zeros_npz(tmp_path / "big.npz", (1 << 24, 2))
    np.save(tmp_path / "small.npy", np.zeros((10, 2)))
    small = str(tmp_path / "small.npy")
    decoded = (1 << 24) * 2 * 8
    _, baseline = _peak("validate", small, small, "--n-params", "1", "--max-lag", "0")
    for argv in (("validate", big, small, "--n-params", "1"), ("validate", small, big, "--n-params", "1"),
                 ("compare", small, "--model", f"a={big}:1")):
        proc, peak = _peak(*argv)
        assert proc.returncode == 1 and "ShapeMismatch" in proc.stderr and "(16777216, 2)" in proc.stderr, proc.stderr
        assert peak - baseline < 0.1 * decoded, f"{argv[0]}: {(peak - baseline) / 1e6:.0f} MB over the baseline"


def test_reading_what_is_kept_costs_at_most_twice_its_decoded_size(tmp_path):
    """Compressed and plain files that agree: the peak over a run of tiny files stays within twice
    the decoded size of the two arrays kept (max_lag=0: the report itself adds little)."""
    rng = np.random.default_rng(2)
    meas = rng.standard_normal((1 << 20, 2))
    np.savez_compressed(tmp_path / "m.npz", meas)
    np.save(tmp_path / "p.npy", meas + 0.1)
    np.save(tmp_path / "s.npy", meas[:10])
    kept = 2 * meas.nbytes
    _, baseline = _peak("validate", str(tmp_path / "s.npy"), str(tmp_path / "s.npy"), "--n-params", "1",
                        "--max-lag", "0")
    proc, peak = _peak("validate", str(tmp_path / "m.npz"), str(tmp_path / "p.npy"), "--n-params", "1",
                       "--max-lag", "0")
    assert proc.returncode in (0, 1), proc.stderr
    assert peak - baseline <= 2 * kept, f"{(peak - baseline) / kept:.2f} times the {kept / 1e6:.0f} MB kept"


def test_a_fleet_log_with_mismatched_files_is_an_error_row_without_decoding(tmp_path):
    from dynval.fleet import LogSpec, validate_many

    big = _zeros_npz(tmp_path / "big.npz", (1 << 22, 2))   # 64 MB decoded
    rng = np.random.default_rng(1)
    good = rng.standard_normal((300, 2))
    np.save(tmp_path / "m.npy", good)
    np.save(tmp_path / "p.npy", good + 0.1 * rng.standard_normal(good.shape))
    logs = [LogSpec("r1", str(k), str(tmp_path / "m.npy"), str(tmp_path / "p.npy"), 1, log=f"log{k}")
            for k in range(3)]
    bad_log = LogSpec("r1", "9", str(tmp_path / "m.npy"), big, 1, log="bad")

    def traced(items):
        tracemalloc.start()
        try:
            fleet = validate_many(items, scheduler="single", max_lag=5, progress=False, min_baseline=2)
            return fleet, tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()

    traced(logs)  # imports and caches first
    _, baseline = traced(logs)
    fleet, peak = traced([*logs, bad_log])
    bad = [row for row in fleet.logs if row.log == "bad"]
    assert len(bad) == 1 and bad[0].error.startswith("ShapeMismatch") and "(4194304, 2)" in bad[0].error
    assert peak - baseline < 0.1 * (1 << 22) * 2 * 8, f"{(peak - baseline) / 1e6:.0f} MB over the good logs"


def test_a_shape_numpy_cannot_describe_is_left_to_the_reader(tmp_path):
    """(2**40, 2**40) is no array numpy can even stand in for: the reader refuses the file by its size."""
    from dynval.io._shapes import _describable

    assert _describable((1 << 40, 1 << 40)) is None
    assert _describable((None, 3)) == (None, 3) and _describable((10, 2)) == (10, 2)
    path = tmp_path / "huge.npz"
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive, \
            archive.open("arr_0.npy", "w", force_zip64=True) as member:
        np.lib.format.write_array_header_1_0(member, {"descr": "<f8", "fortran_order": False,
                                                      "shape": (1 << 40, 1 << 40)})
        member.write(bytes(1000))
    np.save(tmp_path / "m.npy", np.zeros((5, 2)))
    with pytest.raises(FileInputError, match="holds only 1000 bytes after the header"):
        check_declared(str(path), {"tau_pred": str(tmp_path / "m.npy")})
