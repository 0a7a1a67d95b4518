"""The ``dynval`` command line.

Subcommands:

* ``dynval validate MEAS PRED --n-params P [...]`` — validate predicted torques against
  measured ones from .npy, .npz, .csv, Parquet or HDF5 files and print the report (text or JSON);
* ``dynval compare MEAS --model NAME=PRED:P [--model ...]`` — candidate models side by side,
  a ranking and the decision (accept, refine, redesign);
* ``dynval demo`` — the embedded demonstration (a simulated 2-DOF arm), no input needed;
* ``dynval conform`` — the conformance runner for ports (see ``dynval conform --help``);
* ``dynval validate-many LOGS...`` — many logs of many robots: the fleet table and drift per robot
  (``dynval.fleet``), in this process or on a dask cluster.

Exit codes (contract §7): 0 success, 1 input error (a file refused, or an error of the dynval
contract, with the message on stderr), 2 usage error, 3 internal error, 130 interrupted, 141 the
reader of standard output went away (``dynval validate ... | head -1``).
"""

from __future__ import annotations

import argparse
import errno
import math
import os
import re
import sys
from collections.abc import Sequence

from .checks._errors import InputError
from .checks._validation import format_value
from .io._files import (
    FileInputError,
    csv_header,
    file_path,
    load_array,
    physical_memory,
    read_column,
    read_table,
    split_column,
)
from .io._readers import DEFAULT_CHUNK_ROWS, decoded_size, open_column, open_rows
from .metrics._profiles import PROFILE_NAMES
from .report._text import printable

__all__ = ["main", "load_array", "build_parser", "FileInputError"]

EXIT_OK, EXIT_INPUT, EXIT_USAGE, EXIT_INTERNAL = 0, 1, 2, 3
EXIT_INTERRUPTED = 130  # 128 + SIGINT
EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE: what the shell sees of a program the closed pipe killed


# --------------------------------------------------------------------------- parser


def _segments_arg(text: str):
    try:
        values = [int(v) for v in text.replace(";", ",").split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            "expected comma-separated integers: lengths such as 500,300 or starts such as 0,500, "
            f"got {format_value(text)}"
        ) from None
    if not values:
        raise argparse.ArgumentTypeError("expected at least one integer")
    return values


_EXIT_CODES = ("Exit codes: 0 success, 1 input error (message on stderr), 2 usage error, 3 internal error, "
               "141 output pipe closed (contract §7).")


