#!/usr/bin/env python3
"""dynval conformance port written from golden/PROTOCOL.md alone (numpy + scipy only).

Speaks protocol 1 on stdin/stdout; implements every operation of PROTOCOL.md section 11
of the eight required families (not the optional streaming family).
"""
import math
import re
import sys
import traceback

import numpy as np
from scipy import special, stats

INT64_MIN, INT64_MAX = -(2 ** 63), 2 ** 63 - 1
BOUND = 1e144


class PortError(Exception):
    def __init__(self, kind, msg=""):
        super().__init__(msg)
        self.kind = kind
        self.msg = msg


class Garbage(Exception):
    pass


# ---------------------------------------------------------------- grammar / typed values
_DEC = re.compile(r"^[+-]?([0-9]+(\.[0-9]*)?|\.[0-9]+)([eE][+-]?[0-9]+)?$")
_INT = re.compile(r"^[+-]?[0-9]+$")
_HEX = re.compile(r"^[+-]?0[xX]([0-9a-fA-F]+(\.[0-9a-fA-F]*)?|\.[0-9a-fA-F]+)[pP][+-]?[0-9]+$")
_NAN = re.compile(r"^[+-]?nan(\([A-Za-z0-9_]*\))?$", re.I)
_INF = re.compile(r"^[+-]?(inf|infinity)$", re.I)
_STR = re.compile(r'^"([A-Za-z0-9_.\-]|%[0-9A-Fa-f]{2})*"$')


def read_number(tok):
    if _NAN.match(tok):
        return float("nan")
    if _INF.match(tok):
        return float("-inf") if tok.startswith("-") else float("inf")
    if _DEC.match(tok):
        return float(tok)
    if _HEX.match(tok):
        return float.fromhex(tok)
    raise Garbage("not a number: %r" % tok)


def decode_string(tok):
    body = tok[1:-1]
    out = bytearray()
    i = 0
    while i < len(body):
        if body[i] == "%":
            out.append(int(body[i + 1:i + 3], 16))
            i += 3
        else:
            out.append(ord(body[i]))
            i += 1
    return out.decode("utf-8", errors="replace")


def parse_scalar_value(tok):
    """Typed value: (kind, python value). kind in none,bool,int,float,str,list."""
    low = tok.lower()
    if tok == "none":
        return ("none", None)
    if tok == "true":
        return ("bool", True)
    if tok == "false":
        return ("bool", False)
    if _INT.match(tok):
        return ("int", int(tok))
    if tok.startswith('"'):
        if not _STR.match(tok):
            raise Garbage("bad string %r" % tok)
        return ("str", decode_string(tok))
    if _NAN.match(low) or _INF.match(low) or _DEC.match(tok) or _HEX.match(tok):
        return ("float", read_number(tok))
    raise Garbage("bad value %r" % tok)


def parse_value(tok):
    if tok.startswith("["):
        if not tok.endswith("]"):
            raise Garbage("bad list %r" % tok)
        inner = tok[1:-1]
        if inner == "":
            return ("list", [])
        return ("list", [parse_scalar_value(t) for t in inner.split(",")])
    return parse_scalar_value(tok)


# ---------------------------------------------------------------- output
def fmt(x):
    x = float(x)
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return "%.16e" % x


def result_line(name, arr, typ="real"):
    a = np.asarray(arr)
    dims = list(a.shape)
    vals = a.reshape(-1)
    if typ == "real":
        sv = [fmt(v) for v in vals]
    elif typ == "int":
        sv = [str(int(v)) for v in vals]
    else:
        sv = ["1" if bool(v) else "0" for v in vals]
    return " ".join(["result", name, typ, str(len(dims))] + [str(d) for d in dims] + sv)


# ---------------------------------------------------------------- case helpers
class Case:
    def __init__(self, family, tcid, op, conv):
        self.family = family
        self.tcid = tcid
        self.op = op
        self.conv = conv          # key -> typed value
        self.scalars = {}         # name -> typed value
        self.arrays = {}          # name -> (type, np.ndarray)

    def c(self, key, default):
        return self.conv.get(key, default)


def is_int(v):
    return v[0] == "int" and INT64_MIN <= v[1] <= INT64_MAX


