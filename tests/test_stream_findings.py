"""A streamed report and ``validate`` on the same data give the same findings wherever both test
(contract §4.1): the README's example (tests/test_stream_bias.py), every demo scenario and a KUKA
LWR4+ run. The stream's findings are ``validate``'s less the kinds of the tests its report names
as not tested (and whiteness where ``validate`` decimated: it then tests at the information rate,
the stream at the logged rate), by kind and joints (a whiteness finding's severity follows the
deficiencies of the tests run, so it is not compared)."""

from __future__ import annotations

import numpy as np
import pytest

import dynval
from dynval import coverage
from dynval.datasets import load_kuka_lwr4
from dynval.identify import identify
from dynval.simulate import SCENARIOS, simulate
from dynval.stream import ValidationAccumulator


def _streamed(tau, pred, regressor=None, *, time=None, chunk=613, **keywords):
    acc = ValidationAccumulator(**keywords)
    for a in range(0, tau.shape[0], chunk):
        acc.update(tau[a:a + chunk], pred[a:a + chunk], None if regressor is None else regressor[a:a + chunk],
                   time=None if time is None else time[a:a + chunk])
    return acc.result()


def _agree(streamed, whole, given) -> None:
    decimated = whole.whiteness is not None and whole.whiteness["decimation"] > 1
    excused = coverage.excused_kinds("stream", given, decimated)
    assert streamed.provenance["not_tested"] == coverage.not_tested("stream", given, _skipped(streamed))
    want = sorted((f.kind, f.joints) for f in whole.findings if f.kind not in excused)
    assert sorted((f.kind, f.joints) for f in streamed.findings if f.kind not in excused) == want
    # a test the stream did not run gives no finding (whiteness runs, at the logged rate)
    assert not {f.kind for f in streamed.findings} & (excused - {"whiteness"})
    if whole.bias is not None and streamed.bias is not None:
        np.testing.assert_allclose(streamed.bias["n_eff"], whole.bias["n_eff"], rtol=1e-9)


def _skipped(streamed) -> dict[str, str]:
    """The tests a stream left out for a reason of its data (the bias test's bandwidth)."""
    return {t["test"]: t["why"] for t in streamed.provenance["not_tested"] if t["test"] in coverage.RUNTIME}


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_demo_scenarios(scenario, backend):
    d = simulate(scenario, seed=2, n_samples=2500)
    est, val = d.estimation, d.validation
    for name in d.candidates:
        fit = identify(est.regressors[name], est.tau_meas)
        pred = fit.predict(val.regressors[name])
        for regressor in (None, val.full_regressor):
            # with a rate, validate's default max_lag follows the motion's band, which a stream does
            # not know (contract §4.1): the same explicit max_lag for both
            keywords = dict(n_params=fit.rank, sample_rate=d.sample_rate, max_lag=50)
            whole = dynval.validate(val.tau_meas, pred, regressor=regressor, **keywords)
            streamed = _streamed(val.tau_meas, pred, regressor, backend=backend, **keywords)
            _agree(streamed, whole, {"lags"} | ({"regressor"} if regressor is not None else set()))


def test_a_kuka_run_residual_only(backend):
    """Run 2 against run 1 (the same commanded trajectory) with the logged time stamps. The
    residual is smooth: Andrews' bandwidth needs about 1,960 lags, more than the 143 a stream
    holds, so the stream names the bias test as not tested; with max_lag large enough it runs and
    equals validate's."""
    r1, r2 = load_kuka_lwr4(1), load_kuka_lwr4(2)
    tau, pred, time = r2.tau, r1.tau, r2.time
    whole = dynval.validate(tau, pred, n_params=10, time=time, max_lag=50)
    streamed = _streamed(tau, pred, time=time, n_params=10, backend=backend, max_lag=50)
    _agree(streamed, whole, {"lags", "time"})
    needed = int(whole.bias["bandwidth"].max()) + 1
    assert streamed.bias is None and needed > 143
    assert [t["test"] for t in streamed.provenance["not_tested"]] == ["bias", "information_rate", "prediction_artefact"]
    assert streamed.spectrum is not None  # no regressor: the stream's Welch sums are validate's
    longer = _streamed(tau, pred, time=time, n_params=10, backend=backend, max_lag=needed, chunk=2000)
    np.testing.assert_allclose(longer.bias["n_eff"], whole.bias["n_eff"], rtol=1e-9)
    np.testing.assert_allclose(longer.bias["statistic"], whole.bias["statistic"], rtol=1e-9)