def build_parser() -> argparse.ArgumentParser:
    """The ``dynval`` argument parser (subcommands validate, compare, demo, conform)."""
    from ._version import __version__

    parser = argparse.ArgumentParser(
        prog="dynval",
        description="Validation metrics for identified robot dynamic models (tau = Y pi + e): "
                    "RMSE, VAF, fit, R², residual whiteness, regressor cross-correlation, AIC/BIC.",
        epilog="Exit codes: 0 success, 1 input error, 2 usage error, 3 internal error, "
               "141 output pipe closed.")
    parser.add_argument("--version", action="version", version=f"dynval {__version__}")
    sub = parser.add_subparsers(dest="command",
                                metavar="{validate,compare,demo,conform,validate-many,validate-log}")

    val = sub.add_parser(
        "validate", help="validate predicted torques against measured ones",
        description="Validate predicted joint torques against measured ones and print the report. "
                    "Files: .npy, .npz (file.npz:key, else the first array), .csv (tab, ';', ',' or "
                    "whitespace; a first line without any number is a header), .parquet (file.parquet:a,b,c, "
                    "else every column; extra dynval[parquet]) or .h5 (file.h5:/dataset, else the only "
                    "dataset; extra dynval[hdf5]); pickles are refused.",
        epilog=_EXIT_CODES)
    val.add_argument("meas", metavar="MEAS", help="measured torques, (N,) or (N, m)")
    val.add_argument("pred", metavar="PRED", help="predicted torques, same shape as MEAS")
    val.add_argument("--n-params", type=int, required=True, metavar="P",
                     help="number of identified parameters (required: there is no default)")
    _add_report_options(val)
    stream = val.add_argument_group(
        "files larger than memory",
        "--stream reads the files a block of rows at a time into dynval.stream.ValidationAccumulator "
        "(.npy, .npz members, CSV, Parquet and HDF5 from disk; a compressed .npz member is inflated block "
        "after block, read whole first only when Fortran-ordered). "
        "It is chosen by itself when the inputs together, decoded, exceed a quarter of this machine's memory. "
        "An array read whole may decode to at most 1 GiB as float64 (environment variable "
        "DYNVAL_MAX_DECODED_BYTES=BYTES raises the limit); larger ones need --stream. A "
        "streamed report runs the bias test from its lag sums and, without --regressor, the spectrum window by "
        "window, and names under its findings what it leaves out (decimated whiteness; with --regressor the "
        "spectrum and the colour-aware cross-correlation; contract §4.1). With --q it runs the missing-physics "
        "test from sums of the library's columns (its prewhitening filter fixed on the first 40,000 rows; "
        "conventions §5.2), not the delay and periodic tests; --segments, --estimation and --decimate are "
        "refused with it.")
    stream.add_argument("--stream", action="store_true", help="validate block by block (see above)")
    stream.add_argument("--chunk-rows", type=int, default=None, metavar="R",
                        help=f"rows per block when streaming (default {DEFAULT_CHUNK_ROWS})")
    stream.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                        help="progress (rows, rate, time left) on stderr while streaming; by default shown "
                             "when stderr is a terminal and the run takes over 2 s")
    val.set_defaults(subparser=val)

    cmp = sub.add_parser(
        "compare", help="compare candidate models: table, ranking and decision",
        description="Validate several candidate models on the same measured torques, rank them "
                    "(no deficiency first, then by the criterion) and give the decision of the lesson's "
                    "flowchart: accept, refine (which term, from which evidence) or redesign the experiment.",
        epilog="Example: dynval compare tau.npy --model rigid=rigid.npy:10 --model friction=fric.npy:14 "
               "--regressor Y_full.npy --sample-rate 200 --estimation q=q_est.npy --q q_val.npy. "
               + _EXIT_CODES)
    cmp.add_argument("meas", metavar="MEAS", help="measured torques of the validation run, (N,) or (N, m)")
    cmp.add_argument("--model", action="append", required=True, metavar="NAME=PRED:P", type=_model_arg,
                     help="a candidate: its name, its predicted torques (file) and its number of parameters "
                          "(repeat for each candidate)")
    cmp.add_argument("--model-columns", action="append", default=[], metavar="NAME=COLS", type=_model_columns_arg,
                     help="the regressor columns a candidate contains (indices from 0 or --column-names names, "
                          "comma-separated; needs --regressor): the other columns are then tested as terms it "
                          "lacks (repeat for each candidate)")
    cmp.add_argument("--criterion", default="aic", choices=("aic", "bic", "aicc", "aic_neff", "bic_neff", "aicc_neff"),
                     help="criterion of the ranking and the Akaike weights (default aic, the lesson's)")
    _add_report_options(cmp)
    cmp.set_defaults(subparser=cmp)

    demo = sub.add_parser("demo", help="simulate, identify and validate a 2-DOF arm (no input needed)")
    from .demo import build_parser as build_demo_parser

    build_demo_parser(demo)
    demo.epilog = "Exit codes: 0 success, 2 usage error."

    sub.add_parser("conform", help="run the conformance corpus against a port (see dynval conform --help)",
                   add_help=False)
    _add_validate_many(sub)
    from ._logcli import add_validate_log

    add_validate_log(sub, _EXIT_CODES)
    return parser


