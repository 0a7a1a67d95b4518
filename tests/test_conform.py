"""``dynval conform`` end to end: dynval's own ports pass, every wrong port fails for its reason.

The wrong ports (tests/ports/) run against a small hand-written corpus
(tests/ports/tiny_corpus.py) so that their expected outcomes do not move with the
real corpus; dynval's backends run against the real corpus.
"""

from __future__ import annotations

import io
import json
import os
import pathlib
import re
import subprocess
import sys
import time

import pytest

import dynval
from dynval import protocol
from dynval.conform import main
from dynval.golden import FAMILIES, OPTIONAL_FAMILIES
from ports.tiny_corpus import case_ids, write_tiny_corpus

PORTS = pathlib.Path(__file__).resolve().parent / "ports"
PACKAGE_ROOT = str(pathlib.Path(dynval.__file__).resolve().parent.parent)


@pytest.fixture(autouse=True)
def _ports_find_dynval(monkeypatch):
    # Ports are separate processes: they must import the dynval under test.
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [PACKAGE_ROOT, os.environ.get("PYTHONPATH")])))
    # A verbose editable install prints "Running cmake --build ..." on standard output when
    # dynval is imported, ahead of the port's greeting.
    monkeypatch.setenv("SKBUILD_EDITABLE_VERBOSE", "0")


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    return str(write_tiny_corpus(tmp_path_factory.mktemp("corpus")))


def conform(args, tmp_path, *, corpus=None):
    """Run ``dynval conform`` in process; return (exit code, stdout, report dict)."""
    report = tmp_path / "report.json"
    out, err = io.StringIO(), io.StringIO()
    options = ["--report", str(report), "--quiet"] + (["--corpus", corpus] if corpus else [])
    split = args.index("--")
    code = main(args[:split] + options + args[split:], stdout=out, stderr=err)
    data = json.loads(report.read_text()) if report.exists() else None
    return code, out.getvalue(), data


def port(script, *args, corpus):
    return ["--", sys.executable, str(PORTS / script), "--corpus", corpus, *args]


def by_status(report, status):
    return {c["id"]: c for c in report["cases"] if c["status"] == status}


# The tiny corpus has one case protocol 1 cannot carry (a nested plain list as data).
NOT_EXPRESSIBLE = {"errors-6"}


# --------------------------------------------------------------------------- a correct port


def test_oracle_port_passes(tiny, tmp_path):
    code, out, report = conform(port("oracle.py", corpus=tiny), tmp_path, corpus=tiny)
    assert code == 0, out
    assert set(by_status(report, "passed")) == set(case_ids()) - NOT_EXPRESSIBLE
    skipped = by_status(report, "skipped")
    assert set(skipped) == NOT_EXPRESSIBLE and skipped["errors-6"]["reason"] == "not-expressible"
    assert report["counts"]["total"] == {"passed": 19, "failed": 0, "skipped": 1, "partial": 0}
    assert report["protocol_version"] == 1 and report["port"]["name"] == "oracle"
    assert report["exit_code"] == 0 and report["restarts"] == 0
    # the table: one row per family of the tiny corpus (it has no optional family), then the total
    for family in set(FAMILIES) - set(OPTIONAL_FAMILIES):
        assert family in out
    assert "OK: 19 passed, 0 failed, 1 skipped, 0 partial" in out


def test_strict_fails_on_skipped_cases(tiny, tmp_path):
    code, out, _ = conform(["--strict", *port("oracle.py", corpus=tiny)], tmp_path, corpus=tiny)
    assert code == 1 and "FAILED: 19 passed, 0 failed, 1 skipped" in out


def test_families_subset(tiny, tmp_path):
    code, _, report = conform(["--families", "norms,errors", *port("oracle.py", corpus=tiny)], tmp_path, corpus=tiny)
    assert code == 0
    assert {c["family"] for c in report["cases"]} == {"norms", "errors"}
    assert report["families"] == ["norms", "errors"]


# --------------------------------------------------------------------------- number encodings


