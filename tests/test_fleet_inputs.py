"""Fleet inputs are checked like data files (contract §10): manifests bounded and refused with their
file and row, every setting checked before any log runs, and a log that cannot be named or read an
error row while the rest of the fleet goes on (in this process and on a dask bag).

The cases that could hang or fill the memory (a FIFO, /dev/zero) run the command line in a subprocess
with a timeout, so that a regression fails instead of stalling the suite.
"""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import dynval
import dynval.fleet as fleet
from dynval.cli import main
from dynval.fleet import _drift, _logs, _run
from dynval.io._files import MAX_LINE_BYTES, FileInputError

ROOT = pathlib.Path(__file__).resolve().parents[1]
HEADER = "robot,time,tau_meas,tau_pred,n_params\n"


def _subprocess(*argv, timeout=60):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT / "python")] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
    return subprocess.run([sys.executable, "-m", "dynval", *map(str, argv)], capture_output=True, text=True,
                          env=env, timeout=timeout)


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """1 robot × 5 logs × 200 samples, written as directories with a manifest."""
    directory = tmp_path_factory.mktemp("fleet")
    specs = fleet.write_fleet(fleet.simulate_fleet(n_robots=1, n_logs=5, n_samples=200), str(directory))
    return directory, specs


def _refused(capsys, path, *needles):
    """validate-many refuses the manifest with exit 1, the file and every needle on stderr, nothing printed."""
    code = main(["validate-many", str(path), "--n-params", "1", "--no-progress"])
    out, err = capsys.readouterr()
    assert code == 1 and out == "", err
    assert "internal error" not in err and f"{path}" in err
    for needle in needles:
        assert needle in err, err
    return err


# --------------------------------------------------------------------------- N4: a manifest is a bounded regular file


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_a_fifo_manifest_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "fleet.csv"
    os.mkfifo(fifo)
    done = _subprocess("validate-many", fifo, "--n-params", "1", "--no-progress")
    assert done.returncode == 1, done.stderr
    assert f"{fifo}: is not a regular file (a FIFO (named pipe))" in done.stderr


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/null"])
def test_a_manifest_linked_to_a_device_is_refused_without_reading(tmp_path, device):
    if not os.path.exists(device):
        pytest.skip(f"no {device}")
    link = tmp_path / "fleet.json"
    os.symlink(device, link)
    done = _subprocess("validate-many", link, "--n-params", "1", "--no-progress")
    assert done.returncode == 1, done.stderr
    assert f"{link}: is not a regular file (a character device)" in done.stderr


def test_a_directory_named_like_a_manifest_is_refused(tmp_path, capsys):
    (tmp_path / "fleet.csv").mkdir()
    _refused(capsys, tmp_path / "fleet.csv", "is not a regular file (a directory)")


def test_a_manifest_over_the_size_limit_is_refused_before_it_is_read(tmp_path, monkeypatch, capsys):
    path = tmp_path / "fleet.csv"
    path.write_text(HEADER + "r,1,a.npy,b.npy,1\n" * 20, encoding="utf-8")
    monkeypatch.setattr(_logs, "MAX_MANIFEST_BYTES", 100)
    monkeypatch.setattr(_logs, "_csv_rows", lambda *a: pytest.fail("a manifest over the limit was parsed"))
    _refused(capsys, path, f"{path.stat().st_size} bytes, more than a manifest's limit of 100 bytes")


# --------------------------------------------------------------------------- N5: bad manifests name file and row


