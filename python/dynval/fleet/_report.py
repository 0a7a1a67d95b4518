"""The fleet report: one row per log, the drift test per robot, and their text and JSON forms."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ..checks._json import to_jsonable
from ..report._text import p_clause
from ._drift import Drift
from ._run import LogSummary

__all__ = ["FleetReport", "TABLE_COLUMNS"]

TABLE_COLUMNS = ("robot", "time", "log", "n_samples", "n_joints", "rmse", "vaf", "decision", "n_findings", "kinds",
                 "error", "sees")
"""The columns of :meth:`FleetReport.table`, in order."""


@dataclass(frozen=True)
class FleetReport:
    """What :func:`dynval.fleet.validate_many` returns.

    Attributes
    ----------
    logs : tuple of LogSummary
        One row per log: robots in the order they first appear, each robot's logs in time order.
    drift : tuple of Drift
        The drift test of each robot, in the same robot order.
    level : float
        Confidence level of the findings (α = 1 − level, Holm over the robots for drift).
    provenance : dict
        Where and how it ran (``scheduler``, ``workers``, ``seconds``, ``n_logs``, ``n_robots``, ...).
    """

    logs: tuple[LogSummary, ...]
    drift: tuple[Drift, ...]
    level: float
    provenance: dict[str, Any] = field(default_factory=dict)

    @property
    def robots(self) -> tuple[str, ...]:
        """The robots, in the order of the table."""
        return tuple(d.robot for d in self.drift)

    @property
    def findings(self) -> tuple[Any, ...]:
        """The drift findings (deficiencies first, then notes)."""
        found = [d.finding for d in self.drift if d.finding is not None]
        return tuple(sorted(found, key=lambda f: f.severity != "deficiency"))

    def table(self) -> list[dict[str, Any]]:
        """The fleet table: one dict per log with the keys of :data:`TABLE_COLUMNS`."""
        return [{c: getattr(row, c) for c in TABLE_COLUMNS} for row in self.logs]

    def robot_table(self) -> list[dict[str, Any]]:
        """One dict per robot: ``robot``, ``n_logs``, ``n_errors``, the median ``rmse`` and ``vaf`` of
        its valid logs, ``decisions`` (decision → count) and its ``drift`` (``deficiency``, ``note``,
        ``none`` or ``not tested``) with ``from_log``."""
        out = []
        for d in self.drift:
            rows = [r for r in self.logs if r.robot == d.robot]
            valid = [r for r in rows if r.error is None]
            decisions: dict[str, int] = {}
            for r in rows:
                decisions[r.decision] = decisions.get(r.decision, 0) + 1
            state = d.finding.severity if d.finding is not None else ("none" if d.tested else "not tested")
            out.append({"robot": d.robot, "n_logs": len(rows), "n_errors": len(rows) - len(valid),
                        "rmse": float(np.median([r.rmse for r in valid])) if valid else float("nan"),
                        "vaf": float(np.median([r.vaf for r in valid])) if valid else float("nan"),
                        "decisions": decisions, "drift": state,
                        "from_log": d.change_log if d.finding is not None else None})
        return out

    @property
    def notes(self) -> tuple[str, ...]:
        """Sentences that reconcile a robot's drift with its per-log decisions where they would read as
        a contradiction: a drifting robot whose logs from the change on are accepted (contract §10)."""
        return tuple(note for d in self.drift if (note := _drift_note(d, self.logs)))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary: ``robots`` (:meth:`robot_table`), ``logs``, ``drift`` (each with its
        ``finding``), ``findings``, ``notes``,
        ``level`` and ``provenance`` (non-finite numbers as strings, as a report's)."""
        drift = [{**{k: v for k, v in asdict(d).items() if k != "finding"},
                  "finding": None if d.finding is None else d.finding.to_dict()} for d in self.drift]
        out: dict[str, Any] = to_jsonable({"level": self.level, "robots": self.robot_table(),
                                           "logs": [asdict(r) for r in self.logs],
                                           "drift": drift, "findings": [f.to_dict() for f in self.findings],
                                           "notes": list(self.notes),
                                           "provenance": self.provenance})
        return out

    def to_json(self, indent: int | None = 2) -> str:
        """:meth:`to_dict` as JSON text."""
        return json.dumps(self.to_dict(), indent=indent)

    def summary(self) -> str:
        """The fleet table, the drift per robot and the findings, as text."""
        return "\n".join(_summary_lines(self))

    def __str__(self) -> str:
        return self.summary()


