"""The port protocol's line grammar: numbers, typed values, arrays, cases, answers, capabilities.

The reference reader/writer (dynval.protocol) is checked against the grammar of
golden/PROTOCOL.md; the C, Java, MATLAB/Octave and Wolfram Language recipes printed in
PROTOCOL.md are extracted, run and checked against the same numbers.
"""

from __future__ import annotations

import math
import os
import pathlib
import re
import shutil
import struct
import subprocess

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from dynval import protocol
from dynval.protocol import ProtocolError

ROOT = pathlib.Path(__file__).resolve().parent.parent
PROTOCOL_MD = ROOT / "golden" / "PROTOCOL.md"

# Every binary64 class: signed zeros, subnormals, extremes, non-finite.
EDGE_FLOATS = [
    0.0, -0.0, 5e-324, -5e-324, 2.2250738585072009e-308, 2.2250738585072014e-308,
    1.7976931348623157e308, -1.7976931348623157e308, 0.1, 1 / 3, 1e23, 9007199254740993.0,
    -4593.170185988091, math.pi, math.inf, -math.inf, math.nan,
]


def bits(x: float) -> int:
    return struct.unpack("<Q", struct.pack("<d", x))[0]


def same_float(a: float, b: float) -> bool:
    """Bit-identical, except that every NaN equals every NaN (the wire drops NaN payloads)."""
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return bits(a) == bits(b)


# --------------------------------------------------------------------------- numbers


@pytest.mark.parametrize("x", EDGE_FLOATS, ids=repr)
def test_real_round_trip_edges(x):
    text = protocol.format_real(x)
    assert same_float(protocol.parse_real(text), x)
    assert float(text) == x or math.isnan(x)  # any strtod-like reader gets the same double


@settings(max_examples=1000)
@given(st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True))
def test_real_round_trip_every_float64(x):
    assert same_float(protocol.parse_real(protocol.format_real(x)), x)


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_real_is_written_with_17_significant_digits(x):
    text = protocol.format_real(x)
    assert re.fullmatch(r"-?[0-9]\.[0-9]{16}e[+-][0-9]{2,3}", text), text


@pytest.mark.parametrize(
    ("token", "expected"),
    [
        ("-4.5931701859880914e+03", -4593.170185988091),
        ("1.5E-3", 0.0015), ("1.5e-3", 0.0015), ("+2", 2.0), ("-7", -7.0), ("3.", 3.0), (".5", 0.5),
        ("1e5", 1e5), ("1.0E-5", 1e-5),  # Java's Double.toString
        ("inf", math.inf), ("+inf", math.inf), ("INF", math.inf), ("Inf", math.inf), ("-Inf", -math.inf),
        ("Infinity", math.inf), ("-Infinity", -math.inf), ("-INFINITY", -math.inf),
        ("-0.0000000000000000e+00", -0.0),
    ],
)
def test_parse_real_accepts(token, expected):
    assert same_float(protocol.parse_real(token), expected)


@pytest.mark.parametrize("token", ["nan", "NaN", "-nan", "+nan", "NAN", "nan(ind)", "-nan(ind)", "nan(0x7ff)"])
def test_parse_real_accepts_every_nan(token):
    assert math.isnan(protocol.parse_real(token))


@pytest.mark.parametrize(
    "token",
    ["", "1,5", "1.5*^-3", "0x1.8p+0", "0x10", "1e", "e5", ".", "-", "1.5.3", "inf5", "nanx", "Indeterminate",
     "1.0d0", "1_000", " 1", "1 ", "١", "infinit", "1e+", "--1", "+-1", "true"],
)
def test_parse_real_rejects(token):
    with pytest.raises(ProtocolError, match="expected a number"):
        protocol.parse_real(token)


def test_parse_int():
    assert protocol.parse_int("-12") == -12
    assert protocol.parse_int("+3") == 3
    for bad in ("1.0", "1e3", "", "true", "0x1"):
        with pytest.raises(ProtocolError, match="expected an integer"):
            protocol.parse_int(bad)


# --------------------------------------------------------------------------- typed values

scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.floats(allow_nan=False),
    st.text(max_size=12),
)


@given(st.one_of(scalars, st.lists(scalars, max_size=5)))
def test_value_round_trip_keeps_types(value):
    token = protocol.format_value(value)
    assert not re.search(r"\s", token), token
    back = protocol.parse_value(token)
    assert type(back) is type(value)
    if isinstance(value, list):
        assert [type(v) for v in back] == [type(v) for v in value]
        assert all(a == b for a, b in zip(back, value))
    else:
        assert back == value