def _workers_arg(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a number of worker processes >= 1, got {format_value(text)}")
    return value


def _add_validate_many(sub) -> None:
    """``dynval validate-many``: dynval.fleet.validate_many from the command line."""
    many = sub.add_parser(
        "validate-many", help="validate many logs of many robots: a fleet table and drift per robot",
        description="Validate every log of a fleet (one row each: RMSE, VAF, decision, findings) and test each "
                    "robot's logs for drift: a model that fits worse from some log on than in that robot's earlier "
                    "logs. LOGS are manifests (.csv or .json with columns robot, time, tau_meas, tau_pred and "
                    "optionally n_params, log, and the files each log is validated with: regressor, q, dq, ddq, "
                    "timestamps, estimation_tau, estimation_regressor, estimation_q; paths relative to the "
                    "manifest) or logs named ROBOT__TIME: a .npz or .h5 file holding tau_meas and tau_pred, or a "
                    "directory holding tau_meas.* and tau_pred.* (and regressor.*, q.*, ...) files. Without q or "
                    "a regressor a log's decision sees its residual only; the table says what each saw "
                    "(contract §10).",
        epilog="Example: dynval validate-many fleet.csv --n-params 40 --workers 2 --html fleet.html. "
               "Exit code 1 also when a log could not be validated (its row then holds the error). " + _EXIT_CODES)
    many.add_argument("logs", nargs="+", metavar="LOGS", help="manifests (.csv, .json) or logs named ROBOT__TIME")
    many.add_argument("--n-params", type=int, metavar="P",
                      help="parameters of every log whose manifest row gives no n_params")
    where = many.add_mutually_exclusive_group()
    where.add_argument("--workers", type=_workers_arg, metavar="W",
                       help="start a local dask cluster of W worker processes for the run (needs dynval[dask]); "
                            "by default the logs are validated one after the other in this process")
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="address of a running dask scheduler (tcp://host:8786); the files must be readable "
                            "where its workers run")
    many.add_argument("--max-lag", type=int, metavar="L",
                      help="largest lag of each log's residual analysis (default: the profile's; 0 skips it)")
    many.add_argument("--level", type=float, default=0.95, metavar="X",
                      help="confidence level of each log's findings and of the drift test (default 0.95)")
    many.add_argument("--profile", default="lesson", choices=PROFILE_NAMES, help="convention profile (default lesson)")
    many.add_argument("--sample-rate", type=float, metavar="HZ", help="samples per second of every log")
    many.add_argument("--min-baseline", type=int, default=3, metavar="K",
                      help="earlier logs a drift needs before it (default 3: a robot needs 4 logs to be tested)")
    many.add_argument("--permutations", type=int, default=1999, metavar="B",
                      help="shuffles of each robot's logs for the drift test's p-value (default 1999)")
    many.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                      help="progress bar on stderr; by default shown when stderr is a terminal and the run takes "
                           "over 2 s")
    many.add_argument("--json", action="store_true", help="print the fleet report as JSON")
    many.add_argument("--output", metavar="FILE", help="write the output to FILE instead of stdout")
    many.add_argument("--html", metavar="FILE",
                      help="also write an HTML fleet page with drift plots (needs dynval[plot])")


def _model_arg(text: str):
    name, sep, rest = text.partition("=")
    path, sep2, p = rest.rpartition(":")
    if not (sep and sep2 and name and path):
        raise argparse.ArgumentTypeError("expected NAME=PRED_FILE:P, e.g. friction=pred.npy:14, "
                                         f"got {format_value(text)}")
    try:
        return printable(name), path, int(p)
    except ValueError:
        raise argparse.ArgumentTypeError("the number of parameters after ':' must be an integer, "
                                         f"got {format_value(p)}") from None


def _model_columns_arg(text: str):
    name, sep, cols = text.partition("=")
    if not sep or not name.strip() or not cols.strip():
        raise argparse.ArgumentTypeError("expected NAME=COLS, e.g. friction=0,1,4 or friction=Fv1,Fc1, "
                                         f"got {format_value(text)}")
    return printable(name.strip()), [int(c) if c.strip().lstrip("-").isdigit() else printable(c.strip())
                                     for c in cols.split(",")]


def _key_file_arg(text: str):
    key, sep, path = text.partition("=")
    if not sep or key not in ("q", "regressor", "tau") or not path:
        raise argparse.ArgumentTypeError(f"expected q=FILE, regressor=FILE or tau=FILE, got {format_value(text)}")
    return key, path


def _names_arg(text: str):
    # A name that was not UTF-8 on the command line (Python keeps byte 0xff as the lone surrogate
    # U+DCFF) is written \xff: as typed, and printable on any terminal, page or figure.
    return [printable(x.strip()) for x in text.split(",")]


def _decimate_arg(text: str):
    if text in ("auto", "none"):
        return None if text == "none" else "auto"
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected auto, none or an integer >= 1, got {format_value(text)}") from None


# How a declared keyword's flag reads its text (``report._options.Flag.read``): argparse's keywords.
_FLAG_KINDS = {
    "int": lambda o: {"type": int, "metavar": o.flag.metavar},
    "float": lambda o: {"type": float, "metavar": o.flag.metavar},
    "text": lambda o: {"default": o.default, "choices": o.flag.choices, "metavar": o.flag.metavar},
    "segments": lambda o: {"type": _segments_arg, "metavar": o.flag.metavar},
    "decimate": lambda o: {"type": _decimate_arg, "default": o.default, "metavar": o.flag.metavar},
    "names": lambda o: {"type": _names_arg, "metavar": o.flag.metavar},
    "file": lambda o: {"metavar": o.flag.metavar},
    "time": lambda o: {"metavar": o.flag.metavar},
    "estimation": lambda o: {"action": "append", "type": _key_file_arg, "metavar": o.flag.metavar},
    "switch": lambda o: {"action": "store_true"},
    "unswitch": lambda o: {"action": "store_false", "default": True},
}


