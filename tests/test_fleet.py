"""dynval.fleet: logs named by manifests or by their path, one task per log that reads its own files,
the fleet table, and the drift test (its size on exchangeable logs, its power and the change's log)."""

from __future__ import annotations

import json
import math
import os
import pickle
import sys
import xml.etree.ElementTree as ET
from dataclasses import replace

import numpy as np
import pytest

import dynval
import dynval.fleet as fleet
from dynval.cli import main
from dynval.fleet._drift import change_point, drift_per_robot
from dynval.io._files import FileInputError


def _write(path, array):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    np.save(path, array)
    return path


def _pair(rng, n=300, m=2, scale=0.1):
    tau = np.sin(np.outer(np.arange(n) / 50.0, np.arange(1, m + 1))) * 10.0
    return tau, tau + scale * rng.normal(size=(n, m))


@pytest.fixture(scope="module")
def small_fleet(tmp_path_factory):
    """4 robots × 10 logs × 300 samples; r02's friction grows by 100 % from log 5 (0-based) on."""
    directory = str(tmp_path_factory.mktemp("fleet"))
    logs = fleet.simulate_fleet(n_robots=4, n_logs=10, n_samples=300, seed=5,
                                degradations={"r02": fleet.Degradation("friction", 5, 1.0)})
    return directory, logs, fleet.write_fleet(logs, directory)


# --------------------------------------------------------------------------- naming the logs


def test_a_csv_manifest_names_logs_relative_to_itself(tmp_path):
    rng = np.random.default_rng(0)
    meas, pred = _pair(rng)
    _write(str(tmp_path / "a" / "m.npy"), meas)
    _write(str(tmp_path / "a" / "p.npy"), pred)
    (tmp_path / "fleet.csv").write_text("robot,time,tau_meas,tau_pred,n_params\n"
                                        "arm1,2026-02-01T10:00,a/m.npy,a/p.npy,4\n"
                                        "arm1,2026-01-01T10:00,a/m.npy,a/p.npy,\n")
    specs = fleet.read_manifest(str(tmp_path / "fleet.csv"), n_params=7)
    assert [s.tau_meas for s in specs] == [str(tmp_path / "a" / "m.npy")] * 2
    assert [s.n_params for s in specs] == [4, 7]  # the row's own, else the default


def test_a_json_manifest_is_read_like_the_csv(tmp_path):
    (tmp_path / "fleet.json").write_text(json.dumps({"logs": [
        {"robot": "arm1", "time": 3, "tau_meas": "m.npy", "tau_pred": "p.npy", "n_params": 2, "log": "x"}]}))
    (spec,) = fleet.read_manifest(str(tmp_path / "fleet.json"))
    assert (spec.robot, spec.time, spec.name, spec.tau_pred) == ("arm1", "3", "x", str(tmp_path / "p.npy"))


def test_a_manifest_without_a_column_is_refused_naming_it(tmp_path):
    (tmp_path / "fleet.csv").write_text("robot,tau_meas,tau_pred\nr,m.npy,p.npy\n")
    with pytest.raises(FileInputError, match=r"fleet\.csv: a manifest's header needs the columns robot, time, "
                                             r"tau_meas, tau_pred; it lacks time \(its header: robot, tau_meas"):
        fleet.read_manifest(str(tmp_path / "fleet.csv"), n_params=1)


def test_a_row_without_n_params_and_no_default_is_refused_naming_the_line(tmp_path):
    (tmp_path / "fleet.csv").write_text("robot,time,tau_meas,tau_pred\nr,1,m.npy,p.npy\n")
    with pytest.raises(dynval.InvalidParameter, match=r"fleet\.csv line 2: n_params is needed"):
        fleet.read_manifest(str(tmp_path / "fleet.csv"))


def test_a_manifest_row_with_an_empty_needed_cell_is_refused_naming_it(tmp_path):
    (tmp_path / "fleet.csv").write_text("robot,time,tau_meas,tau_pred\nr,1,m.npy,\n")
    with pytest.raises(FileInputError, match=r"fleet\.csv line 2: no tau_pred \(a manifest row needs robot, time, "):
        fleet.read_manifest(str(tmp_path / "fleet.csv"), n_params=1)
    (tmp_path / "fleet.json").write_text('{"logs": 3}')
    with pytest.raises(FileInputError, match=r"fleet\.json: a JSON manifest is a list of objects"):
        fleet.read_manifest(str(tmp_path / "fleet.json"), n_params=1)


