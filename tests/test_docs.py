"""The documentation site builds without a warning, and every public name has its reference page.

The build here skips the gallery (``DYNVAL_DOCS_GALLERY=False``): scripts/test.sh builds the whole site,
running every gallery example, as its own step.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
sys.path.insert(0, str(DOCS))

from _ext import api_pages  # noqa: E402

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, DYNVAL_DOCS_GALLERY="False")
    run = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                          "-d", str(out / "doctrees"), str(DOCS), str(out / "html")],
                         capture_output=True, text=True, env=env, cwd=ROOT)
    assert run.returncode == 0, f"the site does not build without warnings:\n{run.stdout}\n{run.stderr}"
    return out / "html"


def test_every_public_name_has_a_reference_page(site):
    names = api_pages.public_names()
    assert len(names["dynval"]) >= 40 and len(names) == 1 + len(api_pages.PUBLIC_MODULES)
    missing = [f"{module}.{name}" for module, listed in names.items() for name in listed
               if not name.startswith("__") and not (site / "api" / "generated" / f"{module}.{name}.html").is_file()]
    assert not missing, f"public names without a reference page: {missing}"


def test_the_pages_of_the_guide_and_the_documents_are_built(site):
    for page in ("index", "getting-started", "contract", "conventions", "lesson", "architecture",
                 "guide/findings", "guide/protocol", "api/index"):
        assert (site / f"{page}.html").is_file(), page


def test_the_findings_page_lists_every_kind_the_code_declares(site):
    import dynval

    text = (site / "guide" / "findings.html").read_text(encoding="utf-8")
    assert all(f">{kind}<" in text for kind in dynval.FINDING_KINDS), "a finding kind is missing from the page"


def test_a_public_name_without_a_section_stops_the_build():
    import dynval

    with pytest.raises(RuntimeError, match="without a section"):
        api_pages._top_page([*dynval.__all__, "a_new_public_function"])