def test_value_tokens_keep_types_apart():
    # The contract rejects booleans and integral floats where an integer is needed:
    # the wire must keep max_lag=True, max_lag=1 and max_lag=1.0 apart.
    assert [protocol.format_value(v) for v in (True, 1, 1.0, "1", None, [])] == [
        "true", "1", "1.0000000000000000e+00", '"1"', "none", "[]"]
    assert protocol.format_value(np.int64(5)) == "5"
    assert protocol.format_value(np.bool_(False)) == "false"
    assert protocol.format_value((0, 500)) == "[0,500]"
    assert protocol.format_value("a b,c|[d]") == '"a%20b%2Cc%7C%5Bd%5D"'
    assert protocol.parse_value('"a%20b%2Cc%7C%5Bd%5D"') == "a b,c|[d]"


@pytest.mark.parametrize("value", [[[1, 2]], {"a": 1}, 1 + 2j, np.zeros((2, 2))])
def test_values_the_protocol_cannot_carry(value):
    with pytest.raises(TypeError, match="cannot be written"):
        protocol.format_value(value)


@pytest.mark.parametrize("token", ['"abc', '"a b"', '"%4"', '"%ZZ"', "[1,2", '"\xe9"'])
def test_parse_value_rejects(token):
    with pytest.raises(ProtocolError):
        protocol.parse_value(token)


# --------------------------------------------------------------------------- arrays

float_arrays = hnp.arrays(
    dtype=np.float64,
    shape=hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=4),
    elements=st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True),
)


@given(float_arrays)
def test_real_array_round_trip(arr):
    line = protocol.encode_array("tau_meas", arr)
    name, back = protocol.decode_array(protocol.split_line(line))
    assert name == "tau_meas"
    assert back.dtype == np.float64 and back.shape == arr.shape
    assert all(same_float(a, b) for a, b in zip(back.ravel().tolist(), arr.ravel().tolist()))


@given(hnp.arrays(dtype=st.sampled_from([np.int64, np.int32, np.uint8, np.bool_]),
                  shape=hnp.array_shapes(min_dims=1, max_dims=2, max_side=5)))
def test_int_and_bool_array_round_trip(arr):
    _, back = protocol.decode_array(protocol.split_line(protocol.encode_array("x", arr)))
    assert back.shape == arr.shape
    assert back.dtype == (np.bool_ if arr.dtype == np.bool_ else np.int64)
    assert np.array_equal(back, arr)


def test_array_is_row_major():
    arr = np.arange(6.0).reshape(2, 3)
    line = protocol.encode_array("e", np.asfortranarray(arr))
    assert line.split()[:6] == ["array", "e", "real", "2", "2", "3"]
    assert [float(t) for t in line.split()[6:]] == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("array x real 1 3 1 2", "needs 3 values, got 2"),
        ("array x real 2 3", "only 1 dimensions follow"),
        ("array x real 1 -1", "negative dimension"),
        ("array x cplx 1 1 1", "type must be one of"),
        ("array 1x real 0 1", "an array name"),
        ("array x int 1 1 1.5", "expected an integer"),
        ("array x bool 1 1 2", "bool values are 0 or 1"),
        ("array x real 1 2 1 1,5", "expected a number"),
    ],
)
def test_decode_array_errors(line, message):
    with pytest.raises(ProtocolError, match=message):
        protocol.decode_array(protocol.split_line(line))


def test_result_lines_are_read_leniently():
    # Ports may write integers and booleans as reals, and booleans as true/false.
    _, df = protocol.decode_array(["result", "df", "int", "1", "2", "1.0000000000000000e+00", "3"], "result",
                                  strict_type=False)
    assert df.tolist() == [1.0, 3.0]
    _, df = protocol.decode_array(["result", "df", "int", "1", "2", "1", "3"], "result", strict_type=False)
    assert df.dtype == np.int64
    _, mask = protocol.decode_array(["result", "m", "bool", "1", "3", "true", "0", "1.0"], "result", strict_type=False)
    assert mask.tolist() == [True, False, True]


# --------------------------------------------------------------------------- cases and answers