def test_hdf5_npz_and_parquet_logs_are_read_with_the_command_line_s_readers(tmp_path):
    h5py = pytest.importorskip("h5py")
    pq = pytest.importorskip("pyarrow.parquet")
    import pyarrow as pa

    rng = np.random.default_rng(3)
    meas, pred = _pair(rng)
    with h5py.File(tmp_path / "r1__1.h5", "w") as f:
        f["tau_meas"], f["tau_pred"] = meas, pred
    np.savez(tmp_path / "r1__2.npz", tau_meas=meas, tau_pred=pred)
    pq.write_table(pa.table({"m0": meas[:, 0], "m1": meas[:, 1], "p0": pred[:, 0], "p1": pred[:, 1]}),
                   str(tmp_path / "log3.parquet"))
    # a cell that names several columns holds commas: quoted, as CSV quotes
    (tmp_path / "fleet.csv").write_text('robot,time,tau_meas,tau_pred\n'
                                        'r1,3,"log3.parquet:m0,m1","log3.parquet:p0,p1"\n')
    logs = [str(tmp_path / "r1__1.h5"), str(tmp_path / "r1__2.npz")]
    report = fleet.validate_many([*logs, str(tmp_path / "fleet.csv")], n_params=2, scheduler="single", max_lag=5)
    want = float(dynval.rmse(meas, pred))
    assert [r.error for r in report.logs] == [None] * 3
    assert [r.rmse for r in report.logs] == pytest.approx([want] * 3, rel=1e-12)


def test_the_naming_pattern_gives_robot_time_and_members(tmp_path):
    spec = fleet.log_from_path(str(tmp_path / "arm_7__2026-03-01T08-00.h5"), n_params=3)
    assert (spec.robot, spec.time, spec.log) == ("arm_7", "2026-03-01T08-00", "arm_7__2026-03-01T08-00")
    assert spec.tau_meas.endswith(".h5:/tau_meas") and spec.tau_pred.endswith(".h5:/tau_pred")
    folder = tmp_path / "arm2__5"
    _write(str(folder / "tau_meas.npy"), np.zeros(3))
    _write(str(folder / "tau_pred.npy"), np.zeros(3))
    _write(str(folder / "regressor.npy"), np.zeros((3, 1)))
    spec = fleet.log_from_path(str(folder), n_params=3)
    assert spec.regressor == str(folder / "regressor.npy") and spec.time == "5"
    with pytest.raises(FileInputError, match=r"a log's name must be ROBOT__TIME"):
        fleet.log_from_path(str(tmp_path / "arm2-5.npz"), n_params=3)
    with pytest.raises(FileInputError, match=r"holds no tau_pred file"):
        os.remove(folder / "tau_pred.npy")
        fleet.log_from_path(str(folder), n_params=3)


def test_times_order_numbers_then_instants_whatever_the_input_order(tmp_path):
    rng = np.random.default_rng(1)
    specs = []
    for time in ("2026-01-10T08-00", "2026-01-02T09:30", "2026-01-02T08:00+00:00"):
        meas, pred = _pair(rng)
        folder = tmp_path / f"r1__{time.replace(':', '')}"
        specs.append(fleet.LogSpec("r1", time, _write(str(folder / "m.npy"), meas), _write(str(folder / "p.npy"), pred),
                                   2))
    report = fleet.validate_many(specs, scheduler="single", max_lag=5)
    assert [r.time for r in report.logs] == ["2026-01-02T08:00+00:00", "2026-01-02T09:30", "2026-01-10T08-00"]
    assert fleet.time_key("10") < fleet.time_key("9e9") < fleet.time_key("1970-01-01") < fleet.time_key("zzz")


# --------------------------------------------------------------------------- the tasks


class _RecordingClient:
    """A stand-in for a dask Client that runs the tasks here but keeps what would travel to workers."""

    def __init__(self):
        self.shipped = []

    def submit(self, *args, **kwargs):  # pragma: no cover - only its presence marks a client
        raise AssertionError

    def map(self, function, items, **kwargs):
        self.shipped = [pickle.dumps((item, kwargs)) for item in items]
        return [_Done(function(item, kwargs["n_params"], kwargs["keywords"])) for item in items]

    def gather(self, futures):
        return [f.value for f in futures]

    def scheduler_info(self):
        return {"workers": {"a": {}, "b": {}}}