def _add_report_options(sub) -> None:
    """The options ``validate`` and ``compare`` share: the regressor, then a flag per declared keyword
    of ``validate`` (``report._options.OPTIONS``, in the contract's order)."""
    from .report._options import OPTIONS

    sub.add_argument("--regressor", metavar="Y",
                     help="regressor of the validation data, (N, m, p), or (N*m, p) with --n-joints")
    for o in OPTIONS:
        if o.flag is not None:
            sub.add_argument(o.flag.flag, dest=o.name, help=o.flag.help, **_FLAG_KINDS[o.flag.read](o))
    sub.add_argument("--json", action="store_true", help="print the report as JSON")
    sub.add_argument("--output", metavar="FILE", help="write the output to FILE instead of stdout")
    sub.add_argument("--html", metavar="FILE",
                     help="also write a self-contained HTML report with figures (needs dynval[plot])")


# --------------------------------------------------------------------------- commands


def _error(command: str, message: str) -> int:
    print(f"dynval {command}: error: {message}", file=sys.stderr)
    return EXIT_INPUT


def _check_combinations(args) -> None:
    """Option combinations argparse cannot express: usage errors (exit 2)."""
    if args.n_joints is not None and args.regressor is None:
        args.subparser.error("--n-joints needs --regressor: it gives the joints m of a stacked (N*m, p) regressor")
    if args.bandwidth is not None and args.sample_rate is None and args.time is None:
        args.subparser.error("--bandwidth needs --sample-rate or --time: it is in Hz")


def _load(path: str, name: str, sources: dict):
    """Read one array; remember where ``name`` came from, to locate errors in the file."""
    table = read_table(path)
    sources[name] = (path, table.lines)
    return table.data


_FROM_ZERO = "rows and columns from 0"
_AT_ROW = re.compile(r"^(\w+) has .* at row (\d+), column (\d+)")
_TIME_AT_ROW = re.compile(r"^time must .*? at row (\d+)")


def _file_position(message: str, sources: dict) -> str:
    """`` (rows and columns from 0; meas.csv line 12, column 1)`` when an API error points into CSV.

    API errors count rows and columns from 0, files from 1 and by physical line (contract §2.3): the
    two positions side by side say which count each uses, so that neither reads as off by one.
    """
    unprefixed = re.sub(r"^chunk \d+: ", "", message)  # a streamed chunk's error
    if unprefixed.startswith("time ") and "time" in sources:
        return _time_position(unprefixed, sources["time"])
    match = _AT_ROW.match(message)
    if not match or match.group(1) not in sources:
        return ""
    path, lines = sources[match.group(1)]
    row, column = int(match.group(2)), int(match.group(3))
    if lines is None or row >= len(lines):
        return ""
    return f" ({_FROM_ZERO}; {path} line {int(lines[row])}, column {column + 1})"


def _time_position(message: str, source: tuple) -> str:
    """`` (log.csv line 12, column 1)`` for an error at a row of the time stamps, else the file they came from."""
    spec, lines, column = source
    match = _TIME_AT_ROW.match(message)
    if match and lines is not None and int(match.group(1)) < len(lines):
        return (f" ({_FROM_ZERO}; {file_path(split_column(spec)[0])} line {int(lines[int(match.group(1))])}, "
                f"column {column + 1})")
    return f" (time from {spec})"


def _load_time(spec: str, sources: dict):
    """``--time FILE[:COLUMN]``: the stamps as an (N,) array; remembers where they came from."""
    table, column = read_column(spec)
    sources["time"] = (spec, table.lines, column)
    return table.data


def _contract_error(command: str, exc: InputError, sources: dict) -> int:
    """Report an error of the dynval contract, worded for the command line."""
    message = (str(exc).replace("pass allow_wide=True", "pass --allow-wide")
               .replace("time_units_checked=False", "--time-units-unchecked"))
    return _error(command, f"{type(exc).__name__}: {message}{_file_position(str(exc), sources)}"
                           f"{_transpose_hint(message)}")


_SHAPES = re.compile(r"^(\w+) and (\w+) must have the same shape, got \((\d+), (\d+)\) and \((\d+), (\d+)\)")


def _transpose_hint(message: str) -> str:
    """When one file's shape is the other's reversed: which one looks transposed (samples are rows)."""
    m = _SHAPES.match(message)
    if not m:
        return ""
    a, b = (int(m.group(3)), int(m.group(4))), (int(m.group(5)), int(m.group(6)))
    if a != b[::-1] or a == b:
        return ""
    name = m.group(1) if a[0] < a[1] else m.group(2)
    return f"; {name} looks transposed (its shape is the other's reversed): samples are rows, save it as (N, m)"


