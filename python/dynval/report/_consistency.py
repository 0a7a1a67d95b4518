"""Physical consistency of a robot's dynamic parameters (docs/conventions.md §8).

A model can predict a run well and still be no robot at all. Three questions, one module:

* **Is this parameter set a robot?** (:func:`check_parameters`.) Per link, the ten parameters
  ``m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz`` (pinocchio's order; first moment ``h = m·c`` and
  inertia ``I`` about the joint frame's origin) have a density that realises them if and only if
  the 4×4 *pseudo-inertia*

      J = [[Σ, h], [hᵀ, m]],    Σ = ½ tr(I)·1 − I     (J = ∫ [x; 1][x; 1]ᵀ ρ(x) dV)

  is positive semidefinite (Wensing, Kim & Slotine 2017). With ``m > 0``, J ⪰ 0 is the same as its
  Schur complement ``Σ_C = Σ − h hᵀ/m = ½ tr(I_C)·1 − I_C`` being PSD, ``I_C`` the inertia about the
  centre of mass; the eigenvalues of Σ_C are ``(I_j + I_k − I_i)/2`` for the principal moments, so
  the condition is the triangle inequality ``I_1 + I_2 ≥ I_3`` of the sorted principal moments
  (which also makes them positive). The check therefore names the link, reports the mass if it is
  not positive, and otherwise the triangle inequality's deficit ``I_3 − I_1 − I_2`` (kg·m²), with
  the smallest eigenvalue of J beside it. A centre of mass outside a box given for its link, and a
  viscous or Coulomb friction coefficient below zero (friction that pushes instead of resisting),
  are findings too.
* **Do identified base parameters come from some robot?** (:func:`base_consistency`.) Least
  squares identifies only the base combinations ``β = K π``; β̂ is consistent when some π with every
  link's J ⪰ 0 and friction ≥ 0 maps to it. The distance ``d² = min (Kπ − β̂)ᵀ Cov(β̂)⁻¹ (Kπ − β̂)``
  over consistent π is a convex problem (a semidefinite program). When the true parameters are
  consistent, d² is at most the Mahalanobis distance of β̂ from the truth, so ``P(χ²_r > d²)`` is an
  upper bound of its p-value whatever the shape of the consistent set. ``d²/(rows − r)`` is the
  share of the estimation run's residual mean square that a consistent robot costs (the practical effect).
* **Identification under the constraints** (:func:`constrained_fit`, ``identify(physical=True)``).
  The same program with the data's own metric: ``min ‖W(Aπ − b)‖²/σ̂² + λ‖π − π₀‖²`` over consistent
  π, A reduced to its R factor first (one QR of ``[A b]``: ‖Aπ − b‖² = ‖R₁₁π − r₁₂‖² + r₂₂²), and
  solved in working units (:func:`_working_units`) so that its answer does not depend on the units of
  the torques or of the regressor (contract §8). The
  Euclidean prior π₀ (the URDF's a-priori values, or zero) with a small weight makes the answer
  unique in the directions the data cannot see; column c's λ_c is ``prior_weight`` times the
  curvature of the data term in its link (:func:`_column_weights`), so ``prior_weight`` is unit-free and
  the balance between links does not depend on their units. The entropic prior replaces each link's
  Euclidean term by the Bregman divergence of −log det between its pseudo-inertia and the prior's
  (Lee & Park 2018), which keeps J positive definite (:func:`_prior_term`).

The decision variables of the programs are the pseudo-inertias themselves (4×4 symmetric, ⪰ 0),
the friction coefficients (≥ 0) and the free columns; π is a linear function of them. The solver
is cvxpy (the ``physical`` extra) with Clarabel, an interior-point conic solver (SCS if Clarabel is
missing). Its answer is feasible to the solver's tolerance; the pseudo-inertias' eigenvalues are
then clipped at zero and the friction at zero, so that the returned parameters pass
:func:`check_parameters` exactly.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import scipy.linalg
    import scipy.stats
else:
    from .._lazy import scipy

from ..checks._errors import InputError, InvalidParameter
from ..checks._typing import FloatArray, IntArray
from ..checks._validation import check_finite, format_value, is_real_number, parameter_error, to_float_array
from ._findings import Finding
from ._text import p_clause

__all__ = [
    "PARAM_NAMES",
    "Layout",
    "layout",
    "pseudo_inertia",
    "from_pseudo_inertia",
    "check_parameters",
    "BaseConsistency",
    "base_consistency",
    "base_findings",
    "constrained_fit",
    "resolve",
    "findings",
    "report_findings",
    "INSTALL_HINT",
]

PARAM_NAMES = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
"""pinocchio's order of the ten dynamic parameters of a body."""

INSTALL_HINT = "pip install 'dynval[physical]' (cvxpy, with its default solver Clarabel)"

TOLERANCE = 1e-9
# Inertia about the centre of mass beyond this (kg·m²) comes from a mass tiny against its first moment:
# the data range is 1e144 (contract §1.2), so such a link is no body, and its moments are not computed.
_FAR = 1e150
"""A triangle-inequality deficit or a centre-of-mass excursion smaller than this share of the
link's largest principal moment, about its centre of mass or about the joint frame's origin
(or of the box's size), is rounding (a URDF printed to 16 digits, a solver's answer, the
parallel-axis subtraction of a point mass off the origin), not a finding."""

SHARE_THRESHOLD = 0.01
"""The practical effect of base parameters outside the consistent set: the share of the estimation
run's residual mean square that the nearest consistent robot adds (0.01, conventions §5.3's missing_term)."""

_FRICTION = {"Fv": ("viscous", "N·m·s/rad"), "Fc": ("Coulomb", "N·m")}
_ACTION_LINK = ("identify under physical constraints (URDFModel.identify(..., physical=True)) or correct "
                "the link's inertial parameters")
_ACTION_FRICTION = ("identify under physical constraints (URDFModel.identify(..., physical=True)) or model "
                    "the effect the negative coefficient absorbs (an offset, a torque-sensor error)")