def test_case_round_trip():
    inputs = {
        "e": np.array([[1.0, -0.0], [math.nan, 5e-324], [math.inf, -1.5]]),
        "regressor": np.arange(12.0).reshape(3, 2, 2),
        "max_lag": 2,
        "lags": [1, 2],
        "tau_pred": None,
        "level": 0.95,
    }
    conventions = {"adjusted": True, "segments": [0, 2], "multioutput": "raw_values", "convention": None, "ddof": 1}
    lines = protocol.encode_case("cross_correlation", 17, "cross_correlation", conventions, inputs)
    decoder = protocol.CaseDecoder()
    results = [decoder.feed(line + "\n") for line in lines]
    assert results[:-1] == [None] * (len(lines) - 1)
    case = results[-1]
    assert (case.family, case.tc_id, case.operation) == ("cross_correlation", 17, "cross_correlation")
    assert case.conventions == conventions
    assert [type(v) for v in case.conventions.values()] == [type(v) for v in conventions.values()]
    assert case.inputs.keys() == inputs.keys()
    np.testing.assert_array_equal(case.inputs["e"], inputs["e"])
    assert math.copysign(1, case.inputs["e"][0, 1]) == -1
    np.testing.assert_array_equal(case.inputs["regressor"], inputs["regressor"])
    assert case.inputs["max_lag"] == 2 and case.inputs["lags"] == [1, 2] and case.inputs["tau_pred"] is None
    assert decoder.feed("quit\n") == "quit"


@pytest.mark.parametrize(
    "lines",
    [["hello"], ["case norms"], ["case norms 1 sse", "result value real 0 1"], ["case norms 1 sse", "scalar n"],
     ["case norms x sse"], ["case norms 1 sse multioutput"]],
)
def test_case_decoder_rejects(lines):
    decoder = protocol.CaseDecoder()
    with pytest.raises(ProtocolError):
        for line in lines:
            decoder.feed(line)


def test_reply_round_trip():
    outputs = {"statistic": np.array([[4.5, math.nan]]), "df": np.array([1]), "mask": np.array([True, False]),
               "value": np.float64(-math.inf)}
    decoder = protocol.ReplyDecoder()
    replies = [decoder.feed(line) for line in protocol.encode_reply(outputs)]
    reply = replies[-1]
    assert replies[:-1] == [None] * len(outputs)
    assert reply.error_kind is None and reply.outputs.keys() == outputs.keys()
    for name, value in outputs.items():
        np.testing.assert_array_equal(reply.outputs[name], value)
    assert reply.outputs["value"].shape == ()


def test_error_reply_and_comments():
    lines = ["# warming up", "", *protocol.encode_reply(error_kind="TooFewSamples", message="r2 needs\nat least 2")]
    decoder = protocol.ReplyDecoder()
    reply = [decoder.feed(line) for line in lines][-1]
    assert reply.error_kind == "TooFewSamples"
    assert reply.error_message == "r2 needs at least 2"
    assert reply.outputs == {}


@pytest.mark.parametrize(
    ("lines", "message"),
    [
        (["error TooFewSamples", "result value real 0 1"], "after an 'error' line"),
        (["result value real 0 1", "error TooFewSamples"], "only answer"),
        (["result value real 0 1", "result value real 0 2"], "sent twice"),
        (["error"], "needs the error kind"),
        (["value 1.0"], "expected 'result', 'error' or 'end'"),
    ],
)
def test_reply_decoder_rejects(lines, message):
    decoder = protocol.ReplyDecoder()
    with pytest.raises(ProtocolError, match=message):
        for line in lines:
            decoder.feed(line)


# --------------------------------------------------------------------------- handshake


def test_greeting():
    assert protocol.parse_greeting("dynval-port 1 my port 0.3") == (1, "my port 0.3")
    for bad in ("dynval-port", "dynval-port one", "hello 1"):
        with pytest.raises(ProtocolError):
            protocol.parse_greeting(bad)


def test_capability_matching():
    cap = protocol.parse_capability('capability r2 multioutput="pooled"|"raw_values" segments=none')
    assert cap.matches("r2", {"multioutput": "pooled"})  # absent segments counts as none
    assert cap.matches("r2", {"multioutput": "raw_values", "segments": None})
    assert not cap.matches("r2", {"multioutput": "uniform_average"})
    assert not cap.matches("r2", {"multioutput": "pooled", "segments": [3, 2]})
    assert not cap.matches("vaf", {"multioutput": "pooled"})
    assert not cap.matches("r2", {})  # multioutput absent = none, not listed
    assert protocol.format_capability(cap) == 'capability r2 multioutput="pooled"|"raw_values" segments=none'
    # types are kept apart: ddof=1 does not match a case with ddof=1.0 or ddof=True
    ddof = protocol.parse_capability("capability residual_variance ddof=0|1")
    assert ddof.matches("residual_variance", {"ddof": 1})
    assert not ddof.matches("residual_variance", {"ddof": 1.0})
    assert not ddof.matches("residual_variance", {"ddof": True})


def test_covered_outputs():
    caps = [protocol.parse_capability("capability ljung_box outputs=statistic,df"),
            protocol.parse_capability("capability ljung_box outputs=lags model_df=0"),
            protocol.parse_capability("capability rmse")]
    assert protocol.covered_outputs(caps, "ljung_box", {"model_df": 0}) == {"statistic", "df", "lags"}
    assert protocol.covered_outputs(caps, "ljung_box", {"model_df": 2}) == {"statistic", "df"}
    assert protocol.covered_outputs(caps, "rmse", {}) is None
    assert protocol.covered_outputs(caps, "r2", {}) is False


