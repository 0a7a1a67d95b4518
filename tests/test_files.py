"""Reading data files for the command line (contract §7): bounded, and refusing with a reason.

Every case here once gave a traceback, a wrong diagnosis, a hang or unbounded memory. The cases that
could hang or grow (a FIFO, /dev/zero, a sparse file) run the command line in a subprocess with a
timeout, so a regression fails instead of stalling the suite.
"""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import dynval
from dynval import cli

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.fixture
def pred(tmp_path):
    path = tmp_path / "pred.npy"
    np.save(path, np.linspace(0.0, 1.0, 20).reshape(10, 2))
    return str(path)


def run(capsys, *argv):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def refused(capsys, path, pred, *needles):
    """The command line refuses ``path`` with exit 1, the path and every needle on stderr."""
    code, out, err = run(capsys, "validate", path, pred, "--n-params", "1")
    assert code == 1 and out == "", err
    assert err.startswith(f"dynval validate: error: {path}: "), err
    assert "Traceback" not in err and len(err) < 600, err
    for needle in needles:
        assert needle in err, err
    return err


def run_subprocess(*argv, timeout=30):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT / "python")] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
    return subprocess.run([sys.executable, "-m", "dynval", *map(str, argv)], capture_output=True, text=True,
                          env=env, timeout=timeout)


# --------------------------------------------------------------------------- .npy and .npz


def test_an_empty_npy_is_refused(tmp_path, pred, capsys):
    empty = tmp_path / "empty.npy"
    empty.write_bytes(b"")
    refused(capsys, empty, pred, "empty (0 bytes)")


def test_csv_text_named_npy_is_not_called_a_pickle(tmp_path, pred, capsys):
    text = tmp_path / "tau.npy"
    text.write_text("1,2\n3,4\n")
    err = refused(capsys, text, pred, "not a .npy file", "text")
    assert "pickle" not in err


def test_garbage_npz_is_not_called_a_pickle(tmp_path, pred, capsys):
    garbage = tmp_path / "tau.npz"
    garbage.write_bytes(bytes(range(7, 200)) * 3)
    err = refused(capsys, garbage, pred, "not a .npz archive")
    assert "pickle" not in err and "None" not in err


def test_an_npy_header_declaring_a_huge_shape_is_refused_before_allocating(tmp_path, pred, capsys):
    path = tmp_path / "huge.npy"
    with open(path, "wb") as handle:
        np.lib.format.write_array_header_1_0(
            handle, {"descr": "<f8", "fortran_order": False, "shape": (10**12, 3)})
        handle.write(np.zeros(6).tobytes())
    refused(capsys, path, pred, "(1000000000000, 3)", "48 bytes")


def test_an_npz_member_declaring_a_huge_shape_is_refused(tmp_path, pred, capsys):
    import zipfile

    header = tmp_path / "member.npy"
    with open(header, "wb") as handle:
        np.lib.format.write_array_header_1_0(
            handle, {"descr": "<f8", "fortran_order": False, "shape": (10**9, 10**9)})
    path = tmp_path / "huge.npz"
    with zipfile.ZipFile(path, "w") as archive:
        archive.write(header, "tau.npy")
    refused(capsys, path, pred, "(1000000000, 1000000000)")


def test_object_arrays_inside_an_npz_are_refused_as_pickles(tmp_path, pred, capsys):
    path = tmp_path / "obj.npz"
    np.savez(path, tau=np.array([{"a": 1}], dtype=object))
    refused(capsys, path, pred, "'tau'", "pickled Python objects")


def test_npy_and_npz_still_load(tmp_path):
    data = np.arange(12.0).reshape(6, 2)
    np.save(tmp_path / "a.npy", data)
    np.save(tmp_path / "f.npy", np.asfortranarray(data).astype(">f4"))
    np.savez_compressed(tmp_path / "b.npz", x=data[:, 0], y=data)
    assert np.array_equal(cli.load_array(str(tmp_path / "a.npy")), data)
    assert np.array_equal(cli.load_array(str(tmp_path / "f.npy")), data)
    assert np.array_equal(cli.load_array(str(tmp_path / "b.npz")), data[:, 0])
    assert np.array_equal(cli.load_array(str(tmp_path / "b.npz") + ":y"), data)


def test_file_errors_are_dynval_input_errors(tmp_path):
    with pytest.raises(dynval.InputError, match="no such file") as info:
        cli.load_array(str(tmp_path / "missing.csv"))
    assert isinstance(info.value, cli.FileInputError) and info.value.kind == "InvalidFile"


# --------------------------------------------------------------------------- not a regular file


def test_a_fifo_is_refused_without_blocking(tmp_path, pred):
    fifo = tmp_path / "tau.csv"
    os.mkfifo(fifo)
    done = run_subprocess("validate", fifo, pred, "--n-params", "1")
    assert done.returncode == 1, done.stderr
    assert f"{fifo}: is not a regular file (a FIFO (named pipe))" in done.stderr
    assert "Traceback" not in done.stderr


def test_a_csv_symlinked_to_dev_zero_is_refused_without_reading(tmp_path, pred):
    link = tmp_path / "tau.csv"
    os.symlink("/dev/zero", link)
    done = run_subprocess("validate", link, pred, "--n-params", "1")
    assert done.returncode == 1, done.stderr
    assert f"{link}: is not a regular file (a character device)" in done.stderr


def test_a_directory_is_refused(tmp_path, pred, capsys):
    folder = tmp_path / "tau.csv"
    folder.mkdir()
    refused(capsys, folder, pred, "is not a regular file (a directory)")