def test_hex_port_receives_hex_and_may_answer_in_both(tiny, tmp_path):
    record = tmp_path / "received.txt"
    for answers in ("hex", "decimal"):
        code, out, report = conform(port("oracle.py", "--encoding", "hex", "--answer-encoding", answers,
                                         "--record", str(record), corpus=tiny), tmp_path, corpus=tiny)
        assert code == 0, out
        assert report["counts"]["total"] == {"passed": 19, "failed": 0, "skipped": 1, "partial": 0}
        assert report["port"]["encoding"] == "hex"
        assert "hexadecimal floats" in out
    received = record.read_text()
    floats = re.findall(r"-?0x[0-9a-f.]+p[+-][0-9]+", received)
    assert floats and all(t == protocol.format_real(protocol.parse_real(t, hex_ok=True), "hex") for t in floats)
    assert not re.search(r"[0-9]\.[0-9]{16}e[+-][0-9]+", received)


def test_hex_answers_without_the_handshake_are_garbage(tiny, tmp_path):
    code, _, report = conform(port("oracle.py", "--answer-encoding", "hex", corpus=tiny), tmp_path, corpus=tiny)
    assert code == 1
    assert report["port"]["encoding"] == "decimal"
    failed = by_status(report, "failed")
    assert failed and {c["reason"] for c in failed.values()} == {"garbage"}
    assert all("encoding hex" in c["detail"] for c in failed.values())


def test_decimal_port_receives_decimal(tiny, tmp_path):
    record = tmp_path / "received.txt"
    code, out, _ = conform(port("oracle.py", "--record", str(record), corpus=tiny), tmp_path, corpus=tiny)
    assert code == 0, out
    assert "0x" not in record.read_text()


@pytest.mark.parametrize(("lines", "says"), [(["encoding hex", "encoding hex"], "sent 2 times"),
                                             (["encoding octal"], "expected 'encoding decimal|hex'")])
def test_bad_encoding_line_is_a_handshake_failure(tiny, tmp_path, lines, says):
    script = tmp_path / "bad_encoding.py"
    script.write_text("import sys\nprint('dynval-port 1 x')\n" + "".join(f"print({line!r})\n" for line in lines)
                      + "print('capability r2')\nprint('ready', flush=True)\nsys.stdin.read()\n")
    code, _, report = conform(["--", sys.executable, str(script)], tmp_path, corpus=tiny)
    assert code == 1
    assert says in report["port"]["startup_error"]


def test_dynval_port_passes_the_real_corpus_in_hex(tmp_path):
    code, out, report = conform(["--", sys.executable, "-m", "dynval.port", "--backend", "python", "--encoding", "hex"],
                                tmp_path)
    assert report["counts"]["total"]["failed"] == 0, out
    assert code == 0
    assert report["port"]["encoding"] == "hex"
    assert report["counts"]["total"]["passed"] >= 0.99 * len(report["cases"])


# --------------------------------------------------------------------------- wrong ports


def test_wrong_value_is_caught(tiny, tmp_path):
    code, out, report = conform(port("wrong_value.py", "--operation", "rmse", corpus=tiny), tmp_path, corpus=tiny)
    assert code == 1
    failed = by_status(report, "failed")
    assert set(failed) == {"norms-2", "norms-3"}  # the two rmse vectors, nothing else
    assert all(c["reason"] == "mismatch" for c in failed.values())
    assert "expected 1.2909944487358056, got 1.29099574" in failed["norms-2"]["detail"]
    assert failed["norms-2"]["expected"] == {"value": 1.2909944487358056}
    assert "FAILED norms-2  [mismatch]  rmse" in out and "expected:" in out and "got:" in out


def test_wrong_error_kind_is_caught(tiny, tmp_path):
    code, _, report = conform(port("wrong_error_kind.py", corpus=tiny), tmp_path, corpus=tiny)
    assert code == 1
    failed = by_status(report, "failed")
    assert set(failed) == {"errors-1", "errors-2", "errors-3", "errors-4", "errors-5"}
    assert all(c["reason"] == "wrong-error" for c in failed.values())
    assert failed["errors-1"]["detail"].startswith("raised NonFiniteInput, expected TooFewSamples")
    assert failed["errors-1"]["got"] == {"error": "NonFiniteInput"}