def get_data(case, name):
    """InvalidType check: returns float ndarray."""
    if name in case.arrays:
        typ, a = case.arrays[name]
        if typ == "bool":
            raise PortError("InvalidType", "%s is a bool array" % name)
        return a.astype(float)
    v = case.scalars.get(name)
    if v is not None and v[0] in ("float", "int"):
        # a number sent on a scalar line is a 0-D array (InvalidShape later), not InvalidType
        return np.array(float(v[1]))
    raise PortError("InvalidType", "%s is not an array of reals" % name)


def check_signal_shape(a, name):
    if a.ndim not in (1, 2):
        raise PortError("InvalidShape", "%s must be 1-D or 2-D, got %d-D" % (name, a.ndim))
    if a.ndim == 2 and a.shape[1] == 0:
        raise PortError("InvalidShape", "%s has zero columns" % name)


def promote(a):
    return a.reshape(-1, 1) if a.ndim == 1 else a


def bad_mask(a):
    return ~np.isfinite(a) | (np.abs(np.where(np.isfinite(a), a, 0.0)) > BOUND)


def nan_policy_of(case):
    return case.c("nan_policy", ("str", "raise"))


def check_nan_policy(case):
    v = nan_policy_of(case)
    if not (v[0] == "str" and v[1] in ("raise", "omit")):
        raise PortError("InvalidParameter", "nan_policy must be 'raise' or 'omit'")
    return v[1]


def finite_or_omit(case, named, min_n, sample_rows):
    """named: list of (name, array with samples along axis 0 in groups of sample_rows[i]).
    Returns (arrays after omit, kept original sample indices)."""
    pol = nan_policy_of(case)
    n = named[0][1].shape[0] // sample_rows[0] if named else 0
    if not (pol[0] == "str" and pol[1] == "omit"):
        for name, a in named:
            if bad_mask(a).any():
                raise PortError("NonFiniteInput", "%s holds a NaN, inf or |x| > 1e144" % name)
        return [a for _, a in named], np.arange(n)
    keep = np.ones(n, dtype=bool)
    for (name, a), r in zip(named, sample_rows):
        bm = bad_mask(a).reshape(n, -1).any(axis=1) if a.size else np.zeros(n, bool)
        keep &= ~bm
    out = []
    for (name, a), r in zip(named, sample_rows):
        if r == 1:
            out.append(a[keep])
        else:
            out.append(a.reshape((n, r) + a.shape[1:])[keep].reshape((-1,) + a.shape[1:]))
    idx = np.nonzero(keep)[0]
    if idx.size < min_n:
        raise PortError("TooFewSamples", "needs at least %d samples after omitting, got %d" % (min_n, idx.size))
    return out, idx


def parse_segments(case, n_orig):
    v = case.c("segments", ("none", None))
    if v[0] == "none":
        return [n_orig]
    if v[0] != "list" or len(v[1]) == 0:
        raise PortError("InvalidParameter", "segments must be none or a non-empty list")
    items = v[1]
    if not all(is_int(x) for x in items):
        raise PortError("InvalidParameter", "segments must hold integers")
    vals = [x[1] for x in items]
    if vals[0] == 0:
        # starts
        for a, b in zip(vals, vals[1:]):
            if b <= a:
                raise PortError("InvalidParameter", "segment starts must increase strictly")
        if vals[-1] >= n_orig:
            raise PortError("InvalidParameter", "segment start beyond N")
        ends = vals[1:] + [n_orig]
        return [b - a for a, b in zip(vals, ends)]
    if any(x < 1 for x in vals):
        raise PortError("InvalidParameter", "segment lengths must be positive")
    if sum(vals) != n_orig:
        raise PortError("InvalidParameter", "segment lengths must sum to N")
    return vals


def effective_segments(lengths, kept_idx):
    """Segments of the kept rows: original records, broken where rows were deleted."""
    if len(kept_idx) == 0:
        return []
    seg_id = np.repeat(np.arange(len(lengths)), lengths)
    out = []
    cur = 1
    for a, b in zip(kept_idx[:-1], kept_idx[1:]):
        if b == a + 1 and seg_id[a] == seg_id[b]:
            cur += 1
        else:
            out.append(cur)
            cur = 1
    out.append(cur)
    return out


