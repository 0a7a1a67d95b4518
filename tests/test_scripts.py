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


def test_a_failed_build_says_what_to_try():
    # pip shows the backend's output only when the build fails: the message must name the way out
    import pytest

    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    build = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["scikit-build"]
    failure = build["messages"]["after-failure"]
    assert "C++17" in failure and "pip install . --config-settings=wheel.cmake=false" in failure


def test_the_module_compiles_as_one_unit_by_default():
    # benchmarks/build_time.sh: one unit builds about 5x faster than one per family
    text = (ROOT / "CMakeLists.txt").read_text(encoding="utf-8")
    assert re.search(r'option\(DYNVAL_UNITY_BUILD "[^"]*" ON\)', text)
    assert re.search(r"set_target_properties\(_core PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE 0\)", text)
