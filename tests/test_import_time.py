"""``import dynval`` stays light: the heavy optional or numerical libraries load on first use."""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
HEAVY = ("scipy", "matplotlib", "dask", "pinocchio", "pandas")


def _modules_after(code: str) -> set[str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT / "python") + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-c", code + "\nimport sys, json; print(json.dumps(sorted(sys.modules)))"],
                          capture_output=True, text=True, env=env, timeout=120, check=True)
    return {name.split(".")[0] for name in json.loads(done.stdout.splitlines()[-1])}


def test_import_dynval_loads_none_of_the_heavy_libraries():
    assert sorted(_modules_after("import dynval") & set(HEAVY)) == []


@pytest.mark.parametrize("name", ["rmse", "validate", "compare", "identify", "physical_consistency"])
def test_public_names_resolve_without_the_heavy_libraries(name):
    assert sorted(_modules_after(f"import dynval; dynval.{name}") & set(HEAVY)) == []


def test_scipy_loads_on_first_use():
    # The lazy name stands for scipy: the first statistic that needs it imports it.
    loaded = _modules_after("import numpy as np, dynval; x = np.sin(np.arange(400.0)); "
                            "dynval.validate(x, 0.9 * x, n_params=1, max_lag=5)")
    assert "scipy" in loaded


def test_a_first_validate_limits_scipys_blas_too():
    # scipy loads during the first call now; its BLAS must still run on one thread there, as when
    # scipy came with the package import (kernels/_blas.py).
    code = """
import json, numpy as np, threadpoolctl, dynval
from dynval.report import _motion
seen = []
original = _motion.motion_phase
def spy(*args):
    seen.extend(lib["num_threads"] for lib in threadpoolctl.threadpool_info() if lib["user_api"] == "blas")
    return original(*args)
_motion.motion_phase = spy
x = np.sin(np.arange(400.0))
dynval.validate(np.c_[x, x], np.c_[0.9 * x, x], n_params=1, max_lag=5, regressor=np.ones((400, 2, 1)))
print(json.dumps(sorted(set(seen))))
"""
    env = dict(os.environ, PYTHONPATH=str(ROOT / "python") + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120,
                          check=True)
    assert json.loads(done.stdout.splitlines()[-1]) == [1]