def lag_sum(x, y, segs, lag):
    """sum over segments of x[k] * y[k - lag] (k and k - lag in the same segment), along axis 0."""
    tot = np.zeros(x.shape[1:])
    start = 0
    for ln in segs:
        if ln > lag:
            tot = tot + np.sum(x[start + lag:start + ln] * y[start:start + ln - lag], axis=0)
        start += ln
    return tot


def n_lag(segs, lag):
    return sum(max(s - lag, 0) for s in segs)


def pow2scale(*arrays):
    """A power of two near the largest |x|, so that x / s is O(1) (exact scaling)."""
    mx = 0.0
    for a in arrays:
        if a.size:
            mx = max(mx, float(np.max(np.abs(a))))
    if mx == 0 or not math.isfinite(mx):
        return 1.0
    return math.ldexp(1.0, math.frexp(mx)[1])


def is_constant(col):
    return col.size > 0 and np.min(col) == np.max(col)


# ---------------------------------------------------------------- common pipelines
def two_signals(case, min_n):
    tm = get_data(case, "tau_meas")
    tp = get_data(case, "tau_pred")
    check_signal_shape(tm, "tau_meas")
    check_signal_shape(tp, "tau_pred")
    both_1d = tm.ndim == 1 and tp.ndim == 1
    tm2, tp2 = promote(tm), promote(tp)
    if tm2.shape != tp2.shape:
        raise PortError("ShapeMismatch", "tau_meas %s vs tau_pred %s" % (tm.shape, tp.shape))
    if tm2.shape[0] < min_n:
        raise PortError("TooFewSamples", "needs at least %d samples, got N=%d" % (min_n, tm2.shape[0]))
    (tm2, tp2), idx = finite_or_omit(case, [("tau_meas", tm2), ("tau_pred", tp2)], min_n, [1, 1])
    check_nan_policy(case)
    return tm2, tp2, both_1d


def one_signal(case, min_n):
    e = get_data(case, "e")
    check_signal_shape(e, "e")
    one_d = e.ndim == 1
    e2 = promote(e)
    n_orig = e2.shape[0]
    if n_orig < min_n:
        raise PortError("TooFewSamples", "needs at least %d samples, got N=%d" % (min_n, n_orig))
    (e2,), idx = finite_or_omit(case, [("e", e2)], min_n, [1])
    check_nan_policy(case)
    return e2, one_d, n_orig, idx


def get_multioutput(case, allowed):
    v = case.c("multioutput", ("str", "pooled"))
    if not (v[0] == "str" and v[1] in allowed):
        raise PortError("InvalidParameter", "multioutput %r not accepted" % (v,))
    return v[1]


def combine(per_joint, mo, weights=None):
    if mo == "raw_values":
        return per_joint
    if mo == "uniform_average":
        return np.float64(np.mean(per_joint))
    if mo == "variance_weighted":
        w = weights
        nz = w > 0
        if not nz.any():
            return np.float64(np.mean(per_joint))
        return np.float64(np.sum(w[nz] * per_joint[nz]) / np.sum(w[nz]))
    raise AssertionError(mo)


def get_int_param(v, name):
    if v is None or not is_int(v):
        raise PortError("InvalidParameter", "%s must be an integer" % name)
    return v[1]


# ---------------------------------------------------------------- operations
def op_residuals(case):
    tm, tp, both_1d = two_signals(case, 1)
    e = tm - tp
    return [result_line("value", e[:, 0] if both_1d else e)]


def op_sse(case):
    tm, tp, _ = two_signals(case, 1)
    mo = get_multioutput(case, ("pooled", "raw_values"))
    e = tm - tp
    if mo == "pooled":
        return [result_line("value", np.sum(e * e))]
    return [result_line("value", np.sum(e * e, axis=0))]


def op_rmse(case):
    tm, tp, _ = two_signals(case, 1)
    mo = get_multioutput(case, ("pooled", "raw_values", "uniform_average"))
    conv = case.c("convention", ("none", None))
    if conv[0] == "none":
        cv = None
    elif conv[0] == "str" and conv[1] in ("per_element", "per_sample"):
        cv = conv[1]
    else:
        raise PortError("InvalidParameter", "unknown convention")
    if mo != "pooled" and cv is not None:
        raise PortError("InvalidParameter", "convention only with multioutput pooled")
    e = tm - tp
    n, m = e.shape
    if mo == "pooled":
        sc = pow2scale(e)
        es = e / sc
        sse = np.sum(es * es)
        return [result_line("value", sc * np.sqrt(sse / (n if cv == "per_sample" else n * m)))]
    pj = np.empty(m)
    for j in range(m):
        sc = pow2scale(e[:, j])
        es = e[:, j] / sc
        pj[j] = sc * np.sqrt(np.sum(es * es) / n)
    return [result_line("value", combine(pj, mo))]