@pytest.mark.parametrize("line", ["capability", "capability 1x", "capability r2 outputs=", "capability r2 ddof"])
def test_capability_rejects(line):
    with pytest.raises(ProtocolError):
        protocol.parse_capability(line)


# --------------------------------------------------------------------------- hexadecimal floats (encoding hex)


@pytest.mark.parametrize(
    ("x", "text"),
    [(3.0, "0x1.8000000000000p+1"), (-0.0, "-0x0.0p+0"), (0.0, "0x0.0p+0"), (5e-324, "0x0.0000000000001p-1022"),
     (2.2250738585072014e-308, "0x1.0000000000000p-1022"), (1.7976931348623157e308, "0x1.fffffffffffffp+1023"),
     (0.1, "0x1.999999999999ap-4"), (-1.0, "-0x1.0000000000000p+0"),
     (math.nan, "nan"), (math.inf, "inf"), (-math.inf, "-inf")],
)
def test_hex_writer_is_float_hex(x, text):
    assert protocol.format_real(x, "hex") == text
    assert same_float(protocol.parse_real(text, hex_ok=True), x)


@settings(max_examples=2000)
@given(st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True))
def test_hex_round_trip_every_float64(x):
    text = protocol.format_real(x, "hex")
    assert same_float(protocol.parse_real(text, hex_ok=True), x)
    if math.isfinite(x):
        assert text == x.hex()
        assert re.fullmatch(r"-?0x[01]\.[0-9a-f]+p[+-][0-9]+", text), text


@settings(max_examples=500)
@given(st.integers(min_value=0, max_value=2**64 - 1))
def test_hex_round_trip_every_bit_pattern(pattern):
    # Uniform over bit patterns: subnormals, both zeros and both extremes get their share.
    x = struct.unpack("<d", struct.pack("<Q", pattern))[0]
    assert same_float(protocol.parse_real(protocol.format_real(x, "hex"), hex_ok=True), x)


@pytest.mark.parametrize(
    ("token", "expected"),
    [
        ("0x1.8p+1", 3.0), ("0x1.8p1", 3.0), ("0X1.8P1", 3.0), ("+0x1p0", 1.0), ("0x.8p2", 2.0), ("0x1.p0", 1.0),
        ("0x1p-1074", 5e-324), ("0x0.0000000000001p-1022", 5e-324), ("-0x0.0p0", -0.0), ("0x0p+0", 0.0),
        ("0x1.0p-1022", 2.2250738585072014e-308),  # Java's Double.toHexString
        ("0x18p-3", 3.0), ("0x1.fffffffffffffp+1023", 1.7976931348623157e308), ("0x1p+1024", math.inf),
        ("-0x1p5000", -math.inf), ("0x1p-1080", 0.0),
        ("1.5e-3", 0.0015), ("NaN", math.nan), ("-Infinity", -math.inf),  # decimal stays readable
    ],
)
def test_parse_hex_accepts(token, expected):
    assert same_float(protocol.parse_real(token, hex_ok=True), expected)


@pytest.mark.parametrize("token", ["0x10", "0x1.8", "0x", "0xp1", "0x.p1", "1.8p1", "0x1.8p", "0x1.8e1", "0x1.8p+1.0",
                                   "0x1,8p1", "0x1.8p 1", "0xg.0p0", "0x1.8p+-1", "0b1p0"])
def test_parse_hex_rejects(token):
    with pytest.raises(ProtocolError, match="expected a number"):
        protocol.parse_real(token, hex_ok=True)


def test_hex_needs_the_handshake():
    with pytest.raises(ProtocolError, match="encoding hex"):
        protocol.parse_real("0x1.8p+1")
    with pytest.raises(ProtocolError):
        protocol.ReplyDecoder().feed("result value real 0 0x1.8p+1")
    decoder = protocol.ReplyDecoder("hex")
    reply = [decoder.feed(line) for line in ("result value real 0 0x1.8p+1", "end")][-1]
    assert reply.outputs["value"] == 3.0


def test_hex_keeps_types_apart():
    # Integers, booleans, strings and none are unchanged; only floats change form.
    tokens = [protocol.format_value(v, "hex") for v in (True, 1, 1.0, "1", None, [0.5, 2], 0.95)]
    assert tokens == ["true", "1", "0x1.0000000000000p+0", '"1"', "none", "[0x1.0000000000000p-1,2]",
                      "0x1.e666666666666p-1"]
    back = [protocol.parse_value(t, hex_ok=True) for t in tokens]
    assert back == [True, 1, 1.0, "1", None, [0.5, 2], 0.95]
    assert [type(v) for v in back[:3]] == [bool, int, float]