def test_claimed_output_missing_is_caught(tiny, tmp_path):
    args = port("missing_output.py", "--operation", "ljung_box", "--drop", "pvalue", corpus=tiny)
    code, _, report = conform(args, tmp_path, corpus=tiny)
    assert code == 1
    failed = by_status(report, "failed")
    assert set(failed) == {"portmanteau-1", "portmanteau-2"}
    assert all(c["reason"] == "missing-output" and c["detail"] == "pvalue: missing" for c in failed.values())


def test_claimed_capability_not_answered_is_caught(tiny, tmp_path):
    args = port("missing_output.py", "--operation", "ljung_box", "--drop", "-", "--silent", corpus=tiny)
    code, _, report = conform(args, tmp_path, corpus=tiny)
    assert code == 1
    failed = by_status(report, "failed")
    assert set(failed) == {"portmanteau-1", "portmanteau-2"}
    assert all(c["reason"] == "missing-output" for c in failed.values())


def test_declared_partial_capability_is_partial_not_passed(tiny, tmp_path):
    # A port without a chi-square survival function: statistics yes, p-values no.
    args = port("missing_output.py", "--operation", "ljung_box", "--drop", "pvalue,log_pvalue",
                "--keep", "lags,statistic,df", "--declare", corpus=tiny)
    code, out, report = conform(args, tmp_path, corpus=tiny)
    assert code == 0, out
    partial = by_status(report, "partial")
    assert set(partial) == {"portmanteau-1", "portmanteau-2"}
    assert partial["portmanteau-1"]["skipped_outputs"] == ["pvalue", "log_pvalue"]
    assert "capability ljung_box outputs=df,lags,statistic" in report["port"]["capabilities"]
    assert "portmanteau-1" not in by_status(report, "passed")
    code, _, _ = conform(["--strict", *args], tmp_path, corpus=tiny)
    assert code == 1


def test_crash_is_caught_and_the_port_restarted(tiny, tmp_path):
    code, _, report = conform(port("crash.py", "--target", "normalized_fit-2", corpus=tiny), tmp_path, corpus=tiny)
    assert code == 1
    failed = by_status(report, "failed")
    assert set(failed) == {"normalized_fit-2"}
    assert failed["normalized_fit-2"]["reason"] == "crash"
    assert "exited with code 3" in failed["normalized_fit-2"]["detail"]
    assert "segmentation fault (simulated)" in failed["normalized_fit-2"]["detail"]  # the port's stderr
    assert report["restarts"] == 1
    assert len(by_status(report, "passed")) == 18  # every case after the crash ran


def test_hang_is_caught_within_the_timeout(tiny, tmp_path):
    start = time.monotonic()
    # --timeout alone would also bound the restart's handshake to 0.5 s: too short to import dynval.
    code, _, report = conform(["--timeout", "0.5", "--startup-timeout", "60",
                               *port("hang.py", "--target", "norms-3", corpus=tiny)], tmp_path, corpus=tiny)
    assert time.monotonic() - start < 15
    assert code == 1
    failed = by_status(report, "failed")
    assert set(failed) == {"norms-3"}
    assert failed["norms-3"]["reason"] == "timeout" and "timed out after 0.5 s" in failed["norms-3"]["detail"]
    assert report["restarts"] == 1 and len(by_status(report, "passed")) == 18


def test_hang_at_start_is_a_handshake_failure(tiny, tmp_path):
    start = time.monotonic()
    code, out, report = conform(["--startup-timeout", "2", *port("hang.py", "--at-start", corpus=tiny)],
                                tmp_path, corpus=tiny)
    assert time.monotonic() - start < 15
    assert code == 1 and "port did not start" in out
    assert {c["reason"] for c in report["cases"]} == {"handshake"}
    assert "waiting for the capability lines" in report["port"]["startup_error"]


@pytest.mark.parametrize("extra", [[], ["--no-newline"]], ids=["lines", "one-endless-line"])
def test_flood_is_caught(tiny, tmp_path, extra):
    start = time.monotonic()
    code, _, report = conform(["--timeout", "10", *port("flood.py", "--target", "norms-1", *extra, corpus=tiny)],
                              tmp_path, corpus=tiny)
    assert time.monotonic() - start < 15  # killed on the byte budget, long before the timeout
    assert code == 1
    failed = by_status(report, "failed")
    assert set(failed) == {"norms-1"} and failed["norms-1"]["reason"] == "flood"
    assert failed["norms-1"]["detail"].startswith("output flood")
    assert len(by_status(report, "passed")) == 18


