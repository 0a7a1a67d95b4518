"""Per-log decisions of a fleet see what ``validate`` sees (contract §10): each log validated with the
files its manifest row names (regressor, q, dq, ddq, time stamps, the robot's estimation run), the
table says what each decision saw, and a drift beside accepted logs is explained in a sentence.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

import dynval
import dynval.fleet as fleet
from dynval.fleet._drift import drift_per_robot
from dynval.io._files import FileInputError


@pytest.fixture(scope="module")
def worn(tmp_path_factory):
    """The README's fleet, smaller: 3 robots × 9 logs × 1000 samples, r02's friction +30 % from log 5 on;
    written twice, with every file (default) and with the torques alone."""
    logs = fleet.simulate_fleet(n_robots=3, n_logs=9, degradations={"r02": fleet.Degradation("friction", 5, 0.3)})
    full, bare = (str(tmp_path_factory.mktemp(name)) for name in ("full", "bare"))
    fleet.write_fleet(logs, full)
    fleet.write_fleet(logs, bare, regressor=False)
    run = dict(scheduler="single", max_lag=20, progress=False)
    return (fleet.validate_many([os.path.join(full, "manifest.csv")], **run),
            fleet.validate_many([os.path.join(bare, "manifest.csv")], **run))


def _is_worn(row):
    return row.robot == "r02" and row.time >= "2026-01-06"


def test_the_worn_robot_s_logs_are_flagged_and_the_healthy_ones_accepted(worn):
    report, _ = worn
    after = [r for r in report.logs if _is_worn(r)]
    healthy = [r for r in report.logs if not _is_worn(r)]
    assert len(after) == 4 and all(r.decision == "refine" for r in after), [(r.log, r.decision) for r in after]
    # the friction's own tests name it: the regressor's friction columns and the physics library on q
    assert all({"regressor_correlation", "missing_physics"} <= set(r.kinds) for r in after)
    flagged = [r for r in healthy if r.decision != "accept"]
    assert len(flagged) <= 2, [(r.log, r.decision, r.kinds) for r in flagged]  # 23 healthy logs at α = 0.05
    assert {r.sees for r in report.logs} == {"residual, q, regressor, estimation run"}
    assert [d.robot for d in report.drift if d.finding] == ["r02"] and report.notes == ()


def test_a_residual_only_decision_says_so_and_a_drift_beside_it_is_explained(worn):
    _, bare = worn
    assert {r.sees for r in bare.logs} == {"residual only: no q, no regressor"}
    assert [d.robot for d in bare.drift if d.finding] == ["r02"]
    accepted = sum(r.decision == "accept" for r in bare.logs if _is_worn(r))
    assert accepted >= 1  # what the issue saw: the residual alone does not show the friction
    note, = bare.notes
    assert note.startswith(f"r02 drifts from log r02__2026-01-06T08-00 on, yet {accepted} of its 4 logs from then on "
                           "are accepted: the drift compares the robot's logs with each other, each per-log decision "
                           "compares one log with the model alone, from the residual only (no q, no regressor)")
    text = bare.summary()
    assert "Each log's decision saw: residual only: no q, no regressor." in text and note in text
    data = json.loads(bare.to_json())
    assert data["notes"] == [note] and data["logs"][0]["sees"] == "residual only: no q, no regressor"
    assert bare.table()[0]["sees"] == "residual only: no q, no regressor"


def test_a_drift_beside_logs_accepted_with_every_input_gets_its_own_sentence():
    rmse = [1.0, 1.02, 0.98, 1.01, 0.99, 1.0, 1.3, 1.32, 1.29, 1.31]
    sees = "residual, q, regressor, estimation run"
    rows = [fleet.LogSummary("a", str(k), f"a{k}", rmse=v, decision="accept", sees=sees) for k, v in enumerate(rmse)]
    report = fleet.FleetReport(tuple(rows), tuple(drift_per_robot(rows, level=0.95, n_permutations=999)), 0.95)
    note, = report.notes
    assert note == ("a drifts from log a6 on, yet 4 of its 4 logs from then on are accepted: the drift compares the "
                    "robot's logs with each other, each per-log decision compares one log with the model alone "
                    f"({sees}), and within one log the change is not (yet) beyond what its tests allow.")
    # no note once the logs from the change on are flagged
    flagged = [r if k < 6 else fleet.LogSummary("a", r.time, r.log, rmse=r.rmse, decision="refine", sees=sees)
               for k, r in enumerate(rows)]
    assert fleet.FleetReport(tuple(flagged), report.drift, 0.95).notes == ()


def test_a_mixed_fleet_shows_what_each_row_saw(worn, tmp_path):
    report, bare = worn
    mixed = fleet.FleetReport(report.logs[:2] + bare.logs[2:4], (), 0.95)
    lines = mixed.summary().splitlines()
    assert "Each log's decision saw" not in lines[1]
    assert lines[3].endswith("[saw: residual, q, regressor, estimation run]")
    assert lines[5].endswith("[saw: residual only: no q, no regressor]")


def test_the_manifest_s_data_columns_reach_the_log_s_validation(tmp_path):
    logs = fleet.simulate_fleet(n_robots=1, n_logs=1, n_samples=400)
    spec, = fleet.write_fleet(logs, str(tmp_path))
    assert spec.data.keys() == set(fleet.DATA_COLUMNS)
    read, = fleet.read_manifest(str(tmp_path / "manifest.csv"))
    assert read == spec
    # a log directory gives its own q, dq, ddq, time stamps and regressor (its robot's run is elsewhere)
    folder = fleet.log_from_path(str(tmp_path / spec.log), n_params=10)
    assert set(folder.data) == {"regressor", "q", "dq", "ddq", "timestamps"}
    row = fleet.summarise_log(folder, keywords={"max_lag": 5})
    assert row.sees == "residual, q, regressor; no estimation run"
    log = logs[0]
    want = dynval.compare(log.tau_meas, {"m": (log.tau_pred, 10, log.regressor)}, max_lag=5, q=log.q, dq=log.dq,
                          ddq=log.ddq, time=log.timestamps)
    assert (row.decision, set(row.kinds)) == (want.verdict.decision,
                                              {f.kind for f in want.reports["m"].findings if f.severity != "note"})


def test_an_estimation_run_needs_its_torques_and_its_regressor(tmp_path):
    path = tmp_path / "fleet.csv"
    path.write_text("robot,time,tau_meas,tau_pred,n_params,estimation_tau\nr,1,a.npy,b.npy,2,e.npy\n")
    with pytest.raises(FileInputError, match=r"fleet\.csv line 2: an estimation run is its torques and its regressor: "
                                             r"give both estimation_tau and estimation_regressor, or neither"):
        fleet.read_manifest(str(path))


def test_a_log_s_data_given_to_the_whole_fleet_is_refused(tmp_path):
    with pytest.raises(dynval.InvalidParameter, match=r"^q= is one log's data, not the fleet's: give each log's file "
                                                      r"in the manifest's q column"):
        fleet.validate_many([], q=np.zeros((10, 2)))
    with pytest.raises(dynval.InvalidParameter, match=r"^time= is one log's data.*timestamps column"):
        fleet.validate_many([], time=np.arange(10.0))


def test_a_bad_data_file_of_one_log_is_its_error_row(tmp_path):
    logs = fleet.simulate_fleet(n_robots=1, n_logs=2, n_samples=400)
    first, second = fleet.write_fleet(logs, str(tmp_path))
    np.save(second.q, np.zeros((7, 2)))  # q of another length than the torques
    report = fleet.validate_many([first, second], scheduler="single", max_lag=5)
    assert report.logs[0].error is None
    assert report.logs[1].decision == "error" and "q" in report.logs[1].error


def test_the_fleet_page_shows_what_each_decision_saw_and_the_note(worn):
    from dynval.html import render_fleet_report

    _, bare = worn
    page = render_fleet_report(bare)
    assert "the decision saw" in page and "residual only: no q, no regressor" in page
    note, = bare.notes
    assert f"<li>{note}</li>" in page  # text content: quotes stay as they are
