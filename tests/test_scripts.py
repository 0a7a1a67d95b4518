"""The set-up script's behaviour where it depends on the machine (run on a stub toolchain)."""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _ctest_block() -> str:
    text = (ROOT / "scripts" / "test.sh").read_text(encoding="utf-8")
    match = re.search(r'^step "C\+\+ core: ctest"\n.*?^fi\n', text, flags=re.S | re.M)
    assert match, "scripts/test.sh has no ctest block"
    return match.group(0)


def _run_block(tmp_path, *, ci: bool):
    # cmake that cannot find GoogleTest, and a non-root user.
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    (bin_dir / "cmake").write_text('#!/bin/sh\necho "CMake Error at cpp/tests/CMakeLists.txt:1 (find_package):"\n'
                                   'echo "  Could not find a package configuration file provided by GTest"\nexit 1\n')
    (bin_dir / "id").write_text("#!/bin/sh\necho 1000\n")
    for f in bin_dir.iterdir():
        f.chmod(0o755)
    script = tmp_path / "run.sh"
    script.write_text('set -euo pipefail\nstep() { printf "\\n== %s\\n" "$*"; }\n' + _ctest_block() + "echo AFTER\n")
    env = {k: v for k, v in os.environ.items() if k != "CI"}
    env["PATH"] = f"{bin_dir}:{env['PATH']}"
    if ci:
        env["CI"] = "true"
    return subprocess.run(["bash", str(script)], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=60)


def test_without_googletest_a_developer_is_told_and_the_run_goes_on(tmp_path):
    out = _run_block(tmp_path, ci=False)
    assert out.returncode == 0, out.stderr
    assert "SKIPPED: the C++ unit tests" in out.stdout and "GTest" in out.stdout
    assert out.stdout.rstrip().endswith("AFTER")


def test_without_googletest_ci_fails(tmp_path):
    out = _run_block(tmp_path, ci=True)
    assert out.returncode != 0 and "AFTER" not in out.stdout