@pytest.mark.parametrize(
    ("what", "says"),
    [("comma", "'1,5'"), ("wolfram", "'1.5*^-3'"), ("hexfloat", "'0x1.8p+0'"), ("word", "'hello world'"),
     ("binary", "non-ASCII")],
)
def test_garbage_is_caught(tiny, tmp_path, what, says):
    code, _, report = conform(port("garbage.py", "--target", "information_criteria-1", "--what", what, corpus=tiny),
                              tmp_path, corpus=tiny)
    assert code == 1
    failed = by_status(report, "failed")
    assert set(failed) == {"information_criteria-1"}
    assert failed["information_criteria-1"]["reason"] == "garbage"
    assert says in failed["information_criteria-1"]["detail"]
    assert len(by_status(report, "passed")) == 18


@pytest.mark.parametrize(("extra", "says"), [([], "speaks protocol 99"), (["--no-greeting"], "expected the greeting")])
def test_bad_handshake(tiny, tmp_path, extra, says):
    code, _, report = conform(port("bad_handshake.py", *extra, corpus=tiny), tmp_path, corpus=tiny)
    assert code == 1
    assert report["counts"]["total"]["failed"] == 20
    assert all(c["reason"] == "handshake" and says in c["detail"] for c in report["cases"])


def test_command_that_cannot_start(tiny, tmp_path):
    code, _, report = conform(["--", str(tmp_path / "no-such-port")], tmp_path, corpus=tiny)
    assert code == 1
    assert "cannot start the port" in report["port"]["startup_error"]


def test_restart_budget(tiny, tmp_path):
    # A port that crashes on its first case, every time: stop restarting after --max-restarts.
    script = tmp_path / "always_crash.py"
    script.write_text("import sys\nprint('dynval-port 1 x')\nprint('capability r2')\nprint('ready', flush=True)\n"
                      "sys.stdin.readline()\nsys.exit(9)\n")
    code, _, report = conform(["--max-restarts", "1", "--", sys.executable, str(script)], tmp_path, corpus=tiny)
    assert code == 1
    reasons = [c["reason"] for c in report["cases"] if c["operation"] == "r2"]
    assert reasons[:2] == ["crash", "crash"] and set(reasons[2:]) == {"not-run"}
    assert report["restarts"] == 1


# --------------------------------------------------------------------------- usage


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["--families", "bogus", "--", "x"], "--families must be among"),
        (["--quiet"], "give the port command after '--'"),
        (["--corpus", "/nonexistent", "--", "x"], "no norms.json"),
        (["--timeout", "0", "--", "x"], "--timeout must be a positive number"),
    ],
)
def test_usage_errors(argv, says):
    err = io.StringIO()
    assert main(argv, stdout=io.StringIO(), stderr=err) == 2
    assert says in err.getvalue()


def test_progress_on_a_terminal():
    from dynval.conform import _Progress
    from dynval.conform._runner import RunResult

    class Tty(io.StringIO):
        def isatty(self):
            return True

    stream = Tty()
    progress = _Progress(stream, enabled=True)
    result = RunResult(command=["x"], corpus="", families=["norms"])
    progress.last -= 1
    progress(1, 2, result)
    progress(2, 2, result)
    assert stream.getvalue().startswith("\rconform: 1/2 cases, 0 failed")
    assert stream.getvalue().endswith("\n")


