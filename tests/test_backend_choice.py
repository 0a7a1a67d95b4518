"""Which backend runs: ``backends()`` names the default, and a bad ``DYNVAL_BACKEND`` names the variable."""

from __future__ import annotations

import pytest

import dynval
from dynval.kernels import _backend


@pytest.fixture
def fresh(monkeypatch):
    monkeypatch.setitem(_backend._state, "current", None)
    return monkeypatch


def test_backends_marks_exactly_one_default(fresh):
    fresh.delenv("DYNVAL_BACKEND", raising=False)
    info = dynval.backends()
    assert [n for n, b in info.items() if b["default"]] == [_backend.default_backend()]
    fresh.setenv("DYNVAL_BACKEND", "python")
    assert [n for n, b in dynval.backends().items() if b["default"]] == ["python"]


def test_set_backend_moves_the_default(fresh):
    fresh.delenv("DYNVAL_BACKEND", raising=False)
    dynval.set_backend("python")
    try:
        assert dynval.backends()["python"]["default"] and not dynval.backends()["cpp"]["default"]
    finally:
        dynval.set_backend(None)


def test_invalid_environment_variable_is_named(fresh):
    fresh.setenv("DYNVAL_BACKEND", "fortran")
    with pytest.raises(dynval.InvalidParameter, match=r"^DYNVAL_BACKEND \(environment variable\) must be one of "
                                                      r"'python'.*got 'fortran'$"):
        dynval.rmse([1.0, 2.0], [1.0, 2.5])
    # backends() still answers, with no default, so the user can see what is available
    info = dynval.backends()
    assert info["python"]["available"] and not any(b["default"] for b in info.values())