class _Done:
    def __init__(self, value):
        self.value = value


def test_tasks_receive_file_names_not_arrays(small_fleet, monkeypatch):
    import distributed

    monkeypatch.setattr(distributed, "as_completed", lambda futures: iter(futures))
    _, _, specs = small_fleet
    client = _RecordingClient()
    report = fleet.validate_many(specs, scheduler=client, max_lag=10)
    batches = [pickle.loads(b)[0] for b in client.shipped]
    assert [spec for batch in batches for spec in batch] == list(specs) and len(report.logs) == len(specs)
    # a few tasks per worker thread (2 workers of 1 thread here), each a run of consecutive logs
    assert len(batches) == min(len(specs), 2 * fleet._run.TASKS_PER_THREAD)
    # a log's arrays are 300 × 2 float64 (4.8 kB each): what travels is its names and settings
    assert max(len(b) / len(batch) for b, batch in zip(client.shipped, batches)) < 1000
    assert report.provenance["where"] == "2 dask workers"


def test_a_row_holds_the_log_s_metrics_and_decision(small_fleet):
    _, logs, specs = small_fleet
    row = fleet.summarise_log(specs[0], keywords={"max_lag": 10})
    log = logs[0]
    assert row.rmse == pytest.approx(float(dynval.rmse(log.tau_meas, log.tau_pred)), rel=1e-12)
    assert row.vaf == pytest.approx(float(dynval.vaf(log.tau_meas, log.tau_pred)), rel=1e-12)
    run = log.estimation  # the log is validated with everything it gives, as validate would be
    want = dynval.compare(log.tau_meas, {"m": (log.tau_pred, 10, log.regressor)}, max_lag=10, q=log.q, dq=log.dq,
                          ddq=log.ddq, time=log.timestamps,
                          estimation={"tau": run.tau, "regressor": run.regressor, "q": run.q})
    assert row.decision == want.verdict.decision
    kinds = [f.kind for f in want.reports["m"].findings if f.severity != "note"]
    assert row.n_findings == len(kinds) and set(row.kinds) == set(kinds)
    assert (row.n_samples, row.n_joints, row.robot, row.log) == (300, 2, "r01", specs[0].log)


def test_a_log_that_cannot_be_read_is_a_row_with_its_error(small_fleet, tmp_path):
    _, _, specs = small_fleet
    bad = tmp_path / "broken.npy"
    bad.write_bytes(b"not a numpy file")
    specs = [specs[0], fleet.LogSpec("r09", "1", str(bad), specs[0].tau_pred, 10)]
    report = fleet.validate_many(specs, scheduler="single", max_lag=5)
    row = {r.robot: r for r in report.logs}["r09"]
    assert row.decision == "error" and row.error.startswith(f"FileInputError: {bad}: not a .npy file")
    assert {r.robot: r for r in report.logs}["r01"].error is None


def test_without_distributed_the_run_stays_in_this_process(small_fleet, monkeypatch):
    _, _, specs = small_fleet
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed then fails
    report = fleet.validate_many(specs[:2], max_lag=5)
    assert report.provenance["where"] == "this process"


def test_a_progress_bar_goes_to_stderr(small_fleet, capsys):
    _, _, specs = small_fleet
    fleet.validate_many(specs[:3], scheduler="single", progress=True, max_lag=5)
    assert "3/3" in capsys.readouterr().err


def test_no_logs_give_an_empty_report():
    report = fleet.validate_many([], scheduler="single")
    assert (report.logs, report.drift, report.findings, report.table()) == ((), (), (), [])