def _drift_note(d: Drift, logs: tuple[LogSummary, ...]) -> str:
    """Why a drifting robot's logs from the change on can be accepted one by one, or ''."""
    if d.finding is None or d.change is None:
        return ""
    valid = [r for r in logs if r.robot == d.robot and r.error is None and r.rmse > 0 and np.isfinite(r.rmse)]
    later = valid[d.change:]
    accepted = [r for r in later if r.decision == "accept"]
    if not accepted:
        return ""
    seen = sorted({r.sees for r in accepted})
    if all(s.startswith("residual only") for s in seen):
        why = (", from the residual only (no q, no regressor), where a grown friction or a new payload that leaves "
               "the residual zero-mean and no more coloured than before does not show; give the logs' q and regressor "
               "(manifest columns q, regressor) for per-log tests that can see it")
    else:
        why = f" ({'; '.join(seen)}), and within one log the change is not (yet) beyond what its tests allow"
    return (f"{d.robot} drifts from log {d.change_log} on, yet {len(accepted)} of its {len(later)} logs from then on "
            f"are accepted: the drift compares the robot's logs with each other, each per-log decision compares one "
            f"log with the model alone{why}.")


def _summary_lines(fleet: FleetReport) -> list[str]:
    prov = fleet.provenance
    lines = [f"dynval fleet report — {len(fleet.logs)} logs of {len(fleet.drift)} robots "
             f"(ran on {prov.get('where', 'this process')}, {prov.get('seconds', 0.0):.1f} s)", ""]
    # the inputs the decisions saw: once above the table when every log saw the same, else per row
    inputs = {r.sees for r in fleet.logs if r.error is None}
    if len(inputs) == 1:
        lines[-1:-1] = [f"Each log's decision saw: {next(iter(inputs))}."]
    lines.append(f"  {'robot':<10} {'time':<20} {'log':<24} {'N':>7} {'m':>2} {'RMSE':>10} {'VAF %':>7} "
                 f"{'decision':<9} findings")
    for r in fleet.logs:
        found = r.error if r.error else (f"{r.n_findings}: {', '.join(r.kinds)}" if r.n_findings else "0")
        seen = f" [saw: {r.sees}]" if len(inputs) > 1 and r.error is None else ""
        lines.append(f"  {r.robot:<10.10} {r.time:<20.20} {r.log:<24.24} {r.n_samples:>7} {r.n_joints:>2} "
                     f"{r.rmse:>10.4g} {r.vaf:>7.2f} {r.decision:<9} {found}{seen}")
    alpha = 1.0 - fleet.level
    tested = sum(d.tested for d in fleet.drift)
    lines += ["", "Robots (median over their valid logs):"]
    for robot in fleet.robot_table():
        decisions = ", ".join(f"{n} {k}" for k, n in sorted(robot["decisions"].items()))
        lines.append(f"  {robot['robot']}: {robot['n_logs']} logs, RMSE {robot['rmse']:.4g}, VAF {robot['vaf']:.2f} %; "
                     f"{decisions}")
    lines += ["", f"Drift (change point in each robot's log RMSE, permutation test, Holm over {tested} robot"
                  f"{'s' * (tested != 1)}, α = {alpha:g}):"]
    for d in fleet.drift:
        if not d.tested:
            lines.append(f"  {d.robot}: not tested ({d.reason})")
        elif d.finding is None:
            lines.append(f"  {d.robot}: no drift over {d.n_logs} logs (largest change from log {d.change_log} on, "
                         f"RMSE ×{d.ratio:.3g}, Holm-adjusted p {p_clause(d.pvalue_adjusted)})")
        else:
            lines.append(f"  {d.robot}: DRIFT from log {d.change_log} ({d.change_time}) on, RMSE ×{d.ratio:.3g}, "
                         f"Holm-adjusted p {p_clause(d.pvalue_adjusted)} [{d.finding.severity}]")
    if fleet.findings:
        lines += ["", "Findings:"] + [f"  - [{f.severity}] {f.message}" for f in fleet.findings]
    if fleet.notes:
        lines += ["", "Drift and the per-log decisions:"] + [f"  - {note}" for note in fleet.notes]
    return lines