def test_a_directory_without_a_data_suffix_is_called_a_directory_not_a_file_type(tmp_path, pred, capsys):
    folder = tmp_path / "runs"
    folder.mkdir()
    refused(capsys, folder, pred, f"{folder}: is not a regular file (a directory)")


# --------------------------------------------------------------------------- CSV bounds


def test_a_sparse_gigabyte_csv_is_refused_at_its_first_block(tmp_path, pred):
    sparse = tmp_path / "tau.csv"
    with open(sparse, "wb") as handle:
        handle.write(b"1,2\n3,4\n")
        handle.truncate(1 << 30)  # a hole: reads as NUL bytes, takes no disk space
    done = run_subprocess("validate", sparse, pred, "--n-params", "1")
    assert done.returncode == 1, done.stderr
    assert f"{sparse}: holds binary data (a NUL byte in its first 65536 bytes)" in done.stderr


def test_nul_bytes_after_the_first_block_are_refused_on_their_line(tmp_path, pred, capsys):
    path = tmp_path / "tau.csv"
    rows = "1.0,2.0\n" * 10000
    path.write_text(rows + "3.0,\x004.0\n")
    refused(capsys, path, pred, "line 10001", "NUL byte")


def test_a_line_longer_than_the_limit_is_refused(tmp_path, pred, capsys):
    from dynval.io._files import MAX_LINE_BYTES

    path = tmp_path / "wide.csv"
    path.write_text("1," * (MAX_LINE_BYTES // 2 + 10) + "1\n")
    refused(capsys, path, pred, "line 1", f"longer than {MAX_LINE_BYTES} bytes")


def test_a_field_beyond_the_csv_module_limit_is_reported_not_raised(tmp_path, pred, capsys):
    path = tmp_path / "tau.csv"
    path.write_text("a,b\n1," + "x" * 200_000 + "\n")
    refused(capsys, path, pred, "line 2, column 2", "is not a number")
    quoted = tmp_path / "quoted.csv"
    quoted.write_text('"' + "h" * 200_000 + '",b\n1,2\n')
    refused(capsys, quoted, pred, "line 1")


def test_invalid_utf8_is_refused(tmp_path, pred, capsys):
    path = tmp_path / "tau.csv"
    path.write_bytes(b"1,2\n3,\xff\xfe4\n")
    refused(capsys, path, pred, "not UTF-8 text")


# --------------------------------------------------------------------------- CSV content rules


def test_a_first_row_with_one_bad_cell_is_an_error_not_a_header(tmp_path, pred, capsys):
    path = tmp_path / "tau.csv"
    path.write_text("1.5,x\n3,4\n5,6\n")
    refused(capsys, path, pred, "line 1, column 2", "'x' is not a number", "header")


def test_an_all_text_first_row_is_a_header(tmp_path):
    path = tmp_path / "tau.csv"
    path.write_text('"joint 1",joint2\n1,2\n3,4\n')
    assert cli.load_array(str(path)).tolist() == [[1.0, 2.0], [3.0, 4.0]]


def test_csv_positions_are_1_based_physical_lines(tmp_path, pred, capsys):
    path = tmp_path / "tau.csv"
    path.write_text("# comment\nq1;q2\n\n1;2\n3;oops\n")
    refused(capsys, path, pred, "line 5, column 2: 'oops' is not a number")
    ragged = tmp_path / "ragged.csv"
    ragged.write_text("1,2\n\n3\n")
    refused(capsys, ragged, pred, "line 3 has 1 values, line 1 has 2")


def test_empty_values_are_errors_but_a_trailing_delimiter_is_not(tmp_path, pred, capsys):
    trailing = tmp_path / "trailing.csv"
    trailing.write_text("1,2,\n3,4,\n")
    assert cli.load_array(str(trailing)).tolist() == [[1.0, 2.0], [3.0, 4.0]]
    hole = tmp_path / "hole.csv"
    hole.write_text("1,,2\n3,4,5\n")
    refused(capsys, hole, pred, "line 1, column 2: empty value")


def test_long_bad_values_are_cut_in_messages(tmp_path, pred, capsys):
    path = tmp_path / "tau.csv"
    path.write_text("1,2\n3," + "y" * 5000 + "\n")
    err = refused(capsys, path, pred, "line 2, column 2")
    assert "y" * 41 not in err


def test_whitespace_delimited_text_with_numpy_comments(tmp_path):
    path = tmp_path / "tau.txt"
    np.savetxt(path, np.arange(6.0).reshape(3, 2), header="two joints")
    assert cli.load_array(str(path)).tolist() == [[0.0, 1.0], [2.0, 3.0], [4.0, 5.0]]


def test_a_non_finite_csv_value_is_located_in_the_file_too(tmp_path, capsys):
    meas = tmp_path / "meas.csv"
    meas.write_text("q1,q2\n# run 1\n1,2\n3,4\nnan,6\n7,8\n")
    pred = tmp_path / "pred.csv"
    pred.write_text("1,2\n3,4\n5,6\n7,9\n")
    code, _, err = run(capsys, "validate", meas, pred, "--n-params", "1")
    assert code == 1
    assert ("NonFiniteInput: tau_meas has a non-finite value (nan) at row 2, column 0 "
            f"(rows and columns from 0; {meas} line 5, column 1)") in err


def test_a_line_of_delimiters_only_is_refused(tmp_path, pred, capsys):
    path = tmp_path / "tau.csv"
    path.write_text("1,2\n,,\n3,4\n")
    refused(capsys, path, pred, "line 2 holds delimiters but no value")