def test_bad_settings_are_refused_with_their_value(small_fleet):
    _, _, specs = small_fleet
    with pytest.raises(dynval.InvalidParameter, match=r"^min_baseline must be an integer >= 2, got 1$"):
        fleet.validate_many(specs, scheduler="single", min_baseline=1)
    with pytest.raises(dynval.InvalidParameter, match=r"^scheduler must be None, 'single', a dask Client"):
        fleet.validate_many(specs, scheduler=3)
    with pytest.raises(dynval.InvalidParameter, match=r"^level must be a number with 0 < level < 1, got 1.5$"):
        fleet.validate_many(specs, scheduler="single", level=1.5)
    # validate's own settings are checked once, before any log is read
    with pytest.raises(dynval.InvalidParameter, match=r"^max_lag must be"):
        fleet.validate_many(specs, scheduler="single", max_lag=-3)
    with pytest.raises(TypeError, match=r"unexpected keyword argument 'max_lags'"):
        fleet.validate_many(specs, scheduler="single", max_lags=3)


# --------------------------------------------------------------------------- drift


def test_the_degraded_robot_is_flagged_from_the_log_it_changed(small_fleet):
    _, _, specs = small_fleet
    report = fleet.validate_many(specs, scheduler="single", max_lag=10)
    flagged = [(d.robot, d.change, d.change_log) for d in report.drift if d.finding is not None]
    assert flagged == [("r02", 5, specs[10 + 5].log)]
    (finding,) = report.findings
    assert finding.kind == "drift" and finding.severity == "deficiency"
    assert finding.details["robot"] == "r02" and finding.details["from_log"] == specs[15].log
    assert finding.message.startswith(f"robot r02: the model fits worse from log {specs[15].log} (")


def test_a_new_payload_is_flagged_from_its_log_and_only_on_its_robot():
    logs = fleet.simulate_fleet(n_robots=3, n_logs=10, n_samples=300, seed=11,
                                degradations={"r03": fleet.Degradation("payload", 6, 1.0)})
    rows = [fleet.LogSummary(g.robot, g.time, f"{g.robot}#{i % 10}", rmse=float(dynval.rmse(g.tau_meas, g.tau_pred)))
            for i, g in enumerate(logs)]
    drift = drift_per_robot(rows, level=0.95, n_permutations=999)
    assert [(d.robot, d.change_log) for d in drift if d.finding is not None] == [("r03", "r03#6")]


def test_a_degradation_of_an_unknown_kind_is_refused():
    with pytest.raises(dynval.InvalidParameter, match=r"^kind must be one of 'friction', 'payload', got 'wear'$"):
        fleet.Degradation("wear", 3, 0.1)


def test_change_point_finds_the_split_and_gives_a_permutation_p():
    x = np.r_[np.zeros(6), np.ones(4)] + 0.01 * np.arange(10) % 0.03
    k, t, p = change_point(x, n_permutations=999, rng=np.random.default_rng(0))
    assert k == 6 and t > 10
    # the 4 largest values last: 1 order in C(10, 4) = 210 puts them there, so p ≈ 1/210 ≥ 1/(B + 1)
    assert 1 / 1000 <= p < 3 / 210


def test_identical_logs_show_no_change():
    _, t, p = change_point(np.full(8, 0.3), rng=np.random.default_rng(0))
    assert t == 0.0 and p == 1.0


def test_the_size_holds_on_exchangeable_logs():
    # 1000 robots of 12 i.i.d. heavy-tailed log RMSEs: the raw p-value is at most α in 5 % of them
    # (a per-split t-test without the permutation of the maximum rejects in about 25 %)
    rng = np.random.default_rng(7)
    rejected = sum(change_point(rng.standard_t(3, size=12), n_permutations=199, rng=rng)[2] <= 0.05
                   for _ in range(1000))
    assert rejected <= 65  # 5 % of 1000 plus two binomial standard deviations (6.9)


def test_healthy_simulated_fleets_raise_no_drift_beyond_the_size():
    rows = []
    raw = total = 0
    for seed in range(12):
        logs = fleet.simulate_fleet(n_robots=5, n_logs=10, n_samples=200, seed=100 + seed)
        rows = [fleet.LogSummary(g.robot, g.time, str(i), rmse=float(dynval.rmse(g.tau_meas, g.tau_pred)))
                for i, g in enumerate(logs)]
        drift = drift_per_robot(rows, level=0.95, n_permutations=199, seed=seed)
        raw += sum(d.pvalue <= 0.05 for d in drift)
        total += len(drift)
        assert all(d.finding is None for d in drift), seed
    assert raw <= 0.05 * total + 2 * np.sqrt(0.05 * 0.95 * total)