@given(float_arrays)
def test_hex_array_round_trip(arr):
    line = protocol.encode_array("e", arr, encoding="hex")
    assert "e+" not in line and "e-" not in line
    _, back = protocol.decode_array(protocol.split_line(line), hex_ok=True)
    assert back.shape == arr.shape
    assert all(same_float(a, b) for a, b in zip(back.ravel().tolist(), arr.ravel().tolist()))


def test_hex_case_and_reply():
    inputs = {"e": np.array([[0.1, -0.0], [5e-324, 1e300]]), "max_lag": 1, "rss": 8.5, "lags": [1, 5]}
    conventions = {"level": 0.95, "segments": [0, 1], "adjusted": False, "multioutput": "pooled"}
    lines = protocol.encode_case("autocorrelation", 3, "autocorrelation", conventions, inputs, encoding="hex")
    assert lines[0] == ('case autocorrelation 3 autocorrelation level=0x1.e666666666666p-1 segments=[0,1] '
                        'adjusted=false multioutput="pooled"')
    assert lines[1] == ("array e real 2 2 2 0x1.999999999999ap-4 -0x0.0p+0 0x0.0000000000001p-1022 "
                        "0x1.7e43c8800759cp+996")
    assert lines[2:] == ["scalar max_lag 1", "scalar rss 0x1.1000000000000p+3", "scalar lags [1,5]", "end"]
    with pytest.raises(ProtocolError):  # a decimal-only reader rejects the hex case
        for line in lines:
            protocol.CaseDecoder().feed(line)
    decoder = protocol.CaseDecoder("hex")
    case = [decoder.feed(line) for line in lines][-1]
    assert case.conventions == conventions and case.inputs["rss"] == 8.5 and case.inputs["max_lag"] == 1
    assert all(same_float(a, b) for a, b in zip(case.inputs["e"].ravel(), inputs["e"].ravel()))
    reply_lines = protocol.encode_reply({"value": np.array([1.5, -0.0])}, encoding="hex")
    assert reply_lines[0] == "result value real 1 2 0x1.8000000000000p+0 -0x0.0p+0"


def test_encoding_line():
    assert protocol.parse_encoding("encoding hex") == "hex"
    assert protocol.parse_encoding("encoding decimal") == "decimal"
    for bad in ("encoding", "encoding HEX", "encoding hex decimal", "encoding binary"):
        with pytest.raises(ProtocolError):
            protocol.parse_encoding(bad)
    with pytest.raises(ValueError, match="encoding must be one of"):
        protocol.format_real(1.0, "binary")
    # capability filters of a hex port may carry hex floats; they match the decimal value
    cap = protocol.parse_capability("capability confidence_band level=0x1.e666666666666p-1", hex_ok=True)
    assert cap.matches("confidence_band", {"level": 0.95})


# --------------------------------------------------------------------------- the real corpus


def _corpus_cases():
    from dynval.golden import FAMILIES, corpus_dir, iter_cases

    directory = corpus_dir()
    return [case for family in FAMILIES if (directory / f"{family}.json").is_file()
            for case in iter_cases(directory, [family])]


def test_every_corpus_case_crosses_the_wire_unchanged():
    """What a port decodes is bit for bit what the API tests use (only uncarriable cases excepted)."""
    cases = _corpus_cases()
    assert cases, "the golden corpus is empty"
    carried = 0
    for case in cases:
        try:
            lines = protocol.encode_case(case.family, case.tc_id, case.operation, case.conventions, case.inputs)
        except TypeError:
            continue
        carried += 1
        decoder = protocol.CaseDecoder()
        message = [decoder.feed(line) for line in lines][-1]
        assert message.conventions == case.conventions, case.id
        assert message.inputs.keys() == case.inputs.keys(), case.id
        for name, value in case.inputs.items():
            got = message.inputs[name]
            if isinstance(value, np.ndarray) and value.ndim:
                assert got.shape == value.shape and got.dtype.kind == value.dtype.kind, (case.id, name)
                assert all(same_float(float(a), float(b)) for a, b in zip(got.ravel(), value.ravel())), (case.id, name)
            else:
                assert protocol.format_value(got) == protocol.format_value(value), (case.id, name)
    assert carried >= 0.95 * len(cases)


