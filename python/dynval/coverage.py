"""Which tests each entry point runs: the one declaration behind a report's "not tested" line and
the table of docs/contract.md §4.1.

Every way into dynval ends in the same findings (docs/conventions.md §5), but not every way can
compute every test: a stream keeps sums of bounded size, a fleet's log has the files its manifest
row names. :data:`TESTS`
lists the tests of a report (what each needs from the caller in :func:`dynval.validate`, and the
finding kinds it can give); :data:`NOT_RUN` says, per entry point, which of them it leaves out and
why. A streamed report names what it left out in its findings' closing line and in
``provenance["not_tested"]`` (:func:`not_tested`); ``python -m dynval.coverage`` prints the table
(:func:`table`; ``--write docs/contract.md`` puts it there), and tests/test_entry_points.py checks
both against what the entry points find.

Examples
--------
>>> from dynval.coverage import not_tested
>>> [t["test"] for t in not_tested("stream", {"lags"})]
['information_rate', 'prediction_artefact']
>>> [t["test"] for t in not_tested("stream", {"lags", "regressor"})]
['information_rate', 'spectrum', 'prediction_artefact', 'regressor_correlation', 'excitation']
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from dataclasses import dataclass, replace

from .report.kinds import KINDS as _DECLARED_KINDS
from .streaming._welch import OFF_GRID  # why a merged stream has no spectrum, as dask's blocks are merged

__all__ = ["Test", "TESTS", "INPUTS", "ENTRY_POINTS", "CAVEATS", "NOT_RUN", "NOT_RUN_WITH", "OFF_GRID", "RUNTIME",
           "not_tested", "excused_kinds", "runs", "table", "write_table"]


@dataclass(frozen=True)
class Test:
    """One test of a report: its ``name``, the finding ``kinds`` it can give, the inputs it
    ``needs`` (names from :data:`INPUTS`, all of them) and what it tests (``what``)."""

    name: str
    kinds: tuple[str, ...]
    needs: tuple[str, ...]
    what: str


INPUTS = {
    "lags": "max_lag > 0 (the default)",
    "regressor": "regressor=",
    "model_columns": "model_columns=",
    "q": "q=",
    "estimation": "estimation=",
    "time": "time=",
}
"""What a caller gives that a test needs, and how it is given to :func:`dynval.validate`."""

_LISTED_TESTS: tuple[Test, ...] = (
    Test("worse_than_constant", ("worse_than_constant", "pooling"), (), "R² per joint and pooled"),
    Test("data_notes", ("constant_target", "omitted_rows", "information_criteria"), (),
         "constant joints, omitted rows, n_params against the observations"),
    Test("bias", ("bias",), ("lags",), "residual mean against its coloured-noise standard error"),
    Test("whiteness", ("whiteness",), ("lags",), "Ljung–Box at the logged rate"),
    Test("information_rate", ("sampling_colour",), ("lags",),
         "whiteness at the information rate (decimated), when the data are oversampled"),
    Test("spectrum", ("oscillation",), ("lags",), "narrow peaks of the residual's Welch spectrum"),
    Test("prediction_artefact", ("prediction_artefact",), ("lags",),
         "a residual line the prediction holds more of than the measured torque: the model's own"),
    Test("regressor_correlation", ("regressor_correlation",), ("regressor",),
         "residual × regressor columns against a colour-aware band"),
    Test("missing_term", ("regressor_correlation",), ("regressor", "model_columns"),
         "the columns the model lacks (added variable)"),
    Test("excitation", ("excitation",), ("regressor",), "the validation regressor's excitation"),
    Test("missing_physics", ("missing_physics",), ("q",), "the residual against the library of physical terms"),
    Test("delay", ("delay",), ("q",), "measured against predicted torque shifted in time"),
    Test("periodic_error", ("periodic_error",), ("q",), "what every period of a periodic trajectory shares"),
    Test("low_information", ("low_information",), ("q",), "the smallest term the run can detect"),
    Test("predictive_failure", ("predictive_failure",), ("regressor", "estimation"),
         "validation error against the estimation run's noise and Cov(π̂)"),
    Test("repeat_trajectory", ("repeat_trajectory",), ("estimation",), "the validation run repeats the estimation run"),
    Test("time_stamps", ("time_stamps",), ("time",), "the time stamps' grid"),
)
"""The tests, with the kinds listed here."""


def _with_declared_kinds(tests: tuple[Test, ...]) -> tuple[Test, ...]:
    """The tests with the kinds whose modules (``report/kinds/``) name them (``Kind.test``) added."""
    added: dict[str, list[str]] = {}
    for kind in _DECLARED_KINDS.values():
        if kind.test is not None:
            added.setdefault(kind.test, []).append(kind.name)
    return tuple(replace(t, kinds=t.kinds + tuple(k for k in added.get(t.name, ()) if k not in t.kinds))
                 for t in tests)


TESTS = _with_declared_kinds(_LISTED_TESTS)
"""Every test of a report, in the order of the findings' rules."""

