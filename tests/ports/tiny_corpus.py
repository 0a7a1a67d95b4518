"""A small hand-written corpus for the runner's own tests.

The runner's behaviour (statuses, reasons, restarts) is tested against these
few vectors so that the tests do not move when the real corpus grows. Every
expected value is a closed form worked out in the comment next to it.
"""

from __future__ import annotations

import json
import math
import pathlib

FAMILIES = ("norms", "normalized_fit", "residual_statistics", "autocorrelation",
            "portmanteau", "cross_correlation", "information_criteria", "errors")


def arr(shape, values):
    return {"shape": list(shape), "values": list(values)}


def test(tc_id, comment, inputs, expected, tolerance=None, result="valid", flags=("Basic",)):
    entry = {"tcId": tc_id, "comment": comment, "flags": list(flags), "inputs": inputs, "expected": expected,
             "result": result}
    entry["tolerance"] = tolerance if tolerance is not None else {k: 1e-12 for k in expected if k != "error"}
    return entry


COL3 = arr((3, 1), [1.0, 2.0, 3.0])
ONES3 = arr((3, 1), [1.0, 1.0, 1.0])
ALT4 = arr((4, 1), [1.0, -1.0, 1.0, -1.0])
# e = (1, -1, 1, -1): mean 0, R(0) = 1, biased R(1) = -3/4, so rho(1) = -0.75;
# Ljung-Box Q(1) = N(N+2) rho^2/(N-1) = 4*6*0.5625/3 = 4.5, chi2(1) sf = erfc(sqrt(4.5/2)).
LB_P = math.erfc(1.5)
# Y column (1, 2, 3, 4) against e: sum e*(Y-2.5) = -2, /N = -0.5; R_Y(0) = 1.25.
XC0 = -0.5 / math.sqrt(1.25)
Z975 = 1.959963984540054  # Phi^-1(0.975)

