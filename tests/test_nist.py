"""NIST StRD univariate summary statistics: mean, SD (n−1) and lag-1 autocorrelation.

The data and certified values live in the repository, ``golden/data/nist_strd/`` (see its
``SOURCES.md``): the test never depends on anything outside it. For NumAcc3/NumAcc4 the doubles
nearest to the decimal data differ from the data enough that no float64 program can reach all
certified digits, so each result is judged
against the exact value for the doubles it was given (rational arithmetic, computed here with
:mod:`fractions` and :mod:`mpmath`) and, beside it, against the certified value with the
tolerance that float64 input allows.
"""

from __future__ import annotations

import json
from fractions import Fraction
from pathlib import Path

import mpmath
import numpy as np
import pytest

import dynval

STRD = Path(__file__).resolve().parents[1] / "golden" / "data" / "nist_strd"
DATASETS = ["NumAcc1", "NumAcc2", "NumAcc3", "NumAcc4", "Michelso", "Lew", "Lottery", "Mavro", "PiDigits"]

# Relative tolerances of the reference against the exact value for the float64 data.
TOL_MEAN = 1e-15
TOL_SD = 1e-13
TOL_LAG1 = 1e-13


def load(name):
    lines = (STRD / f"{name}.dat").read_text().splitlines()
    values = [line.strip() for line in lines if line.strip() and not line.lstrip().startswith("#")]
    return np.array([float(v) for v in values])


def certified(name):
    return json.loads((STRD / "certified.json").read_text())["univariate"][name]


def exact_statistics(y):
    """Mean, SD and lag-1 autocorrelation of the doubles in ``y``, exactly (SD to 40 digits)."""
    q = [Fraction(v) for v in y.tolist()]
    n = len(q)
    mean = sum(q) / n
    d = [v - mean for v in q]
    ss = sum(v * v for v in d)
    lag1 = sum(d[i] * d[i - 1] for i in range(1, n)) / ss
    with mpmath.workdps(40):
        sd = mpmath.sqrt(mpmath.mpf(ss.numerator) / mpmath.mpf(ss.denominator) / (n - 1))
        return float(mean), float(sd), float(lag1)


def rel(a, b):
    return abs(a - b) / abs(b)


@pytest.mark.parametrize("name", DATASETS)
def test_univariate(backend, name):
    y = load(name)
    cert = certified(name)
    assert y.size == cert["n"]
    mean = float(dynval.residual_mean(y, backend=backend)[0])
    sd = float(np.sqrt(dynval.residual_variance(y, ddof=1, backend=backend)[0]))
    lag1 = float(dynval.autocorrelation(y, 1, adjusted=False, backend=backend)[1])

    exact_mean, exact_sd, exact_lag1 = exact_statistics(y)
    assert rel(mean, exact_mean) <= TOL_MEAN
    assert rel(sd, exact_sd) <= TOL_SD
    assert rel(lag1, exact_lag1) <= TOL_LAG1

    # Against the certified digits: as close as float64 input allows (the exact value for the
    # doubles is itself that far from the certified decimal value), and never worse than 1e-13.
    for got, exact, key in ((mean, exact_mean, "mean"), (sd, exact_sd, "sd"), (lag1, exact_lag1, "lag1_autocorr")):
        want = float(cert[key])
        allowed = max(1e-13, 2.0 * rel(exact, want))
        assert rel(got, want) <= allowed, (key, got, want)


def test_numacc4_is_the_hard_case(backend):
    # The offset 1e7 with deviations of 0.1: a one-pass (Σy² − nȳ²) variance loses every digit.
    y = load("NumAcc4")
    naive = (np.sum(y * y) - y.size * np.mean(y) ** 2) / (y.size - 1)
    _, exact_sd, _ = exact_statistics(y)
    assert rel(np.sqrt(abs(naive)), exact_sd) > 1e-3
    sd = float(np.sqrt(dynval.residual_variance(y, ddof=1, backend=backend)[0]))
    assert rel(sd, exact_sd) <= TOL_SD
