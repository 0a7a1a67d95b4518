"""The dynval command line: file formats, output, exit codes, subcommand dispatch."""

from __future__ import annotations

import json
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
def files(tmp_path):
    rng = np.random.default_rng(0)
    t = np.arange(200) / 20.0
    meas = np.column_stack([10 * np.sin(t), np.cos(2 * t)])
    pred = meas + rng.normal(0.0, 0.1, meas.shape)
    Y = rng.normal(size=(200, 2, 3))
    paths = {
        "meas_npy": tmp_path / "meas.npy",
        "pred_npy": tmp_path / "pred.npy",
        "npz": tmp_path / "both.npz",
        "meas_csv": tmp_path / "meas.csv",
        "pred_csv": tmp_path / "pred.csv",
        "reg_npy": tmp_path / "Y.npy",
        "reg_csv": tmp_path / "Y.csv",
    }
    np.save(paths["meas_npy"], meas)
    np.save(paths["pred_npy"], pred)
    np.save(paths["reg_npy"], Y)
    np.savez(paths["npz"], meas=meas, pred=pred)
    np.savetxt(paths["meas_csv"], meas, delimiter=";", header="joint1;joint2", comments="")
    np.savetxt(paths["pred_csv"], pred, delimiter=",", fmt="%.17g")
    np.savetxt(paths["reg_csv"], Y.reshape(400, 3), delimiter="\t", fmt="%.17g")
    return {k: str(v) for k, v in paths.items()}, meas, pred, Y


def run(capsys, *argv):
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_validate_npy_prints_the_summary(files, capsys):
    paths, meas, pred, _ = files
    code, out, err = run(capsys, "validate", paths["meas_npy"], paths["pred_npy"], "--n-params", "3")
    assert code == 0 and err == ""
    assert out == dynval.validate(meas, pred, n_params=3).summary() + "\n"


def test_validate_json_matches_the_api(files, capsys):
    paths, meas, pred, Y = files
    code, out, _ = run(capsys, "validate", paths["meas_npy"], paths["pred_npy"], "--n-params", "3",
                       "--regressor", paths["reg_npy"], "--max-lag", "7", "--profile", "matlab", "--json")
    assert code == 0
    expected = dynval.validate(meas, pred, n_params=3, regressor=Y, max_lag=7, profile="matlab").to_dict()
    assert json.loads(out) == json.loads(json.dumps(expected))


def test_validate_csv_with_header_and_sniffed_delimiters(files, capsys):
    paths, meas, pred, Y = files
    code, out, _ = run(capsys, "validate", paths["meas_csv"], paths["pred_csv"], "--n-params", "3",
                       "--regressor", paths["reg_csv"], "--n-joints", "2", "--json", "--max-lag", "4")
    assert code == 0
    got = json.loads(out)
    # meas.csv was written with %.18e (exact); pred.csv with 17 significant digits (exact); its
    # header names the joints
    ref = dynval.validate(meas, pred, n_params=3, regressor=Y.reshape(400, 3), n_joints=2, max_lag=4,
                          joint_names=["joint1", "joint2"])
    assert got == json.loads(ref.to_json())


def test_the_measured_csv_header_names_the_joints_unless_told_otherwise(files, capsys, tmp_path):
    paths, meas, _, _ = files
    code, out, _ = run(capsys, "validate", paths["meas_csv"], paths["pred_npy"], "--n-params", "3", "--json")
    assert code == 0 and json.loads(out)["provenance"]["joint_names"] == ["joint1", "joint2"]
    code, out, _ = run(capsys, "validate", paths["meas_csv"], paths["pred_npy"], "--n-params", "3", "--json",
                       "--joint-names", "shoulder,elbow")
    assert json.loads(out)["provenance"]["joint_names"] == ["shoulder", "elbow"]
    code, out, _ = run(capsys, "compare", paths["meas_csv"], "--model", f"a={paths['pred_npy']}:3", "--json")
    assert code == 0 and json.loads(out)["reports"]["a"]["provenance"]["joint_names"] == ["joint1", "joint2"]
    # a header that does not name every column once is not taken for names
    for header in ("a;a", "t;a;b", ""):
        bad = tmp_path / "bad.csv"
        np.savetxt(bad, meas, delimiter=";", header=header, comments="")
        code, out, _ = run(capsys, "validate", str(bad), paths["pred_npy"], "--n-params", "3", "--json")
        assert code == 0 and json.loads(out)["provenance"]["joint_names"] == ["joint 1", "joint 2"], header