def test_module_entry_point(tiny, tmp_path):
    done = subprocess.run(
        [sys.executable, "-m", "dynval.conform", "--corpus", tiny, "--families", "norms", "--",
         sys.executable, str(PORTS / "oracle.py"), "--corpus", tiny],
        capture_output=True, text=True, timeout=60,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert "OK: 4 passed, 0 failed" in done.stdout


# --------------------------------------------------------------------------- dynval's own ports


def _available(backend):
    return dynval.backends()[backend]["available"]


def test_dynval_port_passes_the_real_corpus(backend, tmp_path):
    # ``backend`` runs over every available backend (tests/conftest.py)
    code, out, report = conform(["--", sys.executable, "-m", "dynval.port", "--backend", backend], tmp_path)
    assert report["counts"]["total"]["failed"] == 0, out
    assert code == 0
    assert report["counts"]["total"]["passed"] >= 0.99 * len(report["cases"])
    assert f"({backend} backend)" in report["port"]["name"]


def test_dynval_port_speaks_the_protocol_directly():
    # A hand-written session: what a port author sees.
    session = "\n".join([
        'case norms 1 sse multioutput="pooled"',
        "array tau_meas real 2 2 1 1.0 2.0",
        "array tau_pred real 2 2 1 0.0 0.0",
        "end",
        'case errors 1 r2 multioutput="pooled"',
        "array tau_meas real 2 1 1 1.0",
        "array tau_pred real 2 1 1 1.0",
        "end",
        "quit",
    ]) + "\n"
    done = subprocess.run([sys.executable, "-m", "dynval.port", "--backend", "python"], input=session,
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("dynval-port 1 dynval")
    ready = lines.index("ready")
    assert all(line.startswith("capability ") for line in lines[1:ready])
    assert lines[ready + 1 :] == [
        "result value real 0 5.0000000000000000e+00", "end",  # SSE = 1 + 4
        "error TooFewSamples r2 needs at least 2 samples, got N=1", "end",
    ]


def test_dynval_port_refuses_an_unavailable_backend():
    # A None entry in sys.modules makes `import dynval._core` fail, as on a pure-Python install,
    # so the check runs whether or not the compiled backend is built here.
    hide_core = ("import runpy, sys; sys.modules['dynval._core'] = None; sys.argv = ['dynval.port'] + sys.argv[1:]; "
                 "runpy.run_module('dynval.port', run_name='__main__')")
    done = subprocess.run([sys.executable, "-c", hide_core, "--backend", "cpp"], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 2 and "not available" in done.stderr, (done.returncode, done.stderr)


# --------------------------------------------------------------------------- the conformance matrix

README_TEXT = """# x

intro

## Conformance

One line.

<!-- conformance-matrix:start -->
stale
<!-- conformance-matrix:end -->

## Layout
"""


def matrix(args):
    out, err = io.StringIO(), io.StringIO()
    code = main(["--matrix", "--quiet", *args], stdout=out, stderr=err)
    return code, out.getvalue(), err.getvalue()


def _port_option(name, script, *args, corpus):
    return f"--port={name}={sys.executable} {PORTS / script} --corpus {corpus} " + " ".join(args)


def _table_rows(out):
    return {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[2:-1]]
            for line in out.splitlines() if line.startswith("| ") and not line.startswith("| port")}


def test_matrix_of_dynval_ports(tmp_path):
    code, out, err = matrix(["--ports", "python,cpp", "--families", "information_criteria,errors"])
    assert code == 0, out + err
    lines = out.splitlines()
    assert lines[0] == "| port | `information_criteria` | `errors` | all |"
    assert lines[1] == "|---|---:|---:|---:|"
    from dynval.golden import iter_cases

    counts = [sum(1 for _ in iter_cases(families=[f])) for f in ("information_criteria", "errors")]
    cells = [f"{n}/{n}" for n in counts] + [f"{sum(counts)}/{sum(counts)}"]
    expected = {"python": cells, "cpp": cells} if _available("cpp") else {"python": cells}
    assert _table_rows(out) == expected


def test_matrix_rows_for_wrong_ports(tiny):
    code, out, _ = matrix(["--corpus", tiny, _port_option("oracle", "oracle.py", corpus=tiny),
                           _port_option("wrong", "wrong_value.py", "--operation", "rmse", corpus=tiny),
                           _port_option("crash", "crash.py", "--target", "norms-3", corpus=tiny)])
    assert code == 1  # a port that ran failed cases
    rows = _table_rows(out)
    assert list(rows) == ["oracle", "wrong", "crash"]
    # the tiny corpus: norms 4, normalized_fit 3, residual_statistics 2, autocorrelation 1, portmanteau 2,
    # cross_correlation 1, information_criteria 1, errors 6 (one of them not expressible: skipped)
    assert rows["oracle"] == ["4/4", "3/3", "2/2", "1/1", "2/2", "1/1", "1/1", "5/6", "19/20"]
    assert rows["wrong"][0] == "2/4" and rows["wrong"][-1] == "17/20"
    assert rows["crash"] == ["3/4"] + rows["oracle"][1:-1] + ["18/20"]


def test_matrix_says_which_ports_did_not_run(tmp_path, tiny):
    code, out, _ = matrix(["--corpus", tiny, "--root", str(tmp_path), "--ports", "java,matlab,wolfram",
                           _port_option("oracle", "oracle.py", corpus=tiny)])
    assert code == 0, out
    assert list(_table_rows(out)) == ["oracle"]
    for label, folder in (("java", "java"), ("matlab (Octave)", "matlab"), ("wolfram (Mathics)", "wolfram")):
        assert f"Not run: {label}: no {folder}/run-port under {tmp_path}" in out
    # a folder without its toolchain
    (tmp_path / "wolfram").mkdir()
    (tmp_path / "wolfram" / "run-port").write_text("#!/bin/sh\nexit 1\n")
    (tmp_path / "wolfram" / "run-port").chmod(0o755)
    env_path = os.environ["PATH"]
    try:
        os.environ["PATH"] = str(tmp_path / "empty")
        code, out, _ = matrix(["--corpus", tiny, "--root", str(tmp_path), "--ports", "wolfram"])
    finally:
        os.environ["PATH"] = env_path
    assert code == 0 and "Not run: wolfram (Mathics): toolchain missing: mathics not on PATH" in out


def test_matrix_writes_and_checks_the_readme(tmp_path, tiny):
    readme = tmp_path / "README.md"
    readme.write_text(README_TEXT)
    ports = ["--corpus", tiny, _port_option("oracle", "oracle.py", corpus=tiny)]
    code, out, _ = matrix([*ports, "--check-readme", str(readme)])
    assert code == 1 and "differs from a fresh run" in out and "-stale" in out
    code, out, _ = matrix([*ports, "--write-readme", str(readme)])
    assert code == 0 and "matrix updated" in out
    text = readme.read_text()
    before, _, rest = text.partition("<!-- conformance-matrix:start -->\n")
    table, _, after = rest.partition("\n<!-- conformance-matrix:end -->")
    assert before == README_TEXT.partition("<!-- conformance-matrix:start -->")[0]  # nothing else touched
    assert after == README_TEXT.partition("<!-- conformance-matrix:end -->")[2]
    assert table.splitlines()[2] == "| oracle | 4/4 | 3/3 | 2/2 | 1/1 | 2/2 | 1/1 | 1/1 | 5/6 | 19/20 |"
    code, out, _ = matrix([*ports, "--check-readme", str(readme)])
    assert code == 0 and "matrix is current" in out
    code, out, _ = matrix([*ports, "--write-readme", str(readme)])
    assert code == 0 and "already current" in out
    # a fresh run that differs (a wrong port now) fails the check
    wrong = ["--corpus", tiny, _port_option("oracle", "wrong_value.py", "--operation", "rmse", corpus=tiny)]
    code, out, _ = matrix([*wrong, "--check-readme", str(readme)])
    assert code == 1 and "-| oracle | 4/4" in out and "+| oracle | 2/4" in out


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["--matrix", "--", "x"], "give no command after '--'"),
        (["--write-readme", "--", "x"], "need --matrix"),
        (["--matrix", "--ports", "fortran"], "unknown port 'fortran'"),
        (["--matrix", "--port", "nocommand"], "--port needs NAME=COMMAND"),
        (["--matrix", "--ports", "python", "--check-readme", "/nonexistent/README.md"], "No such file"),
        (["--matrix", "--ports", "python", "--write-readme", "x", "--check-readme", "y"], "exclude each other"),
    ],
)
def test_matrix_usage_errors(argv, says, tmp_path):
    err = io.StringIO()
    assert main(argv, stdout=io.StringIO(), stderr=err) == 2
    assert says in err.getvalue()


