"""The Java port (java/): its own JUnit 5 tests, and the whole corpus through the protocol.

Both tests need a JDK and Maven (``mvn -o`` builds offline from the local repository ~/.m2).
Where they are missing the tests skip, unless the environment variable
DYNVAL_REQUIRE_TOOLCHAINS (comma-separated, e.g. ``java,octave,mathics``) names ``java``: then
a missing toolchain is a failure, so that CI cannot pass by skipping.
"""

from __future__ import annotations

import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
from collections import Counter

import pytest

from dynval.golden import FAMILIES, iter_cases

ROOT = pathlib.Path(__file__).resolve().parents[1]
JAVA_DIR = ROOT / "java"
RUN_PORT = JAVA_DIR / "run-port"
TOOLS = ("java", "javac", "mvn")


def _require_java() -> None:
    missing = [tool for tool in TOOLS if shutil.which(tool) is None]
    if not missing:
        return
    required = {name.strip() for name in os.environ.get("DYNVAL_REQUIRE_TOOLCHAINS", "").split(",")}
    reason = f"Java toolchain not found ({', '.join(missing)} missing from PATH); java/install-toolchain installs it"
    if "java" in required:
        pytest.fail(f"DYNVAL_REQUIRE_TOOLCHAINS names java, but: {reason}")
    pytest.skip(reason)


@pytest.mark.slow
def test_java_unit_tests():
    """``mvn -o test`` in java/: every JUnit 5 test passes, and there are tests to pass."""
    _require_java()
    proc = subprocess.run(
        ["mvn", "-o", "-B", "test"],
        cwd=JAVA_DIR,
        capture_output=True,
        text=True,
        timeout=900,
    )
    tail = proc.stdout[-4000:] + proc.stderr[-2000:]
    assert proc.returncode == 0, f"mvn -o test failed:\n{tail}"
    totals = re.findall(r"Tests run: (\d+), Failures: (\d+), Errors: (\d+), Skipped: (\d+)\s*$", proc.stdout, re.M)
    assert totals, f"no JUnit summary in the Maven output:\n{tail}"
    run, failures, errors, _ = (int(x) for x in totals[-1])
    assert run > 0 and failures == 0 and errors == 0, tail


@pytest.mark.slow
def test_java_port_passes_the_whole_corpus(tmp_path):
    """``dynval conform --strict -- java/run-port``: exit 0 and every vector of all eight families passed."""
    _require_java()
    report_path = tmp_path / "java-conform.json"
    proc = subprocess.run(
        [sys.executable, "-m", "dynval", "conform", "--strict", "--report", str(report_path), "--", str(RUN_PORT)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=1200,
    )
    assert proc.returncode == 0, f"conform exited {proc.returncode}:\n{proc.stdout[-6000:]}\n{proc.stderr[-3000:]}"
    report = json.loads(report_path.read_text())
    assert report["exit_code"] == 0

    corpus = Counter(case.family for case in iter_cases())
    assert set(corpus) == set(FAMILIES)
    counts = report["counts"]
    for family in FAMILIES:
        assert counts[family].get("passed", 0) == corpus[family], (family, counts[family], corpus[family])
        for status in ("failed", "skipped", "partial"):
            assert counts[family].get(status, 0) == 0, (family, counts[family])
    assert counts["total"]["passed"] == sum(corpus.values())
    statuses = Counter(case["status"] for case in report["cases"])
    assert statuses == Counter({"passed": sum(corpus.values())}), statuses
