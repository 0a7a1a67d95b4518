"""The fused metrics' one typed result (``checks._typing.FusedMetrics``, contract §5.1): the C++ kernel,
the numpy reference and the stream's sums give the same names, of the declared kinds, and the same
values."""

from __future__ import annotations

import numpy as np
import pytest

from dynval import stream
from dynval.checks._typing import FusedMetrics
from dynval.kernels._reference import metrics as reference

PER_JOINT = {"sse", "rmse", "max_abs_error", "vaf", "fit_percent", "r2", "residual_mean", "residual_variance",
             "constant_target"}
COUNTS = {"n_samples", "n_joints", "n_params"}


def _pair():
    rng = np.random.default_rng(11)
    tau = rng.standard_normal((400, 3)) * np.array([1.0, 5.0, 0.2])
    return tau, tau + 0.1 * rng.standard_normal((400, 3))


def _streamed(monkeypatch, tau, pred):
    seen = []
    original = stream._fused_metrics

    def keep(*args, **kwargs):
        seen.append(original(*args, **kwargs))
        return seen[-1]

    monkeypatch.setattr(stream, "_fused_metrics", keep)
    acc = stream.ValidationAccumulator(n_params=2, max_lag=0)
    acc.update(tau, pred)
    acc.result()
    return seen[-1]


def test_every_producer_gives_the_typed_results_names_and_kinds(monkeypatch):
    core = pytest.importorskip("dynval._core")
    tau, pred = _pair()
    results = {"cpp": core.compute_metrics(tau, pred, 2, 1, "pooled"),
               "reference": reference.compute_metrics(tau, pred, 2, 1, "pooled"),
               "stream": _streamed(monkeypatch, tau, pred)}
    for who, km in results.items():
        assert set(km) == FusedMetrics.__required_keys__, who
        for name, value in km.items():
            if name in PER_JOINT:
                assert isinstance(value, np.ndarray) and value.shape == (3,), (who, name)
            elif name in COUNTS:
                assert isinstance(value, int), (who, name)
            elif name == "constant_target_pooled":
                assert isinstance(value, bool), who
            else:
                assert isinstance(value, float), (who, name)
    for name in FusedMetrics.__required_keys__:
        want = np.asarray(results["reference"][name], dtype=float)
        for who in ("cpp", "stream"):
            np.testing.assert_allclose(np.asarray(results[who][name], dtype=float), want, rtol=1e-9, atol=0,
                                       err_msg=f"{who}: {name}")