def test_matrix_needs_the_markers(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text("# no markers\n")
    err = io.StringIO()
    assert main(["--matrix", "--ports", "python", "--check-readme", str(readme)], stdout=io.StringIO(),
                stderr=err) == 2
    assert "markers" in err.getvalue()


# --------------------------------------------------------------------------- time limits and cleanup

# A port that leaves a sleeping child behind. MODE "stdout": the child keeps the port's
# standard output open and the port exits at once, without greeting. MODE "setsid": the
# child leaves the port's process group and session (os.setsid) and the port itself then
# greets with one capability and either exits on `quit` (ON_QUIT "exit") or ignores it
# (ON_QUIT "hang", so that the runner has to kill it).
ORPHAN_PORT = '''\
import os, subprocess, sys, time
mode, on_quit, pidfile, token = sys.argv[1:5]
child = ("import os, sys, time\\n"
         "if sys.argv[1] == 'setsid':\\n    os.setsid()\\n"
         "open(sys.argv[2] + '.tmp', 'w').write(str(os.getpid()))\\n"
         "os.replace(sys.argv[2] + '.tmp', sys.argv[2])\\n"
         "time.sleep(3600)\\n")
quiet = {} if mode == "stdout" else {"stdin": subprocess.DEVNULL, "stdout": subprocess.DEVNULL,
                                     "stderr": subprocess.DEVNULL}
subprocess.Popen([sys.executable, "-c", child, mode, pidfile, token], **quiet)
for _ in range(1000):
    if os.path.exists(pidfile):
        break
    time.sleep(0.01)
if mode == "stdout":
    sys.exit(0)
print("dynval-port 1 orphaner")
print("capability rmse")
print("ready", flush=True)
for line in sys.stdin:
    if line.strip() == "quit":
        break
    if line.strip() == "end":
        print("error InvalidParameter no", flush=True)
        print("end", flush=True)
if on_quit == "hang":
    time.sleep(3600)
'''


def _running(pid: int, token: str) -> bool:
    """True while the process ``pid`` lives and is the one carrying ``token`` on its command line."""
    try:
        stat = pathlib.Path(f"/proc/{pid}/stat").read_text()
        cmdline = pathlib.Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return False
    return stat.rpartition(")")[2].split()[0] != "Z" and token.encode() in cmdline


def _gone(pid: int, token: str, within: float = 3.0) -> bool:
    deadline = time.monotonic() + within
    while _running(pid, token):
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize(("mode", "on_quit"), [("stdout", "exit"), ("setsid", "exit"), ("setsid", "hang")])
def test_no_process_of_the_port_survives_the_run(tiny, tmp_path, mode, on_quit):
    script = tmp_path / "orphaner.py"
    script.write_text(ORPHAN_PORT)
    pidfile = tmp_path / "child.pid"
    token = f"dynval-orphan-{os.getpid()}-{mode}-{on_quit}-{time.monotonic_ns()}"
    # A process of the test's own, outside the port: the cleanup must leave it alone.
    bystander = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)", token + "-bystander"])
    pid = None
    try:
        start = time.monotonic()
        conform(["--timeout", "3", "--families", "norms", "--", sys.executable, str(script), mode, on_quit,
                 str(pidfile), token], tmp_path, corpus=tiny)
        assert time.monotonic() - start < 20
        pid = int(pidfile.read_text())
        assert _gone(pid, token), f"the port's child {pid} ({mode}) is still running"
        assert bystander.poll() is None, "the runner killed a process that was not the port's"
    finally:
        bystander.kill()
        bystander.wait()
        if pid is not None and _running(pid, token):
            os.kill(pid, 9)