def test_holm_is_over_the_robots_and_too_few_logs_are_not_tested():
    rows = [fleet.LogSummary(robot, str(k), f"{robot}{k}", rmse=float(v))
            for robot, values in (("a", [1, 1.1, 0.9, 1, 5, 5.2, 4.9, 5.1]), ("b", [1, 1.2, 0.8, 1.1, 0.9, 1, 1.1, 1]),
                                  ("c", [1, 2, 3]))
            for k, v in enumerate(values)]
    drift = {d.robot: d for d in drift_per_robot(rows, level=0.95, n_permutations=999)}
    assert not drift["c"].tested and drift["c"].reason == "only 3 valid logs; the drift test needs at least 4"
    raw = sorted([drift["a"].pvalue, drift["b"].pvalue])
    assert drift["a"].pvalue_adjusted == pytest.approx(2 * raw[0])  # Holm over the 2 tested robots
    assert drift["a"].change == 4 and drift["a"].finding is not None and drift["b"].finding is None


def test_a_small_significant_drift_is_a_note():
    rows = [fleet.LogSummary("a", str(k), str(k), rmse=float(v))
            for k, v in enumerate([1.0, 1.01, 0.99, 1.0, 1.0, 1.01, 1.05, 1.06, 1.05, 1.06])]
    (d,) = drift_per_robot(rows, level=0.95, n_permutations=999)
    assert d.finding is not None and d.finding.severity == "note" and d.finding.action == ""
    assert "below the 1.1× that counts" in d.finding.message


# --------------------------------------------------------------------------- outputs