@dataclass(frozen=True)
class Layout:
    """Where each link's ten parameters and each friction coefficient sit among the columns.

    ``link_columns[k, i]`` is the column of link k's parameter ``PARAM_NAMES[i]`` (-1 when absent:
    the model fixes it at zero); ``friction`` holds ``(joint, "Fv" | "Fc", column)``. Link k is moved
    by joint k (the order of :meth:`dynval.robots.URDFModel.column_names`).
    """

    column_names: tuple[str, ...]
    links: tuple[str, ...]
    link_columns: IntArray
    friction: tuple[tuple[int, str, int], ...]
    joint_names: tuple[str, ...]

    @property
    def n_columns(self) -> int:
        return len(self.column_names)

    def joint_label(self, j: int) -> str:
        return self.joint_names[j] if j < len(self.joint_names) else f"joint {j + 1}"

    def link_label(self, k: int) -> str:
        return f"{self.links[k]} ({self.joint_label(k)})"


def layout(column_names: Sequence[str], joint_names: Sequence[str] | None = None) -> Layout:
    """The :class:`Layout` of columns named as :meth:`dynval.robots.URDFModel.column_names` names them.

    ``<link>:<param>`` (param in :data:`PARAM_NAMES`) is a link's parameter, ``Fv_<joint>`` and
    ``Fc_<joint>`` its joint's viscous and Coulomb friction; any other column is free.
    """
    names = tuple(column_names)
    links: dict[str, list[int]] = {}
    friction: list[tuple[str, str, int]] = []
    for c, name in enumerate(names):
        link, _, param = name.rpartition(":")
        if link and param in PARAM_NAMES:
            links.setdefault(link, [-1] * 10)[PARAM_NAMES.index(param)] = c
        elif name[:3] in ("Fv_", "Fc_") and len(name) > 3:
            friction.append((name[3:], name[:2], c))
    joints = list(joint_names) if joint_names is not None else []
    for joint, _, _ in friction:
        if joint not in joints:
            joints.append(joint)
    columns = np.array(list(links.values()), dtype=np.int64).reshape(len(links), 10)
    return Layout(names, tuple(links), columns, tuple((joints.index(j), kind, c) for j, kind, c in friction),
                  tuple(joints))


def pseudo_inertia(params: FloatArray) -> FloatArray:
    """The 4×4 pseudo-inertia ``[[½tr(I)·1 − I, h], [hᵀ, m]]`` of ten parameters in pinocchio's order."""
    m, h, (ixx, ixy, iyy, ixz, iyz, izz) = params[0], params[1:4], params[4:10]
    inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    out = np.empty((4, 4))
    out[:3, :3] = 0.5 * np.trace(inertia) * np.eye(3) - inertia
    out[:3, 3] = out[3, :3] = h
    out[3, 3] = m
    return out


def from_pseudo_inertia(j: FloatArray) -> FloatArray:
    """The ten parameters (pinocchio's order) of a pseudo-inertia: ``I = tr(Σ)·1 − Σ``."""
    sigma = 0.5 * (j[:3, :3] + j[:3, :3].T)
    inertia = np.trace(sigma) * np.eye(3) - sigma
    return np.array([j[3, 3], j[0, 3], j[1, 3], j[2, 3], inertia[0, 0], inertia[0, 1], inertia[1, 1],
                     inertia[0, 2], inertia[1, 2], inertia[2, 2]])


def link_parameters(values: FloatArray, lay: Layout) -> FloatArray:
    """``(n_links, 10)``: each link's parameters from the full vector (0 where a column is absent)."""
    padded = np.append(values, 0.0)
    out: FloatArray = padded[lay.link_columns]
    return out


# --------------------------------------------------------------------------- the check


def resolve_com_bounds(com_bounds: Any, links: Sequence[str]) -> dict[str, tuple[FloatArray, FloatArray]]:
    """``None``; one ``(lower, upper)`` pair of 3-vectors (m, joint frame) for every link; or a
    mapping link → pair. Returns link → (lower, upper), checked."""
    if com_bounds is None:
        return {}
    requirement = "None, a pair (lower, upper) of 3-vectors with lower <= upper, or a mapping link -> such a pair"
    pairs = com_bounds.items() if isinstance(com_bounds, Mapping) else [(link, com_bounds) for link in links]
    out = {}
    for link, pair in pairs:
        if link not in links:
            raise parameter_error("com_bounds", f"a mapping whose keys are among the links {list(links)}", link)
        try:
            lower, upper = (to_float_array(x, "com_bounds").reshape(3) for x in pair)
        except (TypeError, ValueError):
            raise parameter_error("com_bounds", requirement, com_bounds) from None
        if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper)) and np.all(lower <= upper)):
            raise parameter_error("com_bounds", requirement, com_bounds)
        out[str(link)] = (lower, upper)
    return out


def _mass_finding(lay: Layout, k: int, m: float, columns: tuple[int, ...]) -> Finding:
    return Finding(
        kind="physical_consistency", severity="deficiency", joints=(k,), columns=columns,
        effect=0.0 - m, effect_unit="kg", threshold=0.0, action=_ACTION_LINK,
        details={"link": lay.links[k], "condition": "mass > 0", "mass": m},
        message=f"{lay.link_label(k)}: mass {m:.4g} kg is not positive: no body has it (condition mass > 0).")


def _inertia_finding(lay: Layout, k: int, p10: FloatArray, tolerance: float,
                     columns: tuple[int, ...]) -> Finding | None:
    """The triangle inequality of the principal moments about the centre of mass (J ⪰ 0 with m > 0)."""
    m, h = float(p10[0]), p10[1:4]
    with np.errstate(over="ignore", invalid="ignore"):
        sigma_c = pseudo_inertia(p10)[:3, :3] - np.outer(h, h) / m  # Schur complement: ½tr(I_C)·1 − I_C
        inertia_c = np.trace(sigma_c) * np.eye(3) - sigma_c
    if not np.all(np.abs(inertia_c) <= _FAR):
        return _far_centre_finding(lay, k, p10, columns)
    moments = np.linalg.eigvalsh(inertia_c)                        # principal moments about the CoM
    deficit = float(moments[2] - moments[0] - moments[1])          # = −2 λ_min(Σ_C)
    # I_C = I − m(|c|²·1 − c cᵀ) rounds at the scale of the inertia about the joint frame's origin
    # (a point mass off the origin has I_C = 0 up to that rounding): the tolerance is relative to both
    j = pseudo_inertia(p10)
    inertia_o = np.trace(j[:3, :3]) * np.eye(3) - j[:3, :3]      # about the joint frame's origin
    scale = max(abs(float(moments[2])), float(np.max(np.abs(np.linalg.eigvalsh(inertia_o)))))
    if deficit <= tolerance * max(scale, np.finfo(float).tiny):
        return None
    lam = float(np.linalg.eigvalsh(j)[0])
    i1, i2, i3 = (float(x) for x in moments)
    return Finding(
        kind="physical_consistency", severity="deficiency", joints=(k,), columns=columns,
        effect=deficit, effect_unit="kg·m²", threshold=0.0, action=_ACTION_LINK,
        details={"link": lay.links[k], "condition": "pseudo-inertia positive semidefinite",
                 "pseudo_inertia_min_eigenvalue": lam, "principal_moments": [i1, i2, i3],
                 "centre_of_mass": (h / m).tolist(), "mass": m},
        message=(f"{lay.link_label(k)}: no mass distribution has these inertial parameters: about the centre "
                 f"of mass the principal moments {i1:.4g}, {i2:.4g}, {i3:.4g} kg·m² break the triangle "
                 f"inequality I1 + I2 >= I3 by {deficit:.3g} kg·m² (the pseudo-inertia's smallest "
                 f"eigenvalue is {lam:.3g}; condition: pseudo-inertia positive semidefinite)."))