def test_every_corpus_case_crosses_the_wire_unchanged_in_hex():
    carried = 0
    for case in _corpus_cases():
        try:
            lines = protocol.encode_case(case.family, case.tc_id, case.operation, case.conventions, case.inputs,
                                         encoding="hex")
        except TypeError:
            continue
        carried += 1
        decoder = protocol.CaseDecoder("hex")
        message = [decoder.feed(line) for line in lines][-1]
        assert message.conventions == case.conventions, case.id
        for name, value in case.inputs.items():
            got = message.inputs[name]
            if isinstance(value, np.ndarray) and value.ndim:
                assert got.shape == value.shape and got.dtype.kind == value.dtype.kind, (case.id, name)
                assert all(same_float(float(a), float(b)) for a, b in zip(got.ravel(), value.ravel())), (case.id, name)
            else:
                assert protocol.format_value(got) == protocol.format_value(value), (case.id, name)
    assert carried > 900


# --------------------------------------------------------------------------- the recipes of PROTOCOL.md
#
# Each recipe of PROTOCOL.md §8 is extracted, wrapped in a small harness that reads one token
# per line and writes "<decimal> <hex>" (or BAD), and run on the same hard values. A recipe
# whose tool is not installed is skipped, unless DYNVAL_REQUIRE_TOOLCHAINS (comma-separated:
# cc, java, octave, mathics) names it: then the test fails, so that CI cannot skip it silently.


def _recipe(language: str) -> str:
    text = PROTOCOL_MD.read_text(encoding="utf-8")
    blocks = re.findall(rf"```{language}\n(.*?)```", text, flags=re.S)
    assert len(blocks) == 1, f"PROTOCOL.md must hold exactly one {language} recipe"
    return blocks[0]


def _require(key: str, *executables: str, install: str) -> None:
    missing = [e for e in executables if shutil.which(e) is None]
    if not missing:
        return
    required = {k.strip() for k in os.environ.get("DYNVAL_REQUIRE_TOOLCHAINS", "").split(",") if k.strip()}
    message = f"{', '.join(missing)} not found on PATH (install: {install})"
    if key in required:
        pytest.fail(f"DYNVAL_REQUIRE_TOOLCHAINS names {key}, but {message}")
    pytest.skip(message)


def _hard_values(count: int) -> list[float]:
    """Random bit patterns (every class of double, a fifth of them subnormal), 17 digits each."""
    import random

    rng = random.Random(20261123)
    values = []
    while len(values) < count:
        bits_ = rng.getrandbits(52) if len(values) % 5 == 0 else rng.getrandbits(64)
        x = struct.unpack("<d", struct.pack("<Q", bits_))[0]
        if math.isfinite(x):
            values.append(x)
    return values


SPELLINGS = ["-nan", "NaN", "nan", "INF", "-Inf", "Infinity", "-infinity", "+inf", "1.5E-3", "1e5", "-7", ".5",
             "1e-9", "9007199254740993", "0x1.8p1", "0X1P-1074", "-0x0.0p0", "0x1.0p-1022", "0x0p+0", "0x.8p2"]


def recipe_tokens(random_count: int) -> list[str]:
    values = EDGE_FLOATS + _hard_values(random_count)
    return ([protocol.format_real(x) for x in values] + [protocol.format_real(x, "hex") for x in values]
            + SPELLINGS)


def _check_recipe_output(tokens: list[str], lines: list[str], *, exact: bool, signed_zero: bool = True) -> None:
    """Every token is read as the double it denotes and written back in both forms.

    ``exact``: the writers give the runner's own strings (C's %.16e and float.hex); Java's
    Double.toHexString and C's %a write other, equally exact, spellings of the same double.
    """
    assert len(lines) == len(tokens), (len(lines), len(tokens))
    for token, line in zip(tokens, lines):
        x = protocol.parse_real(token, hex_ok=True)
        decimal, hexa = line.split()
        if not signed_zero and x == 0:
            x = 0.0  # no signed zero in the language
        for out, encoding in ((decimal, "decimal"), (hexa, "hex")):
            got = protocol.parse_real(out, hex_ok=encoding == "hex")
            assert same_float(got, x), (token, out)
            if exact:
                assert out == protocol.format_real(x, encoding), (token, out)
        assert re.fullmatch(r"nan|-?inf|-?[0-9]\.[0-9]{16}e[+-][0-9]{2,3}", decimal), (token, decimal)


C_HARNESS = r"""
int main(void)
{
    char token[128];
    double x;
    while (scanf("%127s", token) == 1) {
        if (dv_read_real(token, &x) != 0) { printf("BAD\n"); continue; }
        dv_write_real(stdout, x);
        putchar(' ');
        dv_write_hex(stdout, x);
        putchar('\n');
    }
    if (dv_read_real("1,5", &x) == 0 || dv_read_real("", &x) == 0 || dv_read_real("1.5*^-3", &x) == 0) return 3;
    return 0;
}
"""