def test_timeout_bounds_the_handshake_of_a_silent_port(tiny, tmp_path):
    script = tmp_path / "silent.py"
    script.write_text("import time\ntime.sleep(3600)\n")
    start = time.monotonic()
    code, out, report = conform(["--timeout", "2", "--families", "norms", "--", sys.executable, str(script)],
                                tmp_path, corpus=tiny)
    assert time.monotonic() - start < 15
    assert code == 1 and "port did not start" in out
    assert "2 s" in report["port"]["startup_error"]
    assert {c["reason"] for c in report["cases"]} == {"handshake"}


def test_startup_timeout_still_overrides_the_timeout(tiny, tmp_path):
    # A port that needs 2 s to start passes with --timeout 1 when --startup-timeout allows it.
    script = tmp_path / "slow_start.py"
    script.write_text(f"import runpy, sys, time\ntime.sleep(2)\nsys.path.insert(0, {str(PORTS)!r})\n"
                      f"sys.argv = sys.argv[1:]\nrunpy.run_path({str(PORTS / 'oracle.py')!r}, run_name='__main__')\n")
    code, out, _ = conform(["--timeout", "1", "--startup-timeout", "30", "--families", "norms", "--",
                            sys.executable, str(script), str(PORTS / "oracle.py"), "--corpus", tiny],
                           tmp_path, corpus=tiny)
    assert code == 0, out