def _far_centre_finding(lay: Layout, k: int, p10: FloatArray, columns: tuple[int, ...]) -> Finding:
    """A mass so small against its first moment that m·c·cᵀ leaves float64 (a subnormal mass, say).

    Every inertia about the joint frame is at most 1e144 (contract §1.2), and ``h hᵀ/m`` is beyond
    _FAR, so the Schur complement ``Σ − h hᵀ/m`` is not positive semidefinite: no body has these
    parameters. The pseudo-inertia's smallest eigenvalue is taken of J scaled to unit size, where
    nothing overflows.
    """
    m, h = float(p10[0]), p10[1:4]
    j = pseudo_inertia(p10)
    size = float(np.max(np.abs(j)))
    lam = float(np.linalg.eigvalsh(j / size)[0]) * size
    first = ", ".join(f"{x:.4g}" for x in h)
    return Finding(
        kind="physical_consistency", severity="deficiency", joints=(k,), columns=columns,
        effect=abs(lam), effect_unit="kg·m²", threshold=0.0, action=_ACTION_LINK,
        details={"link": lay.links[k], "condition": "pseudo-inertia positive semidefinite",
                 "pseudo_inertia_min_eigenvalue": lam, "principal_moments": None, "centre_of_mass": None,
                 "mass": m},
        message=(f"{lay.link_label(k)}: no mass distribution has these inertial parameters: the mass "
                 f"{m:.4g} kg is too small for the first moment ({first}) kg·m, which puts the centre of mass "
                 f"beyond any robot (more than 1e150 kg·m² of inertia about it; the pseudo-inertia's smallest "
                 f"eigenvalue is {lam:.3g}; condition: pseudo-inertia positive semidefinite)."))


def _com_finding(lay: Layout, k: int, p10: FloatArray, box: tuple[FloatArray, FloatArray], tolerance: float,
                 columns: tuple[int, ...]) -> Finding | None:
    lower, upper = box
    with np.errstate(over="ignore"):
        c = p10[1:4] / p10[0]
    if not np.all(np.isfinite(c)):  # a centre beyond float64: the far-centre finding of this link says it
        return None
    outside = float(np.max(np.concatenate([lower - c, c - upper, [0.0]])))
    if outside <= tolerance * max(float(np.max(np.abs(np.concatenate([lower, upper])))), 1e-300):
        return None
    where = ", ".join(f"{x:.4g}" for x in c)
    return Finding(
        kind="physical_consistency", severity="deficiency", joints=(k,), columns=columns,
        effect=outside, effect_unit="m", threshold=0.0, action=_ACTION_LINK,
        details={"link": lay.links[k], "condition": "centre of mass inside its box", "centre_of_mass": c.tolist(),
                 "lower": lower.tolist(), "upper": upper.tolist()},
        message=(f"{lay.link_label(k)}: the centre of mass ({where}) m lies {outside:.3g} m outside the box "
                 f"given for it (condition: centre of mass inside its box)."))


def check_parameters(values: FloatArray, lay: Layout, *, com_bounds: object = None,
                     tolerance: float = TOLERANCE) -> list[Finding]:
    """Every violated condition of a full parameter vector, one finding each (links, then friction).

    Per link: mass > 0; then the pseudo-inertia PSD (as the triangle inequality about the centre
    of mass, module notes); then the centre of mass inside its box when one is given. Per
    friction column: the coefficient ≥ 0.
    """
    boxes = resolve_com_bounds(com_bounds, lay.links)
    out: list[Finding] = []
    for k, p10 in enumerate(link_parameters(values, lay)):
        columns = tuple(int(c) for c in lay.link_columns[k] if c >= 0)
        if not p10[0] > 0:
            out.append(_mass_finding(lay, k, float(p10[0]), columns))
            continue
        found = _inertia_finding(lay, k, p10, tolerance, columns)
        if found is not None:
            out.append(found)
        if lay.links[k] in boxes:
            found = _com_finding(lay, k, p10, boxes[lay.links[k]], tolerance, columns)
            if found is not None:
                out.append(found)
    for joint, kind, c in lay.friction:
        value = float(values[c])
        if value >= 0:
            continue
        what, unit = _FRICTION[kind]
        out.append(Finding(
            kind="physical_consistency", severity="deficiency", joints=(joint,), columns=(c,),
            effect=-value, effect_unit=unit, threshold=0.0, action=_ACTION_FRICTION,
            details={"joint": lay.joint_label(joint), "condition": f"{what} friction >= 0", "value": value},
            message=(f"{lay.joint_label(joint)}: {what} friction {kind} = {value:.4g} {unit} is negative: friction "
                     f"that pushes instead of resisting (condition {kind} >= 0).")))
    return out


# --------------------------------------------------------------------------- the convex programs


def import_cvxpy(what: str) -> Any:
    """cvxpy, or an ImportError that names the extra to install."""
    try:
        import cvxpy
    except ImportError as exc:
        raise ImportError(f"{what} needs cvxpy: {INSTALL_HINT}") from exc
    return cvxpy