def test_the_command_line_prints_the_fleet_and_writes_the_page(small_fleet, tmp_path, capsys):
    directory, _, _ = small_fleet
    page = tmp_path / "fleet.html"
    code = main(["validate-many", os.path.join(directory, "manifest.csv"), "--max-lag", "10", "--json",
                 "--html", str(page), "--no-progress"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and len(out["logs"]) == 40
    assert [f["details"]["robot"] for f in out["findings"]] == ["r02"]
    root = ET.fromstring(page.read_text(encoding="utf-8").split("\n", 1)[1])  # well-formed, as the reports
    text = "".join(root.itertext())
    assert "Robots and their drift" in text and "deficiency" in text
    assert len(root.findall(".//{http://www.w3.org/1999/xhtml}img")) == 2


def test_the_command_line_names_a_bad_log_and_exits_1(tmp_path, capsys):
    # a log that cannot be named is an error row (contract §10), the report printed, exit 1
    assert main(["validate-many", str(tmp_path / "nothing-here.npz"), "--n-params", "2", "--json"]) == 1
    row, = json.loads(capsys.readouterr().out)["logs"]
    assert row["decision"] == "error" and "a log's name must be ROBOT__TIME" in row["error"]
    assert main(["validate-many", "x.npz", "--workers", "0"]) == 2


def test_the_summary_lists_every_log_and_the_drift(small_fleet):
    _, _, specs = small_fleet
    report = fleet.validate_many(specs, scheduler="single", max_lag=10)
    text = report.summary()
    assert text.count("\n  r0") >= 40 + 4 and "r02: DRIFT from log" in text
    table = report.table()
    assert len(table) == 40 and tuple(table[0]) == fleet.TABLE_COLUMNS
    assert [row["robot"] for row in table[::10]] == ["r01", "r02", "r03", "r04"]
    robots = report.robot_table()
    assert [r["robot"] for r in robots] == ["r01", "r02", "r03", "r04"]
    assert robots[1]["rmse"] == pytest.approx(np.median([row["rmse"] for row in table[10:20]]))
    assert sum(robots[1]["decisions"].values()) == 10 and robots[1]["n_errors"] == 0
    assert (robots[1]["drift"], robots[1]["from_log"]) == ("deficiency", specs[15].log)
    assert robots[0]["drift"] == "none"


# --------------------------------------------------------------------------- a real cluster


@pytest.mark.slow
def test_a_local_cluster_gives_the_single_process_report(small_fleet):
    distributed = pytest.importorskip("distributed")
    bag = pytest.importorskip("dask.bag")
    import dynval.dask
    _, _, specs = small_fleet
    single = fleet.validate_many(specs, scheduler="single", max_lag=10)
    with fleet.local_cluster(2) as c:
        by_address = fleet.validate_many(specs, scheduler=c.scheduler_address, max_lag=10)
        with distributed.Client(c) as client:
            # the workers keep freed memory for the next log's temporaries (dynval.fleet._cluster)
            environ = client.run(lambda: (os.environ.get("MALLOC_MMAP_THRESHOLD_"),
                                          os.environ.get("DYNVAL_NUM_THREADS")))
            # and one thread each for dynval's own parallel work (the worker runs a task per thread)
            assert set(environ.values()) == {(str(16 << 20), "1")}
            assert "MALLOC_MMAP_THRESHOLD_" not in os.environ  # set for the workers only
            # LogSpecs: a log's folder alone does not name its robot's estimation run (write_fleet keeps it
            # beside the logs, in the manifest), so its decision would see less
            from_bag = dynval.dask.validate_many(bag.from_sequence(specs, npartitions=3), n_params=10, max_lag=10)
    strip = [{k: v for k, v in vars(r).items() if k not in ("seconds", "log", "time")} for r in single.logs]
    for other in (by_address, from_bag):
        assert [{k: v for k, v in vars(r).items() if k not in ("seconds", "log", "time")} for r in other.logs] == strip
        assert [(d.robot, d.change, d.pvalue) for d in other.drift] == [(d.robot, d.change, d.pvalue)
                                                                         for d in single.drift]
    assert by_address.provenance["where"] == "2 dask workers"


@pytest.mark.slow
def test_the_command_line_runs_on_a_scheduler_s_address(small_fleet, capsys):
    distributed = pytest.importorskip("distributed")
    directory, _, _ = small_fleet
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, dashboard_address=":0") as c:
        code = main(["validate-many", os.path.join(directory, "manifest.csv"), "--max-lag", "10", "--json",
                     "--scheduler", c.scheduler_address])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["provenance"]["where"] == "1 dask worker" and len(out["logs"]) == 40


def test_a_bag_without_a_client_runs_in_this_process(small_fleet):
    bag = pytest.importorskip("dask.bag")
    directory, _, specs = small_fleet
    folders = [os.path.join(directory, s.log) for s in specs[:6]]
    report = fleet.validate_many(bag.from_sequence(folders, npartitions=2), scheduler="single", n_params=10,
                                 max_lag=5)
    assert report.provenance["where"] == "this process"
    assert [r.log for r in report.logs] == [s.log for s in specs[:6]]


# --------------------------------------------------------------------------- the drift test, value by value


def _row(robot, i, rmse, error=None):
    return fleet.LogSummary(robot=robot, time=str(i), log=f"{robot}__{i}", rmse=rmse, error=error,
                            decision="error" if error else "accept")


def test_each_split_statistic_is_the_pooled_two_sample_t():
    import scipy.stats

    from dynval.fleet._drift import _split_statistics

    x = np.array([[0.3, -0.2, 0.5, 0.1, 0.9, 1.4, 0.7, 1.1], [1.0, 2.0, 0.5, 3.0, 2.5, 0.0, 1.5, 1.0]])
    for min_baseline in (2, 3, 5):
        t = _split_statistics(x, min_baseline)
        assert t.shape == (2, 8 - min_baseline)
        for row in range(2):
            for col, k in enumerate(range(min_baseline, 8)):
                want = scipy.stats.ttest_ind(x[row, k:], x[row, :k], equal_var=True).statistic
                assert t[row, col] == pytest.approx(want, rel=1e-12)
    assert np.array_equal(_split_statistics(np.ones((1, 6)), 3), np.zeros((1, 3)))  # 0/0: no change
    equal_logs = np.log(np.full((1, 3), 0.1))  # equal, but not exactly after rounding, without centring
    assert np.array_equal(_split_statistics(equal_logs, 2), np.zeros((1, 1)))
    jump = np.array([[0.0, 0.0, 0.0, 1.0]])  # a jump without spread: +inf, and no overflow after
    assert _split_statistics(jump, 3)[0, 0] == np.inf
    k, t, p = change_point(jump[0], min_baseline=3, n_permutations=99)
    assert (k, t) == (3, np.inf) and p == pytest.approx(0.25, abs=0.15)


def test_change_point_returns_the_largest_split_and_a_permutation_p_on_its_grid():
    x = [0.0, 0.1, -0.1, 0.05, 0.0, 1.0, 1.1, 0.9]
    k, t, p = change_point(x, min_baseline=3, n_permutations=99, rng=np.random.default_rng(1))
    assert k == 5
    import scipy.stats
    assert t == pytest.approx(scipy.stats.ttest_ind(x[5:], x[:5]).statistic, rel=1e-12)
    assert round(p * 100) >= 1 and p * 100 == pytest.approx(round(p * 100), abs=1e-9)
    # only orders that put the three large values last reach this t: 3!·5!/8! = 1/56 of them
    k, t, p = change_point(x, min_baseline=3, n_permutations=4999, rng=np.random.default_rng(2))
    assert p == pytest.approx(1 / 56, abs=4 * np.sqrt((1 / 56) * (55 / 56) / 5000) + 1 / 5000)
    # a decrease is not a drift: the one-sided test gives a large p
    assert change_point(x[::-1], min_baseline=3, n_permutations=199)[2] > 0.5


def test_the_drift_of_each_robot_counts_its_valid_logs_and_holm_runs_over_the_tested_ones():
    from statsmodels.stats.multitest import multipletests

    rising = [0.1, 0.11, 0.1, 0.1, 0.105, 0.2, 0.21, 0.2, 0.2]
    flat = [0.1, 0.12, 0.09, 0.11, 0.1, 0.1, 0.11, 0.1, 0.09]
    rows = [_row("a", i, v) for i, v in enumerate(rising)]
    rows += [_row("b", i, v) for i, v in enumerate(flat)]
    rows += [_row("c", 0, 0.1), _row("c", 1, 0.0), _row("c", 2, float("nan")), _row("c", 3, 0.2, error="E"),
             _row("c", 4, 0.3)]  # two valid logs: zero, NaN and failed logs do not count
    out = {d.robot: d for d in drift_per_robot(rows, level=0.95, n_permutations=999)}
    assert not out["c"].tested and out["c"].n_logs == 2
    assert out["c"].reason == "only 2 valid logs; the drift test needs at least 4"
    assert out["c"].finding is None and math.isnan(out["c"].pvalue_adjusted)
    raw = [out["a"].pvalue, out["b"].pvalue]
    assert [out["a"].pvalue_adjusted, out["b"].pvalue_adjusted] == pytest.approx(
        list(multipletests(raw, method="holm")[1]), rel=1e-12)
    a = out["a"]
    assert (a.change, a.change_log, a.change_time, a.n_logs) == (5, "a__5", "5", 9)
    assert a.ratio == pytest.approx(np.exp(np.mean(np.log(rising[5:])) - np.mean(np.log(rising[:5]))), rel=1e-12)
    assert a.finding is not None and out["b"].finding is None
    one = drift_per_robot([_row("d", i, v) for i, v in enumerate([0.1, 0.1, 0.1, 0.1])], level=0.95)[0]
    assert one.tested and one.n_logs == 4 and one.change == 3
    few = drift_per_robot([_row("e", i, 0.1) for i in range(3)], level=0.95, min_baseline=2)[0]
    assert few.tested and few.change == 2
    single = drift_per_robot([_row("f", 0, 0.1)], level=0.95)[0]
    assert single.reason == "only 1 valid log; the drift test needs at least 4"


def test_a_drift_finding_is_a_deficiency_from_the_threshold_on_and_says_so():
    from dynval.fleet._drift import Drift, _drift, _finding

    logs = [_row("r", i, v) for i, v in enumerate([1.0, 2.0, 4.0, 8.0])]
    at = Drift("r", 4, True, change=2, change_log="r__2", change_time="2", statistic=3.5, pvalue=0.01,
               pvalue_adjusted=0.02, ratio=1.1)
    f = _finding(at, logs, 1.1)
    assert (f.kind, f.severity, f.statistic, f.pvalue, f.pvalue_adjusted, f.effect, f.threshold) == (
        "drift", "deficiency", 3.5, 0.01, 0.02, 1.1, 1.1)
    assert f.effect_unit == "× RMSE"
    assert f.message == ("robot r: the model fits worse from log r__2 (2) on: 1.1× the RMSE of its 2 earlier logs "
                         "(geometric means; change point in log RMSE over its 4 logs, permutation test, "
                         "Holm-adjusted p = 0.02 over the fleet's robots)")
    assert f.action.startswith("re-identify robot r's model on its logs from r__2 on, or find what changed then")
    assert f.details == {"robot": "r", "from_log": "r__2", "from_time": "2", "from_index": 2, "n_logs": 4,
                         "rmse_before": pytest.approx(np.sqrt(2.0)), "rmse_after": pytest.approx(np.sqrt(32.0))}
    below = _finding(replace(at, ratio=1.0999, change=1), logs, 1.1)
    assert below.severity == "note" and below.action == ""
    assert "1.1× the RMSE of its 1 earlier logs, below the 1.1× that counts" in below.message
    one = _finding(replace(at, change=1), logs, 1.1)
    assert "of its 1 earlier log (" in one.message
    # significance at exactly α is a finding; just above it is not
    res = (2, 3.5, 0.05)
    assert _drift("r", logs, res, 0.05, 0.95, 3, 1.1).finding is not None
    assert _drift("r", logs, res, 0.0501, 0.95, 3, 1.1).finding is None
    d = _drift("r", logs, res, 0.05, 0.95, 3, 1.1)
    assert (d.change, d.change_log, d.statistic, d.pvalue, d.pvalue_adjusted) == (2, "r__2", 3.5, 0.05, 0.05)
    assert d.ratio == pytest.approx(4.0, rel=1e-12)  # sqrt(32) / sqrt(2)


def test_the_drift_p_values_are_reproducible_per_robot_and_on_the_permutation_grid():
    import zlib

    rising = [0.1, 0.11, 0.1, 0.1, 0.105, 0.2, 0.21, 0.2, 0.2]
    # an untested robot first: the robots after it are still tested
    rows = [_row("c", 0, 0.1)] + [_row("a", i, v) for i, v in enumerate(rising)]
    out = {d.robot: d for d in drift_per_robot(rows, level=0.95, n_permutations=999)}
    assert out["c"].tested is False and out["a"].tested is True
    # the shuffles of robot a come from the seed and its name, whatever else is in the fleet
    own = np.random.default_rng([0, zlib.crc32(b"a")])
    assert out["a"].pvalue == change_point(np.log(rising), n_permutations=999, rng=own)[2]
    assert out["a"].pvalue * 1000 == pytest.approx(round(out["a"].pvalue * 1000), abs=1e-9)  # B = 999
    again = drift_per_robot(rows, level=0.95, n_permutations=999)
    assert math.isnan(again[0].pvalue) and again[1].pvalue == out["a"].pvalue
    other = drift_per_robot(rows, level=0.95, n_permutations=999, seed=5)
    assert other[1].pvalue == change_point(np.log(rising), n_permutations=999,
                                           rng=np.random.default_rng([5, zlib.crc32(b"a")]))[2]
    # change_point itself: the generator given is the one used, and without one it is seeded
    x = [0.0, 0.3, -0.2, 0.1, 0.4, 0.2, 0.5]
    assert change_point(x, n_permutations=199) == change_point(x, n_permutations=199)
    assert change_point(x, n_permutations=199) == change_point(x, n_permutations=199, rng=np.random.default_rng(0))
    ps = {change_point(x, n_permutations=199, rng=np.random.default_rng(s))[2] for s in range(1, 6)}
    assert len(ps) > 1


def test_a_drop_without_spread_is_minus_infinity_and_the_boundary_of_alpha_is_a_finding():
    from dynval.fleet._drift import _drift, _split_statistics

    assert _split_statistics(np.array([[1.0, 1.0, 1.0, 0.0]]), 3)[0, 0] == -np.inf
    logs = [_row("r", i, v) for i, v in enumerate([1.0, 2.0, 4.0, 8.0])]
    assert _drift("r", logs, (2, 3.5, 0.25), 0.25, 0.75, 3, 1.1).finding is not None  # 1 − 0.75 is 0.25 exactly
    assert _drift("r", logs, (2, 3.5, 0.25), 0.2500001, 0.75, 3, 1.1).finding is None
    f = _drift("r", logs, (2, 3.5, 0.25), 0.25, 0.75, 3, 1.1).finding
    assert f.action == ("re-identify robot r's model on its logs from r__2 on, or find what changed then "
                        "(friction wear, a new payload or tool, a sensor's calibration)")
