"""Shared pytest configuration: backend parametrisation and hypothesis profiles.

Every test that takes a ``backend`` argument runs once per *available* backend (ids
``python`` and ``cpp``); an unavailable compiled core is reported in the header, not as an error.
"""

from __future__ import annotations

import os

import hypothesis
import pytest

import dynval

hypothesis.settings.register_profile("ci", derandomize=True, deadline=None, max_examples=50)
hypothesis.settings.register_profile("dev", deadline=None, max_examples=100)
hypothesis.settings.load_profile("ci" if os.environ.get("CI") else "dev")

BACKEND_ORDER = ("python", "cpp")


def available_backends() -> list[str]:
    info = dynval.backends()
    return [name for name in BACKEND_ORDER if info[name]["available"]]


def pytest_configure(config):
    # A backend the run must test (DYNVAL_REQUIRE_BACKENDS=python,cpp, set by scripts/test.sh and CI)
    # that is unavailable fails the run at the start: a missing backend would otherwise only make the
    # parametrisation smaller and every one of its tests would silently disappear.
    required = [b.strip() for b in os.environ.get("DYNVAL_REQUIRE_BACKENDS", "").split(",") if b.strip()]
    info = dynval.backends()
    for name in required:
        if name not in info:
            raise pytest.UsageError(f"DYNVAL_REQUIRE_BACKENDS names an unknown backend {name!r}")
        if not info[name]["available"]:
            raise pytest.UsageError(f"DYNVAL_REQUIRE_BACKENDS requires backend {name!r}, which is unavailable: "
                                    f"{info[name]['detail']}")


def pytest_report_header(config):
    info = dynval.backends()
    lines = [f"dynval {dynval.__version__}, contract {dynval.CONTRACT_VERSION}"]
    for name in BACKEND_ORDER:
        state = "tested" if info[name]["available"] else "not tested"
        lines.append(f"  backend {name}: {state} ({info[name]['detail']})")
    return lines


def pytest_collection_modifyitems(config, items):
    # With pytest-xdist (scripts/test.sh runs -n 2) a long test collected last runs alone at the end
    # while the other worker idles: the tests marked slow (the ports' unit tests, the calibrations)
    # start first. The order is otherwise the collection's; a serial run is not reordered.
    if getattr(config.option, "numprocesses", None):
        items.sort(key=lambda item: item.get_closest_marker("slow") is None)


def pytest_generate_tests(metafunc):
    # Plain parametrisation (not a fixture) so that hypothesis @given tests can use it too.
    if "backend" in metafunc.fixturenames:
        names = available_backends()
        metafunc.parametrize("backend", names, ids=names)