def _from_j_matrix() -> FloatArray:
    """The (10, 16) map from vec(J) (column-major) to the ten parameters: m = J₃₃, h = J[:3, 3],
    I = tr(Σ)·1 − Σ, i.e. Ixx = Σ₁₁ + Σ₂₂, Ixy = −Σ₀₁, ... (:func:`from_pseudo_inertia`, linear)."""
    out = np.zeros((10, 16))
    for k in range(16):
        unit = np.zeros(16)
        unit[k] = 1.0
        out[:, k] = from_pseudo_inertia(unit.reshape(4, 4, order="F"))
    return out


_FROM_J = _from_j_matrix()


@dataclass
class _Program:
    """π as a linear function of the decision variables, and the constraints that keep it a robot."""

    pi: Any
    constraints: list[Any]
    lmis: list[Any] = field(default_factory=list)
    friction: Any = None
    pseudo_inertias: list[Any] = field(default_factory=list)


def _program(cp: Any, lay: Layout, boxes: dict[str, tuple[FloatArray, FloatArray]]) -> _Program:
    p = lay.n_columns
    terms, constraints, lmis = [], [], []
    used = np.zeros(p, dtype=bool)
    for k, cols in enumerate(lay.link_columns):
        jk = cp.Variable((4, 4), symmetric=True, name=f"J_{lay.links[k]}")
        lmi = jk >> 0
        lmis.append(lmi)
        constraints.append(lmi)
        vec = cp.vec(jk, order="F")
        present = cols >= 0
        place = np.zeros((p, 16))
        place[cols[present]] = _FROM_J[present]
        terms.append(place @ vec)
        if not present.all():
            constraints.append(_FROM_J[~present] @ vec == 0)      # an absent column: the model's zero
        used[cols[present]] = True
        if lay.links[k] in boxes:
            lower, upper = boxes[lay.links[k]]
            constraints += [jk[:3, 3] >= jk[3, 3] * lower, jk[:3, 3] <= jk[3, 3] * upper]
    bound = None
    if lay.friction:
        fric = cp.Variable(len(lay.friction), name="friction")
        place = np.zeros((p, len(lay.friction)))
        place[[c for _, _, c in lay.friction], np.arange(len(lay.friction))] = 1.0
        used[[c for _, _, c in lay.friction]] = True
        terms.append(place @ fric)
        bound = fric >= 0
        constraints.append(bound)
    free = np.flatnonzero(~used)
    if free.size:
        u = cp.Variable(free.size, name="free")
        place = np.zeros((p, free.size))
        place[free, np.arange(free.size)] = 1.0
        terms.append(place @ u)
    pi = terms[0]
    for term in terms[1:]:
        pi = pi + term
    return _Program(pi=pi, constraints=constraints, lmis=lmis, friction=bound,
                    pseudo_inertias=[lmi.args[0] for lmi in lmis])


def _prior_term(cp: Any, prog: _Program, lay: Layout, prior: FloatArray | None, w: FloatArray,
                metric: str, d: FloatArray) -> Any:
    """``Σ_c w_c·(π_c − prior_c)²`` (Euclidean; ``π = d·π̂``, ``d`` from :func:`_working_units`, ``w``
    from :func:`_column_weights`), or with ``metric="entropic"`` each link's Bregman divergence of
    −log det, ``2·w_k·‖J₀‖²_F·(tr(J₀⁻¹J) − log det J + log det J₀ − 4)`` (w_k its columns' weight; near
    J₀ of the order of ``w_k·‖J − J₀‖²_F``, so that ``prior_weight`` reads alike; the constants are left
    out of the objective; the divergence itself does not depend on the units), and the Euclidean term
    for the other columns (friction, offsets)."""
    target = 0.0 if prior is None else prior
    # √w·d in one constant: the solver sees the same numbers whatever the units (w and d apart would
    # carry the units' powers into the program)
    root = np.sqrt(w) * d
    if metric != "entropic":
        return cp.sum_squares(cp.multiply(root, prog.pi - target))
    rest = np.ones(lay.n_columns, dtype=bool)
    terms = []
    for k, jk in enumerate(prog.pseudo_inertias):
        j0 = pseudo_inertia(link_parameters(np.asarray(prior), lay)[k])
        terms.append(_link_prior_weight(lay, w, d, k) * float(np.sum(j0**2))
                     * (cp.trace(np.linalg.inv(j0) @ jk) - cp.log_det(jk)))
        rest[lay.link_columns[k][lay.link_columns[k] >= 0]] = False
    if rest.any():
        keep = np.flatnonzero(rest)
        terms.append(cp.sum_squares(cp.multiply(root[keep], prog.pi[keep] - np.asarray(prior)[rest])))
    return cp.sum(cp.hstack(terms)) if len(terms) > 1 else terms[0]


def _link_prior_weight(lay: Layout, w: FloatArray, d: FloatArray, k: int) -> float:
    """2·w_k·s_k²: the entropic term's factor of ‖J₀‖²_F for link k in working units."""
    cols = lay.link_columns[k][lay.link_columns[k] >= 0]
    return 2.0 * float(w[cols[0]]) * _link_scale(lay, d, k) ** 2 if cols.size else 0.0


def _link_scale(lay: Layout, d: FloatArray, k: int) -> float:
    """Link k's scale s_k (every present column of the link has it, :func:`_working_units`)."""
    cols = lay.link_columns[k][lay.link_columns[k] >= 0]
    return float(d[cols[0]]) if cols.size else 1.0


def _objective_scale(g_mat: FloatArray, w: FloatArray, prior: FloatArray | None, lay: Layout, metric: str,
                     d: FloatArray) -> float:
    """With the entropic prior, the size of the objective's curvature (the data term's mean plus the
    prior's largest), by which the objective is divided; 1 otherwise (the Euclidean programs solve
    as they are)."""
    if metric != "entropic" or prior is None or not np.any(w > 0):
        return 1.0
    data = float(np.sum(g_mat**2)) / max(g_mat.shape[1], 1)
    largest = max((0.5 * _link_prior_weight(lay, w, d, k) * float(np.sum(pseudo_inertia(p10) ** 2))
                   for k, p10 in enumerate(link_parameters(prior, lay))), default=0.0)
    return float(max(data, 1e-300) + largest)


def _pow2(x: FloatArray) -> FloatArray:
    """The power of two nearest each positive x (in the logarithm)."""
    return np.ldexp(1.0, np.rint(np.log2(x)).astype(np.int64))


