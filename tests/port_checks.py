"""What the ports' tests share: requiring a toolchain, and running the whole corpus through one port.

A missing toolchain skips a port's tests, unless the environment variable DYNVAL_REQUIRE_TOOLCHAINS
(comma-separated, e.g. ``java,octave,mathics``) names it: then it is a failure, so that CI cannot
pass by skipping.
"""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys
from collections import Counter

import pytest

from dynval.golden import FAMILIES, OPTIONAL_FAMILIES, iter_cases

ROOT = pathlib.Path(__file__).resolve().parents[1]


def require_toolchain(name: str, missing: list, hint: str) -> None:
    """Skip (or fail, when DYNVAL_REQUIRE_TOOLCHAINS names ``name``) if anything is ``missing``."""
    if not missing:
        return
    required = {n.strip() for n in os.environ.get("DYNVAL_REQUIRE_TOOLCHAINS", "").split(",")}
    reason = f"{name} toolchain not found ({', '.join(missing)}: missing); {hint}"
    if name in required:
        pytest.fail(f"DYNVAL_REQUIRE_TOOLCHAINS names {name}, but: {reason}")
    pytest.skip(reason)


def assert_passes_whole_corpus(run_port: pathlib.Path, report_path: pathlib.Path, timeout: float = 1200,
                               jobs: int = 1) -> dict:
    """``dynval conform --strict -- RUN_PORT``: exit 0 and every vector of the eight required families
    passed (and of the optional ``streaming`` family when the port claims it)."""
    proc = subprocess.run(
        [sys.executable, "-m", "dynval", "conform", "--strict", "--jobs", str(jobs), "--report", str(report_path), "--",
         str(run_port)],
        cwd=ROOT, capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, f"conform exited {proc.returncode}:\n{proc.stdout[-6000:]}\n{proc.stderr[-3000:]}"
    report = json.loads(report_path.read_text())
    assert report["exit_code"] == 0
    assert set(report["unclaimed_families"]) <= set(OPTIONAL_FAMILIES)
    families = [f for f in FAMILIES if f not in report["unclaimed_families"]]
    corpus = Counter(case.family for case in iter_cases() if case.family in families)
    assert set(corpus) == set(families)
    counts = report["counts"]
    for family in families:
        assert counts[family].get("passed", 0) == corpus[family], (family, counts[family], corpus[family])
        for status in ("failed", "skipped", "partial"):
            assert counts[family].get(status, 0) == 0, (family, counts[family])
    assert counts["total"]["passed"] == sum(corpus.values())
    statuses = Counter(case["status"] for case in report["cases"])
    assert statuses == Counter({"passed": sum(corpus.values())}), statuses
    return report
