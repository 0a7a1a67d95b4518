"""The ``dynval`` command line.

Subcommands:

* ``dynval validate MEAS PRED --n-params P [...]`` — validate predicted torques against
  measured ones from .npy, .npz or .csv files and print the report (text or JSON);
* ``dynval compare MEAS --model NAME=PRED:P [--model ...]`` — candidate models side by side,
  a ranking and the decision (accept, refine, redesign);
* ``dynval demo`` — the embedded demonstration (a simulated 2-DOF arm), no input needed;
* ``dynval conform`` — the conformance runner for ports (see ``dynval conform --help``).

Exit codes: 0 success, 1 input error (bad file, or an error of the dynval contract, with the
message on stderr), 2 usage error.
"""

from __future__ import annotations

import argparse
import csv
import io
import os
import sys

import numpy as np

from ._errors import InputError
from ._profiles import PROFILE_NAMES

__all__ = ["main", "load_array", "build_parser"]

EXIT_OK, EXIT_INPUT, EXIT_USAGE = 0, 1, 2


class FileInputError(Exception):
    """A data file cannot be read as a numeric array (exit code 1)."""


# --------------------------------------------------------------------------- loading


def _split_key(spec: str):
    """``file.npz:key`` → (``file.npz``, ``key``); anything else → (spec, None)."""
    head, sep, tail = spec.rpartition(":")
    if sep and head.lower().endswith(".npz") and tail and not os.path.exists(spec):
        return head, tail
    return spec, None


def _load_npy(path: str) -> np.ndarray:
    try:
        return np.load(path, allow_pickle=False)
    except ValueError as exc:
        if "allow_pickle" in str(exc) or "pickle" in str(exc).lower():
            raise FileInputError(f"{path}: holds pickled Python objects, which dynval refuses to load; "
                                 "save a plain numeric array (numpy.save of a float array)") from None
        raise FileInputError(f"{path}: not a readable .npy file ({exc})") from None


def _load_npz(path: str, key: str | None) -> np.ndarray:
    try:
        with np.load(path, allow_pickle=False) as archive:
            names = list(archive.files)
            if not names:
                raise FileInputError(f"{path}: the archive holds no array")
            if key is None:
                key = names[0]
            elif key not in names:
                raise FileInputError(f"{path}: no array named {key!r}; the archive holds "
                                     + ", ".join(repr(n) for n in names))
            return archive[key]
    except ValueError as exc:
        if "pickle" in str(exc).lower():
            raise FileInputError(f"{path}: array {key!r} holds pickled Python objects, which dynval "
                                 "refuses to load; save plain numeric arrays") from None
        raise FileInputError(f"{path}: not a readable .npz file ({exc})") from None


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _load_csv(path: str) -> np.ndarray:
    with open(path, newline="", encoding="utf-8-sig") as handle:
        text = handle.read()
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise FileInputError(f"{path}: no data rows")
    sample = "\n".join(lines[:20])
    try:
        delimiter = csv.Sniffer().sniff(sample, delimiters=",;\t ").delimiter
    except csv.Error:
        delimiter = ","  # one column: no delimiter to find
    reader = csv.reader(io.StringIO("\n".join(lines)), delimiter=delimiter, skipinitialspace=True)
    rows = [[cell.strip() for cell in row if cell.strip() != ""] for row in reader]
    rows = [r for r in rows if r]
    if rows and not all(_is_number(c) for c in rows[0]):
        rows = rows[1:]  # a header row
    if not rows:
        raise FileInputError(f"{path}: no data rows after the header")
    width = len(rows[0])
    for i, row in enumerate(rows):
        if len(row) != width:
            raise FileInputError(f"{path}: data row {i + 1} has {len(row)} values, the first has {width}")
        for cell in row:
            if not _is_number(cell):
                raise FileInputError(f"{path}: data row {i + 1} holds a non-numeric value {cell!r}")
    data = np.array([[float(c) for c in row] for row in rows], dtype=np.float64)
    return data[:, 0] if width == 1 else data