def _working_units(lay: Layout, g_mat: FloatArray, metric: str, prior: FloatArray | None, weight: float) -> FloatArray:
    """d: the program is solved for π̂ with π = d·π̂ (contract §8). G and g are already in units of the
    noise (divided by σ̂), so the torques' unit is gone from the data term but not from π; d per column
    is the power of two nearest 1/‖G_c‖, one value per link (the geometric mean of its columns' norms:
    the pseudo-inertia's cone holds J ⪰ 0 for any positive multiple of J, not for each entry scaled
    apart; the centre-of-mass boxes and absent columns are homogeneous too), one per friction
    coefficient and free column. The solver then sees a data matrix G·d with columns near unit norm
    whatever the units of the torques and of the regressor: a unit changed by a power of two gives the
    same data matrix bit for bit (and, up to the rounding of the prior's weights, the same program).
    A column of zeros takes the geometric mean of the others. With the entropic prior the exponential
    cones of log det converge with the parameters near unit size: one d for every column, the power of
    two nearest the prior's largest |value| (the prior carries the parameters' units as the data do)."""
    if metric == "entropic" and prior is not None and weight > 0 and np.any(np.asarray(prior) != 0):
        return np.full(g_mat.shape[1], _pow2(np.array([np.max(np.abs(prior))]))[0])
    return _pow2(np.exp2(-_log_link_norms(lay, g_mat)))


def _log_link_norms(lay: Layout, g_mat: FloatArray) -> FloatArray:
    """log₂ of each column's norm in G, the geometric mean over a link's ten columns; a column of
    zeros (or a link of them) takes the geometric mean of the nonzero columns (1 without any)."""
    with np.errstate(over="ignore", under="ignore", divide="ignore"):
        norms = np.sqrt(np.einsum("ij,ij->j", g_mat, g_mat))
    live = (norms > 0) & np.isfinite(norms)
    typical = float(np.mean(np.log2(norms[live]))) if live.any() else 0.0
    log_n = np.full(norms.shape, typical)
    log_n[live] = np.log2(norms[live])
    for cols in lay.link_columns:
        cols = cols[cols >= 0]
        known = cols[live[cols]]
        log_n[cols] = np.mean(log_n[known]) if known.size else typical
    return log_n


def _column_weights(lay: Layout, g_mat: FloatArray, weight: float) -> FloatArray:
    """The Euclidean prior's weight of each column: ``weight`` (prior_weight × the data term's mean
    curvature ΣG²/p) times its link's curvature ‖G_c‖² over that mean (:func:`_log_link_norms`), i.e.
    prior_weight × its own link's curvature. A column's unit then scales its weight as it scales the
    square of its parameter's change, and the prior's balance between links and friction does not
    depend on their units (with one weight for all, a link in a unit 1e6 times smaller would pull the
    others towards the prior 1e12 times harder)."""
    mean = float(np.sum(g_mat**2)) / max(g_mat.shape[1], 1)
    if not weight > 0 or not mean > 0 or not np.isfinite(mean):
        return np.full(g_mat.shape[1], float(weight))
    out: FloatArray = float(weight) * np.exp2(2.0 * _log_link_norms(lay, g_mat)) / mean
    return out




def _solve(lay: Layout, g_mat: FloatArray, g_vec: FloatArray, *, com_bounds: object = None,
           prior: FloatArray | None = None, weight: float = 0.0, metric: str = "euclidean",
           what: str = "physical consistency") -> dict[str, Any]:
    """``min ‖G π − g‖² + (the prior's term)`` over consistent π; the clipped π and the solver's record.

    Solved in working units (:func:`_working_units`): ``‖(G d) π̂ − g‖²`` and the prior's term over
    π̂ = π/d, which is consistent exactly when π is; the answer and the duals are put back in the
    units given."""
    cp = import_cvxpy(what)
    d = _working_units(lay, g_mat, metric, prior, weight)
    g_w = g_mat * d
    prior_w = None if prior is None else np.asarray(prior, dtype=float) / d
    prog = _program(cp, lay, resolve_com_bounds(com_bounds, lay.links))
    objective = cp.sum_squares(g_w @ prog.pi - g_vec)
    w = _column_weights(lay, g_mat, weight)
    if weight > 0:
        objective = objective + _prior_term(cp, prog, lay, prior_w, w, metric, d)
    # one overall scale keeps the conic solver's numbers moderate when the entropic prior's weight is
    # large (the exponential cones of log det fail to converge beyond a weight of about 100 otherwise)
    scale = _objective_scale(g_w, w, prior_w, lay, metric, d)
    problem = cp.Problem(cp.Minimize(objective / scale), prog.constraints)
    solver = "CLARABEL" if "CLARABEL" in cp.installed_solvers() else "SCS"
    start = time.perf_counter()
    try:
        problem.solve(solver=solver)
    except cp.error.SolverError as exc:
        raise RuntimeError(f"{what}: the solver {solver} failed ({exc})") from None
    elapsed = time.perf_counter() - start
    if problem.status not in ("optimal", "optimal_inaccurate"):
        raise RuntimeError(f"{what}: the solver {solver} ended with status {problem.status!r}")
    raw = d * np.asarray(prog.pi.value, dtype=float)
    clipped = _clip(raw, lay)
    status = _checked_status(str(problem.status), g_w, g_vec, raw / d, clipped / d)
    # the duals in the units given: the objective was divided by scale, link k's J and friction
    # coefficient i by their d (a dual is the objective's rate per unit of its constraint)
    link_d = [_link_scale(lay, d, k) for k in range(len(lay.links))]
    # the duals in working units are unit-free (a relaxation by one working unit moves the fit by
    # about one noise σ): what decides which constraints bind (:func:`_binding`)
    unit_free = ([scale * float(np.trace(c.dual_value)) for c in prog.lmis],
                 [] if prog.friction is None else (scale * np.asarray(prog.friction.dual_value)).tolist())
    return {"pi": clipped, "unit_free_duals": unit_free, "solver": solver, "status": status,
            "solve_time": elapsed, "solver_time": float(problem.solver_stats.solve_time or 0.0),
            "lmi_duals": [scale / s_k * float(np.trace(c.dual_value)) for c, s_k in zip(prog.lmis, link_d)],
            "friction_duals": ([] if prog.friction is None
                               else (scale / np.array([d[c] for _, _, c in lay.friction])
                                     * np.asarray(prog.friction.dual_value)).tolist())}


CLIP_TOLERANCE = 1e-6
"""The share of the data term by which the clip of the solver's answer may raise it for the answer
still to be called ``optimal``: a solver within its tolerance moves it by about 1e-10."""