@pytest.mark.parametrize("name, content, needle", [
    ("latin1.csv", HEADER.encode() + b"r\xe9,1,a.npy,b.npy,2\n",
     "latin1.csv: line 2 is not UTF-8 text (invalid continuation byte at byte 2 of the line)"),
    ("nul.csv", HEADER.encode() + b"r,1,a.npy\x00,b.npy,2\n", "nul.csv: line 2 holds a NUL byte"),
    ("inf.json", b'[{"robot": "r", "time": "1", "tau_meas": "a.npy", "tau_pred": "b.npy", "n_params": 1e400}]',
     "inf.json $[0].n_params: a number beyond float64's range"),
    ("nan.json", b'{"logs": [{"robot": "r", "time": NaN, "tau_meas": "a.npy", "tau_pred": "b.npy"}]}',
     "nan.json: not a JSON manifest (NaN is not a number a manifest holds)"),
    ("deep.json", b"[" * 100_000 + b"]" * 100_000, "deep.json: nested too deeply for a JSON manifest"),
    ("object.json", b'{"logs": [{"robot": "r", "time": "1", "tau_meas": {"a": 1}, "tau_pred": "b.npy"}]}',
     "object.json $.logs[0].tau_meas: a manifest's cell is text or a number, got an object"),
    ("huge_cell.csv", HEADER.encode() + b'r,1,"' + b"a" * 200_000 + b'",b.npy,1\n',
     "huge_cell.csv line 2: a cell longer than 4096 characters"),
    ("long_cell.csv", HEADER.encode() + b"r,1," + b"a" * 5000 + b",b.npy,1\n",
     "long_cell.csv line 2, column tau_meas: a cell longer than 4096 characters"),
    ("long_cell.json", b'[{"robot": "' + b"r" * 5000 + b'", "time": "1", "tau_meas": "a", "tau_pred": "b"}]',
     "long_cell.json $[0].robot: a cell longer than 4096 characters"),
    ("extra.csv", HEADER.encode() + b"r,1,a.npy,b.npy,1,2\n", "extra.csv line 2: 6 cells, more than the header's 5"),
    ("quote.csv", HEADER.encode() + b'r,1,a"b",c,1\n' + b'r,2,"unclosed\n', "quote.csv line 3"),
    ("inf_text.csv", HEADER.encode() + b"r,1,a.npy,b.npy,inf\n", "inf_text.csv line 2: n_params must be an integer"),
], ids=lambda value: value if isinstance(value, str) and value.endswith((".csv", ".json")) else "")
def test_a_bad_manifest_is_refused_naming_its_file_and_row(tmp_path, capsys, name, content, needle):
    path = tmp_path / name
    path.write_bytes(content)
    _refused(capsys, path, needle)


def test_a_manifest_line_over_the_line_limit_is_refused_naming_it(tmp_path, capsys):
    path = tmp_path / "fleet.csv"
    path.write_text(HEADER + "r,1,a.npy,b.npy,1\n" + "#" * (MAX_LINE_BYTES + 1) + "\n", encoding="utf-8")
    _refused(capsys, path, f"line 3 is longer than {MAX_LINE_BYTES} bytes")


def test_a_json_n_params_of_1e400_is_refused_from_python_too(tmp_path):
    path = tmp_path / "fleet.json"
    path.write_text('[{"robot": "r", "time": 1, "tau_meas": "a", "tau_pred": "b", "n_params": 1e400}]')
    with pytest.raises(FileInputError, match=r"fleet\.json \$\[0\]\.n_params: a number beyond"):
        fleet.read_manifest(str(path))
    # the same number from a mapping (no JSON reader in between): its row's InvalidParameter, not OverflowError
    row, = fleet.validate_many([{"robot": "r", "time": "1", "tau_meas": "a", "tau_pred": "b",
                                 "n_params": float("inf")}], scheduler="single").logs
    assert row.error.startswith("InvalidParameter: log 'a': n_params must be an integer >= 0, got inf")


def test_a_utf8_manifest_with_a_byte_order_mark_and_non_ascii_names_is_read(tmp_path):
    path = tmp_path / "fleet.csv"
    path.write_bytes(b"\xef\xbb\xbf" + HEADER.encode() + "bras-é,1,a.npy,b.npy,2\n".encode())
    spec, = fleet.read_manifest(str(path))
    assert (spec.robot, spec.n_params, spec.tau_meas) == ("bras-é", 2, str(tmp_path / "a.npy"))


def test_an_empty_manifest_and_a_header_alone_are_refused(tmp_path, capsys):
    (tmp_path / "empty.csv").write_bytes(b"")
    _refused(capsys, tmp_path / "empty.csv", "a manifest's header needs the columns", "(its header: none)")
    (tmp_path / "header.csv").write_text(HEADER, encoding="utf-8")
    _refused(capsys, tmp_path / "header.csv", "header.csv: the manifest names no log")
    (tmp_path / "empty.json").write_text("[]", encoding="utf-8")
    _refused(capsys, tmp_path / "empty.json", "empty.json: the manifest names no log")


def test_a_log_listed_twice_is_refused_naming_both_rows(tmp_path, logs):
    path = tmp_path / "fleet.csv"
    path.write_text(HEADER + "r,1,a.npy,b.npy,1\nr,2,a.npy,b.npy,1\nr,1,c.npy,d.npy,1\n", encoding="utf-8")
    with pytest.raises(FileInputError, match=r"fleet\.csv line 4: robot r's log 1 is listed twice \(also .*fleet\.csv "
                                             r"line 2\)"):
        fleet.validate_many([str(path)], scheduler="single")
    # across inputs too: the same manifest twice
    _, specs = logs
    with pytest.raises(FileInputError, match=r"is listed twice"):
        fleet.validate_many([specs[0], specs[1], specs[0]], scheduler="single")


# --------------------------------------------------------------------------- N6: settings before any log