def load_array(spec: str) -> np.ndarray:
    """Load one numeric array from ``.npy``, ``.npz`` (``file.npz:key``, else the first array)
    or ``.csv`` (delimiter sniffed, one header row allowed).

    Pickled objects are refused. Raises :class:`FileInputError` with a message naming the file.

    Examples
    --------
    >>> import numpy as np, tempfile, os
    >>> path = os.path.join(tempfile.mkdtemp(), "tau.csv")
    >>> with open(path, "w") as handle:
    ...     _ = handle.write("j1,j2\\n1,2\\n3,4\\n")
    >>> load_array(path).tolist()
    [[1.0, 2.0], [3.0, 4.0]]
    """
    path, key = _split_key(spec)
    lower = path.lower()
    if lower.endswith((".pkl", ".pickle")):
        raise FileInputError(f"{path}: pickle files are refused (they can run arbitrary code); "
                             "use .npy, .npz or .csv")
    if not os.path.exists(path):
        raise FileInputError(f"{path}: no such file")
    if os.path.isdir(path):
        raise FileInputError(f"{path}: is a directory, not a data file")
    try:
        if lower.endswith(".npy"):
            return _load_npy(path)
        if lower.endswith(".npz"):
            return _load_npz(path, key)
        if lower.endswith((".csv", ".txt", ".tsv")):
            return _load_csv(path)
    except OSError as exc:
        raise FileInputError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise FileInputError(f"{path}: not a text file") from None
    raise FileInputError(f"{path}: unsupported file type; use .npy, .npz (file.npz:key) or .csv")


# --------------------------------------------------------------------------- parser


