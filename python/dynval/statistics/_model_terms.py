"""A named physical term relative to the model: mis-weighted, of another shape, coupling, or missing.

The physics library (:mod:`dynval.statistics._physics`) names the *kind* of structure a joint's
residual follows. Whether the model lacks that term or has it with another weight depends on the
model's columns (docs/conventions.md §5.2, "Advice relative to the model"):

* a library column *lies in the model's span* on joint j when, both normalised to unit RMS, less
  than :data:`SPAN_TOLERANCE` of its RMS stays outside the span of joint j's model columns on the
  validation run (at least 99 % of its square inside);
* each column is *own* (a function of joint j's variables only) or *coupling* (of other joints' too:
  the posture chains sin/cos(q_i + … + q_k) with i < j or k > j, and q̈_k for k ≠ j);
* what re-identifying and adding would gain is measured out of sample, by cross-fitting on the
  validation run (:func:`crossfit_sse`: alternate blocks, fit on one half, scored on the other), in
  shares of the joint's residual mean square: ``reweight`` (the model's own columns refitted),
  ``outside`` (the group's columns outside the span added to them), ``outside_own`` (its own
  columns only).

The relation (:func:`relate`): ``reweight`` when what lies outside the span adds less than the
practical share; otherwise ``partial`` (the model spans some of the kind's own columns, the rest
remains: another shape of a friction, a centre-of-mass component), ``coupling`` (it spans the
kind's own columns, the cross-joint columns remain) or ``missing`` (it spans no column of the kind).
``unsupported``: the model spans no own column of the kind and adding it does not carry to held-out
rows (what remains is rather the model's own terms mis-weighted, ``reweight_share``).

Applied to the physics test's named terms (the last parts of the module): which kinds the model
holds per joint (:func:`model_kinds`, :func:`declared_groups`), a rigid-body kind it holds on no
joint (:func:`name_absent_kinds`), each named term's relation and the model's coefficients closest
to it (:func:`relate_terms`), a simulator model's own parameters refitted
(:func:`simulator_parameters`), and a term named on the validation run where the estimation run's
refit names none (:func:`name_on_validation`: the groups' cross-fitted gains beyond the model's
columns, else the held kind the model's re-weighting adds).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from . import _physics
from ._columns import unit_norm_columns
from ._physics import PhysicsTest

if TYPE_CHECKING:
    from ._estimation import EstimationFit

__all__ = ["SPAN_TOLERANCE", "CROSSFIT_ROWS", "coupling_mask", "span_basis", "outside_fraction", "crossfit_sse",
           "relate", "kinds_present", "declared_kinds", "RIGID_BODY_PARAMETERS", "SIMULATOR_PARAMETERS",
           "simulator_attribute", "RIGID_BODY_KINDS", "declared_groups", "model_kinds", "name_absent_kinds",
           "relate_terms", "simulator_parameters", "name_on_validation", "validation_refit_gains", "reweighted_group"]

SPAN_TOLERANCE = 0.1
"""A column lies in the model's span when less than this fraction of its RMS stays outside."""

CROSSFIT_ROWS = 100
"""Rows per contiguous block of the cross-fit (at least 8 blocks, at most 64): even blocks and odd
blocks are the two halves. Short blocks interleave the halves so each sees every posture the other
does (a position-dependent fit does not extrapolate); each block still spans many samples, so a
fit of the noise does not carry to the next block unless the noise is slower than a block."""


def coupling_mask(group: str, j: int, m: int, width: int) -> np.ndarray:
    """Which of the group's library columns (in :func:`dynval.statistics._physics.library`'s
    order) depend on joints other than j."""
    mask = np.zeros(width, dtype=bool)
    if group == "gravity":
        pos = 0
        for i in range(j + 1):
            for k in range(j, m):
                mask[pos:pos + 2] = not (i == j and k == j)
                pos += 2
    elif group == "inertia":
        mask[:] = [k != j for k in range(width)]
    return mask


def span_basis(y_j: np.ndarray) -> np.ndarray:
    """An orthonormal basis (N, r) of joint j's model columns (each scaled to unit RMS; columns
    that are zero on the joint dropped)."""
    rms = np.sqrt(np.mean(y_j * y_j, axis=0)) if y_j.size else np.zeros(0)
    active = rms > 1e-12 * max(float(rms.max(initial=0.0)), 1e-300)
    if not np.any(active):
        return np.zeros((y_j.shape[0], 0))
    u, s, _ = np.linalg.svd(y_j[:, active] / rms[active], full_matrices=False)
    return u[:, s > 1e-8 * s[0]]