def _checked_status(status: str, g_w: FloatArray, g_vec: FloatArray, raw_w: FloatArray, clipped_w: FloatArray) -> str:
    """The solver's status, or ``optimal_inaccurate`` when its "optimal" answer lay so far outside the
    consistent set that clipping it raised the data term ‖G π − g‖² (working units, in units of the
    noise) by more than :data:`CLIP_TOLERANCE` of it (and of 1): the answer returned is then not the
    optimum the status claims."""
    if status != "optimal":
        return status
    with np.errstate(over="ignore", invalid="ignore"):
        before = float(np.sum((g_w @ raw_w - g_vec) ** 2))
        after = float(np.sum((g_w @ clipped_w - g_vec) ** 2))
    if not np.isfinite(after) or after - before > CLIP_TOLERANCE * max(1.0, before):
        return "optimal_inaccurate"
    return status


def _clip(values: FloatArray, lay: Layout) -> FloatArray:
    """Each link's pseudo-inertia with its eigenvalues clipped at zero, friction at zero: the
    solver's answer made consistent exactly (the change is of the solver's tolerance)."""
    out: FloatArray = np.array(values, dtype=float)
    for k, p10 in enumerate(link_parameters(values, lay)):
        lam, vec = np.linalg.eigh(pseudo_inertia(p10))
        fixed = from_pseudo_inertia((vec * np.clip(lam, 0.0, None)) @ vec.T)
        present = lay.link_columns[k] >= 0
        out[lay.link_columns[k][present]] = fixed[present]
    for _, _, c in lay.friction:
        out[c] = max(out[c], 0.0)
    return out


# --------------------------------------------------------------------------- base parameters


@dataclass(frozen=True)
class BaseConsistency:
    """How far identified base parameters are from every physically consistent robot.

    Attributes
    ----------
    distance2 : float
        ``d² = min (Kπ − β̂)ᵀ Cov(β̂)⁻¹ (Kπ − β̂)`` over consistent full parameters π.
    dof : int
        The number of base parameters r (the χ² bound's degrees of freedom).
    pvalue : float
        ``P(χ²_r > d²)``: an upper bound of the p-value of "the true parameters are consistent".
    share : float
        ``d²/(rows − r)``: the share of the estimation run's (weighted) residual mean square that the
        nearest consistent robot adds, when the covariance is the fit's own.
    nearest_base, nearest_full : ndarray
        ``Kπ*`` and π*, the nearest consistent parameters (π* is one of possibly many).
    binding : tuple of (str, int, tuple of int)
        The constraints that hold β̂ away: ``(label, joint, columns)`` of each link pseudo-inertia
        and friction bound whose dual (the rate at which d² falls as the bound is relaxed, in the
        program's working units: unit-free) exceeds ``1e-4·max(1, d²)``, largest first within links,
        then friction.
    solver : dict
        Solver name, status, times, and the duals of each link's LMI (trace) and friction bound.
    """

    distance2: float
    dof: int
    pvalue: float
    share: float
    nearest_base: FloatArray
    nearest_full: FloatArray
    binding: tuple[tuple[str, int, tuple[int, ...]], ...]
    solver: dict[str, Any]


def _whitener(cov: FloatArray) -> FloatArray:
    """``U`` with ``xᵀ Cov⁺ x = ‖U x‖²`` (eigen-decomposition: a singular covariance is allowed)."""
    lam, vec = np.linalg.eigh(0.5 * (cov + cov.T))
    keep = lam > lam.max() * cov.shape[0] * np.finfo(float).eps
    out: FloatArray = (vec[:, keep] / np.sqrt(lam[keep])).T
    return out


def base_consistency(result: Any, *, covariance: FloatArray | None = None, com_bounds: object = None,
                     joint_names: Sequence[str] | None = None) -> BaseConsistency:
    """The distance of an :class:`~dynval.identify.IdentificationResult`'s base estimate to the
    physically consistent set, in the metric of its covariance (or of ``covariance``)."""
    lay = layout(result.column_names, joint_names)
    if not len(lay.links) and not lay.friction:
        raise parameter_error("result", "an identification whose column names name link parameters "
                              "('<link>:m', ...) or friction ('Fv_<joint>', 'Fc_<joint>')",
                              list(result.column_names[:3]))
    cov = np.asarray(result.covariance if covariance is None else covariance, dtype=float)
    r = int(result.rank)
    if cov.shape != (r, r) or not np.all(np.isfinite(cov)):
        raise parameter_error("covariance", f"a finite ({r}, {r}) matrix", f"shape {cov.shape}")
    u = _whitener(cov)
    k_mat = np.asarray(result.combination, dtype=float)
    beta = np.asarray(result.estimate, dtype=float)
    solved = _solve(lay, u @ k_mat, u @ beta, com_bounds=com_bounds,
                    what="physical_consistency of identified base parameters")
    nearest = k_mat @ solved["pi"]
    d2 = float(np.sum((u @ (nearest - beta)) ** 2))
    dof_resid = int(result.rows) - r
    return BaseConsistency(
        distance2=d2, dof=r, pvalue=float(scipy.stats.chi2.sf(d2, r)),
        share=d2 / dof_resid if dof_resid > 0 else float("nan"),
        nearest_base=nearest, nearest_full=solved["pi"], binding=_binding(lay, solved, d2),
        solver={k: v for k, v in solved.items() if k not in ("pi", "unit_free_duals")})


def _binding(lay: Layout, solved: dict[str, Any], d2: float) -> tuple[tuple[str, int, tuple[int, ...]], ...]:
    """The constraints with a dual above ``1e-4·max(1, d²)`` in working units (BaseConsistency.binding):
    unit-free, where a dual in the units given scales with the inverse of its parameters' unit."""
    floor = 1e-4 * max(1.0, d2)
    lmi_duals, friction_duals = solved["unit_free_duals"]
    links = [(dual, f"{lay.link_label(k)} pseudo-inertia", k, tuple(int(c) for c in lay.link_columns[k] if c >= 0))
             for k, dual in enumerate(lmi_duals) if dual > floor]
    friction = [(dual, f"{lay.joint_label(j)} {kind}", j, (c,))
                for (j, kind, c), dual in zip(lay.friction, friction_duals) if dual > floor]
    return tuple((label, j, cols) for _, label, j, cols in sorted(links, key=lambda x: -x[0])
                 + sorted(friction, key=lambda x: -x[0]))