def op_max_abs_error(case):
    tm, tp, _ = two_signals(case, 1)
    mo = get_multioutput(case, ("pooled", "raw_values"))
    e = np.abs(tm - tp)
    if mo == "pooled":
        return [result_line("value", np.max(e))]
    return [result_line("value", np.max(e, axis=0))]


FIT_MO = ("pooled", "raw_values", "uniform_average", "variance_weighted")


def _tss(y):
    return np.sum((y - np.mean(y)) ** 2)


def _fit_value(kind, y, e):
    """y: target values (1-D), e: residual (1-D)."""
    const_y = is_constant(y)
    sy, se = pow2scale(y), pow2scale(e)
    y, e = y / sy, e / se
    f = (se / sy) ** 2
    if kind == "vaf":
        const_e = is_constant(e)
        if const_y:
            return float("nan") if const_e else float("-inf")
        ve = np.sum((e - np.mean(e)) ** 2)
        if const_e:
            ve = 0.0
        return 100.0 * (1.0 - (ve / _tss(y)) * f)
    sse = np.sum(e * e)
    if const_y:
        return float("nan") if sse == 0 else float("-inf")
    if kind == "fit_percent":
        return 100.0 * (1.0 - np.sqrt((sse / _tss(y)) * f))
    return 1.0 - (sse / _tss(y)) * f


def fit_op(case, kind):
    tm, tp, _ = two_signals(case, 2)
    mo = get_multioutput(case, FIT_MO)
    e = tm - tp
    if mo == "pooled":
        return [result_line("value", _fit_value(kind, tm.reshape(-1), e.reshape(-1)))]
    m = e.shape[1]
    pj = np.array([_fit_value(kind, tm[:, j], e[:, j]) for j in range(m)])
    st = pow2scale(tm)
    w = np.array([0.0 if is_constant(tm[:, j]) else _tss(tm[:, j] / st) for j in range(m)])
    return [result_line("value", combine(pj, mo, w))]


def op_residual_mean(case):
    e, _, _, _ = one_signal(case, 1)
    return [result_line("value", np.mean(e, axis=0))]


def op_residual_variance(case):
    e, _, _, _ = one_signal(case, 2)
    ddof = get_int_param(case.c("ddof", ("int", 1)), "ddof")
    n = e.shape[0]
    if not (0 <= ddof < n):
        raise PortError("InvalidParameter", "ddof must satisfy 0 <= ddof < N")
    out = []
    for j in range(e.shape[1]):
        col = e[:, j]
        if is_constant(col):
            out.append(0.0)
        else:
            out.append(np.sum((col - np.mean(col)) ** 2) / (n - ddof))
    return [result_line("value", np.array(out))]


def op_zero_mean_test(case):
    e, _, n_orig, idx = one_signal(case, 2)
    segs = effective_segments(parse_segments(case, n_orig), idx)
    n, m = e.shape
    K = int(math.floor(4.0 * (n / 100.0) ** (2.0 / 9.0)))
    K = min(K, n - 1)
    means, stds, st_iid, p_iid, st_eff, p_eff, neffs = [], [], [], [], [], [], []
    for j in range(m):
        sc = pow2scale(e[:, j])
        col = e[:, j] / sc
        const = is_constant(col)
        mu = col[0] if const else np.mean(col)
        c = col - mu
        sd = 0.0 if const else math.sqrt(np.sum(c * c) / (n - 1))
        if const:
            neff = float(n)
        else:
            r0 = np.sum(c * c)
            s = 0.0
            for k in range(1, K + 1):
                s += (1.0 - k / (K + 1.0)) * (lag_sum(c, c, segs, k) / r0)
            if s <= 0:
                neff = float(n)
            else:
                neff = min(max(n / (1.0 + 2.0 * s), 2.0), float(n))
        if sd == 0:
            if mu == 0:
                ti = te = pi = pe = float("nan")
            else:
                ti = te = math.copysign(float("inf"), mu)
                pi = pe = 0.0
        else:
            ti = mu * math.sqrt(n) / sd
            te = mu * math.sqrt(neff) / sd
            pi = 2.0 * stats.t.sf(abs(ti), n - 1)
            pe = 2.0 * stats.t.sf(abs(te), neff - 1)
        means.append(mu * sc); stds.append(sd * sc); st_iid.append(ti); p_iid.append(pi)
        st_eff.append(te); p_eff.append(pe); neffs.append(neff)
    neffs = np.array(neffs)
    return [
        result_line("mean", np.array(means)),
        result_line("std", np.array(stds)),
        result_line("n_samples", np.array(n), "int"),
        result_line("statistic_iid", np.array(st_iid)),
        result_line("pvalue_iid", np.array(p_iid)),
        result_line("df_iid", np.array(n - 1), "int"),
        result_line("statistic_eff", np.array(st_eff)),
        result_line("pvalue_eff", np.array(p_eff)),
        result_line("df_eff", neffs - 1.0),
        result_line("n_eff", neffs),
        result_line("bandwidth", np.array(K), "int"),
    ]