def test_npz_first_array_and_key(files, capsys):
    paths, meas, pred, _ = files
    code, out, _ = run(capsys, "validate", paths["npz"], paths["npz"] + ":pred", "--n-params", "1", "--json")
    assert code == 0
    assert json.loads(out)["pooled"]["sse"] == pytest.approx(float(np.sum((meas - pred) ** 2)), rel=1e-12)
    code, _, err = run(capsys, "validate", paths["npz"] + ":nope", paths["npz"], "--n-params", "1")
    assert code == 1 and "no array named 'nope'" in err


def test_output_file(files, capsys, tmp_path):
    paths, _meas, _pred, _ = files
    target = tmp_path / "report.json"
    code, out, _ = run(capsys, "validate", paths["meas_npy"], paths["pred_npy"], "--n-params", "2",
                       "--json", "--output", str(target))
    assert code == 0 and out == ""
    assert json.loads(target.read_text())["provenance"]["n_params"] == 2


def test_segments_nan_policy_level(files, capsys, tmp_path):
    paths, meas, _pred, _ = files
    bad = meas.copy()
    bad[10, 0] = np.nan
    np.save(tmp_path / "bad.npy", bad)
    code, out, err = run(capsys, "validate", str(tmp_path / "bad.npy"), paths["pred_npy"], "--n-params", "2",
                         "--nan-policy", "omit", "--segments", "100,100", "--level", "0.9", "--json")
    assert code == 0, err
    prov = json.loads(out)["provenance"]
    assert prov["segments"] == [10, 89, 100] and prov["omitted_rows"] == 1
    assert prov["conventions"]["level"] == 0.9
    code, _, err = run(capsys, "validate", str(tmp_path / "bad.npy"), paths["pred_npy"], "--n-params", "2")
    assert code == 1
    assert "NonFiniteInput: tau_meas has a non-finite value (nan) at row 10, column 0" in err


def test_pickles_are_refused(tmp_path, capsys, files):
    paths = files[0]
    obj = tmp_path / "obj.npy"
    np.save(obj, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    code, out, err = run(capsys, "validate", str(obj), paths["pred_npy"], "--n-params", "1")
    assert code == 1 and out == ""
    assert "pickled Python objects" in err and "refuses" in err
    pkl = tmp_path / "x.pkl"
    pkl.write_bytes(b"\x80\x04N.")
    code, _, err = run(capsys, "validate", str(pkl), paths["pred_npy"], "--n-params", "1")
    assert code == 1 and "pickle files are refused" in err


@pytest.mark.parametrize("argv, needle", [
    (["validate", "{meas}", "missing.npy", "--n-params", "1"], "missing.npy: no such file"),
    (["validate", "{meas}", "{meas}.txt", "--n-params", "1"], "no such file"),
    (["validate", "{meas}", "{pred}", "--n-params", "-1"],
     "InvalidParameter: n_params must be an integer with n_params >= 0, got -1"),
    (["validate", "{meas}", "{pred}", "--n-params", "1", "--max-lag", "500"],
     "InvalidParameter: max_lag must be an integer with 0 <= max_lag < 200, got 500"),
    (["validate", "{meas}", "{pred}", "--n-params", "1", "--backend", "fortran"], "InvalidParameter: backend"),
])
def test_input_errors_exit_1_with_message(argv, needle, files, capsys):
    paths = files[0]
    argv = [a.format(meas=paths["meas_npy"], pred=paths["pred_npy"]) for a in argv]
    code, out, err = run(capsys, *argv)
    assert code == 1 and out == ""
    assert needle in err


def test_bad_csv_is_an_input_error(tmp_path, capsys, files):
    bad = tmp_path / "bad.csv"
    bad.write_text("a,b\n1,2\n3,x\n")
    code, _, err = run(capsys, "validate", str(bad), files[0]["pred_npy"], "--n-params", "1")
    assert code == 1 and f"{bad}: line 3, column 2: 'x' is not a number" in err
    ragged = tmp_path / "ragged.csv"
    ragged.write_text("1,2\n3\n")
    code, _, err = run(capsys, "validate", str(ragged), files[0]["pred_npy"], "--n-params", "1")
    assert code == 1 and "line 2 has 1 values, line 1 has 2" in err


@pytest.mark.parametrize("argv", [
    ["validate", "a.npy", "b.npy"],                       # --n-params missing
    ["validate", "a.npy", "b.npy", "--n-params", "x"],    # not an integer
    ["validate", "a.npy", "b.npy", "--n-params", "1", "--profile", "R"],
    ["validate", "a.npy", "b.npy", "--n-params", "1", "--segments", "a,b"],
    ["frobnicate"],
    [],
])
def test_usage_errors_exit_2(argv, capsys):
    code, _out, err = run(capsys, *argv)
    assert code == 2
    assert "usage:" in err


@pytest.mark.parametrize("argv", [["--help"], ["validate", "--help"], ["demo", "--help"]])
def test_help_exits_0(argv, capsys):
    code, out, _ = run(capsys, *argv)
    assert code == 0 and "usage:" in out


def test_conform_is_dispatched_with_the_rest_of_the_arguments(monkeypatch):
    import dynval.conform

    seen = {}

    def fake_main(argv):
        seen["argv"] = list(argv)
        return 3

    monkeypatch.setattr(dynval.conform, "main", fake_main)
    assert cli.main(["conform", "--families", "norms", "--", "./port", "-x"]) == 3
    assert seen["argv"] == ["--families", "norms", "--", "./port", "-x"]


def test_python_dash_m_and_exit_codes():
    env = dict(os.environ, PYTHONPATH=str(ROOT / "python") + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-m", "dynval", "--help"], capture_output=True, text=True, env=env,
                          timeout=60)
    assert done.returncode == 0 and "validate" in done.stdout and "demo" in done.stdout
    done = subprocess.run([sys.executable, "-m", "dynval", "validate", "nothing.npy", "nothing.npy",
                           "--n-params", "1"], capture_output=True, text=True, env=env, timeout=60)
    assert done.returncode == 1 and "nothing.npy: no such file" in done.stderr


def _env():
    return dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT / "python")] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))


