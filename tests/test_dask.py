"""dynval.dask on a two-process local cluster: the report equals validate on the same data.

The cluster is what a real one is to dask (separate worker processes, the accumulators pickled
between them); only the scheduler's address would differ.
"""

from __future__ import annotations

import numpy as np
import pytest

da = pytest.importorskip("dask.array")
distributed = pytest.importorskip("distributed")

import dynval  # noqa: E402
import dynval.dask  # noqa: E402
from dynval.stream import ValidationAccumulator  # noqa: E402
from test_stream import assert_same_report  # noqa: E402

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1, dashboard_address=":0")
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


def robot_like(n, m, p, seed):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 500.0
    tau = 20.0 * np.sin(np.outer(t, np.arange(1, m + 1))) + rng.normal(size=(1, m)) * 5.0
    e = 0.3 * rng.normal(size=(n, m)) + 0.05 * np.cumsum(rng.normal(size=(n, m)), axis=0) / np.sqrt(n) + 0.2
    y = np.stack([np.sin(np.outer(t, np.arange(1, m + 1)) * (c + 1)) for c in range(p)], axis=2)
    return tau, tau - e, y + rng.normal(scale=0.01, size=y.shape)


def test_local_cluster_equals_validate(client, backend):
    tau, pred, y = robot_like(40_000, 3, 4, seed=0)
    segments = [15_000, 25_000]
    got = dynval.dask.validate(da.from_array(tau, chunks=(7_000, 3)), da.from_array(pred, chunks=(5_000, 3)),
                               n_params=8, regressor=da.from_array(y, chunks=(10_000, 3, 4)), max_lag=30,
                               segments=segments, split_every=3, backend=backend)
    want = dynval.validate(tau, pred, n_params=8, regressor=y, max_lag=30, segments=segments, backend="python",
                           cross_correlation_detail="full")
    assert_same_report(got, want, tau, pred, y)
    assert got.provenance["segments"] == segments
    assert got.provenance["backend"] == backend


def test_local_cluster_errors_name_the_block(client):
    tau, pred, _ = robot_like(4_000, 2, 1, seed=1)
    pred[2_503, 1] = np.nan
    with pytest.raises(dynval.NonFiniteInput, match=r"^chunk 2: tau_pred has a non-finite value \(nan\) at row 503, "
                                                    r"column 1 \(row 2503 of the stream\)$"):
        dynval.dask.validate(da.from_array(tau, chunks=(1_000, 2)), da.from_array(pred, chunks=(1_000, 2)),
                             n_params=1, max_lag=5)
    report = dynval.dask.validate(da.from_array(tau, chunks=(1_000, 2)), da.from_array(pred, chunks=(1_000, 2)),
                                  n_params=1, max_lag=5, nan_policy="omit")
    assert report.provenance["omitted_rows"] == 1 and report.provenance["segments"] == [2_503, 1_496]


@pytest.mark.parametrize("chunk", [100, 37, 1000])
def test_time_stamps_give_the_streams_report(chunk, backend):
    # dynval.dask.validate(time=...) raised a raw TypeError from the accumulator's constructor
    rng = np.random.default_rng(3)
    n = 3000
    tau = rng.normal(size=(n, 2))
    pred = tau + 0.1 * rng.normal(size=(n, 2))
    t = 12.0 + np.arange(n) / 100.0
    t[1500:] += 0.5  # a gap: a segment break, wherever the blocks end
    t[700] = t[699]  # a duplicated stamp
    acc = ValidationAccumulator(n_params=1, max_lag=5, backend=backend)
    acc.update(tau, pred, time=t)
    streamed = acc.result()
    got = dynval.dask.validate(da.from_array(tau, chunks=(chunk, 2)), da.from_array(pred, chunks=(chunk, 2)),
                               n_params=1, max_lag=5, backend=backend, time=da.from_array(t, chunks=500))
    assert got.timing["gaps"] == 1 and got.timing["duplicated_stamps"] == 1 and got.timing["sample_rate"] == 100.0
    for key in ("gaps", "gap_rows", "duplicated_stamps", "repeated_rows", "irregular_steps", "nominal_step"):
        assert got.timing[key] == streamed.timing[key], key
    assert got.provenance["segments"] == [1500, 1500]
    want = dynval.validate(tau, pred, n_params=1, max_lag=5, backend=backend, time=t)
    assert_same_report(got, want, tau, pred)


def test_time_stamps_are_checked_with_validates_messages():
    tau = np.zeros((400, 2))
    blocks = da.from_array(tau, chunks=(100, 2))
    t = np.arange(400) / 100.0
    with pytest.raises(dynval.ShapeMismatch, match=r"time must have one stamp per sample, shape \(400,\), got"):
        dynval.dask.validate(blocks, blocks, n_params=1, max_lag=3, time=t[:-1])
    back = t.copy()
    back[250] = 0.0
    with pytest.raises(dynval.InvalidParameter, match=r"time must never decrease, got 0.0 at row 250"):
        dynval.dask.validate(blocks, blocks, n_params=1, max_lag=3, time=back)
    with pytest.raises(dynval.InvalidParameter, match="these look like milliseconds: pass time / 1000"):
        dynval.dask.validate(blocks, blocks, n_params=1, max_lag=3, time=t * 1e3)


@pytest.mark.parametrize("chunk", [50, 100, 150, 1000])
def test_a_frozen_clock_inside_a_block(chunk):
    # a block of one stamp, after a block still waiting for its grid: the merge refused it
    rng = np.random.default_rng(6)
    n = 2000
    tau = rng.normal(size=(n, 2))
    pred = tau + 0.1 * rng.normal(size=(n, 2))
    t = np.arange(n) / 100.0
    t[500:800] = t[500]
    got = dynval.dask.validate(da.from_array(tau, chunks=(chunk, 2)), da.from_array(pred, chunks=(chunk, 2)),
                               n_params=1, max_lag=5, time=t)
    want = dynval.validate(tau, pred, n_params=1, max_lag=5, time=t)
    for key in ("duplicated_stamps", "gaps", "gap_rows", "sample_rate", "irregular_steps"):
        assert got.timing[key] == want.timing[key], key
    assert_same_report(got, want, tau, pred)