def get_adjusted(case):
    v = case.c("adjusted", ("bool", True))
    if v[0] != "bool":
        raise PortError("InvalidParameter", "adjusted must be true or false")
    return v[1]


def get_level(case):
    v = case.c("level", ("float", 0.95))
    if v[0] not in ("float", "int") or not (0.0 < float(v[1]) < 1.0):
        raise PortError("InvalidParameter", "level must be a number in (0, 1)")
    return float(v[1])


def acf(e, segs, max_lag, adjusted):
    n, m = e.shape
    out = np.empty((max_lag + 1, m))
    for j in range(m):
        col = e[:, j]
        if is_constant(col):
            out[:, j] = np.nan
            continue
        col = col / pow2scale(col)
        c = col - np.mean(col)
        r0 = np.sum(c * c) / n
        out[0, j] = 1.0
        for l in range(1, max_lag + 1):
            d = n_lag(segs, l) if adjusted else n
            out[l, j] = (lag_sum(c, c, segs, l) / d) / r0
    return out


def op_autocorrelation(case):
    e, one_d, n_orig, idx = one_signal(case, 2)
    segs = effective_segments(parse_segments(case, n_orig), idx)
    ml = get_int_param(case.scalars.get("max_lag"), "max_lag")
    if not (0 <= ml < max(segs)):
        raise PortError("InvalidParameter", "max_lag must satisfy 0 <= max_lag < longest segment")
    adj = get_adjusted(case)
    r = acf(e, segs, ml, adj)
    return [result_line("value", r[:, 0] if one_d else r)]


def op_confidence_band(case):
    n = get_int_param(case.scalars.get("n"), "n")
    if n < 1:
        raise PortError("InvalidParameter", "n must be >= 1")
    lv = get_level(case)
    z = special.ndtri((1.0 + lv) / 2.0)
    return [result_line("value", z / math.sqrt(n))]


def log_chi2_sf(q, df):
    """ln chi2.sf(q, df), finite where the p-value underflows (PROTOCOL.md: log_pvalue)."""
    if math.isnan(q):
        return float("nan")
    sf = special.chdtrc(df, q)
    if sf > 1e-280:
        return math.log(sf)
    # chi2.sf(q, k) = Q(k/2, q/2); for x = q/2 far above a = k/2 (an underflowing p-value needs
    # x > 640) the asymptotic series Q(a, x) = x^(a-1) e^(-x) / Γ(a) · Σ_j (a-1)(a-2)…(a-j) / x^j
    # converges to double precision long before its terms grow again
    a, x = df / 2.0, q / 2.0
    total = term = 1.0
    for j in range(1, 400):
        term *= (a - j) / x
        total += term
        if abs(term) < 1e-17 * abs(total):
            break
    return (a - 1.0) * math.log(x) - x - special.gammaln(a) + math.log(total)


