"""The words of the findings: each kind's message and action, and the units of its effect.

Only wording: what decides (which joint, which column, deficiency or note) is in
``_findings.py``, which passes the numbers it decided on. A function per kind returns
``(message, action)``; the summary's wording is in ``_summary.py``, a comparison's in
``_reasons.py``, and every number is written by ``_text`` (contract §4).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from ._text import number_text, p_clause

Words = tuple[str, str]
"""``(message, action)`` of one finding."""

NEGLIGIBLE = ": significant but negligible."


def joint_name(names: Sequence[str] | None, j: int) -> str:
    return names[j] if names and j < len(names) else f"joint {j + 1}"


def column_name(names: Sequence[str] | None, c: int) -> str:
    return names[c] if names and c < len(names) else f"column {c + 1}"


def p_text(p: Any, log_p: Any = None) -> str:
    """``= 0.0123`` or ``< 1e-300``: the relation and the value, for "p {…}" in a message
    (:func:`dynval.report._text.p_clause`, the one p-value wording of every text, contract §4)."""
    return p_clause(p, log_p)


def lag_text(lag: int, sample_rate: float | None) -> str:
    """``lag 36`` or, with a rate, ``lag 36 (36 ms)``."""
    if sample_rate is None or lag == 0:
        return f"lag {lag}"
    seconds = lag / sample_rate
    return f"lag {lag} ({seconds:.3g} s)" if seconds >= 1 else f"lag {lag} ({1e3 * seconds:.3g} ms)"


def listed_columns(cols: Sequence[str] | None, columns: Sequence[int], most: int = 6) -> str:
    names = [column_name(cols, c) for c in columns]
    return ", ".join(names[:most]) + (f", … ({len(names)} in all)" if len(names) > most else "")


# -- the data -----------------------------------------------------------------------------------

# -- the fit ------------------------------------------------------------------------------------

BIAS_KINDS = (("offset", "a torque offset (sensor bias)"), ("friction", "a friction"), ("gravity", "a gravity term"))


def bias_action(name: str, kinds: Mapping[str, bool | None] | None) -> str:
    """What to do about a bias, relative to the model: add only what it lacks; re-identify what it has.

    ``kinds``: for "offset", "friction", "gravity", True (the model's columns span it on the joint),
    False (they do not) or None (not known); None when the model's columns are unknown."""
    if kinds is None:
        return (f"look for a torque offset (sensor bias), a friction or a gravity term on {name}: a bias of this "
                "kind remains (the model's columns are unknown, so whether it has them cannot be told)")
    lacks = [w for k, w in BIAS_KINDS if kinds.get(k) is False]
    has = [w.replace("a ", "", 1) for k, w in BIAS_KINDS if kinds.get(k) is True]
    unknown = [w for k, w in BIAS_KINDS if kinds.get(k) is None]
    parts = []
    if lacks:
        parts.append(f"add {' or '.join(lacks)} on {name} (the model lacks it)")
    if unknown:
        parts.append(f"look for {' or '.join(unknown)} (with q the report would tell whether the model has it)")
    if has:
        parts.append(("re-identify " if not parts else "or re-identify ") + f"the {', '.join(has)} the model has on "
                     f"{name}: its weight differs on this run (changed between runs, or the sensor's offset moved)")
    return "; ".join(parts)


PARTIAL_FORMS = {"coulomb": "the friction shape it lacks (a smooth sign or a Stribeck term)",
            "gravity": "the posture terms it lacks (a centre-of-mass component)",
            "position_harmonic": "the position harmonics it lacks",
            "inertia": "the acceleration terms it lacks (a motor's reflected inertia J_a·q̈ on the joint, or a body the "
                       "model does not have)"}


def simulator_words(name: str, column: str, given: float, refit: float) -> Words | None:
    """When ``column`` is a simulator parameter of joint ``name`` (an MJCF model's ``damping_<joint>``,
    ...): what the residual follows, in that parameter's unit (the column's coefficient refitted on
    this run, as ``MJCFModel.retune`` refits it, minus its value in the prediction), and the value
    to retune it to. None for another column, or one the run could not refit."""
    from ..statistics._model_terms import SIMULATOR_PARAMETERS, simulator_attribute

    parsed = simulator_attribute(column)
    delta = refit - given
    if parsed is None or parsed[1] != name or math.isnan(delta):
        return None
    attribute = parsed[0]
    motion, unit = SIMULATOR_PARAMETERS[attribute]
    side = "low" if delta > 0 else "high"
    return (f"{attribute} on {name} is too {side}: the residual follows {motion} with {delta:+.2g} {unit} "
            f"({number_text(given, '.4g')} in the model, {number_text(refit, '.4g')} refitted on this run)",
            f"retune {attribute} on {name} in the simulator model: {number_text(given, '.4g')} → "
            f"{number_text(refit, '.4g')} {unit} (refitted on this run; MJCFModel.retune gives its standard "
            "deviation)")


def coupling_terms(group: str, name: str) -> str:
    if group == "gravity":
        return f"the posture terms sin/cos(q_i + … + q_k) of the link-angle chains through {name}"
    if group == "inertia":
        return "the other joints' accelerations q̈_k (the mass matrix's off-diagonal terms)"
    return "the other joints' terms"


def percent(share: float) -> str:
    """A share in per cent with the digits a reader needs: ``98 %``, ``4.2 %``, ``0.56 %``."""
    x = 100.0 * share
    return f"{x:.0f} %" if abs(x) >= 10 else f"{x:.2g} %"
