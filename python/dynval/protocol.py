"""Reference reader and writer for the dynval port protocol (``golden/PROTOCOL.md``).

The port protocol lets a program written in any language prove that it computes
dynval's metrics correctly: ``dynval conform -- COMMAND`` starts the program,
sends it every golden vector as plain text lines and compares what comes back.
This module is the normative Python implementation of the line grammar; the
runner (:mod:`dynval.conform`) and the Python port (:mod:`dynval.port`) both use
it, and its tests pin the grammar that other languages must follow.

Numbers
-------
Writers emit 17 significant digits in decimal exponent form, which round-trips
every IEEE binary64 value exactly::

    >>> format_real(-4593.170185988091)
    '-4.5931701859880914e+03'
    >>> format_real(float("nan")), format_real(float("-inf"))
    ('nan', '-inf')

Readers accept any decimal form and the usual spellings of the non-finite
values, in any letter case (C's ``-nan``, MATLAB's ``NaN``/``Inf``, Java's
``Infinity``)::

    >>> parse_real("1.5E-3"), parse_real("-NaN"), parse_real("Infinity")
    (0.0015, nan, inf)

A port that prints ``encoding hex`` in its handshake gets every float as a C99
hexadecimal float, exactly as :meth:`float.hex` writes it, and may answer in
that form; a language without a correctly rounded decimal reader reads it
exactly with integer arithmetic::

    >>> format_real(3.0, "hex"), format_real(-0.0, "hex"), format_real(5e-324, "hex")
    ('0x1.8000000000000p+1', '-0x0.0p+0', '0x0.0000000000001p-1022')
    >>> parse_real("0x1.8p1", hex_ok=True)
    3.0

Lines
-----
>>> encode_array("e", [[1.0, 2.0], [3.0, 4.0]])
'array e real 2 2 2 1.0000000000000000e+00 2.0000000000000000e+00 3.0000000000000000e+00 4.0000000000000000e+00'
>>> name, arr = decode_array(split_line(encode_array("mask", [True, False])), "array")
>>> name, arr.tolist()
('mask', [True, False])
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

__all__ = [
    "PROTOCOL_VERSION",
    "GREETING",
    "ProtocolError",
    "Capability",
    "CaseMessage",
    "Reply",
    "format_real",
    "parse_real",
    "parse_int",
    "format_value",
    "parse_value",
    "split_line",
    "encode_array",
    "decode_array",
    "encode_case",
    "CaseDecoder",
    "encode_reply",
    "ReplyDecoder",
    "parse_capability",
    "format_capability",
    "parse_greeting",
    "parse_encoding",
    "ENCODINGS",
]

#: Version of the line protocol described in ``golden/PROTOCOL.md``.
PROTOCOL_VERSION = 1

#: First word of the port's first line.
GREETING = "dynval-port"

#: Element types of ``array`` and ``result`` lines.
ARRAY_TYPES = ("real", "int", "bool")

#: Number encodings a port can ask for with an ``encoding NAME`` handshake line.
#: ``decimal`` (the default) writes 17 significant digits; ``hex`` writes C99
#: hexadecimal floats as :meth:`float.hex` does.
ENCODINGS = ("decimal", "hex")

# The grammar of PROTOCOL.md section "Numbers". Hexadecimal floats, digit
# separators, embedded blanks and a bare exponent are rejected on purpose: every
# language's standard library reads what this accepts, and not all read more.
_DECIMAL_RE = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?\Z")
_INT_RE = re.compile(r"[+-]?[0-9]+\Z")
# C99 hexadecimal float with a mandatory binary exponent: what printf("%a"),
# Java's Double.toHexString and Python's float.hex write, and what strtod,
# Double.parseDouble and float.fromhex read. Only accepted after "encoding hex".
_HEX_RE = re.compile(r"[+-]?0[xX](?:[0-9a-fA-F]+(?:\.[0-9a-fA-F]*)?|\.[0-9a-fA-F]+)[pP][+-]?[0-9]+\Z")
# C99 allows printf to write "nan(chars)"; MSVC writes "-nan(ind)".
_NAN_RE = re.compile(r"[+-]?nan(?:\([0-9a-z_]*\))?\Z")
_INF_RE = re.compile(r"[+-]?inf(?:inity)?\Z")
_NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
# Characters written as themselves inside a quoted string; every other byte of
# the UTF-8 encoding is written as %XX, so a string never contains a blank, a
# quote, a comma, a bar or a bracket and a port can split lines naively.
_STRING_SAFE = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_.-")


class ProtocolError(ValueError):
    """A line that does not follow the protocol grammar.

    The message says what was expected and quotes (a bounded part of) what was
    received, so a port author can fix the writer.
    """


def _quote(text: str, limit: int = 80) -> str:
    if len(text) > limit:
        text = text[:limit] + "..."
    return repr(text)


# --------------------------------------------------------------------------- numbers


def _check_encoding(encoding: str) -> str:
    if encoding not in ENCODINGS:
        raise ValueError(f"encoding must be one of {', '.join(ENCODINGS)}, got {encoding!r}")
    return encoding


def format_real(x: float | np.floating[Any], encoding: str = "decimal") -> str:
    """Write one float64 in the protocol's canonical form.

    Parameters
    ----------
    x : float
        Any IEEE binary64 value, including subnormals, signed zeros and
        non-finite values.
    encoding : {"decimal", "hex"}
        ``"hex"`` only for a port that asked for it in its handshake.

    Returns
    -------
    str
        ``d.dddddddddddddddde±XX`` (17 significant digits, at least two exponent
        digits), or with ``encoding="hex"`` the C99 hexadecimal float of
        :meth:`float.hex` (``0x1.8000000000000p+1``, ``-0x0.0p+0``); non-finite
        values are ``nan``, ``inf``, ``-inf`` in both. The sign of a NaN is not kept.

    Examples
    --------
    >>> format_real(0.1)
    '1.0000000000000001e-01'
    >>> format_real(-0.0)
    '-0.0000000000000000e+00'
    >>> format_real(5e-324)
    '4.9406564584124654e-324'
    """
    x = float(x)
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if encoding == "hex":
        return x.hex()
    _check_encoding(encoding)
    return format(x, ".16e")


def parse_real(token: str, *, hex_ok: bool = False) -> float:
    """Read one number written in the protocol grammar.

    Accepts integers, decimals with an optional ``e``/``E`` exponent, and
    ``nan``, ``inf``, ``infinity`` with an optional sign, in any letter case
    (plus C's ``nan(chars)``). With ``hex_ok`` (the port negotiated
    ``encoding hex``), C99 hexadecimal floats with a binary exponent too
    (``0x1.8p1``, ``-0x0.0p+0``, ``0X1P-1074``).

    Raises
    ------
    ProtocolError
        For anything else: empty tokens, ``1,5``, ``1e``, ``1.5*^-3``,
        ``Indeterminate``, ``0x1p3`` without ``hex_ok``, ``0x10`` (no exponent), ...

    Examples
    --------
    >>> parse_real("-4.5931701859880914e+03")
    -4593.170185988091
    >>> parse_real("-INF")
    -inf
    """
    if _DECIMAL_RE.match(token):
        return float(token)
    low = token.lower()
    if _NAN_RE.match(low):
        return math.nan
    if _INF_RE.match(low):
        return -math.inf if low.startswith("-") else math.inf
    if hex_ok and _HEX_RE.match(token):
        try:
            return float.fromhex(token)
        except OverflowError:  # beyond the largest double: infinite, as strtod and float("1e999") say
            return -math.inf if token.startswith("-") else math.inf
    if not hex_ok and _HEX_RE.match(token):
        raise ProtocolError(f"expected a number (e.g. -4.5931701859880914e+03, nan, inf, -inf), got {_quote(token)}: "
                            "hexadecimal floats need the 'encoding hex' handshake line")
    raise ProtocolError(f"expected a number (e.g. -4.5931701859880914e+03, nan, inf, -inf), got {_quote(token)}")


def parse_int(token: str) -> int:
    """Read one integer (``[+-]?[0-9]+``).

    >>> parse_int("-12")
    -12
    """
    if not _INT_RE.match(token):
        raise ProtocolError(f"expected an integer, got {_quote(token)}")
    return int(token)


def _format_int(value: int | np.integer[Any]) -> str:
    return str(int(value))


# --------------------------------------------------------------------------- typed values


def _format_string(text: str) -> str:
    parts = []
    for ch in text:
        if ch in _STRING_SAFE:
            parts.append(ch)
        else:
            parts.extend(f"%{b:02X}" for b in ch.encode("utf-8"))
    return '"' + "".join(parts) + '"'


def _parse_string(token: str) -> str:
    body = token[1:-1]
    raw = bytearray()
    i = 0
    while i < len(body):
        ch = body[i]
        if ch == "%":
            pair = body[i + 1 : i + 3]
            if len(pair) != 2 or not re.fullmatch(r"[0-9A-Fa-f]{2}", pair):
                raise ProtocolError(f"bad %XX escape in string {_quote(token)}")
            raw.append(int(pair, 16))
            i += 3
        elif ch in _STRING_SAFE:
            raw.append(ord(ch))
            i += 1
        else:
            raise ProtocolError(f"character {ch!r} must be %-escaped in string {_quote(token)}")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ProtocolError(f"string {_quote(token)} is not UTF-8: {exc}") from None


def _format_scalar(value: Any, encoding: str = "decimal") -> str:
    # bool before int: bool is a subclass of int, and the wire keeps them apart
    # so that a port can reject max_lag=true as the contract requires.
    if value is None:
        return "none"
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return _format_int(value)
    if isinstance(value, (float, np.floating)):
        return format_real(value, encoding)
    if isinstance(value, str):
        return _format_string(value)
    raise TypeError(f"a {type(value).__name__} cannot be written as a protocol value")


def format_value(value: Any, encoding: str = "decimal") -> str:
    """Write a convention value or scalar input as one typed token.

    ``None`` → ``none``; booleans → ``true``/``false``; integers → ``12``;
    floats → :func:`format_real` in ``encoding`` (always with an exponent, so
    ``5.0`` stays distinguishable from ``5``); strings → ``"pooled"`` (quoted, bytes outside
    ``[A-Za-z0-9_.-]`` as ``%XX``); a flat list or tuple of these → ``[500,300]``.

    Raises
    ------
    TypeError
        For values the protocol cannot carry (nested lists, dicts, complex, ...).

    Examples
    --------
    >>> format_value("raw_values"), format_value(True), format_value([0, 500])
    ('"raw_values"', 'true', '[0,500]')
    >>> format_value(0.95)
    '9.4999999999999996e-01'
    """
    if isinstance(value, np.ndarray):
        if value.ndim == 0:
            return _format_scalar(value.item(), encoding)
        if value.ndim == 1 and value.dtype.kind in "biuf":
            return format_value(value.tolist(), encoding)
        raise TypeError(f"an array of shape {value.shape} cannot be written as a protocol value")
    if isinstance(value, (list, tuple)):
        return "[" + ",".join(_format_scalar(v, encoding) for v in value) + "]"
    return _format_scalar(value, encoding)


def _parse_scalar(token: str, hex_ok: bool = False) -> Any:
    if token == "none":
        return None
    if token == "true":
        return True
    if token == "false":
        return False
    if token.startswith('"'):
        if len(token) < 2 or not token.endswith('"'):
            raise ProtocolError(f"unterminated string {_quote(token)}")
        return _parse_string(token)
    if _INT_RE.match(token):
        return int(token)
    return parse_real(token, hex_ok=hex_ok)


def parse_value(token: str, *, hex_ok: bool = False) -> Any:
    """Read one typed token written by :func:`format_value`.

    ``hex_ok`` also reads hexadecimal floats (a float, never an integer).

    >>> parse_value('"pooled"'), parse_value("[500,300]"), parse_value("1.0000000000000000e+00")
    ('pooled', [500, 300], 1.0)
    """
    if token.startswith("["):
        if not token.endswith("]"):
            raise ProtocolError(f"unterminated list {_quote(token)}")
        inner = token[1:-1]
        if inner == "":
            return []
        return [_parse_scalar(t, hex_ok) for t in inner.split(",")]
    return _parse_scalar(token, hex_ok)


# --------------------------------------------------------------------------- lines


def split_line(line: str) -> list[str]:
    """Split a protocol line into tokens (blanks and tabs; a trailing CR is dropped)."""
    return line.rstrip("\r\n").split()


def _check_name(name: str, what: str) -> str:
    if not _NAME_RE.match(name):
        raise ProtocolError(f"expected {what} (letters, digits, underscore), got {_quote(name)}")
    return name


def _array_type(arr: np.ndarray) -> str:
    kind = arr.dtype.kind
    if kind == "b":
        return "bool"
    if kind in "iu":
        return "int"
    if kind == "f":
        return "real"
    raise TypeError(f"an array of dtype {arr.dtype} cannot be written on an array line")


def encode_array(name: str, values: Any, keyword: str = "array", encoding: str = "decimal") -> str:
    """Write the line ``array NAME TYPE NDIM D1 … Dn V1 … Vk`` (values row-major).

    ``TYPE`` is ``real`` (float arrays; numbers as :func:`format_real`), ``int``
    or ``bool`` (``0``/``1``). ``keyword="result"`` writes a ``result`` line,
    which has the same layout. A 0-d array writes ``NDIM`` 0 and one value.

    >>> encode_array("value", 2.5, keyword="result")
    'result value real 0 2.5000000000000000e+00'
    """
    _check_name(name, "an array name")
    arr = np.asarray(values)
    if arr.dtype.kind in "iu":
        arr = arr.astype(np.int64, copy=False)
    kind = _array_type(arr)
    flat = arr.reshape(-1)  # C order: row-major as the protocol requires
    if kind == "real":
        _check_encoding(encoding)
        body = [format_real(v, encoding) for v in flat.astype(np.float64, copy=False).tolist()]
    elif kind == "int":
        body = [str(v) for v in flat.tolist()]
    else:
        body = ["1" if v else "0" for v in flat.tolist()]
    head = [keyword, name, kind, str(arr.ndim), *(str(d) for d in arr.shape)]
    return " ".join(head + body)


def decode_array(tokens: Sequence[str], keyword: str = "array", *, strict_type: bool = True,
                 hex_ok: bool = False) -> tuple[str, np.ndarray]:
    """Read the tokens of an ``array`` (or ``result``) line.

    Parameters
    ----------
    tokens : sequence of str
        The line split by :func:`split_line`, keyword first.
    keyword : str
        ``"array"`` or ``"result"``.
    strict_type : bool
        If False (the runner reading a port's results), every element is read
        as a number whatever the declared type, ``true``/``false`` included,
        and the result is float64 (bool for ``bool``).
    hex_ok : bool
        Also read hexadecimal floats (after ``encoding hex``).

    Returns
    -------
    (name, ndarray)
        float64, int64 or bool array of the declared shape.
    """
    if len(tokens) < 4 or tokens[0] != keyword:
        raise ProtocolError(f"expected '{keyword} NAME TYPE NDIM DIMS... VALUES...', got {_quote(' '.join(tokens))}")
    name = _check_name(tokens[1], "an array name")
    kind = tokens[2]
    if kind not in ARRAY_TYPES:
        raise ProtocolError(f"{keyword} {name}: type must be one of real, int, bool, got {_quote(kind)}")
    ndim = parse_int(tokens[3])
    if not 0 <= ndim <= 8:
        raise ProtocolError(f"{keyword} {name}: NDIM must be between 0 and 8, got {ndim}")
    if len(tokens) < 4 + ndim:
        raise ProtocolError(f"{keyword} {name}: NDIM is {ndim} but only {len(tokens) - 4} dimensions follow")
    shape = tuple(parse_int(t) for t in tokens[4 : 4 + ndim])
    if any(d < 0 for d in shape):
        raise ProtocolError(f"{keyword} {name}: negative dimension in shape {shape}")
    values = tokens[4 + ndim :]
    count = math.prod(shape)
    if len(values) != count:
        raise ProtocolError(f"{keyword} {name}: shape {shape} needs {count} values, got {len(values)}")
    if kind == "bool":
        out = np.empty(count, dtype=bool)
        for i, t in enumerate(values):
            low = t.lower()
            if low in ("1", "true"):
                out[i] = True
            elif low in ("0", "false"):
                out[i] = False
            elif not strict_type:
                out[i] = bool(parse_real(t, hex_ok=hex_ok))
            else:
                raise ProtocolError(f"{keyword} {name}: bool values are 0 or 1, got {_quote(t)}")
    elif kind == "int" and (strict_type or all(_INT_RE.match(t) for t in values)):
        out = np.array([parse_int(t) for t in values], dtype=np.int64)
    else:
        out = np.array([parse_real(t, hex_ok=hex_ok) for t in values], dtype=np.float64)
    return name, out.reshape(shape)


@dataclass
class CaseMessage:
    """One case as the port receives it: the ``case`` line and its ``scalar``/``array`` lines."""

    family: str
    tc_id: int
    operation: str
    conventions: dict[str, Any] = field(default_factory=dict)
    inputs: dict[str, Any] = field(default_factory=dict)


def encode_case(family: str, tc_id: int, operation: str, conventions: Mapping[str, Any], inputs: Mapping[str, Any],
                encoding: str = "decimal") -> list[str]:
    """Write the lines of one case, ``end`` included.

    Arrays (numpy arrays of at least one dimension) go on ``array`` lines; every
    other input (``n_params``, ``max_lag``, a ``lags`` list, ...) on a ``scalar``
    line; conventions as ``KEY=VALUE`` tokens of the ``case`` line. Every float
    (array element, scalar input, convention value) is written in ``encoding``.

    Raises
    ------
    TypeError
        If an input or a convention cannot be carried by the protocol (complex
        or string arrays, nested lists, ...). The runner reports such cases as
        skipped.

    Examples
    --------
    >>> encode_case("norms", 7, "rmse", {"multioutput": "pooled", "convention": None},
    ...             {"tau_meas": np.array([1.0, 2.0]), "tau_pred": np.array([1.0, 2.5])})[0]
    'case norms 7 rmse multioutput="pooled" convention=none'
    """
    _check_name(family, "a family name")
    _check_name(operation, "an operation name")
    head = ["case", family, str(int(tc_id)), operation]
    _check_encoding(encoding)
    for key, value in conventions.items():
        head.append(f"{_check_name(key, 'a convention name')}={format_value(value, encoding)}")
    lines = [" ".join(head)]
    for name, value in inputs.items():
        if isinstance(value, np.ndarray) and value.ndim >= 1:
            lines.append(encode_array(name, value, encoding=encoding))
        else:
            lines.append(f"scalar {_check_name(name, 'an input name')} {format_value(value, encoding)}")
    lines.append("end")
    return lines


def _parse_keyvalue(token: str) -> tuple[str, str]:
    key, sep, value = token.partition("=")
    if not sep:
        raise ProtocolError(f"expected KEY=VALUE, got {_quote(token)}")
    return _check_name(key, "a convention name"), value


class CaseDecoder:
    """Incremental reader of cases on the port side.

    Feed it lines; :meth:`feed` returns a :class:`CaseMessage` when the ``end``
    line of a case arrives, the string ``"quit"`` for the ``quit`` line, and
    ``None`` otherwise. ``encoding="hex"`` (a port that negotiated it) also
    reads hexadecimal floats.
    """

    def __init__(self, encoding: str = "decimal") -> None:
        self._case: CaseMessage | None = None
        self._hex = _check_encoding(encoding) == "hex"

    def feed(self, line: str) -> CaseMessage | Literal["quit"] | None:
        tokens = split_line(line)
        if not tokens:
            return None
        word = tokens[0]
        if self._case is None:
            if word == "quit":
                return "quit"
            if word != "case" or len(tokens) < 4:
                raise ProtocolError(
                    f"expected 'case FAMILY TCID OPERATION [KEY=VALUE...]' or 'quit', got {_quote(line)}")
            conventions = {}
            for tok in tokens[4:]:
                key, value = _parse_keyvalue(tok)
                conventions[key] = parse_value(value, hex_ok=self._hex)
            self._case = CaseMessage(_check_name(tokens[1], "a family name"), parse_int(tokens[2]),
                                     _check_name(tokens[3], "an operation name"), conventions)
            return None
        if word == "end":
            case, self._case = self._case, None
            return case
        if word == "array":
            name, arr = decode_array(tokens, "array", hex_ok=self._hex)
            self._case.inputs[name] = arr
            return None
        if word == "scalar":
            if len(tokens) != 3:
                raise ProtocolError(f"expected 'scalar NAME VALUE', got {_quote(line)}")
            self._case.inputs[_check_name(tokens[1], "an input name")] = parse_value(tokens[2], hex_ok=self._hex)
            return None
        raise ProtocolError(f"expected 'array', 'scalar' or 'end' inside a case, got {_quote(line)}")


@dataclass
class Reply:
    """A port's answer to one case: outputs, or an error kind (and its message)."""

    outputs: dict[str, np.ndarray] = field(default_factory=dict)
    error_kind: str | None = None
    error_message: str = ""


def encode_reply(outputs: Mapping[str, Any] | None = None, error_kind: str | None = None, message: str = "",
                 encoding: str = "decimal") -> list[str]:
    """Write a port's answer, ``end`` included (reals in ``encoding``).

    >>> encode_reply({"value": 1.0})
    ['result value real 0 1.0000000000000000e+00', 'end']
    >>> encode_reply(error_kind="TooFewSamples", message="r2 needs at least 2 samples, got N=1")
    ['error TooFewSamples r2 needs at least 2 samples, got N=1', 'end']
    """
    if error_kind is not None:
        text = " ".join(message.split())  # one line, whatever the message held
        return [f"error {_check_name(error_kind, 'an error kind')}" + (f" {text}" if text else ""), "end"]
    return [encode_array(name, value, keyword="result", encoding=encoding)
            for name, value in (outputs or {}).items()] + ["end"]


class ReplyDecoder:
    """Incremental reader of a port's answer on the runner side.

    :meth:`feed` returns the :class:`Reply` when the ``end`` line arrives and
    ``None`` before. Blank lines and lines starting with ``#`` (port logging) are
    ignored. Anything else raises :class:`ProtocolError`. Hexadecimal floats
    are read only with ``encoding="hex"`` (the port asked for it).
    """

    def __init__(self, encoding: str = "decimal") -> None:
        self._reply = Reply()
        self._errored = False
        self._hex = _check_encoding(encoding) == "hex"

    def feed(self, line: str) -> Reply | None:
        tokens = split_line(line)
        if not tokens or tokens[0].startswith("#"):
            return None
        word = tokens[0]
        if word == "end":
            reply, self._reply, self._errored = self._reply, Reply(), False
            return reply
        if word == "result":
            if self._errored:
                raise ProtocolError("a 'result' line after an 'error' line")
            name, arr = decode_array(tokens, "result", strict_type=False, hex_ok=self._hex)
            if name in self._reply.outputs:
                raise ProtocolError(f"output {name!r} sent twice")
            self._reply.outputs[name] = arr
            return None
        if word == "error":
            if len(tokens) < 2:
                raise ProtocolError("an 'error' line needs the error kind")
            if self._errored or self._reply.outputs:
                raise ProtocolError("an 'error' line must be the only answer to a case")
            self._reply.error_kind = _check_name(tokens[1], "an error kind")
            self._reply.error_message = line.strip().split(None, 2)[2] if len(tokens) > 2 else ""
            self._errored = True
            return None
        raise ProtocolError(f"expected 'result', 'error' or 'end', got {_quote(line)}")


# --------------------------------------------------------------------------- handshake


@dataclass(frozen=True)
class Capability:
    """One ``capability`` line: an operation, convention filters and an output set.

    ``filters`` maps a convention name to the tuple of accepted values (decoded);
    a case is covered when its operation matches and, for every filtered key,
    its value is one of the accepted ones (a key the case does not set counts
    as ``none``). ``outputs`` is ``None`` (all expected outputs) or the names the
    port computes; other expected outputs of a covered case are not checked and
    are reported as skipped.
    """

    operation: str
    filters: tuple[tuple[str, tuple[Any, ...]], ...] = ()
    outputs: frozenset[str] | None = None

    def matches(self, operation: str, conventions: Mapping[str, Any]) -> bool:
        if operation != self.operation:
            return False
        for key, accepted in self.filters:
            value = conventions.get(key)
            if not any(_same_value(value, a) for a in accepted):
                return False
        return True


def _same_value(a: Any, b: Any) -> bool:
    # Compare as the wire sees them: true differs from 1, 5 from 5.0.
    try:
        return format_value(a) == format_value(b)
    except TypeError:
        return False


def parse_capability(line: str, *, hex_ok: bool = False) -> Capability:
    """Read ``capability OPERATION [outputs=a,b] [KEY=V1|V2...]``.

    >>> cap = parse_capability('capability ljung_box outputs=statistic,df model_df=0|1')
    >>> cap.outputs == frozenset({"statistic", "df"}), cap.matches("ljung_box", {"model_df": 1})
    (True, True)
    """
    tokens = split_line(line)
    if len(tokens) < 2 or tokens[0] != "capability":
        raise ProtocolError(f"expected 'capability OPERATION [outputs=...] [KEY=V1|V2...]', got {_quote(line)}")
    operation = _check_name(tokens[1], "an operation name")
    outputs = None
    filters = []
    for tok in tokens[2:]:
        key, value = _parse_keyvalue(tok)
        if key == "outputs":
            names = [n for n in value.split(",") if n]
            if not names:
                raise ProtocolError(f"outputs= needs at least one output name in {_quote(line)}")
            outputs = frozenset(_check_name(n, "an output name") for n in names)
        else:
            filters.append((key, tuple(parse_value(v, hex_ok=hex_ok) for v in value.split("|"))))
    return Capability(operation, tuple(filters), outputs)


def format_capability(cap: Capability) -> str:
    """Write a :class:`Capability` as its ``capability`` line."""
    parts = ["capability", cap.operation]
    if cap.outputs is not None:
        parts.append("outputs=" + ",".join(sorted(cap.outputs)))
    for key, accepted in cap.filters:
        parts.append(f"{key}=" + "|".join(format_value(v) for v in accepted))
    return " ".join(parts)


def parse_greeting(line: str) -> tuple[int, str]:
    """Read ``dynval-port VERSION [NAME...]`` and return ``(version, name)``."""
    tokens = split_line(line)
    if len(tokens) < 2 or tokens[0] != GREETING:
        raise ProtocolError(f"expected the greeting '{GREETING} {PROTOCOL_VERSION} [NAME]', got {_quote(line)}")
    version = parse_int(tokens[1])
    return version, " ".join(tokens[2:])


def parse_encoding(line: str) -> str:
    """Read the handshake line ``encoding NAME`` and return NAME (``decimal`` or ``hex``).

    >>> parse_encoding("encoding hex")
    'hex'
    """
    tokens = split_line(line)
    if len(tokens) != 2 or tokens[0] != "encoding" or tokens[1] not in ENCODINGS:
        raise ProtocolError(f"expected 'encoding {'|'.join(ENCODINGS)}', got {_quote(line)}")
    return tokens[1]


def covered_outputs(capabilities: Iterable[Capability], operation: str,
                    conventions: Mapping[str, Any]) -> frozenset[str] | bool | None:
    """Outputs a port computes for a case: ``False`` if no capability covers it,
    ``None`` if a matching capability covers every output, else the union of
    the matching capabilities' output sets."""
    found: set[str] = set()
    covered = False
    for cap in capabilities:
        if cap.matches(operation, conventions):
            if cap.outputs is None:
                return None
            covered = True
            found |= cap.outputs
    return frozenset(found) if covered else False