ENTRY_POINTS = {
    "validate": "dynval.validate",
    "compare": "dynval.compare (one candidate)",
    "stream": "dynval.stream.ValidationAccumulator",
    "cli_stream": "dynval validate --stream",
    "fleet": "dynval.fleet.validate_many",
    "dask": "dynval.dask.validate",
}
"""The entry points, by the key :data:`NOT_RUN` and :func:`not_tested` use, and how they are called."""

_WHOLE = "needs the whole series"
RUNTIME = ("bias", "spectrum")
"""Tests a stream may leave out for a reason of its data, named with that reason in ``extra`` of
:func:`not_tested`: the bias test's bandwidth beyond the lags held, a merge off the Welch grid."""
_STREAMED = {
    "information_rate": f"the decimation filter {_WHOLE}; whiteness is tested at the logged rate, where the "
                        "sensor's and its filters' colour counts too",
    "regressor_correlation": "the colour-aware band needs each regressor column's autocorrelation, "
                             "which the streamed sums do not keep (the ρ are reported against the white band)",
    "missing_term": f"model_columns is refused: the added-variable fit {_WHOLE}",
    "prediction_artefact": "the measured and the predicted torque's own spectra are not kept by the streamed sums",
    "excitation": f"the regressor's conditioning {_WHOLE}",
    "delay": f"the realignment {_WHOLE}",
    "periodic_error": f"finding the periods {_WHOLE}",
    "predictive_failure": f"estimation is refused: the refit {_WHOLE}",
    "repeat_trajectory": f"estimation is refused: the distance to its trajectory {_WHOLE}",
}

_MERGED_PHYSICS = {
    "missing_physics": "q is refused: the physics sums of two blocks do not merge (each fixes its prewhitening "
                       "filter on its own first rows)",
    "low_information": "q is refused: the noise's N_eff comes from the library fit",
}
_STREAM_PHYSICS = ("q, dq, ddq with each chunk: the prewhitening filter, the Coulomb velocity scale and N_eff/N fixed "
                   "on the first 40,000 rows, every row tested (validate decimates past 40,000 rows), past 40,000 rows "
                   "the HC1 meat weighted by the residual of the first rows' fit; no naming refit, relation to the "
                   "model's columns or cross-fitted share (conventions §5.2)")
_STREAM_BIAS = ("from the lag sums the stream keeps (contract §4.1); left out, and named, when its bandwidth needs "
                "more lags than the stream holds")
_STREAM_WHITENESS = "at the logged rate only (no decimation)"
_MANIFEST = ("from the files the log's manifest row names (regressor, q, dq, ddq, timestamps, estimation_tau, "
             "estimation_regressor, estimation_q; contract §10)")
_FLEET_WIDE = "model_columns= for every log of the fleet"
CAVEATS: Mapping[str, Mapping[str, str]] = {
    "fleet": {"missing_term": _FLEET_WIDE,
              **{t: _MANIFEST for t in ("regressor_correlation", "excitation", "missing_physics", "delay",
                                        "periodic_error", "low_information", "predictive_failure", "repeat_trajectory",
                                        "time_stamps")}},
    "stream": {"bias": _STREAM_BIAS, "whiteness": _STREAM_WHITENESS, "missing_physics": _STREAM_PHYSICS,
               "low_information": "from the streamed physics test's N_eff"},
    "cli_stream": {"bias": _STREAM_BIAS, "whiteness": _STREAM_WHITENESS, "missing_physics": _STREAM_PHYSICS,
                   "low_information": "from the streamed physics test's N_eff"},
    "dask": {"bias": _STREAM_BIAS, "whiteness": _STREAM_WHITENESS,
             "spectrum": "within one block only: blocks merged without a break between them lose the windows "
                         "across the junction, and the report then names the spectrum as not tested"},
}
"""Per entry point, how a test it runs differs from ``validate``'s (a "yes" with a note in the table)."""

NOT_RUN: Mapping[str, Mapping[str, str]] = {
    "validate": {},
    "compare": {},
    "stream": _STREAMED,
    "cli_stream": {**_STREAMED, "missing_term": "--model-columns is not an option of dynval validate"},
    "fleet": {},
    "dask": {**_STREAMED, **_MERGED_PHYSICS},
}
"""Per entry point, the tests of :data:`TESTS` it does not run, with the reason."""

_PROJECTED = ("with a regressor, the spectrum is that of the residual less its projection on the regressor, which "
              f"{_WHOLE}")