def _report_options(args, sources: dict, meas) -> dict:
    """Load the shared files and collect the shared keywords (FileInputError on a bad file): the
    regressor, then each declared keyword's flag, its file read by its kind."""
    from .report._options import OPTIONS

    options: dict = {"regressor": load_array(args.regressor) if args.regressor else None}
    for o in OPTIONS:
        if o.flag is not None:
            value = getattr(args, o.name)
            load = _LOADERS.get(o.flag.read)
            options[o.name] = load(value, o.name, sources) if load is not None and value else value
    options["joint_names"] = _joint_names(args, meas)
    return options


# The flags whose value names a file: how its array is read (a keyword's ``Flag.read``).
_LOADERS = {
    "file": lambda spec, name, sources: _load(spec, name, sources),
    "time": lambda spec, name, sources: _load_time(spec, sources),
    "estimation": lambda pairs, name, sources: {key: load_array(path) for key, path in pairs},
}


def _stream_options(args) -> tuple[list[str], dict]:
    """The flags a streamed validation refuses (given, and needing the whole series), and the keywords
    of the accumulator from the others (``report._options.OPTIONS``: what the stream supports)."""
    from .report._options import OPTIONS

    flagged = [o for o in OPTIONS if o.flag is not None]
    refused = [o.flag.flag for o in flagged if o.stream.startswith("refused") and getattr(args, o.name) != o.default]
    return refused, {o.name: getattr(args, o.name) for o in flagged if o.stream == "supported"}


def _joint_names(args, meas) -> list[str] | None:
    """--joint-names, else the measured torque's CSV header when it names every column (distinct
    names, one per joint): a logged file's own names beat "joint 1", "joint 2"."""
    if args.joint_names is not None:
        return list(args.joint_names)
    path = file_path(args.meas)
    if not path.lower().endswith((".csv", ".tsv", ".txt")) or split_column(args.meas)[1]:
        return None
    names = csv_header(path)
    width = meas.shape[1] if getattr(meas, "ndim", 0) == 2 else 1
    if not names or len(set(names)) != len(names) or len(names) != width or not all(n.strip() for n in names):
        return None
    return [n.strip() for n in names]


def _emit(command: str, args, text: str) -> int:
    if args.output:
        try:
            with open(args.output, "w", encoding="utf-8") as handle:
                handle.write(text + "\n")
        except OSError as exc:
            return _error(command, f"{args.output}: cannot be written ({exc.strerror or exc})")
        return EXIT_OK
    if sys.stdout is None:  # started with standard output closed: print would drop the report
        return _error(command, "standard output is closed, so the output cannot be written; give --output FILE")
    try:
        print(text)
        sys.stdout.flush()
    except BrokenPipeError:
        raise  # the reader went away: main() ends quietly (141)
    except OSError as exc:  # a full disk, /dev/full, an I/O error
        _discard_stdout()
        return _error(command, f"standard output cannot be written ({exc.strerror or exc})")
    return EXIT_OK


def _write_html(command: str, args, obj, **data) -> int:
    """Write ``--html``; 0 when done or not asked, else the error's exit code."""
    if not args.html:
        return EXIT_OK
    rate = _sample_rate(args, obj)
    problem = None if rate is None else _undrawable_rate(rate, _n_samples(obj))
    if problem:
        return _error(command, f"--html: the sample rate {rate:g} Hz is {problem}; give the rate in another "
                               "time unit")
    try:
        from .html import write_report

        write_report(obj, args.html, sample_rate=_sample_rate(args, obj), **data)
    except ImportError as exc:
        return _error(command, f"--html needs matplotlib (pip install 'dynval[plot]'): {exc}")
    except OSError as exc:
        return _error(command, f"{args.html}: cannot be written ({exc.strerror or exc})")
    return EXIT_OK


# matplotlib's tick arithmetic leaves float64 for axes beyond about 1e±300.
_DRAWABLE = 1e290


def _undrawable_rate(rate: float, n: int) -> str | None:
    """Why the figures cannot be drawn at this rate (their axes in s and Hz), or None."""
    span = n / rate if rate > 0 else math.inf  # the time axis, in s
    step = rate / max(n, 1)  # the spectrum's frequency step, in Hz
    if not span < _DRAWABLE or not step > 1 / _DRAWABLE:
        return f"too small to draw the figures: {n} samples span {span:g} s and the spectrum's step is {step:g} Hz"
    if not rate < _DRAWABLE or not span > 1 / _DRAWABLE:
        return f"too large to draw the figures: {n} samples span {span:g} s"
    return None