def _segments_arg(text: str):
    try:
        values = [int(v) for v in text.replace(";", ",").split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated integers (lengths 500,300 or starts 0,500), got {text!r}") from None
    if not values:
        raise argparse.ArgumentTypeError("expected at least one integer")
    return values


def build_parser() -> argparse.ArgumentParser:
    """The ``dynval`` argument parser (subcommands validate, compare, demo, conform)."""
    from . import __version__

    parser = argparse.ArgumentParser(
        prog="dynval",
        description="Validation metrics for identified robot dynamic models (tau = Y pi + e): "
                    "RMSE, VAF, fit, R², residual whiteness, regressor cross-correlation, AIC/BIC.",
        epilog="Exit codes: 0 success, 1 input error, 2 usage error.")
    parser.add_argument("--version", action="version", version=f"dynval {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="{validate,compare,demo,conform}")

    val = sub.add_parser(
        "validate", help="validate predicted torques against measured ones",
        description="Validate predicted joint torques against measured ones and print the report. "
                    "Files: .npy, .npz (file.npz:key, else the first array) or .csv (delimiter "
                    "sniffed, one header row allowed); pickles are refused.",
        epilog="Exit codes: 0 success, 1 input error (message on stderr), 2 usage error.")
    val.add_argument("meas", metavar="MEAS", help="measured torques, (N,) or (N, m)")
    val.add_argument("pred", metavar="PRED", help="predicted torques, same shape as MEAS")
    val.add_argument("--n-params", type=int, required=True, metavar="P",
                     help="number of identified parameters (required: there is no default)")
    _add_report_options(val)

    cmp = sub.add_parser(
        "compare", help="compare candidate models: table, ranking and decision",
        description="Validate several candidate models on the same measured torques, rank them "
                    "(no deficiency first, then by the criterion) and give the decision of the lesson's "
                    "flowchart: accept, refine (which term, from which evidence) or redesign the experiment.",
        epilog="Example: dynval compare tau.npy --model rigid=rigid.npy:10 --model friction=fric.npy:14 "
               "--regressor Y_full.npy --sample-rate 200 --estimation q=q_est.npy --q q_val.npy. "
               "Exit codes: 0 success, 1 input error (message on stderr), 2 usage error.")
    cmp.add_argument("meas", metavar="MEAS", help="measured torques of the validation run, (N,) or (N, m)")
    cmp.add_argument("--model", action="append", required=True, metavar="NAME=PRED:P", type=_model_arg,
                     help="a candidate: its name, its predicted torques (file) and its number of parameters "
                          "(repeat for each candidate)")
    cmp.add_argument("--criterion", default="aic", choices=("aic", "bic", "aicc", "aic_neff", "bic_neff", "aicc_neff"),
                     help="criterion of the ranking and the Akaike weights (default aic, the lesson's)")
    _add_report_options(cmp)

    demo = sub.add_parser("demo", help="simulate, identify and validate a 2-DOF arm (no input needed)")
    from .demo import build_parser as build_demo_parser

    build_demo_parser(demo)
    demo.epilog = "Exit codes: 0 success, 2 usage error."

    sub.add_parser("conform", help="run the conformance corpus against a port (see dynval conform --help)",
                   add_help=False)
    return parser


def _model_arg(text: str):
    name, sep, rest = text.partition("=")
    path, sep2, p = rest.rpartition(":")
    if not (sep and sep2 and name and path):
        raise argparse.ArgumentTypeError(f"expected NAME=PRED_FILE:P, e.g. friction=pred.npy:14, got {text!r}")
    try:
        return name, path, int(p)
    except ValueError:
        raise argparse.ArgumentTypeError(f"the number of parameters after ':' must be an integer, got {p!r}") from None


def _key_file_arg(text: str):
    key, sep, path = text.partition("=")
    if not sep or key not in ("q", "regressor", "tau") or not path:
        raise argparse.ArgumentTypeError(f"expected q=FILE, regressor=FILE or tau=FILE, got {text!r}")
    return key, path


def _names_arg(text: str):
    return [x.strip() for x in text.split(",")]


def _decimate_arg(text: str):
    if text in ("auto", "none"):
        return None if text == "none" else "auto"
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected auto, none or an integer >= 1, got {text!r}") from None


def _add_report_options(sub) -> None:
    """The options ``validate`` and ``compare`` share."""
    sub.add_argument("--regressor", metavar="Y",
                     help="regressor of the validation data, (N, m, p), or (N*m, p) with --n-joints")
    sub.add_argument("--n-joints", type=int, metavar="M", help="joints m of a stacked 2-D regressor")
    sub.add_argument("--max-lag", type=int, metavar="L",
                     help="largest lag of the residual analysis (default: the profile's; 0 skips it)")
    sub.add_argument("--level", type=float, metavar="X",
                     help="confidence level of bands and findings, 0 < X < 1 (default: the profile's)")
    sub.add_argument("--profile", default="lesson", choices=PROFILE_NAMES,
                     help="convention profile (default lesson)")
    sub.add_argument("--segments", type=_segments_arg, metavar="S",
                     help="independent records: lengths (500,300) or starts (0,500)")
    sub.add_argument("--nan-policy", default="raise", choices=("raise", "omit"),
                     help="raise on NaN/inf, or omit those rows (default raise)")
    sub.add_argument("--noise-model", choices=("pooled", "per_joint", "full"),
                     help="noise model of the information criteria (default: the profile's)")
    sub.add_argument("--sample-rate", type=float, metavar="HZ", help="samples per second (frequencies in Hz)")
    sub.add_argument("--decimate", type=_decimate_arg, default="auto", metavar="Q",
                     help="whiteness at the information rate: auto (default), none, or a factor")
    sub.add_argument("--joint-names", type=_names_arg, metavar="A,B,..", help="joint names, comma-separated")
    sub.add_argument("--column-names", type=_names_arg, metavar="A,B,..",
                     help="regressor column names, comma-separated")
    sub.add_argument("--q", metavar="FILE", help="joint positions of the validation run (N, m)")
    sub.add_argument("--estimation", action="append", type=_key_file_arg, metavar="KEY=FILE",
                     help="the estimation run (repeatable): q=FILE, regressor=FILE, tau=FILE")
    sub.add_argument("--backend", default=None, help="computation backend: python or cpp")
    sub.add_argument("--json", action="store_true", help="print the report as JSON")
    sub.add_argument("--output", metavar="FILE", help="write the output to FILE instead of stdout")
    sub.add_argument("--html", metavar="FILE",
                     help="also write a self-contained HTML report with figures (needs dynval[plot])")


# --------------------------------------------------------------------------- commands


def _error(command: str, message: str) -> int:
    print(f"dynval {command}: error: {message}", file=sys.stderr)
    return EXIT_INPUT


def _report_options(args) -> dict:
    """Load the shared files and collect the shared keywords (FileInputError on a bad file)."""
    est = None
    if args.estimation:
        est = {key: load_array(path) for key, path in args.estimation}
    return dict(regressor=load_array(args.regressor) if args.regressor else None, n_joints=args.n_joints,
                max_lag=args.max_lag, level=args.level, profile=args.profile, segments=args.segments,
                nan_policy=args.nan_policy, backend=args.backend, noise_model=args.noise_model,
                sample_rate=args.sample_rate, decimate=args.decimate, joint_names=args.joint_names,
                column_names=args.column_names, q=load_array(args.q) if args.q else None, estimation=est)


def _emit(command: str, args, text: str) -> int:
    if args.output:
        try:
            with open(args.output, "w", encoding="utf-8") as handle:
                handle.write(text + "\n")
        except OSError as exc:
            return _error(command, f"{args.output}: cannot be written ({exc.strerror or exc})")
    else:
        print(text)
    return EXIT_OK


def _write_html(command: str, args, obj, **data) -> int:
    """Write ``--html``; 0 when done or not asked, else the error's exit code."""
    if not args.html:
        return EXIT_OK
    try:
        from .html import write_report

        write_report(obj, args.html, sample_rate=args.sample_rate, **data)
    except ImportError as exc:
        return _error(command, f"--html needs matplotlib (pip install 'dynval[plot]'): {exc}")
    except OSError as exc:
        return _error(command, f"{args.html}: cannot be written ({exc.strerror or exc})")
    return EXIT_OK


def _run_validate(args) -> int:
    from ._report import validate

    try:
        meas = load_array(args.meas)
        pred = load_array(args.pred)
        options = _report_options(args)
    except FileInputError as exc:
        return _error("validate", str(exc))
    try:
        report = validate(meas, pred, n_params=args.n_params, **options)
    except InputError as exc:
        return _error("validate", f"{type(exc).__name__}: {exc}")
    code = _write_html("validate", args, report, tau_meas=meas, tau_pred=pred)
    return code if code else _emit("validate", args, report.to_json() if args.json else report.summary())


def _run_compare(args) -> int:
    from ._compare import compare

    names = [name for name, _, _ in args.model]
    if len(set(names)) != len(names):
        return _error("compare", f"candidate names must be distinct, got {names}")
    try:
        meas = load_array(args.meas)
        candidates = {name: (load_array(path), p) for name, path, p in args.model}
        options = _report_options(args)
    except FileInputError as exc:
        return _error("compare", str(exc))
    regressor = options.pop("regressor")
    try:
        cmp = compare(meas, candidates, criterion=args.criterion, regressor=regressor, **options)
    except InputError as exc:
        return _error("compare", f"{type(exc).__name__}: {exc}")
    code = _write_html("compare", args, cmp, tau_meas=meas, tau_pred={n: c[0] for n, c in candidates.items()})
    return code if code else _emit("compare", args, cmp.to_json() if args.json else cmp.summary())


def main(argv=None) -> int:
    """Run the ``dynval`` command line; returns the exit code.

    Examples
    --------
    >>> main(["--version"])  # doctest: +SKIP
    dynval 0.1.0
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "conform":
        # The conformance runner parses its own arguments.
        from .conform import main as conform_main

        return int(conform_main(argv[1:]) or 0)
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help/--version (0) or a usage error (2)
        return int(exc.code) if isinstance(exc.code, int) else EXIT_USAGE
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    if args.command == "validate":
        return _run_validate(args)
    if args.command == "compare":
        return _run_compare(args)
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