NOT_RUN_WITH: Mapping[str, Mapping[str, tuple[str, str]]] = {
    "stream": {"spectrum": ("regressor", _PROJECTED)},
    "cli_stream": {"spectrum": ("regressor", _PROJECTED)},
    "dask": {"spectrum": ("regressor", _PROJECTED)},
}
"""Per entry point, tests it runs but not when an input of :data:`INPUTS` is given: ``(input, why)``."""


def runs(entry: str, test: str, given: Collection[str] = ()) -> bool:
    """Whether ``entry`` (a key of :data:`ENTRY_POINTS`) runs ``test`` when given what it needs
    and the inputs ``given``."""
    unless = NOT_RUN_WITH.get(entry, {}).get(test)
    return test not in NOT_RUN[entry] and not (unless is not None and unless[0] in given)


def not_tested(entry: str, given: Collection[str], extra: Mapping[str, str] | None = None) -> list[dict[str, object]]:
    """The tests ``validate`` would run on the inputs ``given`` (names of :data:`INPUTS`) that
    ``entry`` leaves out, each as ``{"test", "kinds", "why"}``, in the order of :data:`TESTS`;
    ``extra`` adds tests left out for a reason of the data (a bandwidth beyond the lags a stream
    holds), by name."""
    extra = dict(extra or {})
    out: list[dict[str, object]] = []
    for t in TESTS:
        unless = NOT_RUN_WITH.get(entry, {}).get(t.name)
        declared = NOT_RUN[entry].get(t.name) or (unless[1] if unless is not None and unless[0] in given else None)
        why = extra.pop(t.name, None) or (declared if set(t.needs) <= set(given) else None)
        if why:
            out.append({"test": t.name, "kinds": list(t.kinds), "why": why})
    assert not extra, f"unknown tests {sorted(extra)}"
    return out


def excused_kinds(entry: str, given: Collection[str], decimated: bool = False) -> set[str]:
    """The finding kinds in which ``entry``'s report may differ from ``validate``'s on the same
    inputs: those of the tests it leaves out, and ``whiteness`` when ``validate`` decimated
    (``decimated``: its whiteness test is then at the information rate, a different test from the
    logged rate's that an entry point without ``information_rate`` runs)."""
    kinds = {k for t in not_tested(entry, given) for k in t["kinds"]}  # type: ignore[attr-defined]
    if decimated and not runs(entry, "information_rate", given):
        kinds.add("whiteness")
    return kinds


def table() -> str:
    """The Markdown table of docs/contract.md §4.1: one row per test, one column per entry point
    ("yes", or "no" and the reason's number; a "yes" with a note has the note's number; the reasons
    and notes listed below the table)."""
    keys = list(ENTRY_POINTS)
    reasons: list[str] = []

    def numbered(text: str) -> int:
        if text not in reasons:
            reasons.append(text)
        return reasons.index(text) + 1

    head = "| test | needs | finding kinds | " + " | ".join(f"`{ENTRY_POINTS[k]}`" for k in keys) + " |"
    lines = [head, "|" + " --- |" * (3 + len(keys))]
    for t in TESTS:
        cells = []
        for k in keys:
            why, note = NOT_RUN[k].get(t.name), CAVEATS.get(k, {}).get(t.name)
            unless = NOT_RUN_WITH.get(k, {}).get(t.name)
            if why is not None:
                cells.append(f"no ({numbered(why)})")
                continue
            cell = "yes" if note is None else f"yes ({numbered(note)})"
            if unless is not None:
                cell += f"; with `{INPUTS[unless[0]]}` no ({numbered(unless[1])})"
            cells.append(cell)
        needs = ", ".join(f"`{INPUTS[n]}`" for n in t.needs) or "—"
        kinds = ", ".join(f"`{k}`" for k in t.kinds)
        lines.append(f"| {t.name}: {t.what} | {needs} | {kinds} | " + " | ".join(cells) + " |")
    lines.append("")
    lines += [f"({i + 1}) {why}." for i, why in enumerate(reasons)]
    return "\n".join(lines)


START, END = "<!-- coverage-table:start -->", "<!-- coverage-table:end -->"
"""The markers around the table in docs/contract.md §4.1."""


def write_table(path: str) -> None:
    """Put :func:`table` between :data:`START` and :data:`END` in the file at ``path``, and the table
    of ``validate``'s keywords (``report._options.options_table``) between its own markers."""
    from .report._options import TABLE_END, TABLE_START, options_table

    with open(path, encoding="utf-8") as f:
        text = f.read()
    for start, end, body in ((START, END, table()), (TABLE_START, TABLE_END, options_table())):
        a, b = text.index(start) + len(start), text.index(end)
        text = text[:a] + "\n" + body + "\n" + text[b:]
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)


if __name__ == "__main__":
    import sys

    # python -m dynval.coverage prints the table; --write docs/contract.md puts it there (and validate's keywords')
    if sys.argv[1:2] == ["--write"] and len(sys.argv) == 3:
        write_table(sys.argv[2])
    else:
        print(table())