# A child that imports dynval, says so on stderr and waits for the go-ahead on stdin before running
# the command line: stdout can then be closed after the import, whatever the import prints.
_PIPE_CHILD = ("import sys, dynval.cli\n"
               "sys.stderr.write('ready\\n'); sys.stderr.flush()\n"
               "sys.stdin.readline()\n"
               "sys.exit(dynval.cli.main(sys.argv[1:]))\n")


def test_a_closed_stdout_ends_quietly_with_the_sigpipe_code(files):
    # `dynval validate ... | head -1`: the reader goes away before the first write, so the write
    # fails whatever the size of the output.
    import threading

    paths = files[0]
    proc = subprocess.Popen([sys.executable, "-c", _PIPE_CHILD, "validate", paths["meas_npy"], paths["pred_npy"],
                             "--n-params", "1"], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env=_env())
    watchdog = threading.Timer(120, proc.kill)
    watchdog.start()
    try:
        for line in proc.stderr:
            if line == b"ready\n":
                break
        proc.stdout.close()
        proc.stdin.write(b"go\n")
        proc.stdin.close()
        err = proc.stderr.read()
        proc.wait()
    finally:
        watchdog.cancel()
        proc.stderr.close()
    assert proc.returncode == 141, err
    assert err == b""


@pytest.mark.parametrize("command", ["validate", "compare"])
def test_the_segments_examples_of_the_help_parse(command, files, capsys):
    import re

    code, out, _ = run(capsys, command, "--help")
    assert code == 0
    text = " ".join(out.split())
    help_line = re.search(r"--segments S (.*?) --", text).group(1)
    examples = re.findall(r"e\.g\. ([^ ,)]+(?:,[^ ,)]+)+)", help_line)
    assert len(examples) == 2, help_line
    paths, _meas, _pred, _ = files
    for example in examples:   # 200 samples: lengths 150,50 and starts 0,150
        argv = ["validate", paths["meas_npy"], paths["pred_npy"], "--n-params", "1", "--segments", example,
                "--json"]
        args = cli.build_parser().parse_args(argv)
        assert args.segments == [int(v) for v in example.split(",")]
    assert run(capsys, "validate", paths["meas_npy"], paths["pred_npy"], "--n-params", "1",
               "--segments", "150,50")[0] == 0
    assert run(capsys, "validate", paths["meas_npy"], paths["pred_npy"], "--n-params", "1",
               "--segments", "0,150")[0] == 0