def _n_samples(obj) -> int:
    report = obj if hasattr(obj, "provenance") else next(iter(obj.reports.values()))
    return int(report.provenance.get("n_samples", 1))


def _sample_rate(args, obj) -> float | None:
    """--sample-rate, else the rate the report inferred from --time."""
    if args.sample_rate is not None:
        return float(args.sample_rate)
    report = obj if hasattr(obj, "provenance") else next(iter(obj.reports.values()))
    rate = report.provenance.get("sample_rate")
    return None if rate is None else float(rate)


def _declared_shapes_refused(command: str, args, predictions: dict) -> int | None:
    """The files' shapes, from their headers, checked against each other before any array is
    decoded (contract §7): the exit code of a refusal, or None."""
    from .io._shapes import check_declared

    try:
        check_declared(args.meas, predictions, regressor=args.regressor, time=args.time,
                       q=getattr(args, "q", None), n_joints=args.n_joints)
    except FileInputError as exc:
        return _error(command, str(exc))
    except InputError as exc:
        return _contract_error(command, exc, {} if args.time is None else {"time": (args.time, None, 0)})
    return None


def _run_validate(args) -> int:
    from .report._report import validate

    refused = _declared_shapes_refused("validate", args, {"tau_pred": args.pred})
    if refused is not None:
        return refused
    if args.stream or _too_large_for_memory(args):
        return _run_validate_streamed(args)
    sources: dict = {}
    try:
        meas = _load(args.meas, "tau_meas", sources)
        pred = _load(args.pred, "tau_pred", sources)
        options = _report_options(args, sources, meas)
    except FileInputError as exc:
        return _error("validate", str(exc))
    try:
        report = validate(meas, pred, n_params=args.n_params, **options)
    except InputError as exc:
        return _contract_error("validate", exc, sources)
    code = _write_html("validate", args, report, tau_meas=meas, tau_pred=pred)
    return code if code else _emit("validate", args, report.to_json() if args.json else report.summary())


def _too_large_for_memory(args) -> bool:
    """Whether the input arrays, decoded, together exceed a quarter of the machine's memory (the
    size on disk of a compressed or sparse file says nothing about it)."""
    memory = physical_memory()
    if memory is None:
        return False
    total = 0
    for spec in (args.meas, args.pred, args.regressor, args.time and split_column(args.time)[0]):
        if spec:
            try:
                total += decoded_size(spec)
            except (FileInputError, OSError):
                return False  # the loader gives the message
    return total > memory // 4