def outside_fraction(basis: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Per column, the fraction of its RMS outside the span of ``basis``."""
    norm = np.sqrt(np.sum(cols * cols, axis=0))
    left = cols - basis @ (basis.T @ cols) if basis.shape[1] else cols
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(norm > 0, np.sqrt(np.sum(left * left, axis=0)) / norm, 0.0)


def crossfit_sse(y: np.ndarray, x: np.ndarray, blocks: int | None = None, full: np.ndarray | None = None) -> float:
    """Sum of squares of ``y`` left by least squares on ``x`` out of sample: the run cut into
    contiguous blocks, fitted on the even ones and scored on the odd ones and the other way round (a
    term must carry to rows its fit did not see, so noise it fits by chance does not count), scaled
    to all N rows.

    Coloured noise carries across a block's edge: rows within ``gap`` of an edge are not scored,
    ``gap`` twice the correlation time of the AR(1) model of what the largest design of the
    comparison, ``full`` (default ``x``), leaves in sample, at most a quarter of a block; blocks are
    about :data:`CROSSFIT_ROWS` long (8 to 64 blocks). Every design compared on one ``y``
    must be given the same ``full``, so the blocks and the rows scored are the same."""
    n = y.shape[0]
    if x.shape[1] == 0:
        return float(y @ y)
    blocks = blocks or int(np.clip(n // CROSSFIT_ROWS, 8, 64))
    # at most a quarter of a block: half of each block is scored, and short blocks keep the halves
    # interleaved (a slow structure's own colour must not stretch them into extrapolation)
    gap = min(_gap(y, x if full is None else full), n // (4 * blocks))
    index = np.arange(n) * blocks // max(n, 1)
    half = index % 2 == 0
    scored = edge_distance(n, np.flatnonzero(np.diff(index)) + 1) >= gap
    sse, rows = 0.0, 0
    for fit_rows in (half, ~half):
        coef, *_ = np.linalg.lstsq(x[fit_rows], y[fit_rows], rcond=None)
        test = ~fit_rows & scored
        r = y[test] - x[test] @ coef
        sse += float(r @ r)
        rows += int(test.sum())
    return float(sse * n / max(rows, 1))


def edge_distance(n: int, starts: np.ndarray) -> np.ndarray:
    """Each of the ``n`` rows' distance to the nearest block edge, |i − b + 1/2| for the block
    starting at row b (``starts`` increasing; inf without one): the nearest edge of a row is the
    start at or before it or the one after it, so two of them are compared, not every block's."""
    if starts.size == 0:
        return np.full(n, np.inf)
    i = np.arange(n)
    k = np.searchsorted(starts, i, side="right")
    before = starts[np.maximum(k - 1, 0)]
    after = starts[np.minimum(k, starts.size - 1)]
    return np.asarray(np.minimum(np.abs(i - before + 0.5), np.abs(i - after + 0.5)), dtype=float)


def _gap(y: np.ndarray, full: np.ndarray) -> int:
    """Twice the correlation time (samples) of the AR(1) model of what ``full`` leaves of ``y``."""
    r = y - full @ np.linalg.lstsq(full, y, rcond=None)[0] if full.shape[1] else y
    r = r - r.mean()
    den = float(r[:-1] @ r[:-1])
    phi = float(r[1:] @ r[:-1]) / den if den > 0 else 0.0
    if not 0.0 < phi < 1.0:
        return 0
    return int(math.ceil(2.0 / -math.log(max(phi, 1e-12)))) if phi < 1.0 - 1e-9 else y.shape[0]


def _shares(e_j: np.ndarray, y_j: np.ndarray, out_own: np.ndarray,
            out_coupling: np.ndarray) -> tuple[float, float, float]:
    total = float(e_j @ e_j)
    if not total > 0:
        return 0.0, 0.0, 0.0
    y = y_j if y_j.size else np.zeros((e_j.shape[0], 0))
    full = np.hstack([y, out_own, out_coupling])
    base = crossfit_sse(e_j, y, full=full) if y.shape[1] else total
    own = crossfit_sse(e_j, np.hstack([y, out_own]), full=full) if out_own.shape[1] else base
    both = crossfit_sse(e_j, full, full=full) if out_coupling.shape[1] else own
    return (total - base) / total, (base - both) / total, (base - own) / total


RIGID_BODY_PARAMETERS = frozenset({"m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz"})
"""A column named ``<link>:<parameter>`` (or a combination of such, as base parameters are named)
is a link's inertial parameter: the model holds the rigid body's gravity and inertia of that link,
its coupling to the other joints included, in a form the library's planar columns only approximate."""


_NAMED_KINDS = (("Fv", "viscous"), ("Fc", "coulomb"), ("off", "offset"))
"""Column-name prefixes of the friction and offset columns (URDFModel.column_names: ``Fv_<joint>``,
``Fc_<joint>``, ``off_<joint>``)."""


SIMULATOR_PARAMETERS = {"armature": ("q̈", "N·m·s²/rad"), "damping": ("q̇", "N·m·s/rad"),
                        "frictionloss": ("sign q̇", "N·m")}
"""A simulator model's joint parameters, as ``dynval.mjcf`` names their columns (``<attribute>_<joint>``,
contract §11): the motion each multiplies and its unit."""


def simulator_attribute(name: Any) -> tuple[str, str] | None:
    """``(attribute, joint)`` of a simulator parameter's column name (``damping_lwr_3_joint``), else None."""
    attribute, _, joint = str(name).partition("_")
    return (attribute, joint) if attribute in SIMULATOR_PARAMETERS and joint else None


def declared_kinds(names: Any) -> set[str]:
    """The library groups a model's column names declare: rigid-body inertial parameters declare
    ``gravity`` and ``inertia`` (coupling included); ``Fv``, ``Fc``, ``off`` columns viscous,
    Coulomb friction and an offset. A rigid-body model's names also declare what it lacks: the
    friction and offset kinds it has no column of are marked ``"-viscous"``, ``"-coulomb"``,
    ``"-offset"`` (on a rich trajectory its many columns can span a friction column numerically,
    yet re-identifying it would not give it friction)."""
    names = [str(x) for x in names]
    out: set[str] = set()
    rigid = False
    for name in names:
        for token in name.replace("+", " ").replace("-", " ").replace("*", " ").split():
            if ":" in token and token.rsplit(":", 1)[1] in RIGID_BODY_PARAMETERS:
                rigid = True
        for prefix, group in _NAMED_KINDS:
            if name.startswith(prefix) and not name[len(prefix):len(prefix) + 1].isalpha():
                out.add(group)
    if rigid:
        out |= {"gravity", "inertia"}
        out |= {f"-{g}" for _, g in _NAMED_KINDS if g not in out}
    return out


def relate(j: int, group: str, e_j: np.ndarray, y_j: np.ndarray, lib_j: Mapping[str, np.ndarray], m: int,
           practical: float, declared: set[str] | frozenset[str] = frozenset()) -> dict[str, Any]:
    """The named ``group`` on joint j relative to the model's columns ``y_j`` (N, k) on the
    validation run: ``relation`` (module docstring), the shares, which of its columns lie in the
    span (own and coupling), and the fraction outside of each. ``declared``: the groups the model's
    column names declare (:func:`declared_kinds`): it has them, coupling included, so what lies
    outside the span is ``partial`` (a link, a load or a rotor inertia it lacks), never missing."""
    cols = lib_j[group]
    mask = coupling_mask(group, j, m, cols.shape[1])
    basis = span_basis(y_j)
    frac = outside_fraction(basis, cols)
    # the names say the model lacks it, whatever the data span
    inside = (frac <= SPAN_TOLERANCE) & (f"-{group}" not in declared)
    out_own = cols[:, ~inside & ~mask]
    out_coupling = cols[:, ~inside & mask]
    active = np.sqrt(np.mean(y_j * y_j, axis=0)) > 0 if y_j.size else np.zeros(0, bool)
    reweight, outside, outside_own = _shares(e_j, y_j[:, active] if y_j.size else y_j, out_own, out_coupling)
    # the model holds a term of this kind when one of its own columns lies in the group's span (a
    # gravity model's column m·g·cos(q_2 + q_3) is a posture term though no single library column is
    # in the model's span): what it lacks of the group is then a part, never the whole term
    holds = model_in_group(y_j[:, active] if y_j.size else y_j, cols) and f"-{group}" not in declared
    has_own = bool(np.any(inside & ~mask)) or group in declared or holds
    if f"-{group}" in declared:
        relation = "missing"
    elif group in declared:
        relation = "reweight" if outside < practical else "partial"
    elif outside < practical and has_own:
        relation = "reweight"
    elif outside < practical:
        relation = "unsupported"
    elif has_own and outside_own < practical and out_coupling.shape[1] and outside - outside_own >= practical:
        relation = "coupling"
    elif bool(np.any(inside)) or holds:
        relation = "partial"
    else:
        relation = "missing"
    return {"relation": relation, "group": group, "reweight_share": reweight, "outside_share": outside,
            "outside_own_share": outside_own, "own_in_span": int(np.sum(inside & ~mask)),
            "own_columns": int(np.sum(~mask)), "coupling_in_span": int(np.sum(inside & mask)),
            "coupling_columns": int(np.sum(mask)), "outside_fraction": [float(x) for x in frac],
            "tolerance": SPAN_TOLERANCE,
            "declared": True if group in declared else False if f"-{group}" in declared else None,
            "model_in_group": holds}


def model_in_group(y_j: np.ndarray, cols: np.ndarray) -> bool:
    """One of the model's columns on the joint lies in the span of the group's columns (within
    :data:`SPAN_TOLERANCE` of its RMS)."""
    if y_j.size == 0 or cols.size == 0:
        return False
    frac = outside_fraction(span_basis(cols), y_j)
    rms = np.sqrt(np.mean(y_j * y_j, axis=0))
    return bool(np.any((frac <= SPAN_TOLERANCE) & (rms > 0)))


def kinds_present(j: int, y_j: np.ndarray, lib_j: Mapping[str, np.ndarray], m: int,
                  declared: set[str] | frozenset[str] = frozenset()) -> dict[str, bool]:
    """Per library group, whether the model spans at least one of its own columns on joint j (or
    its column names declare the group)."""
    fractions = outside_fractions(y_j, lib_j)
    out = {}
    for g, cols in lib_j.items():
        mask = coupling_mask(g, j, m, cols.shape[1])
        spanned = bool(np.any((fractions[g] <= SPAN_TOLERANCE) & ~mask)) or model_in_group(y_j, cols)
        out[g] = g in declared or (spanned and f"-{g}" not in declared)
    return out


def outside_fractions(y_j: np.ndarray, groups: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Per group, :func:`outside_fraction` of its columns and :func:`span_basis` of ``y_j``, from R
    of one QR of the unit-RMS model columns and the groups' columns side by side: the span's basis
    and every projection are taken on R's rows (norms and inner products are R's), so the N rows
    are factored once rather than decomposed by an SVD of N × k."""
    rms = np.sqrt(np.mean(y_j * y_j, axis=0)) if y_j.size else np.zeros(0)
    active = rms > 1e-12 * max(float(rms.max(initial=0.0)), 1e-300)
    ka = int(active.sum())
    r = _physics._tall_r(np.column_stack([y_j[:, active] / rms[active]] + list(groups.values())))
    basis = np.zeros((r.shape[0], 0))
    if ka:
        u, sv, _ = np.linalg.svd(r[:, :ka], full_matrices=False)
        basis = u[:, sv > 1e-8 * sv[0]]
    out, at = {}, ka
    for g, cols in groups.items():
        out[g] = outside_fraction(basis, r[:, at:at + cols.shape[1]])
        at += cols.shape[1]
    return out


def coefficients(y_j: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Least squares of ``target`` on joint j's model columns (minimum norm where they are dependent)."""
    if y_j.shape[1] == 0:
        return np.zeros(0)
    return np.asarray(np.linalg.lstsq(y_j, target, rcond=None)[0], dtype=float)


def aligned_columns(y_j: np.ndarray, cols: np.ndarray, most: int = 2) -> list[int]:
    """Indices of joint j's model columns most aligned with the group's columns (|cosine| of the
    unit-RMS columns), the closest first."""
    rms_y = np.sqrt(np.mean(y_j * y_j, axis=0))
    rms_c = np.sqrt(np.mean(cols * cols, axis=0))
    ok = rms_y > 0
    if not np.any(ok) or not np.any(rms_c > 0):
        return []
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.abs((y_j / np.where(ok, rms_y, 1.0)).T @ (cols / np.where(rms_c > 0, rms_c, 1.0))) / y_j.shape[0]
    best = np.where(ok, np.max(np.nan_to_num(cos), axis=1), -math.inf)
    order = [int(c) for c in np.argsort(-best) if best[c] > 0]
    return order[:most]


def library_for(j: int, q: Any, dq: Any, ddq: Any, n: int, sample_rate: Any) -> dict[str, np.ndarray]:
    """Joint j's library (q may be None: offset and drift only)."""
    return _physics.library(j, q, dq, ddq, np.zeros(n), sample_rate)


# --------------------------------------------------------------------------- the physics test's terms


def declared_groups(reg3: np.ndarray | None, cols: Sequence[int] | None,
                    column_names: Sequence[str] | None) -> list[set[str]] | None:
    """Per joint, the groups the names of the model's columns active on it declare."""
    if reg3 is None or cols is None or not column_names:
        return None
    out = []
    for j in range(reg3.shape[1]):
        active = np.sqrt(np.mean(reg3[:, j, cols] ** 2, axis=0)) > 0
        out.append(declared_kinds([column_names[c] for c, a in zip(cols, active) if a]))
    return out


def model_kinds(e: np.ndarray | None, reg3: np.ndarray | None, cols: Sequence[int] | None,
                libraries: Sequence[Mapping[str, np.ndarray]],
                declared: list[set[str]] | None = None) -> list[dict[str, bool]] | None:
    """Per joint, which library groups the model's columns span (an own column of each within
    the tolerance of :data:`SPAN_TOLERANCE`); None when its columns are unknown.
    ``libraries``: each joint's library (:func:`library_for`)."""
    if reg3 is None or cols is None or e is None:
        return None
    m = e.shape[1]
    # every column: a view of the joint's columns, not a gathered copy of its whole (N, p) block
    # per joint (the same values; a 91-column regressor's copy is 15 MB a joint at 20,000 rows)
    every = len(cols) == reg3.shape[2] and all(int(c) == i for i, c in enumerate(cols))
    out = []
    for j in range(m):
        y_j = reg3[:, j, :] if every else reg3[:, j, cols]
        out.append(kinds_present(j, y_j, libraries[j], m, declared[j] if declared else set()))
    return out


_LACKING = ("missing", "partial", "coupling")
"""Relations in which the model lacks the named term (:func:`dynval.statistics.relate`)."""

RIGID_BODY_KINDS = ("inertia", "gravity")
"""The kinds every rigid-body model of a moving arm holds: a model that holds one of them on no joint
lacks it as a whole (a gravity-only model of a moving arm lacks its inertia)."""


def name_absent_kinds(tests: Sequence[PhysicsTest], kinds: list[dict[str, bool]] | None, e: np.ndarray,
                      libraries: Sequence[Mapping[str, np.ndarray]], practical: float) -> None:
    """Name a rigid-body kind the model holds on no joint where the test selects it (conventions §5.2,
    "A kind the model lacks on every joint"): on a joint whose term was named by a kind the model
    holds (on some joint), the named term is the fit's re-weighting of what it has, bent to make up
    for the kind it lacks; adding that kind and refitting is the step. Named only where the kind's
    own columns, cross-fitted on the validation run, remove a practical share of the joint's mean
    square (its ``term_share`` then). ``kinds``: per joint, the groups the model holds."""
    if not kinds:
        return
    absent = [g for g in RIGID_BODY_KINDS if not any(k.get(g) for k in kinds)]
    held = {g for k in kinds for g, v in k.items() if v}
    for t in tests:
        if t.term is None or t.term not in held:
            continue
        ej = e[:, t.joint]
        total = float(ej @ ej)
        for g in absent:
            if g not in t.selected or g not in libraries[t.joint] or not total > 0:
                continue
            share = (total - crossfit_sse(ej, libraries[t.joint][g])) / total
            if share >= practical:
                t.term, t.term_share, t.refit_run = g, share, "absent"
                break


def relate_terms(tests: Sequence[PhysicsTest], e: np.ndarray, pred: np.ndarray, meas: np.ndarray | None,
                 reg3: np.ndarray | None, cols: Sequence[int] | None, est_fit: EstimationFit | None,
                 practical: float, libraries: Sequence[Mapping[str, np.ndarray]],
                 declared: list[set[str]] | None = None, local: Mapping[int, dict[str, Any]] | None = None) -> None:
    """Each named term's own effect out of sample (alone, cross-fitted on the validation run) and,
    with the model's columns known, its relation to them: mis-weighted, partial, coupling or missing,
    with the coefficients of the model's columns closest to it, estimated and refitted on this run.
    ``libraries``: each joint's library (:func:`library_for`). ``local``: per joint, what the named
    group's own columns added on that joint alone give (:func:`dynval.statistics._term_refit.refit_names`):
    a term the joint's columns span only by bending parameters other joints share is ``local``, not a
    re-weighting."""
    m = e.shape[1]
    for t in tests:
        if t.term is None:
            continue
        j = t.joint
        lib = libraries[j]
        if t.term not in lib:
            continue
        ej = e[:, j]
        total = float(ej @ ej)
        if not total > 0:
            continue
        t.heldout_share = (total - crossfit_sse(ej, lib[t.term])) / total
        if reg3 is None or cols is None:
            continue
        y_j = reg3[:, j, cols]
        active = np.sqrt(np.mean(y_j * y_j, axis=0)) > 0
        both = np.hstack([y_j[:, active], lib[t.term]])
        base = crossfit_sse(ej, y_j[:, active], full=both)
        t.carried_share = (base - crossfit_sse(ej, both, full=both)) / total
        rel = relate(j, t.term, ej, y_j, lib, m, practical, declared[j] if declared else set())
        gain = (local or {}).get(j)
        if (rel["relation"] == "reweight" and gain is not None and gain["group"] == t.term
                and gain["share"] >= practical):
            rel["relation"], rel["local"] = "local", gain
        elif rel["relation"] in _LACKING and gain is not None and gain["group"] == t.term:
            # what its own columns added on this joint alone remove on the others: the parameters
            # the fit bent there for it (conventions §5.10, "One missing column is one step")
            rel["added_alone"] = gain
        near = aligned_columns(y_j, lib[t.term])
        in_pred, refit = _joint_coefficients(y_j, active, pred[:, j], None if meas is None else meas[:, j])
        est_coef = np.asarray(est_fit.coefficients, dtype=float) if est_fit is not None else in_pred
        rel["columns"] = [int(cols[c]) for c in near]
        # the model's columns most aligned with each group the selection took in with the named one:
        # a structure the model lacks leaves its trace on them (a decoupled model's sin q_j carries
        # part of the missing gravity coupling when inertia is the term named)
        rel["trace_columns"] = sorted({int(cols[c]) for g in t.selected if g in lib
                                       for c in aligned_columns(y_j, lib[g])} | set(rel["columns"]))
        # the other joints whose rows these columns enter: a structure the model lacks there bends
        # their shared parameters in the fit, and the error this leaves here is its trace
        rel["shared_with"] = [k for k in range(m) if k != j and any(np.any(reg3[:, k, cols[c]] != 0) for c in near)]
        rel["estimated"] = [float(est_coef[c]) for c in near]
        rel["refitted"] = [float(refit[c]) for c in near]
        rel["estimated_from"] = "estimation" if est_fit is not None else "prediction"
        t.relation = rel


def _joint_coefficients(y_j: np.ndarray, active: np.ndarray, pred_j: np.ndarray,
                        meas_j: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Joint j's model columns' coefficients in the prediction and refitted on the measured torque
    (least squares on the columns active on the joint; nan refitted without the measurement)."""
    in_pred = np.zeros(y_j.shape[1])
    in_pred[active] = coefficients(y_j[:, active], pred_j)
    refit = np.zeros(y_j.shape[1])
    refit[active] = coefficients(y_j[:, active], meas_j) if meas_j is not None else np.nan
    return in_pred, refit


def simulator_parameters(pred: np.ndarray | None, meas: np.ndarray | None, reg3: np.ndarray | None,
                         column_names: Sequence[str] | None) -> list[list[dict[str, Any]]] | None:
    """Per joint, the simulator columns active on it (an MJCF model's ``armature_``, ``damping_``,
    ``frictionloss_<joint>``, contract §11) with their coefficient in the prediction (the model's own
    value) and refitted on this run, by least squares on every regressor column active on the joint:
    an MJCF regressor's columns are each on one joint, so this is the joint's share of
    :func:`dynval.identify.identify` of the whole regressor, the value ``MJCFModel.retune`` refits.
    None when the regressor has no such column."""
    if reg3 is None or not column_names or meas is None or pred is None:
        return None
    if not any(simulator_attribute(name) for name in column_names):
        return None
    out: list[list[dict[str, Any]]] = []
    for j in range(reg3.shape[1]):
        y_j = reg3[:, j, :]
        active = np.sqrt(np.mean(y_j * y_j, axis=0)) > 0
        named = [c for c in range(y_j.shape[1]) if active[c] and simulator_attribute(column_names[c])]
        if not named:
            out.append([])
            continue
        in_pred, refit = _joint_coefficients(y_j, active, pred[:, j], meas[:, j])
        out.append([{"column": c, "name": str(column_names[c]), "predicted": float(in_pred[c]),
                     "refitted": float(refit[c])} for c in named])
    return out if any(out) else None


# --------------------------------------------------------------------------- naming on the validation run


def name_on_validation(t: PhysicsTest, meas_j: np.ndarray, y_j: np.ndarray, coefficients: np.ndarray,
                       lib_j: Mapping[str, np.ndarray], m: int, practical: float,
                       declared: set[str] | None) -> dict[str, float] | None:
    """Joint t.joint's term named on the validation run, where the estimation run's refit names
    none (:func:`dynval.statistics._term_refit.refit_names`): the groups' shares of what the model's
    own columns ``y_j`` (as given, with their estimated ``coefficients``) leave, cross-fitted
    (:func:`validation_refit_gains`), returned when one reaches ``practical`` (the caller names
    the term from them). Otherwise the model's columns span what remains (mis-weighted, not
    missing): where the test named a kind the model does not hold (``declared``: the kinds its
    column names declare, else those it spans), ``t.term`` becomes the held kind its re-weighting
    adds (:func:`reweighted_group`), and None is returned."""
    y_unit = unit_norm_columns(y_j)
    gv = validation_refit_gains(meas_j, y_unit, lib_j)
    if gv and max(gv.values()) >= practical:
        return gv
    held = ({g: g in declared for g in lib_j} if declared is not None else
            kinds_present(t.joint, y_unit, lib_j, m))
    if t.term is None or held.get(t.term):
        return None
    named = reweighted_group(meas_j - y_j @ coefficients, y_unit, {g: x for g, x in lib_j.items() if held.get(g)})
    if named is not None:
        t.term = named
    return None


def validation_refit_gains(tau_j: np.ndarray, y_j: np.ndarray, groups: Mapping[str, np.ndarray]) -> dict[str, float]:
    """Per group, the share of the residual left by the model's columns refitted on this run that
    the group removes when added to them, out of sample: cross-fitted on alternate blocks of the run
    (:func:`crossfit_sse`, the rows near a block's edge unscored), so
    a group that fits the noise of the rows it sees does not count."""
    out = {}
    for g, b in groups.items():
        both = np.hstack([y_j, b])
        base = crossfit_sse(tau_j, y_j, full=both)
        if base > 0:
            out[g] = (base - crossfit_sse(tau_j, both, full=both)) / base
    return out


def reweighted_group(e_j: np.ndarray, y_j: np.ndarray, groups: Mapping[str, np.ndarray]) -> str | None:
    """The library group that best represents what re-weighting the model's columns changes on this
    run: the residual's least-squares fit on the model's columns (the torque the changed weights
    make), and the group of ``groups`` (those the model holds) that explains the most of it. A
    payload changes the weights of the model's gravity and inertia columns: what they then add is a
    posture term, not a position harmonic that the validation test's selection may have taken first.
    None when the re-weighting adds nothing."""
    active = np.sqrt(np.mean(y_j * y_j, axis=0)) > 0
    if not np.any(active) or not groups:
        return None
    y = y_j[:, active]
    r = y @ np.linalg.lstsq(y, e_j, rcond=None)[0]
    total = float(r @ r)
    if not total > 0:
        return None
    shares = {}
    for g, x in groups.items():
        left = r - x @ np.linalg.lstsq(x, r, rcond=None)[0]
        shares[g] = 1.0 - float(left @ left) / total
    # the largest share, not the fewest columns near it: every group is fitted to the same torque
    # of the model's own columns, which a slowly moving joint's constant-like columns all nearly fit
    return max(shares, key=lambda g: (shares[g], -groups[g].shape[1]))