def portmanteau(case, kind):
    e, one_d, n_orig, idx = one_signal(case, 2)
    segs = effective_segments(parse_segments(case, n_orig), idx)
    lv = case.scalars.get("lags")
    if lv is None:
        raise PortError("InvalidParameter", "lags missing")
    if lv[0] == "list":
        if len(lv[1]) == 0:
            raise PortError("InvalidParameter", "lags must not be empty")
        lags = [get_int_param(x, "lags") for x in lv[1]]
    else:
        lags = [get_int_param(lv, "lags")]
    longest = max(segs)
    for h in lags:
        if not (1 <= h < longest):
            raise PortError("InvalidParameter", "every lag must satisfy 1 <= h < longest segment")
    mdf = get_int_param(case.c("model_df", ("int", 0)), "model_df")
    if not (0 <= mdf < min(lags)):
        raise PortError("InvalidParameter", "model_df must satisfy 0 <= model_df < smallest lag")
    n, m = e.shape
    hmax = max(lags)
    r = acf(e, segs, hmax, False)
    stat = np.empty((len(lags), m))
    for i, h in enumerate(lags):
        for j in range(m):
            rho = r[1:h + 1, j]
            if kind == "ljung_box":
                nl = np.array([n_lag(segs, l) for l in range(1, h + 1)], dtype=float)
                stat[i, j] = n * (n + 2.0) * np.sum(rho ** 2 / nl)
            else:
                stat[i, j] = n * np.sum(rho ** 2)
    df = np.array([h - mdf for h in lags])
    pv = np.empty_like(stat)
    lp = np.empty_like(stat)
    for i in range(len(lags)):
        for j in range(m):
            pv[i, j] = special.chdtrc(df[i], stat[i, j]) if not math.isnan(stat[i, j]) else np.nan
            lp[i, j] = log_chi2_sf(stat[i, j], df[i])
    return [
        result_line("lags", np.array(lags), "int"),
        result_line("statistic", stat),
        result_line("pvalue", pv),
        result_line("log_pvalue", lp),
        result_line("df", df, "int"),
    ]


def op_cross_correlation(case):
    e = get_data(case, "e")
    reg = get_data(case, "regressor")
    check_signal_shape(e, "e")
    nj_v = case.scalars.get("n_joints")
    if reg.ndim == 3:
        if reg.shape[2] == 0:
            raise PortError("InvalidShape", "regressor has zero columns")
    elif reg.ndim == 2:
        if nj_v is None:
            raise PortError("InvalidShape", "a 2-D regressor needs n_joints")
        if reg.shape[1] == 0:
            raise PortError("InvalidShape", "regressor has zero columns")
    else:
        raise PortError("InvalidShape", "regressor must be 3-D or 2-D")
    one_d = e.ndim == 1
    e2 = promote(e)
    n_orig, m = e2.shape
    if reg.ndim == 3:
        if reg.shape[0] != n_orig or reg.shape[1] != m:
            raise PortError("ShapeMismatch", "regressor %s vs e %s" % (reg.shape, e2.shape))
        reg3 = reg
    else:
        if reg.shape[0] != n_orig * m:
            raise PortError("ShapeMismatch", "stacked regressor rows %d != N*m = %d" % (reg.shape[0], n_orig * m))
        reg3 = reg.reshape(n_orig, m, reg.shape[1])
    if n_orig < 2:
        raise PortError("TooFewSamples", "needs at least 2 samples, got N=%d" % n_orig)
    (e2, reg3), idx = finite_or_omit(case, [("e", e2), ("regressor", reg3)], 2, [1, 1])
    check_nan_policy(case)
    segs = effective_segments(parse_segments(case, n_orig), idx)
    ml = get_int_param(case.scalars.get("max_lag"), "max_lag")
    if not (0 <= ml < max(segs)):
        raise PortError("InvalidParameter", "max_lag must satisfy 0 <= max_lag < longest segment")
    if reg.ndim == 2 or nj_v is not None:
        nj = get_int_param(nj_v, "n_joints")
        if nj < 1 or reg.shape[0] % nj != 0 or (reg.ndim == 2 and nj != m):
            raise PortError("InvalidParameter", "n_joints must be a positive divisor of the rows")
    adj = get_adjusted(case)
    lv = get_level(case)
    n = e2.shape[0]
    p = reg3.shape[2]
    rho = np.full((m, p, ml + 1), np.nan)
    cmask = np.zeros((m, p), dtype=bool)
    for j in range(m):
        ecol = e2[:, j] / pow2scale(e2[:, j])
        econst = is_constant(ecol)
        ec = ecol - np.mean(ecol)
        re0 = np.sum(ec * ec) / n
        for c in range(p):
            y = reg3[:, j, c]
            if is_constant(y):
                cmask[j, c] = True
                continue
            if econst:
                continue
            y = y / pow2scale(y)
            yc = y - np.mean(y)
            ry0 = np.sum(yc * yc) / n
            den = math.sqrt(re0 * ry0)
            for l in range(ml + 1):
                d = n_lag(segs, l) if adj else n
                rho[j, c, l] = (lag_sum(ec, yc, segs, l) / d) / den
    z = special.ndtri((1.0 + lv) / 2.0)
    return [
        result_line("rho", rho),
        result_line("constant_mask", cmask, "bool"),
        result_line("band", z / math.sqrt(n)),
    ]