def _run_validate_streamed(args) -> int:
    from .stream import ValidationAccumulator

    refused, keywords = _stream_options(args)
    if refused:
        args.subparser.error(f"{', '.join(refused)} cannot be used with a streamed validation (--stream, or "
                             "inputs larger than a quarter of memory): they need the whole series")
    rows = DEFAULT_CHUNK_ROWS if args.chunk_rows is None else args.chunk_rows
    if rows < 1:
        args.subparser.error(f"--chunk-rows must be a positive integer, got {rows}")
    try:
        meas, pred = open_rows(args.meas), open_rows(args.pred)
        reg = open_rows(args.regressor) if args.regressor else None
        stamps = open_column(args.time) if args.time else None
        q = open_rows(args.q) if args.q else None
    except FileInputError as exc:
        return _error("validate", str(exc))
    if meas.shape != pred.shape:
        message = f"tau_meas and tau_pred must have the same shape, got {meas.shape} and {pred.shape}"
        return _error("validate", f"ShapeMismatch: {message}{_transpose_hint(message)}")
    n = meas.n_rows
    if stamps is not None and stamps.n_rows != n:
        return _error("validate", f"ShapeMismatch: time must have one stamp per sample, shape ({n},), got "
                                  f"({stamps.n_rows},) (time from {args.time})")
    if q is not None and q.shape != meas.shape:
        return _error("validate", f"ShapeMismatch: q must have the shape of tau_meas, {meas.shape}, got {q.shape} "
                                  f"(q from {args.q})")
    # a stacked (N·m, p) regressor gives m rows per sample
    per_sample = 1 if reg is None or reg.n_rows == n else max(reg.n_rows // max(n, 1), 1)
    if reg is not None and reg.n_rows != n * per_sample:
        return _error("validate", f"ShapeMismatch: regressor must have N={n} rows (or N*m stacked), got shape "
                                  f"{reg.shape}")
    try:
        acc = ValidationAccumulator(n_params=args.n_params, **keywords)
        show = sys.stderr.isatty() if args.progress is None else args.progress
        from tqdm import tqdm  # type: ignore[import-untyped]

        blocks = zip(meas.chunks(rows), pred.chunks(rows),
                     reg.chunks(rows * per_sample) if reg is not None else iter(lambda: None, 0),
                     stamps.chunks(rows) if stamps is not None else iter(lambda: None, 0),
                     q.chunks(rows) if q is not None else iter(lambda: None, 0))
        with tqdm(total=n, unit=" rows", unit_scale=True, disable=not show, file=sys.stderr,
                  delay=0.0 if args.progress else 2.0, desc="dynval validate") as bar:
            for m_block, p_block, y_block, t_block, q_block in blocks:
                acc.update(m_block, p_block, y_block, time=t_block, q=q_block)
                bar.update(m_block.shape[0])
        acc._entry = "cli_stream"  # the tests it leaves out are the command line's (dynval.coverage)
        report = acc.result()
    except FileInputError as exc:
        return _error("validate", str(exc))
    except InputError as exc:
        return _contract_error("validate", exc, {} if args.time is None else {"time": (args.time, None, 0)})
    if args.html:
        return _error("validate", "--html needs the whole series; it is not available with a streamed validation")
    text = report.to_json() if args.json else report.summary()
    if not args.json:
        text += (f"\n\nStreamed from the files in blocks of {rows} rows: the tests a stream leaves out are listed "
                 "under the findings, \"not tested\" (contract §4.1).")
    return _emit("validate", args, text)


def _run_compare(args) -> int:
    from .comparison._compare import compare

    names = [name for name, _, _ in args.model]
    if len(set(names)) != len(names):
        return _error("compare", f"candidate names must be distinct, got {names}")
    columns = dict(args.model_columns)
    unknown = [n for n in columns if n not in names]
    if unknown:
        args.subparser.error(f"--model-columns names {format_value(unknown[0])}, which is not a --model "
                             f"(candidates: {names})")
    if columns and not args.regressor:
        args.subparser.error("--model-columns needs --regressor: the columns are the regressor's")
    refused = _declared_shapes_refused("compare", args, {name: path for name, path, _ in args.model})
    if refused is not None:
        return refused
    sources: dict = {}
    try:
        meas = _load(args.meas, "tau_meas", sources)
        # Each candidate's prediction is tau_pred in turn: its errors are not located in a file.
        candidates = {name: {"prediction": load_array(path), "n_params": p,
                             **({"model_columns": columns[name]} if name in columns else {})}
                      for name, path, p in args.model}
        options = _report_options(args, sources, meas)
    except FileInputError as exc:
        return _error("compare", str(exc))
    regressor = options.pop("regressor")
    try:
        cmp = compare(meas, candidates, criterion=args.criterion, regressor=regressor, **options)
    except InputError as exc:
        return _contract_error("compare", exc, sources)
    preds = {n: c["prediction"] for n, c in candidates.items()}
    code = _write_html("compare", args, cmp, tau_meas=meas, tau_pred=preds)
    return code if code else _emit("compare", args, cmp.to_json() if args.json else cmp.summary())


def _run_validate_many(args) -> int:
    from .fleet import validate_many

    keywords = {k: v for k, v in (("max_lag", args.max_lag), ("sample_rate", args.sample_rate)) if v is not None}
    try:
        scheduler = _fleet_scheduler(args)
        try:
            fleet = validate_many(args.logs, n_params=args.n_params, scheduler=scheduler, progress=args.progress,
                                  level=args.level, profile=args.profile, min_baseline=args.min_baseline,
                                  n_permutations=args.permutations, **keywords)
        finally:
            if hasattr(scheduler, "close"):  # the local cluster of --workers
                scheduler.close()
    except InputError as exc:
        return _error("validate-many", f"{type(exc).__name__}: {exc}" if not isinstance(exc, FileInputError)
                      else str(exc))
    except ImportError as exc:
        return _error("validate-many", str(exc))
    code = _write_fleet_html(args, fleet)
    code = code or _emit("validate-many", args, fleet.to_json() if args.json else fleet.summary())
    return code or (EXIT_INPUT if any(row.error for row in fleet.logs) else EXIT_OK)


def _fleet_scheduler(args):
    """--workers: a local cluster of that many processes; --scheduler: its address; else this process."""
    if args.scheduler:
        return args.scheduler
    if args.workers is None:
        return "single"
    from .fleet import local_cluster

    try:
        return local_cluster(args.workers)
    except ImportError:
        raise ImportError("--workers needs dask.distributed: pip install 'dynval[dask]'") from None


def _write_fleet_html(args, fleet) -> int:
    if not args.html:
        return EXIT_OK
    try:
        from .html import write_fleet_report

        write_fleet_report(fleet, args.html)
    except ImportError as exc:
        return _error("validate-many", f"--html needs matplotlib (pip install 'dynval[plot]'): {exc}")
    except OSError as exc:
        return _error("validate-many", f"{args.html}: cannot be written ({exc.strerror or exc})")
    return EXIT_OK


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``dynval`` command line; returns the exit code.

    No traceback reaches the user: a closed output pipe ends quietly (141), Ctrl-C gives 130,
    running out of memory is an input error (1) and anything else is reported as an internal
    error (3; ``DYNVAL_TRACEBACK=1`` shows the traceback).

    Examples
    --------
    >>> main(["--version"])  # doctest: +SKIP
    dynval 0.1.0
    """
    from ._startup import restore

    restore()  # from here on, Ctrl-C is a KeyboardInterrupt caught below
    argv = list(sys.argv[1:] if argv is None else argv)
    command = argv[0] if argv and argv[0] in ("validate", "compare", "validate-many", "validate-log", "demo",
                                              "conform") else None
    prefix = f"dynval {command}" if command else "dynval"
    try:
        return _flush_stdout(prefix, _dispatch(argv))  # a closed pipe shows here for buffered output
    except BrokenPipeError:
        _discard_stdout()
        return EXIT_BROKEN_PIPE
    except KeyboardInterrupt:
        print(f"{prefix}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except MemoryError:
        print(f"{prefix}: error: not enough memory for this input", file=sys.stderr)
        return EXIT_INPUT
    except OSError as exc:
        if exc.errno not in _WRITE_FAILURES:
            return _internal_error(prefix, exc)
        # A full disk or /dev/full in the middle of a command's output (the demo prints and writes
        # figures as it goes): the user's environment, not a bug.
        _discard_stdout()  # else Python's own flush at exit fails again, with a traceback
        where = f" {exc.filename}" if exc.filename else ""
        print(f"{prefix}: error: cannot write the output{where} ({exc.strerror or exc})", file=sys.stderr)
        return EXIT_INPUT
    except Exception as exc:
        return _internal_error(prefix, exc)


_WRITE_FAILURES = frozenset(getattr(errno, name) for name in ("ENOSPC", "EDQUOT", "EIO", "EROFS", "EFBIG")
                            if hasattr(errno, name))


def _internal_error(prefix: str, exc: Exception) -> int:
    if os.environ.get("DYNVAL_TRACEBACK"):
        raise exc
    print(f"{prefix}: internal error: {type(exc).__name__}: {exc} (please report it; "
          "DYNVAL_TRACEBACK=1 shows the traceback)", file=sys.stderr)
    return EXIT_INTERNAL


def _flush_stdout(prefix: str, code: int) -> int:
    """Flush standard output (help text and reports are buffered): a full disk or ``/dev/full``
    is an error on stderr (exit 1); a closed pipe propagates (141)."""
    if sys.stdout is None:
        return code
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        raise
    except OSError as exc:
        _discard_stdout()  # else Python's own flush at exit fails again, with a traceback
        print(f"{prefix}: error: standard output cannot be written ({exc.strerror or exc})", file=sys.stderr)
        return EXIT_INPUT
    return code


def _discard_stdout() -> None:
    """After EPIPE, send what is left of standard output to devnull.

    Python flushes stdout at exit; without this the flush fails again and prints a traceback.
    """
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # stdout replaced by an object without a descriptor
        pass


def _dispatch(argv: list) -> int:
    if argv and argv[0] == "conform":
        # The conformance runner parses its own arguments.
        from .conform import main as conform_main

        return int(conform_main(argv[1:]) or 0)
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        if args.command in ("validate", "compare"):
            _check_combinations(args)
    except SystemExit as exc:  # argparse: --help/--version (0) or a usage error (2)
        return int(exc.code) if isinstance(exc.code, int) else EXIT_USAGE
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    if args.command == "validate":
        return _run_validate(args)
    if args.command == "compare":
        return _run_compare(args)
    if args.command == "validate-many":
        return _run_validate_many(args)
    if args.command == "validate-log":
        from ._logcli import run_validate_log

        return run_validate_log(args, _error, _emit, _write_html)
    if args.command == "demo":
        from .demo import run_from_args

        try:
            return run_from_args(args)
        except InputError as exc:
            return _error("demo", f"{type(exc).__name__}: {exc}")
    parser.error(f"unknown command {args.command!r}")  # pragma: no cover
    return EXIT_USAGE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
