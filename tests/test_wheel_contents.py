"""The wheel ships the golden corpus and everything the conformance runner and the ports read at run
time, but not the corpus generator (golden/generate.py, golden/corpus_generator/: source tree only).

Builds the pure-Python wheel (--config-settings=wheel.cmake=false: no compiler, a few seconds) of this source tree into
a temporary directory and reads its file list. Needs scikit-build-core importable (the test extra),
since the build runs without isolation and so without the network.
"""

from __future__ import annotations

import pathlib
import subprocess
import sys
import zipfile

import pytest

from dynval.golden import FAMILIES, SCHEMA_NAME

REPO = pathlib.Path(__file__).resolve().parents[1]
PREFIX = "dynval/golden/"


@pytest.fixture(scope="module")
def wheel_files(tmp_path_factory) -> set[str]:
    if not (REPO / "pyproject.toml").is_file() or not (REPO / "golden" / "generate.py").is_file():
        pytest.skip(f"not run from dynval's source tree ({REPO})")
    pytest.importorskip("scikit_build_core", reason="building the wheel needs scikit-build-core (the test extra)")
    out = tmp_path_factory.mktemp("wheel")
    done = subprocess.run([sys.executable, "-m", "pip", "wheel", str(REPO), "--config-settings=wheel.cmake=false",
                           "--no-build-isolation", "--no-deps", "--no-index", "--quiet", "--disable-pip-version-check",
                           "-w", str(out)], capture_output=True, text=True, check=False, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    (wheel,) = out.glob("dynval-*.whl")
    with zipfile.ZipFile(wheel) as archive:
        return set(archive.namelist())


def test_wheel_leaves_out_the_generator(wheel_files):
    generator = sorted(n for n in wheel_files
                       if n == PREFIX + "generate.py" or n.startswith(PREFIX + "corpus_generator/"))
    assert generator == [], f"the corpus generator is in the wheel: {generator}"


def test_wheel_ships_what_the_runner_and_the_ports_read(wheel_files):
    needed = {f"{PREFIX}vectors/{family}.json" for family in FAMILIES}
    needed |= {f"{PREFIX}schema/{SCHEMA_NAME}", f"{PREFIX}operations.json", f"{PREFIX}PROTOCOL.md",
               f"{PREFIX}README.md", f"{PREFIX}data/nist_strd/certified.json"}
    needed |= {f"{PREFIX}{p.name}" for p in (REPO / "python" / "dynval" / "golden").glob("*.py")}
    assert needed - wheel_files == set()
    # every other file of golden/ (data, vectors, schema, docs) is shipped: only the generator is left out
    golden = REPO / "golden"
    shipped = {PREFIX + p.relative_to(golden).as_posix() for p in golden.rglob("*")
               if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc"
               and p.name != "generate.py" and "corpus_generator" not in p.relative_to(golden).parts}
    assert shipped - wheel_files == set()
