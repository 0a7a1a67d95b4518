"""The Java port (java/): its own JUnit 5 tests, and the whole corpus through the protocol.

Both tests need a JDK and Maven (``mvn -o`` builds offline from the local repository ~/.m2).
Where they are missing the tests skip, unless the environment variable
DYNVAL_REQUIRE_TOOLCHAINS (comma-separated, e.g. ``java,octave,mathics``) names ``java``: then
a missing toolchain is a failure, so that CI cannot pass by skipping.
"""

from __future__ import annotations

import pathlib
import re
import shutil
import subprocess

import pytest

from port_checks import assert_passes_whole_corpus, require_toolchain

ROOT = pathlib.Path(__file__).resolve().parents[1]
JAVA_DIR = ROOT / "java"
RUN_PORT = JAVA_DIR / "run-port"
TOOLS = ("java", "javac", "mvn")


def _require_java() -> None:
    require_toolchain("java", [tool for tool in TOOLS if shutil.which(tool) is None],
                      "java/install-toolchain installs it")


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
    if proc.returncode != 0 and "in offline mode" in proc.stdout:
        # The port itself runs on javac alone (run-port); its JUnit tests need the plugins and JUnit
        # pinned in pom.xml in the local Maven repository, which java/install-toolchain lists.
        require_toolchain("java", ["the Maven plugins and JUnit of pom.xml in the local repository (mvn -o)"],
                          "java/install-toolchain names the missing ones")
    assert proc.returncode == 0, f"mvn -o test failed:\n{tail}"
    totals = re.findall(r"Tests run: (\d+), Failures: (\d+), Errors: (\d+), Skipped: (\d+)\s*$", proc.stdout, re.M)
    assert totals, f"no JUnit summary in the Maven output:\n{tail}"
    run, failures, errors, _ = (int(x) for x in totals[-1])
    assert run > 0 and failures == 0 and errors == 0, tail


@pytest.mark.slow
def test_java_port_passes_the_whole_corpus(tmp_path):
    """``dynval conform --strict -- java/run-port``: exit 0 and every vector of the eight required families passed."""
    _require_java()
    assert_passes_whole_corpus(RUN_PORT, tmp_path / "java-conform.json")
