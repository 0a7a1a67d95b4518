"""The versions are written once (python/dynval/_version.py); every other place reads or claims them."""

from __future__ import annotations

import re
from importlib import metadata
from pathlib import Path

import pytest

import dynval
from dynval import _version

ROOT = Path(__file__).resolve().parents[1]


def test_package_metadata_and_module_agree_with_the_one_source():
    assert dynval.__version__ == _version.__version__
    assert dynval.CONTRACT_VERSION == _version.CONTRACT_VERSION
    assert metadata.version("dynval") == _version.__version__  # pyproject reads _version.py


def test_compiled_core_carries_the_same_versions():
    core = pytest.importorskip("dynval._core")
    assert (core.__version__, core.CONTRACT_VERSION) == (dynval.__version__, dynval.CONTRACT_VERSION)


def test_no_other_file_writes_a_version():
    # The copies that used to drift: pyproject, CMakeLists, the C++ header, the report.
    assert not re.search(r'^version\s*=', (ROOT / "pyproject.toml").read_text(), re.M)
    assert "set(PROJECT_VERSION" not in (ROOT / "CMakeLists.txt").read_text()
    header = (ROOT / "cpp/include/dynval/dynval.hpp").read_text()
    assert "#define DYNVAL_VERSION_STRING" not in header and "#define DYNVAL_CONTRACT_VERSION" not in header
    assert '"1.0"' not in (ROOT / "python/dynval/report/_report.py").read_text()


def test_the_java_port_claims_this_release_and_contract():
    src = ROOT / "java/src/main/java/org/dynval"
    java_contract = re.search(r'CONTRACT_VERSION = "([^"]+)"', (src / "Dynval.java").read_text())
    assert java_contract.group(1) == dynval.CONTRACT_VERSION
    assert re.search(r'VERSION = "([^"]+)"', (src / "PortMain.java").read_text()).group(1) == dynval.__version__
    pom = (ROOT / "java/pom.xml").read_text()
    assert re.search(r"<artifactId>[^<]+</artifactId>\s*<version>([^<]+)</version>", pom).group(1) == dynval.__version__


def test_the_contract_document_states_the_contract_version():
    text = (ROOT / "docs/contract.md").read_text()
    assert f'Contract version: **{dynval.CONTRACT_VERSION}** (`CONTRACT_VERSION = "{dynval.CONTRACT_VERSION}"`)' in text