def base_findings(bc: BaseConsistency, *, level: float = 0.95, threshold: float = SHARE_THRESHOLD,
                  tolerance: float = 1e-6) -> list[Finding]:
    """One finding when the base estimate lies outside the consistent set (``d²`` above the
    solver's ``tolerance``): a deficiency when ``P(χ²_r > d²) <= 1 − level`` and the share reaches
    ``threshold``, otherwise a note."""
    if not bc.distance2 > tolerance:
        return []
    alpha = 1.0 - level
    significant = bc.pvalue <= alpha
    big = significant and bc.share >= threshold
    verdict = ("no physically consistent robot fits the estimation run as well: the base parameters absorb "
               "something the rigid-body model lacks, or the noise" if big else
               ("significant but negligible" if significant else "within the estimate's uncertainty"))
    joints = tuple(dict.fromkeys(j for _, j, _ in bc.binding))
    columns = tuple(dict.fromkeys(c for _, _, cols in bc.binding for c in cols))
    held = ("; held away by " + ", ".join(label for label, _, _ in bc.binding)) if bc.binding else ""
    return [Finding(
        kind="physical_consistency", severity="deficiency" if big else "note", statistic=bc.distance2,
        joints=joints, columns=columns, pvalue=bc.pvalue, effect=bc.share,
        effect_unit="share of the estimation residual mean square", threshold=threshold,
        action=("identify under physical constraints (physical=True) and validate both on another run"
                if big else "none: a consistent robot fits about as well"),
        details={"condition": "base parameters of a physically consistent robot", "distance2": bc.distance2,
                 "dof": bc.dof, "share": bc.share, "level": level,
                 "binding": [label for label, _, _ in bc.binding]},
        message=(f"The identified base parameters are at Mahalanobis distance {np.sqrt(bc.distance2):.3g} "
                 f"(d² = {bc.distance2:.4g}, χ² bound with {bc.dof} df, p {p_clause(bc.pvalue)}) from the "
                 f"nearest physically consistent robot, which adds {100 * bc.share:.3g} % to the estimation "
                 f"run's residual mean square{held}: {verdict}."))]


# --------------------------------------------------------------------------- identification


PRIOR_METRICS = ("euclidean", "entropic")


def _check_prior(prior: object, prior_weight: float, p: int, metric: object = "euclidean",
                 lay: Layout | None = None) -> tuple[FloatArray | None, float]:
    if not is_real_number(prior_weight) or not 0 <= float(prior_weight) < np.inf:
        raise parameter_error("prior_weight", "a finite number >= 0", prior_weight)
    if not isinstance(metric, str) or metric not in PRIOR_METRICS:
        raise parameter_error("prior_metric", "one of 'euclidean', 'entropic'", metric)
    if prior is None:
        if metric == "entropic":
            raise parameter_error("prior", "given (one value per regressor column) with prior_metric='entropic'",
                                  prior)
        return None, float(prior_weight)
    values = to_float_array(prior, "prior").reshape(-1)
    if values.shape != (p,) or not np.all(np.isfinite(values)):
        raise parameter_error("prior", f"None or {p} finite numbers (one per regressor column)", prior)
    if metric == "entropic" and lay is not None:
        for k, p10 in enumerate(link_parameters(values, lay)):
            lam = float(np.linalg.eigvalsh(pseudo_inertia(p10))[0])
            if not lam > 0:
                raise parameter_error("prior", "parameters whose every link has a positive definite "
                                      f"pseudo-inertia with prior_metric='entropic' ({lay.links[k]}: smallest "
                                      f"eigenvalue {lam:.3g})", "...")
    return values, float(prior_weight)


def constrained_fit(a: FloatArray, b: FloatArray, sigma2: float, column_names: Sequence[str], *,
                    prior: object = None, prior_weight: float = 1e-6, prior_metric: str = "euclidean",
                    com_bounds: object = None, joint_names: Sequence[str] | None = None) -> dict[str, Any]:
    """Least squares ``‖Aπ − b‖²`` (rows already weighted) over physically consistent π (module notes).

    ``sigma2`` (the unconstrained fit's residual variance) scales the data term. Returns ``pi`` (the
    full parameters, clipped consistent) and the solver's record (``solver``, ``status``,
    ``solve_time``, the duals, ``prior_weight`` and the absolute ``weight``).
    """
    lay = layout(column_names, joint_names)
    if not len(lay.links) and not lay.friction:
        raise parameter_error("column_names", "names of link parameters ('<link>:m', '<link>:mx', ... as "
                              "URDFModel.column_names gives them) or friction ('Fv_<joint>', 'Fc_<joint>') "
                              "when physical=True", list(column_names[:3]))
    p = a.shape[1]
    prior_values, rel_weight = _check_prior(prior, prior_weight, p, prior_metric, lay)
    import_cvxpy("identify(physical=True)")
    r_aug = scipy.linalg.qr(np.column_stack([a, b]), mode="r", check_finite=False)[0][: p + 1]
    scale = np.sqrt(sigma2) if sigma2 > 0 and np.isfinite(sigma2) else 1.0
    g_mat, g_vec = r_aug[:p, :p] / scale, r_aug[:p, p] / scale
    weight = rel_weight * float(np.sum(g_mat**2)) / p
    solved = _solve(lay, g_mat, g_vec, com_bounds=com_bounds, prior=prior_values, weight=weight,
                    metric=prior_metric, what="identify(physical=True)")
    solved.pop("unit_free_duals")
    return {**solved, "prior_weight": rel_weight, "weight": weight, "prior_metric": prior_metric}


# --------------------------------------------------------------------------- what a caller hands in


def _is_urdf_model(source: object) -> bool:
    """A :class:`dynval.robots.URDFModel` (recognised by what is used of it, so that the report
    layer need not import the robotics layer)."""
    return all(callable(getattr(source, a, None)) for a in ("parameters", "column_names", "regressor")) and \
        hasattr(source, "joint_names")


# The robotics layer's URDF reader (dynval.robots.URDFModel), which registers itself when it is
# imported (``import dynval`` does): this layer is below it and cannot import it.
_urdf_reader: Callable[[Any], Any] | None = None


def register_urdf_reader(reader: Callable[[Any], Any]) -> None:
    """Called by :mod:`dynval.robots` with :class:`~dynval.robots.URDFModel`."""
    global _urdf_reader
    _urdf_reader = reader


