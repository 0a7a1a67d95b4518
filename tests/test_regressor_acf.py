"""The regressor columns' autocorrelations behind the colour-aware cross-correlation band:
compiled direct sums (cpp, few lags, contiguous) and the FFT give the same numbers."""

from __future__ import annotations

import numpy as np
import pytest

from dynval.kernels import _reference
from dynval.kernels._backend import get_backend
from dynval.report import _sections
from dynval.statistics import _stats


@pytest.fixture
def columns():
    rng = np.random.default_rng(21)
    y = rng.standard_normal((700, 9)).cumsum(axis=0) * 0.1 + rng.standard_normal((700, 9))
    y[:, 4] = 2.5  # constant: nan at every lag on both routes
    return y


@pytest.mark.parametrize("starts", [[0], [0, 250, 600]])
def test_direct_sums_equal_the_fft(columns, starts):
    core = get_backend("cpp")
    starts = np.asarray(starts, dtype=np.int64)
    direct = _sections._biased_acf(core, columns, starts, 12)
    fft = _stats.acf_fft(columns, starts, 12)
    np.testing.assert_array_equal(np.isnan(direct), np.isnan(fft))
    np.testing.assert_allclose(direct, fft, rtol=0, atol=1e-14, equal_nan=True)


def test_the_route_depends_on_backend_lags_and_layout(columns, monkeypatch):
    calls = []

    class Spy:
        def autocorrelation(self, *args):
            calls.append(args[1])
            return get_backend("cpp").autocorrelation(*args)

    starts = np.zeros(1, dtype=np.int64)
    _sections._biased_acf(Spy(), columns, starts, _sections._DIRECT_ACF_LAGS)
    assert calls == [_sections._DIRECT_ACF_LAGS]
    _sections._biased_acf(Spy(), columns, starts, _sections._DIRECT_ACF_LAGS + 1)  # more lags: FFT
    _sections._biased_acf(Spy(), np.asfortranarray(columns), starts, 5)  # would need a copy: FFT
    _sections._biased_acf(_reference, columns, starts, 5)  # the python backend: FFT
    assert calls == [_sections._DIRECT_ACF_LAGS]


@pytest.mark.parametrize("starts", [[0], [0, 3, 250, 600]])  # a segment of 3 rows: shorter than the lags
@pytest.mark.parametrize("centre", [True, False])
def test_few_lags_summed_directly_equal_the_fft(columns, starts, centre, monkeypatch):
    starts = np.asarray(starts, dtype=np.int64)
    lags = _stats._DIRECT_LAGS
    direct = _stats.acf_fft(columns + 1e3, starts, lags, centre=centre)
    monkeypatch.setattr(_stats, "_DIRECT_LAGS", -1)  # every lag count by FFT
    fft = _stats.acf_fft(columns + 1e3, starts, lags, centre=centre)
    np.testing.assert_array_equal(np.isnan(direct), np.isnan(fft))
    np.testing.assert_allclose(direct, fft, rtol=0, atol=1e-13, equal_nan=True)