def ic_from(F, p, n, S, nvec):
    aic = F + 2.0 * p
    bic = F + p * math.log(n)
    if p >= n - 1:
        aicc = float("nan")
        fpe = float("nan")
    else:
        aicc = aic + 2.0 * p * (p + 1.0) / (n - p - 1.0)
        fpe = S * (1.0 + p / n) / (1.0 - p / n)
    naic = F / nvec + 2.0 * p / n
    return aic, bic, aicc, fpe, naic


def op_information_criteria(case):
    rv = case.scalars.get("rss")
    if rv is None or rv[0] not in ("float", "int") or not math.isfinite(float(rv[1])) or float(rv[1]) < 0:
        raise PortError("InvalidParameter", "rss must be a finite number >= 0")
    rss = float(rv[1])
    n = get_int_param(case.scalars.get("n_obs"), "n_obs")
    if n < 1:
        raise PortError("InvalidParameter", "n_obs must be >= 1")
    p = get_int_param(case.scalars.get("n_params"), "n_params")
    if not (0 <= p < n - 1):
        raise PortError("InvalidParameter", "n_params must satisfy 0 <= n_params < n_obs - 1")
    S = rss / n
    with np.errstate(divide="ignore"):
        F = n * float(np.log(S))
    aic, bic, aicc, fpe, naic = ic_from(F, p, n, S, n)
    return [result_line("aic", aic), result_line("bic", bic), result_line("aicc", aicc),
            result_line("fpe", fpe), result_line("naic", naic)]


def criteria_values(case):
    tm, tp, _ = two_signals(case, 2)
    p = get_int_param(case.scalars.get("n_params"), "n_params")
    if p < 0:
        raise PortError("InvalidParameter", "n_params must be >= 0")
    nm = case.c("noise_model", ("str", "pooled"))
    if not (nm[0] == "str" and nm[1] in ("pooled", "per_joint", "full")):
        raise PortError("InvalidParameter", "unknown noise_model")
    nm = nm[1]
    e = tm - tp
    N, m = e.shape
    with np.errstate(divide="ignore"):
        if nm == "pooled":
            sc = pow2scale(e)
            es = e / sc
            Ss = np.sum(es * es) / (N * m)
            S = float(Ss * sc * sc)
            F = N * m * (float(np.log(Ss)) + 2.0 * math.log(sc))
            n, nvec = N * m, N * m
        elif nm == "per_joint":
            logs = []
            for j in range(m):
                sc = pow2scale(e[:, j])
                es = e[:, j] / sc
                logs.append(float(np.log(np.sum(es * es) / N)) + 2.0 * math.log(sc))
            S = float(np.exp(np.sum(logs)))
            F = N * float(np.sum(logs))
            n, nvec = N, N
        else:
            sc = pow2scale(e)
            es = e / sc
            M = es.T @ es / N
            sign, logdet = np.linalg.slogdet(M)
            if sign <= 0:
                S, F = 0.0, float("-inf")
            else:
                logdet = float(logdet) + 2.0 * m * math.log(sc)
                S, F = float(np.exp(logdet)), N * logdet
            n, nvec = N, N
    vals = ic_from(F, p, n, S, nvec)
    return vals, n


def op_criteria(case):
    (aic, bic, aicc, fpe, naic), n = criteria_values(case)
    return [result_line("aic", aic), result_line("bic", bic), result_line("aicc", aicc),
            result_line("fpe", fpe), result_line("naic", naic), result_line("n_obs", np.array(n), "int")]