def test_c_recipe(tmp_path):
    _require("cc", "cc", install="apt-get install gcc")
    source = tmp_path / "recipe.c"
    source.write_text(_recipe("c") + C_HARNESS)
    exe = tmp_path / "recipe"
    subprocess.run(["cc", "-std=c99", "-Wall", "-Werror", "-o", str(exe), str(source), "-lm"], check=True)
    tokens = recipe_tokens(300)
    done = subprocess.run([str(exe)], input="\n".join(tokens), capture_output=True, text=True, timeout=30)
    assert done.returncode == 0, done.stderr
    _check_recipe_output(tokens, done.stdout.splitlines(), exact=False)
    # %.16e is C's own: the decimal form is exactly the runner's
    for token, line in zip(tokens, done.stdout.splitlines()):
        assert line.split()[0] == protocol.format_real(protocol.parse_real(token, hex_ok=True)), token


JAVA_HARNESS = r"""
public class Recipe {
    public static void main(String[] args) throws Exception {
        java.io.BufferedReader in = new java.io.BufferedReader(
            new java.io.InputStreamReader(System.in, java.nio.charset.StandardCharsets.US_ASCII));
        StringBuilder out = new StringBuilder();
        for (String line; (line = in.readLine()) != null; ) {
            for (String token : line.trim().split("[ \t]+")) {
                if (token.isEmpty()) continue;
                double x = DvNumbers.readHex(token);
                out.append(DvNumbers.writeReal(x)).append(' ').append(DvNumbers.writeHex(x)).append('\n');
            }
        }
        for (String bad : new String[] {"1,5", "0x1p3", "1.5*^-3", "1d", "NaNx"}) {
            try { DvNumbers.readReal(bad); System.exit(3); } catch (NumberFormatException expected) { }
        }
        for (String bad : new String[] {"0x10", "0x1.8", "1.8p1", "0x1.8e1", "1.5d", "0x1p3f"}) {
            try { DvNumbers.readHex(bad); System.exit(4); } catch (NumberFormatException expected) { }
        }
        System.out.print(out);
        System.out.flush();
    }
}
"""