GROUPS = {
    "norms": [
        ("sse", {"multioutput": "pooled"}, [
            # e = (0, 1, 2): SSE = 5
            test(1, "three samples", {"tau_meas": COL3, "tau_pred": ONES3}, {"value": 5.0}),
        ]),
        ("rmse", {"multioutput": "pooled", "convention": "per_element"}, [
            test(2, "sqrt(5/3)", {"tau_meas": COL3, "tau_pred": ONES3}, {"value": math.sqrt(5 / 3)}),
        ]),
        ("rmse", {"multioutput": "raw_values", "convention": None}, [
            # SSE_j = (1+9, 4+16) over N = 2
            test(3, "two joints", {"tau_meas": arr((2, 2), [1.0, 2.0, 3.0, 4.0]), "tau_pred": arr((2, 2), [0.0] * 4)},
                 {"value": arr((2,), [math.sqrt(5.0), math.sqrt(10.0)])}),
        ]),
        ("max_abs_error", {"multioutput": "pooled"}, [
            test(4, "max |e| = 2", {"tau_meas": COL3, "tau_pred": ONES3}, {"value": 2.0}),
        ]),
    ],
    "normalized_fit": [
        ("r2", {"multioutput": "pooled"}, [
            # SSE = 1, TSS = 2
            test(1, "r2 = 0.5", {"tau_meas": COL3, "tau_pred": arr((3, 1), [1.0, 2.0, 4.0])}, {"value": 0.5}),
            test(2, "constant target, not exact", {"tau_meas": ONES3, "tau_pred": COL3}, {"value": "-Infinity"}),
            test(3, "constant target, exact", {"tau_meas": ONES3, "tau_pred": ONES3}, {"value": "NaN"}),
        ]),
    ],
    "residual_statistics": [
        ("residual_mean", {}, [test(1, "mean 2", {"e": COL3}, {"value": arr((1,), [2.0])})]),
        ("residual_variance", {"ddof": 1}, [test(2, "variance 1", {"e": COL3}, {"value": arr((1,), [1.0])})]),
    ],
    "autocorrelation": [
        ("autocorrelation", {"adjusted": False, "segments": None}, [
            test(1, "alternating", {"e": ALT4, "max_lag": 1}, {"value": arr((2, 1), [1.0, -0.75])}),
        ]),
    ],
    "portmanteau": [
        ("ljung_box", {"model_df": 0, "segments": None}, [
            test(1, "alternating, one lag", {"e": ALT4, "lags": [1]},
                 {"lags": arr((1,), [1]), "statistic": arr((1, 1), [4.5]), "pvalue": arr((1, 1), [LB_P]),
                  "log_pvalue": arr((1, 1), [math.log(LB_P)]), "df": arr((1,), [1])},
                 tolerance={"statistic": 1e-12, "pvalue": 1e-14, "log_pvalue": 1e-12}),
            test(2, "alternating, lags as an int", {"e": ALT4, "lags": 1},
                 {"lags": arr((1,), [1]), "statistic": arr((1, 1), [4.5]), "pvalue": arr((1, 1), [LB_P]),
                  "log_pvalue": arr((1, 1), [math.log(LB_P)]), "df": arr((1,), [1])},
                 tolerance={"statistic": 1e-12, "pvalue": 1e-14, "log_pvalue": 1e-12}),
        ]),
    ],
    "cross_correlation": [
        ("cross_correlation", {"adjusted": True, "level": 0.95, "segments": None}, [
            test(1, "lag 0 only", {"e": ALT4, "regressor": arr((4, 1, 1), [1.0, 2.0, 3.0, 4.0]), "max_lag": 0},
                 {"rho": arr((1, 1, 1), [XC0]), "constant_mask": arr((1, 1), [False]), "band": Z975 / 2},
                 tolerance={"rho": 1e-12, "band": 1e-12}),
        ]),
    ],
    "information_criteria": [
        ("information_criteria", {}, [
            # sigma^2 = rss/n = 2; aicc adds 2p(p+1)/(n-p-1) = 4/3; fpe = 2*1.2/0.8 = 3
            test(1, "rss 10, n 5, p 1", {"rss": 10.0, "n_obs": 5, "n_params": 1},
                 {"aic": 2 + 5 * math.log(2), "bic": math.log(5) + 5 * math.log(2),
                  "aicc": 2 + 5 * math.log(2) + 4 / 3, "fpe": 3.0, "naic": math.log(2) + 0.4}),
        ]),
    ],
    "errors": [
        ("r2", {"multioutput": "pooled"}, [
            test(1, "one sample", {"tau_meas": arr((1, 1), [1.0]), "tau_pred": arr((1, 1), [1.0])},
                 {"error": "TooFewSamples"}, result="invalid", flags=("TooFew",)),
            test(2, "NaN in tau_pred", {"tau_meas": COL3, "tau_pred": arr((3, 1), [1.0, "NaN", 1.0])},
                 {"error": "NonFiniteInput"}, result="invalid", flags=("TooFew",)),
            test(3, "a string as tau_meas", {"tau_meas": "abc", "tau_pred": COL3},
                 {"error": "InvalidType"}, result="invalid", flags=("TooFew",)),
        ]),
        ("rmse", {"multioutput": "bogus"}, [
            test(4, "unknown multioutput", {"tau_meas": COL3, "tau_pred": COL3},
                 {"error": "InvalidParameter"}, result="invalid", flags=("TooFew",)),
        ]),
        ("sse", {"multioutput": "pooled"}, [
            test(5, "shapes differ", {"tau_meas": COL3, "tau_pred": arr((2, 1), [1.0, 2.0])},
                 {"error": "ShapeMismatch"}, result="invalid", flags=("TooFew",)),
            # a nested plain list is not an array encoding: protocol 1 cannot carry it
            test(6, "not expressible", {"tau_meas": [[1.0, 2.0]], "tau_pred": COL3},
                 {"error": "InvalidShape"}, result="invalid", flags=("TooFew",)),
        ]),
    ],
}


def write_tiny_corpus(directory: pathlib.Path | str) -> pathlib.Path:
    """Write the eight family files into ``directory`` and return it."""
    directory = pathlib.Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    for family in FAMILIES:
        groups = [
            {"operation": op, "conventions": conv, "source": {"name": "tiny", "method": "closed form"}, "tests": tests}
            for op, conv, tests in GROUPS[family]
        ]
        n = sum(len(g["tests"]) for g in groups)
        data = {"family": family, "schema": "corpus_v1.schema.json", "numberOfTests": n, "header": ["tiny"],
                "notes": {"Basic": {"bugType": "BASIC", "description": "basic"},
                          "TooFew": {"bugType": "INVALID_INPUT", "description": "invalid"}},
                "testGroups": groups}
        (directory / f"{family}.json").write_text(json.dumps(data, indent=1, allow_nan=False) + "\n")
    return directory


def case_ids() -> list[str]:
    return [f"{family}-{t['tcId']}" for family in FAMILIES for _, _, tests in GROUPS[family] for t in tests]
