"""dynval.datasets: the packaged KUKA LWR4+ runs, and the KUKA example's generated README block."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import dynval
from dynval.datasets import KukaLWR4Run, list_datasets, load_kuka_lwr4

ROOT = Path(__file__).resolve().parents[1]
UPSTREAM = ROOT.parent / "shared" / "data" / "robots" / "kuka_lwr4_flobaroid"
EXAMPLE = ROOT / "examples" / "kuka_lwr4"
JOINTS = tuple(f"lwr_{j}_joint" for j in range(7))


@pytest.mark.parametrize("k", [1, 2, 3])
def test_kuka_run_shapes_dtypes_names_units(k):
    r = load_kuka_lwr4(k)
    assert isinstance(r, KukaLWR4Run) and r.run == k and r.n_samples == 5027
    assert r.time.shape == (5027,)
    for name in ("q", "dq", "ddq", "tau"):
        a = getattr(r, name)
        assert a.shape == (5027, 7) and a.dtype == np.float64 and np.all(np.isfinite(a)), name
    assert r.time.dtype == np.float64 and r.time[0] == 0.0 and np.all(np.diff(r.time) > 0)
    assert r.time[-1] == pytest.approx(25.13, abs=0.01) and r.start_time > 1.4e9
    assert r.sample_rate == 200.0
    assert 1.0 / np.mean(np.diff(r.time)) == pytest.approx(r.sample_rate, rel=1e-4)
    assert r.joint_names == JOINTS
    assert dict(r.units) == {"time": "s", "q": "rad", "dq": "rad/s", "ddq": "rad/s²", "tau": "N·m",
                             "sample_rate": "Hz", "start_time": "s (Unix time)"}
    assert r.urdf.name == "kuka_lwr4.urdf" and r.urdf.is_file()
    assert r.urdf_identified.name == "kuka_lwr4_identified.urdf" and r.urdf_identified.is_file()
    assert r.license == "LGPL-3.0" and f"run {k} of 3" in r.description
    for words in ("FloBaRoID", "LGPL-3.0", "Stefan Bethge", "zero-phase low-pass", "https://github.com/kjyv/FloBaRoID"):
        assert words in r.DESCR
    assert "run=" + str(k) in repr(r) and "array" not in repr(r)


def test_kuka_run_is_frozen_and_read_only():
    r = load_kuka_lwr4(1)
    with pytest.raises(dataclasses.FrozenInstanceError):
        r.run = 2  # type: ignore[misc]
    for name in ("time", "q", "dq", "ddq", "tau"):
        with pytest.raises(ValueError, match="read-only"):
            getattr(r, name)[0] = 1.0
    with pytest.raises(TypeError):
        r.units["tau"] = "Nm"  # type: ignore[index]
    # Each call reads fresh arrays: nothing is shared between results.
    assert not np.shares_memory(r.tau, load_kuka_lwr4(1).tau)


def test_kuka_runs_one_and_two_repeat_run_three_differs():
    q = {k: load_kuka_lwr4(k).q for k in (1, 2, 3)}
    assert np.sqrt(np.mean((q[1] - q[2]) ** 2)) < 0.01
    assert np.sqrt(np.mean((q[1] - q[3]) ** 2)) > 0.1


@pytest.mark.parametrize("bad", [0, 4, -1, "1", 1.0, True, None])
def test_kuka_bad_run_names_the_value_and_the_valid_ones(bad):
    with pytest.raises(dynval.InvalidParameter, match=r"^run must be one of 1, 2, 3, got ") as info:
        load_kuka_lwr4(bad)
    assert str(info.value).endswith(repr(bad)) and isinstance(info.value, ValueError)


def test_kuka_numpy_integer_run_is_accepted():
    assert load_kuka_lwr4(np.int64(3)).run == 3


def test_list_datasets():
    assert list(list_datasets()) == ["kuka_lwr4"]
    assert "LGPL-3.0" in list_datasets()["kuka_lwr4"]


def test_packaged_licence_and_attribution_beside_the_data():
    folder = load_kuka_lwr4(1).urdf.parent
    assert "GNU LESSER GENERAL PUBLIC LICENSE" in (folder / "LICENSE.md").read_text(encoding="utf-8")
    assert "GNU GENERAL PUBLIC LICENSE" in (folder / "GPL-3.0.txt").read_text(encoding="utf-8")
    readme = (folder / "README.md").read_text(encoding="utf-8")
    assert "FloBaRoID" in readme and "LGPL-3.0" in readme and "Stefan Bethge" in readme


@pytest.mark.skipif(not (UPSTREAM / "data" / "measurements_1.npz").is_file(),
                    reason="the upstream FloBaRoID files (../shared/data/robots) are not beside the repository")
@pytest.mark.parametrize("k", [1, 2, 3])
def test_kuka_arrays_are_bit_identical_to_upstream(k):
    r = load_kuka_lwr4(k)
    with np.load(UPSTREAM / "data" / f"measurements_{k}.npz") as f:
        up = {key: f[key] for key in ("times", "positions", "velocities", "accelerations", "torques")}
    for name, key in (("q", "positions"), ("dq", "velocities"), ("ddq", "accelerations"), ("tau", "torques")):
        a, b = getattr(r, name), up[key]
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), name
    assert r.start_time == up["times"][0]
    assert (r.time + r.start_time).tobytes() == up["times"].tobytes()
    for name in ("kuka_lwr4.urdf", "kuka_lwr4_identified.urdf"):
        assert (r.urdf.parent / name).read_bytes() == (UPSTREAM / "model" / name).read_bytes()
    assert (r.urdf.parent / "LICENSE.md").read_bytes() == (UPSTREAM / "LICENSE.md").read_bytes()


def test_importing_dynval_does_not_import_the_datasets():
    code = "import sys, dynval; print('dynval.datasets' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


# ---- examples/kuka_lwr4: the README's verdicts are written by run.py --readme

def _example():
    spec = importlib.util.spec_from_file_location("kuka_lwr4_run", EXAMPLE / "run.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_rewrite_block_replaces_only_between_the_markers():
    run = _example()
    text = f"# Title\nbefore\n{run.BEGIN}\nold line\nold line 2\n{run.END}\nafter\n"
    new = run.rewrite_block(text, "\nnew block\n")
    assert new == f"# Title\nbefore\n{run.BEGIN}\nnew block\n{run.END}\nafter\n"
    assert run.rewrite_block(new, "new block") == new
    assert run.read_block(new) == "new block"
    assert run.rewrite_block(f"{run.BEGIN}{run.END}", "x") == f"{run.BEGIN}\nx\n{run.END}"
    for broken in ("no markers", f"{run.END}\n{run.BEGIN}", f"{run.BEGIN}\n{run.BEGIN}\n{run.END}",
                   f"{run.BEGIN}\nx"):
        with pytest.raises(ValueError, match="must hold one"):
            run.rewrite_block(broken, "x")


def test_render_block_on_a_small_record():
    run = _example()
    rec = {"run": 3, "what": "a different trajectory", "criterion": "aic", "joint_names": ["a_joint", "b_joint"],
           "rows": [{"model": "m1", "p": 2, "rmse": 0.12345, "vaf": 99.123, "r2": 0.99123, "delta_aic": 0.0,
                     "deficiencies": 1, "r2_per_joint": [0.5, -1.25]},
                    {"model": "m2", "p": 0, "rmse": 1.5, "vaf": 90.0, "r2": 0.9, "delta_aic": 12.4,
                     "deficiencies": 0, "r2_per_joint": [0.9, 0.8]}],
           "verdict": {"decision": "refine", "model": "m1", "first_step": "add a term",
                       "decided_by": [{"kind": "missing_physics", "severity": "deficiency", "model": "m1",
                                       "joints": ["a_joint"], "columns": []},
                                      {"kind": "missing_physics", "severity": "deficiency", "model": "m1",
                                       "joints": ["b_joint"], "columns": []}]}}
    lines = run.render_block([rec]).splitlines()
    assert lines[0].startswith("<!--") and lines[1] == ""
    assert lines[2] == ("**Run 3** (a different trajectory): verdict **refine** `m1`, decided by `missing_physics` "
                        "(deficiency of m1) on a_joint, b_joint. First step: add a term.")
    assert lines[4] == "| rank | model | p | RMSE (N·m) | VAF % | R² pooled | ΔAIC | deficiencies | R² a | R² b |"
    assert lines[6] == "| 1 | m1 | 2 | 0.123 | 99.12 | 0.9912 | 0 | 1 | 0.50 | -1.25 |"
    assert lines[7] == "| 2 | m2 | 0 | 1.500 | 90.00 | 0.9000 | 12 | 0 | 0.90 | 0.80 |"
    # with the shares the comparison gives (the count alone reads backwards) and why the first step is first
    rec["rows"][0]["strongest_share"] = 0.62
    rec["verdict"]["first_reason"] = "first because it explains 62 % of the residual's mean square on a_joint"
    lines = run.render_block([rec]).splitlines()
    assert lines[2].endswith("First step: add a term. (First because it explains 62 % of the residual's mean "
                             "square on a_joint.)")
    assert lines[4].startswith("| rank | model | p | RMSE (N·m) | VAF % | R² pooled | ΔAIC | deficiencies "
                               "(strongest share) | R² a |")
    assert lines[6] == "| 1 | m1 | 2 | 0.123 | 99.12 | 0.9912 | 0 | 1 (62 %) | 0.50 | -1.25 |"


def test_readme_block_is_the_one_the_recorded_run_gives():
    # verdicts.json is what `run.py --readme` recorded of its last full run (about a minute, so not
    # repeated here); the README block must be exactly what it renders, so it cannot be edited by hand.
    run = _example()
    recorded = json.loads(run.RECORD.read_text(encoding="utf-8"))
    assert [r["run"] for r in recorded["runs"]] == [2, 3]
    readme = run.README.read_text(encoding="utf-8")
    assert run.read_block(readme) == run.render_block(recorded["runs"]), (
        "examples/kuka_lwr4/README.md's verdicts block differs from verdicts.json: run "
        "`python3 examples/kuka_lwr4/run.py --readme`")