def test_java_recipe(tmp_path):
    _require("java", "javac", "java", install="apt-get install default-jdk-headless")
    (tmp_path / "Recipe.java").write_text(_recipe("java") + JAVA_HARNESS)
    subprocess.run(["javac", "-d", str(tmp_path), str(tmp_path / "Recipe.java")], check=True, timeout=120)
    tokens = recipe_tokens(300)
    done = subprocess.run(["java", "-Duser.language=fr", "-Duser.country=FR", "-cp", str(tmp_path), "Recipe"],
                          input="\n".join(tokens), capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    # Java pads its shortest digits with zeros instead of printing exact ones, and writes 0x1.8p1: same doubles.
    _check_recipe_output(tokens, done.stdout.splitlines(), exact=False)


OCTAVE_BAD = ["1,5", "1.5*^-3", "0x10", "0x1.8", "Indeterminate", "1e", "1.0d0", "0x1.8e1"]

OCTAVE_HARNESS = r"""
tokens = strsplit(fileread('%(tokens)s'), "\n");
out = fopen('%(out)s', 'w');
for i = 1:numel(tokens)
  t = tokens{i};
  if isempty(t), continue; end
  x = dv_read_real(t);
  fprintf(out, '%%s %%s\n', dv_write_real(x), dv_write_hex(x));
end
bad = {%(bad)s};
for i = 1:numel(bad)
  try
    dv_read_real(bad{i});
    fprintf(out, 'ACCEPTED %%s\n', bad{i});
  catch
  end
end
fclose(out);
"""


def test_octave_recipe(tmp_path):
    _require("octave", "octave-cli",
             install="apt-get update -qq; apt-get install -y -qq --no-install-recommends octave")
    tokens = recipe_tokens(300)
    (tmp_path / "tokens.txt").write_text("\n".join(tokens) + "\n")
    out = tmp_path / "out.txt"
    # A script file defines its functions after a first statement ("1;") in Octave.
    script = "1;\n" + _recipe("matlab") + OCTAVE_HARNESS % {
        "tokens": tmp_path / "tokens.txt", "out": out, "bad": ", ".join(f"'{b}'" for b in OCTAVE_BAD)}
    (tmp_path / "recipe_test.m").write_text(script)
    done = subprocess.run(["octave-cli", "--no-gui", "--norc", "--quiet", str(tmp_path / "recipe_test.m")],
                          capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    lines = out.read_text().splitlines()
    assert [line for line in lines if line.startswith("ACCEPTED")] == []
    _check_recipe_output(tokens, lines, exact=True)


WOLFRAM_BAD = ["1,5", "1.5*^-3", "0x10", "0x1.8", "Indeterminate", "1e", "1.0d0"]

WOLFRAM_HARNESS = r"""
Do[x = dvReadReal[t]; Print["OUT ", dvWriteReal[x], " ", dvWriteHex[x]], {t, %(tokens)s}];
Do[If[dvReadReal[t] =!= $Failed, Print["ACCEPTED ", t]], {t, %(bad)s}];
Print["DONE"];
"""


def _wolfram_list(tokens):
    return "{" + ", ".join(f'"{t}"' for t in tokens) + "}"


@pytest.mark.slow
def test_wolfram_recipe(tmp_path):
    _require("mathics", "mathics", install="pip install mathics3 packaging")
    # Mathics3 needs about 0.4 s per number here: the edge values and a few random ones.
    tokens = recipe_tokens(12)
    script = _recipe("wolfram") + WOLFRAM_HARNESS % {"tokens": _wolfram_list(tokens), "bad": _wolfram_list(WOLFRAM_BAD)}
    (tmp_path / "recipe_test.wl").write_text(script)
    done = subprocess.run(["mathics", "-q", "-f", str(tmp_path / "recipe_test.wl")], capture_output=True, text=True,
                          timeout=900, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert "DONE" in lines, done.stdout[-2000:] + done.stderr[-2000:]
    assert [line for line in lines if line.startswith("ACCEPTED")] == []
    _check_recipe_output(tokens, [line[4:] for line in lines if line.startswith("OUT ")], exact=True,
                         signed_zero=False)


def test_a_required_toolchain_fails_instead_of_skipping(monkeypatch):
    monkeypatch.setenv("PATH", "/nonexistent")
    monkeypatch.setenv("DYNVAL_REQUIRE_TOOLCHAINS", "java, octave")
    with pytest.raises(pytest.fail.Exception, match="DYNVAL_REQUIRE_TOOLCHAINS names octave"):
        _require("octave", "octave-cli", install="apt-get install octave")
    monkeypatch.setenv("DYNVAL_REQUIRE_TOOLCHAINS", "java")
    with pytest.raises(pytest.skip.Exception, match="octave-cli not found"):
        _require("octave", "octave-cli", install="apt-get install octave")


def test_protocol_md_states_the_version():
    assert f"**Protocol version {protocol.PROTOCOL_VERSION}.**" in PROTOCOL_MD.read_text(encoding="utf-8")


# --------------------------------------------------------------------------- the operations reference (PROTOCOL.md §11)


def test_operations_section_is_current():
    from dynval.golden import _spec

    assert _spec.current_section() == _spec.render(), (
        "PROTOCOL.md §11 is stale: run python -m dynval.golden operations --write")


def test_operations_section_covers_every_operation():
    from dynval.golden import OPERATIONS, _spec

    spec = _spec.load_spec()
    assert list(spec["operations"]) == list(OPERATIONS)
    text = _spec.current_section()
    for name in OPERATIONS:
        assert f"### `{name}`" in text


def _section(name):
    from dynval.golden import _spec

    text = _spec.current_section()
    body = text.split(f"### `{name}`", 1)[1]
    return body.split("\n### ", 1)[0]


@pytest.mark.parametrize(
    ("case_id", "operation", "needles"),
    [
        # tau_meas (N,) with tau_pred (N, 1): the same signal once (N,) is promoted
        ("norms-51", "rmse", ["promoting `(N,)` to `(N, 1)`", "`(3,)` with `(3, 1)` is not"]),
        ("norms-54", "rmse", ['accepted `"pooled"`, `"raw_values"`, `"uniform_average"`']),
        # |x| > 1e144 is NonFiniteInput
        ("errors-110", "sse", ["|x| > 1e144"]),
        ("errors-111", "residuals", ["|x| > 1e144"]),
        # zero columns: InvalidShape
        ("errors-13", "max_abs_error", ["zero columns `(N, 0)`"]),
        # sse accepts only pooled and raw_values
        ("errors-50", "sse", ['`"uniform_average"`, `"variance_weighted"` (valid for other operations)']),
    ],
)
def test_operations_section_decides_the_vectors_a_protocol_only_port_failed(case_id, operation, needles):
    from dynval.golden import iter_cases

    family, tc = case_id.split("-")
    case = next(c for c in iter_cases(families=[family]) if c.tc_id == int(tc))
    assert case.operation == operation
    body = _section(operation)
    for needle in needles:
        assert needle in body, (case_id, needle)
    assert "nan_policy" in body