def urdf_from_path(source: Any) -> Any:
    """A URDF file's path (str or os.PathLike) or XML text as a :class:`dynval.robots.URDFModel`;
    anything else unchanged. A file that cannot be read is InvalidParameter naming it."""
    if not isinstance(source, (str, os.PathLike)) or _urdf_reader is None:
        return source
    import xml.etree.ElementTree as ET

    def refused(why: str) -> InvalidParameter:
        return InvalidParameter(f"parameters must be a URDFModel, an IdentificationResult, a parameter vector or "
                                f"the path of a readable URDF file, got {format_value(os.fspath(source))} ({why})")

    is_text = isinstance(source, str) and source.lstrip().startswith("<")
    # a FIFO or a device would be read forever: only a regular file is opened
    if not is_text and os.path.exists(source) and not os.path.isfile(source):
        raise refused("not a regular file")
    try:
        return _urdf_reader(source)
    except OSError as exc:
        raise refused(exc.strerror or type(exc).__name__) from None
    except (ET.ParseError, UnicodeDecodeError) as exc:
        raise refused(f"not URDF XML: {exc}") from None
    except InputError:
        raise
    except (ValueError, RuntimeError) as exc:  # pinocchio's parser: XML, but no model it can build
        raise refused(f"not a URDF model: {str(exc).strip().splitlines()[0]}") from None


def resolve(source: Any, column_names: Sequence[str] | None = None,
            joint_names: Sequence[str] | None = None) -> tuple[FloatArray, Layout]:
    """A full parameter vector and its :class:`Layout` from a URDF model, an identification result
    with ``full_parameters``, or a vector (with ``column_names``, or ten per link)."""
    if _is_urdf_model(source):
        names = source.column_names(friction=True, offset=False)
        values = np.asarray(source.parameters(friction=True, offset=False), dtype=float)
        # a URDF's numbers are data as a vector's are: beyond 1e144 the pseudo-inertia overflows
        check_finite(values.reshape(1, -1), "parameters")
        return values, layout(names, source.joint_names if joint_names is None else joint_names)
    if getattr(source, "full_parameters", None) is not None:
        values = np.asarray(source.full_parameters, dtype=float)
        check_finite(values.reshape(1, -1), "parameters")
        return values, layout(source.column_names, joint_names)
    values = to_float_array(source, "parameters")
    if values.ndim == 2 and values.shape[1:] == (10,) and column_names is None:
        values = values.reshape(-1)
    if values.ndim != 1 or values.size == 0:
        # an empty vector has no link to check: "no finding" would read as a sound robot
        raise parameter_error("parameters", "a non-empty 1-D vector (or (n_links, 10) without column_names)",
                              f"shape {values.shape}")
    check_finite(values.reshape(1, -1), "parameters")
    if column_names is None:
        if values.size % 10:
            raise parameter_error("column_names", "given when the parameters are not ten per link "
                                  "(names as URDFModel.column_names gives them)", None)
        column_names = [f"link{k + 1}:{p}" for k in range(values.size // 10) for p in PARAM_NAMES]
    names = tuple(column_names)
    if len(names) != values.size or not all(isinstance(x, str) for x in names):
        raise parameter_error("column_names", f"a sequence of {values.size} strings (one per parameter)",
                              column_names)
    return values, layout(names, joint_names)


def findings(source: Any, *, column_names: Sequence[str] | None = None, joint_names: Sequence[str] | None = None,
             com_bounds: object = None, covariance: Any = None, level: float = 0.95,
             tolerance: float = TOLERANCE) -> list[Finding]:
    """:func:`dynval.robots.physical_consistency` (its documentation): the check of full
    parameters, or the distance of an unconstrained identification's base parameters."""
    # compared as given: float() of an integer beyond float64 (10**400) would be a raw OverflowError
    if not is_real_number(level) or not 0 < level < 1:
        raise parameter_error("level", "a number with 0 < level < 1", level)
    if not is_real_number(tolerance) or not 0 <= tolerance <= sys.float_info.max:
        raise parameter_error("tolerance", "a finite number >= 0", tolerance)
    source = urdf_from_path(source)
    if getattr(source, "full_parameters", 0) is None:
        cov = None if covariance is None else to_float_array(covariance, "covariance")
        bc = base_consistency(source, covariance=cov, com_bounds=com_bounds, joint_names=joint_names)
        return base_findings(bc, level=float(level))
    values, lay = resolve(source, column_names, joint_names)
    return check_parameters(values, lay, com_bounds=com_bounds, tolerance=float(tolerance))


def report_findings(parameters: Any, *, m: int, level: float, column_names: Sequence[str] | None) -> list[Finding]:
    """The ``physical_consistency`` findings of ``validate(..., parameters=...)`` (contract §8).

    ``parameters`` is anything :func:`findings` takes; a vector with as many values as the
    regressor has ``column_names`` is read with those names. Link k and friction joint k must be
    among the m joints of the data (InvalidParameter otherwise). ``columns`` of a finding become the
    regressor columns of the same names (the parameter vector's own indices and names are in
    ``details["parameter_columns"]`` and ``details["parameters"]``).
    """
    names = None
    parameters = urdf_from_path(parameters)
    if _is_urdf_model(parameters):
        source_names = tuple(parameters.column_names(friction=True, offset=False))
    elif hasattr(parameters, "full_parameters"):                    # an IdentificationResult
        source_names = tuple(parameters.column_names)
    else:
        values = to_float_array(parameters, "parameters")
        if column_names is not None and values.ndim == 1 and values.size == len(column_names):
            names = column_names
        source_names = resolve(values, names)[1].column_names
    lay = layout(source_names)
    n_joints = max(len(lay.links), len(lay.joint_names))
    if n_joints > m:
        raise parameter_error("parameters", f"the parameters of a robot with at most m={m} joints (link k moved "
                              f"by joint k, the data's column k)", f"{len(lay.links)} links and friction on "
                              f"{len(lay.joint_names)} joints")
    found = findings(parameters, column_names=names, level=level)
    where = {name: c for c, name in enumerate(column_names or ())}
    out = []
    for f in found:
        params = [source_names[c] for c in f.columns]
        cols = tuple(where[n] for n in params if n in where)
        out.append(replace(f, columns=cols, details={**f.details, "parameter_columns": list(f.columns),
                                                     "parameters": params}))
    return out