@pytest.mark.parametrize("setting, needle", [
    ({"seed": -1}, r"^seed must be an integer with 0 <= seed < 2\*\*63, got -1$"),
    ({"seed": 1.5}, r"^seed must be an integer"),
    ({"seed": True}, r"^seed must be an integer"),
    ({"n_permutations": 10**9}, r"^n_permutations must be an integer with 19 <= n_permutations <= 1000000, "
                                r"got 1000000000$"),
    ({"n_permutations": 18}, r"^n_permutations must be an integer with 19"),
    ({"min_baseline": 2.0}, r"^min_baseline must be an integer >= 2"),
    ({"ratio_threshold": float("nan")}, r"^ratio_threshold must be a number >= 1, got nan$"),
    ({"ratio_threshold": True}, r"^ratio_threshold must be a number >= 1"),
    ({"n_params": -1}, r"^n_params must be None or an integer >= 0, got -1$"),
])
def test_every_setting_is_checked_before_any_log_is_read(logs, monkeypatch, setting, needle):
    _, specs = logs
    monkeypatch.setattr(_run, "summarise_log", lambda *a, **k: pytest.fail("a log ran before the settings' check"))
    with pytest.raises(dynval.InvalidParameter, match=needle):
        fleet.validate_many(specs, scheduler="single", max_lag=5, progress=False, **setting)


def test_a_path_without_n_params_is_refused_before_any_log(logs, monkeypatch):
    directory, specs = logs
    monkeypatch.setattr(_run, "summarise_log", lambda *a, **k: pytest.fail("a log ran before the settings' check"))
    with pytest.raises(dynval.InvalidParameter, match=r"r01__2026-01-01T08-00: n_params is needed: give it to "
                                                      r"validate_many \(--n-params\)"):
        fleet.validate_many(_folders(directory, specs), scheduler="single")


def test_the_command_line_refuses_a_huge_permutation_count_before_any_log(logs, monkeypatch, capsys):
    directory, _ = logs
    monkeypatch.setattr(_run, "summarise_log", lambda *a, **k: pytest.fail("a log ran before the settings' check"))
    code = main(["validate-many", str(directory / "manifest.csv"), "--permutations", str(10**12), "--no-progress"])
    out, err = capsys.readouterr()
    assert code == 1 and out == ""
    assert "InvalidParameter: n_permutations must be an integer with 19 <= n_permutations <= 1000000" in err


def test_permutations_drawn_in_blocks_are_those_of_one_draw(monkeypatch):
    x = np.log([1.0, 1.1, 0.9, 1.05, 0.95, 1.2, 1.3, 1.25, 1.4, 1.1])
    whole = fleet.change_point(x, n_permutations=999, rng=np.random.default_rng(4))
    monkeypatch.setattr(_drift, "_SHUFFLE_BLOCK", 37)  # 999 = 27 × 37: blocks, and a last short one at 10
    assert fleet.change_point(x, n_permutations=999, rng=np.random.default_rng(4)) == whole
    monkeypatch.setattr(_drift, "_SHUFFLE_BLOCK", 100)
    assert fleet.change_point(x, n_permutations=999, rng=np.random.default_rng(4)) == whole


# --------------------------------------------------------------------------- N7: a broken log is an error row


def _folders(directory, specs):
    return [str(directory / s.log) for s in specs]


def test_a_missing_log_directory_is_an_error_row_and_the_fleet_goes_on(logs):
    directory, specs = logs
    missing = str(directory / "r01__2026-09-09")
    report = fleet.validate_many([*_folders(directory, specs), missing], n_params=10, scheduler="single",
                                 max_lag=5, progress=False)
    assert len(report.logs) == 6 and [r.error is None for r in report.logs] == [True] * 5 + [False]
    row = report.logs[-1]
    assert (row.robot, row.time, row.log, row.decision) == ("r01", "2026-09-09", "r01__2026-09-09", "error")
    assert row.error.startswith(f"FileInputError: {missing}: a log named ROBOT__TIME without a suffix is a directory")
    assert report.drift[0].n_logs == 5  # the drift test runs on the valid logs


def test_broken_logs_of_every_kind_are_rows_with_their_reason(logs, tmp_path):
    _, specs = logs
    no_pred = tmp_path / "r02__1"
    no_pred.mkdir()
    np.save(no_pred / "tau_meas.npy", np.zeros((10, 2)))
    folder_file = tmp_path / "r02__2"  # a directory where a file is expected
    (folder_file / "tau_meas.npy").mkdir(parents=True)
    np.save(folder_file / "tau_pred.npy", np.zeros((10, 2)))
    unnamed = tmp_path / "no-robot-here.npz"
    report = fleet.validate_many([specs[0], str(no_pred), str(folder_file), str(unnamed)], n_params=10,
                                 scheduler="single", max_lag=5)
    rows = {r.log: r for r in report.logs}
    assert rows[specs[0].log].error is None
    assert "the log directory holds no tau_pred file" in rows["r02__1"].error
    assert "tau_meas.npy: is not a regular file (a directory)" in rows["r02__2"].error
    # a path without a robot's name: the path stands for its robot, so that the row is seen
    assert rows["no-robot-here.npz"].robot == str(unnamed)
    assert "a log's name must be ROBOT__TIME" in rows["no-robot-here.npz"].error