def test_a_port_that_runs_nothing_fails_loudly(tiny, tmp_path):
    script = tmp_path / "no_capabilities.py"
    script.write_text("import sys\nprint('dynval-port 1 idle')\nprint('ready', flush=True)\nsys.stdin.read()\n")
    out, err = io.StringIO(), io.StringIO()
    code = main(["--quiet", "--corpus", tiny, "--", sys.executable, str(script)], stdout=out, stderr=err)
    assert code == 1, out.getvalue()
    assert "nothing was tested" in err.getvalue()
    assert "0 passed, 0 failed, 20 skipped" in out.getvalue()


def test_several_port_processes_give_the_report_of_one(tiny, tmp_path):
    single = tmp_path / "single"
    single.mkdir()
    code1, _, one = conform(port("oracle.py", corpus=tiny), single, corpus=tiny)
    record = tmp_path / "received.txt"
    code3, out3, three = conform(["--jobs", "3", *port("oracle.py", "--record", str(record), corpus=tiny)],
                                 tmp_path, corpus=tiny)
    assert code1 == code3 == 0, out3
    assert [c["id"] for c in three["cases"]] == [c["id"] for c in one["cases"]]  # corpus order kept
    assert three["counts"] == one["counts"]
    # three processes, each told to quit, and each case sent exactly once
    received = record.read_text().splitlines()
    assert received.count("quit") == 3
    sent = [line.split()[1:3] for line in received if line.startswith("case ")]
    expressible = [c for c in one["cases"] if c["status"] != "skipped"]
    assert sorted(map(tuple, sent)) == sorted((c["family"], str(c["tcId"])) for c in expressible)


def test_jobs_must_be_positive(tmp_path):
    err = io.StringIO()
    assert main(["--jobs", "0", "--", "true"], stdout=io.StringIO(), stderr=err) == 2
    assert "--jobs must be a positive integer" in err.getvalue()


def test_the_matrix_logs_progress_of_long_ports_and_every_failed_case():
    """A long port says how far it is once a minute; a failed case is printed with expected and got,
    so that reading a failure needs no rerun (at most 20, the rest counted)."""
    from dynval.conform._matrix import failure_lines, progress_lines
    from dynval.conform._runner import CaseOutcome, RunResult

    result = RunResult(command=["port"], corpus="c", families=["point"])
    now = [0.0]
    lines: list[str] = []
    progress = progress_lines("wolfram", lines.append, every=60.0, clock=lambda: now[0])
    result.outcomes.append(CaseOutcome(id="point-1", family="point", tc_id=1, operation="rmse", conventions="{}",
                                       status="failed", reason="mismatch", detail="value differs",
                                       expected={"value": 1.0}, got={"value": 2.0}))
    for done, t in ((1, 30.0), (2, 61.0), (3, 90.0), (4, 122.0), (5, 500.0)):
        now[0] = t
        progress(done, 5, result)
    assert lines == ["conform --matrix: wolfram: 2/5 cases, 1 failed so far, 61 s",
                     "conform --matrix: wolfram: 4/5 cases, 1 failed so far, 122 s"]  # none at the end
    assert failure_lines(result) == [
        '  FAILED point-1 (rmse; {}): mismatch: value differs; expected {"value": 1.0}, got {"value": 2.0}']
    for k in range(2, 25):
        result.outcomes.append(CaseOutcome(id=f"point-{k}", family="point", tc_id=k, operation="rmse",
                                           conventions="{}", status="failed" if k % 2 else "passed",
                                           reason="timeout"))
    got = failure_lines(result, most=5)
    assert len(got) == 6 and got[1] == "  FAILED point-3 (rmse; {}): timeout"
    assert got[-1] == "  ... and 7 more failed cases (dynval conform -- COMMAND lists them all)"