def test_n_joints_without_a_regressor_is_a_usage_error(files, capsys):
    paths = files[0]
    code, out, err = run(capsys, "validate", paths["meas_npy"], paths["pred_npy"], "--n-params", "1",
                         "--n-joints", "2")
    assert code == 2 and out == ""
    assert "usage: dynval validate" in err and "--n-joints needs --regressor" in err
    code, _, err = run(capsys, "compare", paths["meas_npy"], "--model", f"a={paths['pred_npy']}:1",
                       "--n-joints", "2")
    assert code == 2 and "--n-joints needs --regressor" in err


def test_transposed_files_are_refused_unless_allow_wide(tmp_path, capsys):
    rng = np.random.default_rng(1)
    meas = rng.normal(size=(6, 50))
    np.save(tmp_path / "meas.npy", meas)
    np.save(tmp_path / "pred.npy", meas + rng.normal(scale=0.1, size=meas.shape))
    argv = ["validate", str(tmp_path / "meas.npy"), str(tmp_path / "pred.npy"), "--n-params", "1"]
    code, out, err = run(capsys, *argv)
    assert code == 1 and out == ""
    assert "TooFewSamples: validate needs at least as many samples as joints (N >= m), got tau_meas of shape " \
           "(6, 50)" in err
    assert "transpose them, or pass --allow-wide if N < m is intended" in err
    code, out, err = run(capsys, *argv, "--allow-wide", "--json")
    assert code == 0, err
    assert json.loads(out)["provenance"]["n_joints"] == 50
    code, _, err = run(capsys, "compare", str(tmp_path / "meas.npy"), "--model", f"a={tmp_path / 'pred.npy'}:1")
    assert code == 1 and "--allow-wide" in err


def test_an_unexpected_error_is_reported_without_a_traceback(files, capsys, monkeypatch):
    import dynval.report._report

    def broken(*args, **kwargs):
        raise RuntimeError("boom")

    monkeypatch.setattr(dynval.report._report, "validate", broken)
    paths = files[0]
    argv = ["validate", paths["meas_npy"], paths["pred_npy"], "--n-params", "1"]
    monkeypatch.delenv("DYNVAL_TRACEBACK", raising=False)
    code, out, err = run(capsys, *argv)
    assert code == 3 and out == ""
    assert err.startswith("dynval validate: internal error: RuntimeError: boom (please report it")
    monkeypatch.setenv("DYNVAL_TRACEBACK", "1")
    with pytest.raises(RuntimeError, match="boom"):
        cli.main(argv)


def test_running_out_of_memory_is_an_input_error(files, capsys, monkeypatch):
    import dynval.report._report

    def too_big(*args, **kwargs):
        raise MemoryError

    monkeypatch.setattr(dynval.report._report, "validate", too_big)
    paths = files[0]
    code, _, err = run(capsys, "validate", paths["meas_npy"], paths["pred_npy"], "--n-params", "1")
    assert code == 1 and err == "dynval validate: error: not enough memory for this input\n"


@pytest.mark.parametrize("which", ["meas", "pred"])
def test_a_file_transposed_alone_is_named_as_transposed(files, capsys, tmp_path, which):
    paths, meas, pred, _ = files
    flipped = tmp_path / "flipped.npy"
    np.save(flipped, (meas if which == "meas" else pred).T)
    argv = ([str(flipped), paths["pred_npy"]] if which == "meas" else [paths["meas_npy"], str(flipped)])
    for extra in ([], ["--stream"]):
        code, _, err = run(capsys, "validate", *argv, "--n-params", "3", *extra)
        assert code == 1
        assert f"; tau_{which} looks transposed (its shape is the other's reversed): samples are rows" in err
    code, _, err = run(capsys, "validate", paths["meas_npy"], paths["pred_npy"], "--n-params", "3")
    assert code == 0 and "transposed" not in err


def test_html_takes_joint_names_that_were_not_utf8(files, tmp_path, capsys):
    """--joint-names with byte 0xff (Python's lone surrogate U+DCFF) ended in exit 3 with --html."""
    paths, _, _, _ = files
    page = tmp_path / "r.html"
    code, _out, err = run(capsys, "validate", paths["meas_npy"], paths["pred_npy"], "--n-params", "1",
                         "--joint-names", "\udcff,$\\frac$", "--html", str(page))
    assert code in (0, 1) and "internal error" not in err, err
    text = page.read_text(encoding="utf-8")
    assert "\\xff" in text and "$\\frac$" in text