def test_a_missing_log_of_a_dask_bag_is_an_error_row_not_a_failed_partition(logs):
    bag = pytest.importorskip("dask.bag")
    directory, specs = logs
    items = [*_folders(directory, specs[:3]), str(directory / "r01__2026-09-09"), str(directory / "unnamed")]
    report = fleet.validate_many(bag.from_sequence(items, npartitions=2), n_params=10, scheduler="single", max_lag=5)
    assert [r.error is None for r in report.logs] == [True, True, True, False, False]
    assert "r01__2026-09-09: a log named ROBOT__TIME without a suffix" in report.logs[3].error
    assert "a log's name must be ROBOT__TIME" in report.logs[4].error


def test_a_bad_row_of_a_mapping_is_an_error_row(logs):
    _, specs = logs
    bad = {"robot": "r09", "time": "1", "tau_meas": specs[0].tau_meas, "tau_pred": "", "n_params": 3}
    report = fleet.validate_many([specs[0], bad], scheduler="single", max_lag=5)
    assert report.logs[0].error is None
    assert report.logs[1].robot == "r09" and "no tau_pred" in report.logs[1].error


def test_a_manifest_naming_itself_as_a_log_s_file_gives_an_error_row(tmp_path, logs):
    _, specs = logs
    path = tmp_path / "fleet.csv"
    path.write_text(HEADER + f"r,1,fleet.csv,{specs[0].tau_pred},10\nr,2,{specs[1].tau_meas},"
                    f"{specs[1].tau_pred},10\n", encoding="utf-8")
    report = fleet.validate_many([str(path)], scheduler="single", max_lag=5)
    assert report.logs[0].decision == "error" and f"{path}" in report.logs[0].error
    assert report.logs[1].error is None


def test_relative_paths_are_relative_to_the_manifest_even_when_they_leave_its_directory(tmp_path, logs, monkeypatch):
    _, specs = logs
    (tmp_path / "data").mkdir()
    (tmp_path / "lists").mkdir()
    np.save(tmp_path / "data" / "m.npy", np.load(specs[0].tau_meas))
    np.save(tmp_path / "data" / "p.npy", np.load(specs[0].tau_pred))
    path = tmp_path / "lists" / "fleet.csv"
    path.write_text(HEADER + "r,1,../data/m.npy,../data/p.npy,10\n", encoding="utf-8")
    monkeypatch.chdir("/")  # not the manifest's directory
    spec, = fleet.read_manifest(str(path))
    assert os.path.normpath(spec.tau_meas) == str(tmp_path / "data" / "m.npy")
    report = fleet.validate_many([str(path)], scheduler="single", max_lag=5)
    assert report.logs[0].error is None


def test_the_command_line_prints_the_fleet_with_its_error_row_and_exits_1(logs, capsys):
    directory, specs = logs
    code = main(["validate-many", *_folders(directory, specs), str(directory / "r01__2026-09-09"),
                 "--n-params", "10", "--max-lag", "5", "--json", "--no-progress"])
    out = json.loads(capsys.readouterr().out)
    assert code == 1 and len(out["logs"]) == 6
    assert [row["decision"] == "error" for row in out["logs"]] == [False] * 5 + [True]


def test_a_robot_named_with_a_byte_that_is_not_utf8_is_tested_for_drift(logs, tmp_path):
    """A log path with byte 0xff in its robot's name (Python keeps it as U+DCFF) stopped the drift test with
    UnicodeEncodeError (exit 3 on the command line) once the robot had enough logs to be tested."""
    _, specs = logs
    for spec in specs:
        name = os.path.basename(spec.tau_meas.rsplit(os.sep, 1)[0])  # ROBOT__TIME of its directory
        os.symlink(os.path.dirname(spec.tau_meas), tmp_path / os.fsdecode(b"r\xff" + name.encode()[name.index("__"):]))
    paths = sorted(str(p) for p in tmp_path.iterdir())
    report = fleet.validate_many(paths, n_params=1, scheduler="single", progress=False, max_lag=5)
    assert [d.robot for d in report.drift] == ["r\udcff"] and report.drift[0].tested
    assert all(r.error is None for r in report.logs)