def op_aic(case):
    vals, _ = criteria_values(case)
    return [result_line("value", vals[0])]


def op_bic(case):
    vals, _ = criteria_values(case)
    return [result_line("value", vals[1])]


OPS = {
    "residuals": op_residuals,
    "sse": op_sse,
    "rmse": op_rmse,
    "max_abs_error": op_max_abs_error,
    "vaf": lambda c: fit_op(c, "vaf"),
    "fit_percent": lambda c: fit_op(c, "fit_percent"),
    "r2": lambda c: fit_op(c, "r2"),
    "residual_mean": op_residual_mean,
    "residual_variance": op_residual_variance,
    "zero_mean_test": op_zero_mean_test,
    "autocorrelation": op_autocorrelation,
    "confidence_band": op_confidence_band,
    "ljung_box": lambda c: portmanteau(c, "ljung_box"),
    "box_pierce": lambda c: portmanteau(c, "box_pierce"),
    "cross_correlation": op_cross_correlation,
    "information_criteria": op_information_criteria,
    "criteria": op_criteria,
    "aic": op_aic,
    "bic": op_bic,
}


# ---------------------------------------------------------------- session
def parse_array(toks):
    # array NAME TYPE NDIM D1..Dn V1..Vk
    name, typ, ndim = toks[1], toks[2], int(toks[3])
    dims = [int(t) for t in toks[4:4 + ndim]]
    vals = toks[4 + ndim:]
    k = int(np.prod(dims)) if dims else 1
    if len(vals) != k:
        raise Garbage("array %s: %d values for shape %s" % (name, len(vals), dims))
    if typ == "real":
        a = np.array([read_number(v) for v in vals], dtype=float)
    elif typ == "int":
        a = np.array([int(v) for v in vals], dtype=np.int64)
    elif typ == "bool":
        a = np.array([v in ("1", "true") for v in vals], dtype=bool)
    else:
        raise Garbage("unknown array type %s" % typ)
    return name, typ, a.reshape(dims)


def write(lines):
    out = sys.stdout
    for ln in lines:
        out.write(ln + "\n")
    out.write("end\n")
    out.flush()


def handle(case):
    fn = OPS.get(case.op)
    if fn is None:
        return ["error InvalidParameter unknown operation %s" % case.op]
    try:
        with np.errstate(all="ignore"):
            return fn(case)
    except PortError as exc:
        msg = re.sub(r"[^\x20-\x7e]", "?", exc.msg)
        return ["error %s %s" % (exc.kind, msg)]


def main():
    out = sys.stdout
    out.write("dynval-port 1 protocol-only-port 0.1 (Python %d.%d, numpy)\n" % sys.version_info[:2])
    for op in OPS:
        out.write("capability %s\n" % op)
    out.write("ready\n")
    out.flush()
    case = None
    bad = None
    import os
    log = open(os.environ["DVPORT_LOG"], "a") if os.environ.get("DVPORT_LOG") else None
    for raw in sys.stdin:
        if log:
            log.write(raw[:400].rstrip("\n") + "\n")
            log.flush()
        line = raw.rstrip("\n").rstrip("\r")
        toks = line.split()
        if not toks:
            continue
        head = toks[0]
        try:
            if head == "quit":
                return 0
            if head == "case":
                conv = {}
                for kv in toks[4:]:
                    k, _, v = kv.partition("=")
                    conv[k] = parse_value(v)
                case = Case(toks[1], toks[2], toks[3], conv)
                bad = None
            elif head == "scalar":
                if case is not None:
                    case.scalars[toks[1]] = parse_value(toks[2])
            elif head == "array":
                if case is not None:
                    name, typ, a = parse_array(toks)
                    case.arrays[name] = (typ, a)
            elif head == "end":
                if bad is not None:
                    write(["error InvalidParameter %s" % bad])
                elif case is None:
                    write(["error InvalidParameter no case"])
                else:
                    try:
                        write(handle(case))
                    except Exception as exc:  # a port bug: report it on stderr
                        traceback.print_exc(file=sys.stderr)
                        write(["error PortBug %s" % type(exc).__name__])
                case = None
                bad = None
        except Garbage as exc:
            bad = str(exc).replace("\n", " ")
            sys.stderr.write("garbage input: %s\n" % bad)
    return 0


if __name__ == "__main__":
    sys.exit(main())
