"""The Wolfram Language port (wolfram/): its own VerificationTest suite, and the whole corpus.

Both tests need Mathics3 (``mathics``; PyPI ``mathics3`` with ``packaging``). Where it is missing
the tests skip, unless the environment variable DYNVAL_REQUIRE_TOOLCHAINS (comma-separated, e.g.
``java,octave,mathics``) names ``mathics``: then a missing toolchain is a failure, so that CI
cannot pass by skipping.
"""

from __future__ import annotations

import importlib.util
import os
import pathlib
import re
import shutil
import subprocess

import pytest

from port_checks import assert_passes_whole_corpus, require_toolchain

ROOT = pathlib.Path(__file__).resolve().parents[1]
WOLFRAM_DIR = ROOT / "wolfram"
RUN_PORT = WOLFRAM_DIR / "run-port"


def _require_mathics() -> None:
    missing = [] if shutil.which("mathics") else ["mathics"]
    # Mathics3 needs packaging at run time but does not declare it
    missing += [name for name in ("mathics", "packaging") if importlib.util.find_spec(name) is None]
    require_toolchain("mathics", missing, "wolfram/install-toolchain installs it")


@pytest.mark.slow
def test_wolfram_unit_tests():
    """``mathics -q -f Tests.wl``: every VerificationTest passes, and there are tests to pass."""
    _require_mathics()
    proc = subprocess.run(["mathics", "-q", "-f", "Tests.wl"], cwd=WOLFRAM_DIR, capture_output=True,
                          text=True, timeout=900, stdin=subprocess.DEVNULL)
    tail = proc.stdout[-4000:] + proc.stderr[-2000:]
    summary = re.findall(r"^(\d+) passed, (\d+) failed$", proc.stdout, re.M)
    assert summary, f"no summary line in the output of Tests.wl:\n{tail}"
    passed, failed = (int(x) for x in summary[-1])
    assert proc.returncode == 0 and failed == 0 and passed > 0, tail


@pytest.mark.slow
def test_wolfram_port_passes_the_whole_corpus(tmp_path):
    """``dynval conform --strict --jobs 2 -- wolfram/run-port``: exit 0 and every vector of the eight required
    families passed (Mathics3 is slow per case: two port processes share the corpus).

    scripts/test.sh names this port in DYNVAL_CORPUS_IN_MATRIX: its conformance-matrix step runs the same
    corpus through it with ``--check-readme``, which fails on any failed or skipped vector, so the run is
    not made twice there."""
    _require_mathics()
    if "wolfram" in os.environ.get("DYNVAL_CORPUS_IN_MATRIX", "").split(","):
        pytest.skip("the whole corpus of the Wolfram port is run by the conformance-matrix step of scripts/test.sh")
    assert_passes_whole_corpus(RUN_PORT, tmp_path / "wolfram-conform.json", timeout=3600, jobs=2)
