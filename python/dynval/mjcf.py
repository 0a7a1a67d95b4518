"""Simulator models: a MuJoCo MJCF arm's inverse dynamics, its terms, and the regressor of its tuned parameters.

Needs MuJoCo (``pip install mujoco``, the ``dynval[mujoco]`` extra); it is imported when an
:class:`MJCFModel` is built. The contract's §11 fixes the names; this docstring says how MuJoCo
computes each term.

The terms (``MJCFModel.terms``)
-------------------------------
``mujoco.mj_inverse`` returns ``qfrc_inverse = M(q)·q̈ + c(q, q̇) − qfrc_passive − qfrc_constraint``,
with the joints' ``armature`` added to the diagonal of ``M``. For the arms dynval takes (below):

* ``rigid_body``: ``mj_inverse`` of the same model with ``armature``, ``damping`` and
  ``frictionloss`` set to zero — the bodies' inertia, Coriolis, centrifugal and gravity torques;
* ``armature``: ``armature·q̈`` (the armature is added to ``M``'s diagonal, nothing else);
* ``damping``: ``damping·q̇`` (a passive force ``−damping·q̇``, which the inverse adds back);
* ``frictionloss``: MuJoCo applies frictionloss as a *soft constraint*, not as a passive force, and
  ``mj_inverse`` does include it (checked numerically): the constraint's force for the given
  ``q̈`` is bounded by ``±frictionloss`` and equals ``frictionloss·sign(q̇)`` once the joint moves
  faster than the constraint's small velocity band (its ``solref``/``solimp`` regularisation);
  within the band (near reversals and at rest) it is a smaller force that depends on ``q̈``.
  The term is MuJoCo's own force (``−qfrc_constraint``), so :meth:`MJCFModel.predict` is what the
  simulator's forward dynamics would turn back into ``q̈``.

``predict`` equals the sum of the terms to 1e-9 of the torques' scale (relative; in practice a few
ulps: each term is computed by its own call or product). :meth:`MJCFModel.saturated` says where the
frictionloss force is ``frictionloss·sign(q̇)``.

What is refused, what is ignored
--------------------------------
Refused (InvalidParameter naming the file): free, ball and slide joints (a fixed-base arm of
hinges only); joints on more than one branch (several trees, or a tree that branches); equality
constraints; tendons; flexes; joint springs (``stiffness``), polynomial damping, gravity
compensation (``gravcomp``), actuators' own armature or damping, fluid forces (``density``,
``viscosity``) — each a torque dynval would not name. Ignored: contacts and joint ranges (the
constraints are disabled: a logged motion is given, not simulated), actuators (the prediction is
the joint torque, not a control), sensors, visual and collision geometry, keyframes, and the
integrator and time step (inverse dynamics does not integrate).

The regressor (``MJCFModel.regressor``)
---------------------------------------
The simulator parameters enter linearly: per joint ``armature_<joint>`` (column ``q̈_j``),
``damping_<joint>`` (``q̇_j``) and ``frictionloss_<joint>``, each non-zero on its own joint only.
The frictionloss column is the shape of MuJoCo's frictionloss force at the model's own value
(the force divided by ``frictionloss``): ``sign q̇_j`` wherever the constraint saturates, and
the smaller soft-constraint force within its velocity band; ``sign q̇_j`` on a joint whose
frictionloss is 0. So ``regressor @ parameters() == predict`` to rounding. The band's force does
not scale with frictionloss (only its bound does), so for another value the column is exact
outside the band only. The rigid-body part is one *known* column per joint, ``rigid_body_<joint>``: its
torque on that joint (parameter 1). This is the chosen form: sim2real tuning adjusts the joints'
armature, damping and frictionloss over fixed CAD inertials, and a scale of the rigid-body torque
per joint keeps the regressor full rank (ten inertial parameters per body would not be
identifiable without a base reduction, and would need pinocchio besides MuJoCo).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .checks._errors import InvalidParameter
from .checks._validation import motion_arrays, parameter_error

__all__ = ["TERMS", "ATTRIBUTES", "MJCFModel", "Retune", "have_mujoco"]

#: The terms of :meth:`MJCFModel.terms`, in the order of their columns in the regressor.
TERMS = ("rigid_body", "armature", "damping", "frictionloss")
#: The MJCF joint attributes the regressor identifies (the terms after ``rigid_body``).
ATTRIBUTES = TERMS[1:]


def have_mujoco() -> bool:
    """True when MuJoCo (PyPI ``mujoco``) can be imported."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True


def _import_mujoco() -> Any:
    try:
        import mujoco
    except ImportError as exc:  # pragma: no cover - exercised where mujoco is absent
        raise ImportError("dynval.mjcf needs MuJoCo: pip install mujoco (or dynval[mujoco])") from exc
    return mujoco


def _load(mujoco: Any, path_or_xml: Any) -> tuple[Any, str]:
    """The compiled model and the label that names it in messages (the file, or ``<MJCF text>``)."""
    text = isinstance(path_or_xml, str) and path_or_xml.lstrip().startswith("<")
    if not text and not isinstance(path_or_xml, (str, Path)):
        raise parameter_error("path_or_xml", "a path to an MJCF file or its XML text", type(path_or_xml).__name__)
    label = "<MJCF text>" if text else str(path_or_xml)
    if not text and not Path(path_or_xml).is_file():
        raise InvalidParameter(f"{label}: no such MJCF file")
    try:
        if text:
            return mujoco.MjModel.from_xml_string(path_or_xml), label
        return mujoco.MjModel.from_xml_path(label), label
    except ValueError as exc:
        raise InvalidParameter(f"{label}: MuJoCo cannot load it: {str(exc).strip()}") from None


def _refusals(mujoco: Any, m: Any) -> list[str]:
    """What makes the model something other than a fixed-base serial arm of hinges (empty when it is one)."""
    out = []
    jt = mujoco.mjtJoint
    kinds = {int(jt.mjJNT_FREE): "free", int(jt.mjJNT_BALL): "ball", int(jt.mjJNT_SLIDE): "slide"}
    for j in range(m.njnt):
        if int(m.jnt_type[j]) in kinds:
            out.append(f"a {kinds[int(m.jnt_type[j])]} joint '{m.joint(j).name}' (only hinge joints)")
    if m.njnt == 0:
        out.append("no joints")
    out += _branches(m)
    for count, what in ((m.neq, "equality constraints"), (m.ntendon, "tendons"), (m.nflex, "flexes")):
        if count:
            out.append(f"{count} {what}")
    for field, what in (("jnt_stiffness", "joint stiffness (springs)"), ("jnt_stiffnesspoly", "polynomial stiffness"),
                        ("dof_dampingpoly", "polynomial damping"), ("body_gravcomp", "gravity compensation (gravcomp)"),
                        ("actuator_armature", "actuator armature"), ("actuator_damping", "actuator damping")):
        # the polynomial and actuator fields are MuJoCo 4's; an older MuJoCo has none of them to refuse
        if np.any(np.asarray(getattr(m, field, 0.0)) != 0):
            out.append(f"non-zero {what}")
    if m.opt.density != 0 or m.opt.viscosity != 0:
        out.append("fluid forces (option density or viscosity non-zero)")
    return out


def _branches(m: Any) -> list[str]:
    """Joints must lie on one chain from the world: each joint's body descends from the previous one's."""
    bodies = [int(b) for b in m.jnt_bodyid]
    for prev, body in zip(bodies, bodies[1:]):
        chain = body
        while chain not in (prev, 0):
            chain = int(m.body_parentid[chain])
        if chain != prev:
            return [f"joints on several branches ('{m.body(prev).name}' and '{m.body(body).name}'; several trees "
                    "or a branching tree)"]
    return []


@dataclass(frozen=True)
class Retune:
    """One simulator parameter to retune: the joint, the MJCF attribute, its value and the refitted one."""

    joint: str
    attribute: str
    current: float
    refitted: float
    std: float

    @property
    def z(self) -> float:
        """How many standard deviations the refitted value is from the current one (inf when std is 0;
        nan when the run could not refit it)."""
        gap = abs(self.refitted - self.current)
        if math.isnan(gap) or math.isnan(self.std):
            return math.nan
        return gap / self.std if self.std > 0 else (0.0 if gap == 0 else math.inf)


class MJCFModel:
    """A fixed-base serial arm of hinge joints from an MJCF file: MuJoCo's inverse dynamics and its terms.

    Parameters
    ----------
    path_or_xml : str or Path
        Path to an MJCF file, or its XML text.

    Attributes
    ----------
    joint_names : tuple of str
        The hinge joints in the model's order (the order of ``q``'s columns).
    armature, damping, frictionloss : ndarray (n,)
        The joints' MJCF attributes (read-only copies).
    source : str
        The file (or ``<MJCF text>``), as messages name it.

    Examples
    --------
    >>> from dynval.mjcf import MJCFModel
    >>> arm = MJCFModel('''<mujoco><worldbody><body><joint name="j" axis="0 1 0" damping="0.5"/>
    ...     <inertial pos="0.5 0 0" mass="2" diaginertia="0.01 0.01 0.01"/></body></worldbody></mujoco>''')
    >>> arm.column_names
    ('rigid_body_j', 'armature_j', 'damping_j', 'frictionloss_j')

    Held horizontal and turning at 1 rad/s: gravity's −m·g·l = −9.81 N·m and the damping's 0.5 N·m.

    >>> {k: round(float(v[0, 0]), 6) for k, v in arm.terms([0.0], [1.0], [0.0]).items()}
    {'rigid_body': -9.81, 'armature': 0.0, 'damping': 0.5, 'frictionloss': 0.0}

    A ball joint is not a serial arm's (the message names the file, or ``<MJCF text>``):

    >>> MJCFModel('''<mujoco><worldbody><body><joint name="b" type="ball"/>
    ...     <geom size="0.1"/></body></worldbody></mujoco>''')  # doctest: +ELLIPSIS
    Traceback (most recent call last):
        ...
    dynval.checks._errors.InvalidParameter: <MJCF text>: dynval.mjcf takes a fixed-base serial arm ...; this
    model has a ball joint 'b' (only hinge joints)
    """

    def __init__(self, path_or_xml: Any) -> None:
        mujoco = _import_mujoco()
        m, self.source = _load(mujoco, path_or_xml)
        refused = _refusals(mujoco, m)
        if refused:
            raise InvalidParameter(f"{self.source}: dynval.mjcf takes a fixed-base serial arm of hinge joints; "
                                   f"this model has {'; '.join(refused)}")
        self._mujoco = mujoco
        # contacts and joint ranges are constraints of a simulation, not terms of a logged motion
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT) | int(mujoco.mjtDisableBit.mjDSBL_LIMIT)
        self.model = m
        self.joint_names = tuple(m.joint(j).name for j in range(m.njnt))
        self.armature = self._frozen(m.dof_armature)
        self.damping = self._frozen(m.dof_damping)
        self.frictionloss = self._frozen(m.dof_frictionloss)
        self._rigid = self._rigid_model(mujoco, m)
        self._data = mujoco.MjData(m)
        self._rigid_data = mujoco.MjData(self._rigid)

    @staticmethod
    def _frozen(values: Any) -> np.ndarray:
        out = np.array(values, dtype=float)
        out.flags.writeable = False
        return out

    @staticmethod
    def _rigid_model(mujoco: Any, m: Any) -> Any:
        rigid = m.__copy__()
        rigid.dof_armature[:] = 0.0
        rigid.dof_damping[:] = 0.0
        rigid.dof_frictionloss[:] = 0.0
        rigid.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS)
        return rigid

    @property
    def n_joints(self) -> int:
        return int(self.model.nv)

    @property
    def column_names(self) -> tuple[str, ...]:
        """The regressor's columns: ``rigid_body_<joint>``, then ``armature_``, ``damping_``, ``frictionloss_``."""
        return tuple(f"{term}_{j}" for term in TERMS for j in self.joint_names)

    def parameters(self) -> np.ndarray:
        """The model's own values in the order of :attr:`column_names` (1 for each rigid-body column)."""
        return np.concatenate([np.ones(self.n_joints), self.armature, self.damping, self.frictionloss])

    def model_columns(self) -> list[int]:
        """The regressor's columns whose parameter is non-zero: the terms the model has (the others
        are tested as terms it lacks when it is validated with its regressor)."""
        return [k for k, value in enumerate(self.parameters()) if value != 0]

    def _inverse(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> tuple[np.ndarray, ...]:
        """Per sample: the full model's qfrc_inverse, its frictionloss force, and the rigid model's."""
        mj = self._mujoco
        full, friction, rigid = (np.empty_like(q) for _ in range(3))
        for d, m in ((self._data, self.model), (self._rigid_data, self._rigid)):
            for k in range(q.shape[0]):
                d.qpos[:], d.qvel[:], d.qacc[:] = q[k], dq[k], ddq[k]
                mj.mj_inverse(m, d)
                if d is self._data:
                    full[k] = d.qfrc_inverse
                    friction[k] = 0.0 - d.qfrc_constraint  # 0 − x, not −x: no −0.0 where there is no friction
                else:
                    rigid[k] = d.qfrc_inverse
        return full, friction, rigid

    def predict(self, q: Any, dq: Any, ddq: Any) -> np.ndarray:
        """Joint torques ``(N, n)``: MuJoCo's ``mj_inverse`` (``qfrc_inverse``) of the model as written."""
        q, dq, ddq = motion_arrays(self.n_joints, q, dq, ddq)
        return self._inverse(q, dq, ddq)[0]

    def terms(self, q: Any, dq: Any, ddq: Any) -> dict[str, np.ndarray]:
        """Each term's torque ``(N, n)``, keyed by :data:`TERMS`; they sum to :meth:`predict`."""
        q, dq, ddq = motion_arrays(self.n_joints, q, dq, ddq)
        _, friction, rigid = self._inverse(q, dq, ddq)
        return {"rigid_body": rigid, "armature": self.armature * ddq, "damping": self.damping * dq,
                "frictionloss": friction}

    def saturated(self, q: Any, dq: Any, ddq: Any) -> np.ndarray:
        """Where MuJoCo's frictionloss force is ``frictionloss·sign(q̇)`` (to 1e-9 of it): bool ``(N, n)``."""
        q, dq, ddq = motion_arrays(self.n_joints, q, dq, ddq)
        friction = self._inverse(q, dq, ddq)[1]
        return _close(friction, self.frictionloss * np.sign(dq), self.frictionloss)

    def regressor(self, q: Any, dq: Any, ddq: Any) -> np.ndarray:
        """The regressor ``(N, n, 4n)`` of :attr:`column_names`: each column on its own joint only."""
        q, dq, ddq = motion_arrays(self.n_joints, q, dq, ddq)
        _, friction, rigid = self._inverse(q, dq, ddq)
        shape = np.sign(dq)
        own = self.frictionloss > 0
        shape[:, own] = friction[:, own] / self.frictionloss[own]
        eye = np.eye(self.n_joints)
        return np.concatenate([x[:, :, None] * eye for x in (rigid, ddq, dq, shape)], axis=2)

    def compare(self, q: Any, dq: Any, ddq: Any, tau_meas: Any, *, estimation: Any = None, name: str = "mjcf",
                **keywords: Any) -> Any:
        """:func:`dynval.compare` of this model's prediction on a run, with every simulator term named.

        The candidate ``name`` is :meth:`predict` with ``n_params`` the regressor's 4n columns,
        ``regressor=self.regressor(q, dq, ddq)``, ``model_columns`` the columns whose parameter is
        non-zero (the terms the model has: the others are tested as missing terms), ``column_names``,
        ``joint_names``, ``q``, ``dq``, ``ddq``; ``estimation`` is None or ``(q, dq, ddq, tau)`` of the
        estimation run (its ``q``, regressor and torque are passed). Other keywords (``time``,
        ``sample_rate``, ``level``, ...) go to :func:`dynval.compare`. The findings then name the
        simulator columns, and :meth:`retune` turns them into the MJCF attributes to change.
        """
        from .comparison._compare import compare

        q, dq, ddq = motion_arrays(self.n_joints, q, dq, ddq)
        if estimation is not None:
            eq, edq, eddq, etau = estimation
            keywords["estimation"] = {"q": eq, "regressor": self.regressor(eq, edq, eddq), "tau": etau}
        candidate = {"prediction": self.predict(q, dq, ddq), "n_params": len(self.column_names),
                     "model_columns": self.model_columns()}
        return compare(tau_meas, {name: candidate}, regressor=self.regressor(q, dq, ddq), q=q, dq=dq, ddq=ddq,
                       joint_names=list(self.joint_names), column_names=list(self.column_names), **keywords)

    def retune(self, report: Any, q: Any, dq: Any, ddq: Any, tau_meas: Any) -> list[Retune]:
        """The MJCF parameters a report's deficiencies name, with their values refitted on the same run.

        ``report`` is a :class:`~dynval.ValidationReport` of this model's prediction validated with
        ``regressor=self.regressor(q, dq, ddq)`` (or a :class:`~dynval.ComparisonReport`, whose best
        candidate's report is read); ``q, dq, ddq, tau_meas`` are that run's. The columns of its
        deficiency findings that are this model's ``armature_``, ``damping_`` or ``frictionloss_``
        columns are returned once each with :func:`dynval.identify.identify`'s estimate of that
        column on the run (all the regressor's columns fitted together) and its standard deviation,
        the farthest from its current value (in standard deviations, :attr:`Retune.z`) first: a
        finding often names a second column that follows the residual only through the first
        (``frictionloss`` beside a wrong ``damping``), and its refitted value stays near its own.
        Columns are read by name when the report has this model's column names, by index otherwise.
        A column the run cannot identify on its own (a joint that does not move, or a column that
        is a combination of others there) has ``refitted`` and ``std`` nan, and comes last.
        """
        from .identify import identify

        names = self.column_names
        chosen = sorted(set(_named_columns(report, names)))
        if not chosen:
            return []
        fit = identify(self.regressor(q, dq, ddq), tau_meas, column_names=names)
        # a base parameter is the column's own value only when no other column is folded into it
        # (the combination's rounding-level entries, ~1e-18, are not columns)
        folded = np.abs(fit.combination) > 1e-9 * np.abs(fit.combination).max(axis=1, keepdims=True)
        alone = {int(np.flatnonzero(row)[0]): k for k, row in enumerate(folded) if row.sum() == 1}
        current = self.parameters()
        out = []
        for c in chosen:
            k = alone.get(c)
            attribute, _, joint = names[c].partition("_")
            out.append(Retune(joint=joint, attribute=attribute, current=float(current[c]),
                              refitted=float(fit.estimate[k]) if k is not None else math.nan,
                              std=float(fit.std[k]) if k is not None else math.nan))
        return sorted(out, key=lambda r: math.inf if math.isnan(r.z) else -r.z)


def _close(a: np.ndarray, b: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """``|a − b| ≤ 1e-9·scale`` elementwise (columns scaled by ``scale``; exact where it is zero)."""
    close: np.ndarray = np.abs(a - b) <= 1e-9 * np.abs(scale)
    return close


def _named_columns(report: Any, names: tuple[str, ...]) -> list[int]:
    """Indices into ``names`` of the simulator columns the report's deficiencies name."""
    if hasattr(report, "verdict"):  # a ComparisonReport: its best candidate's report
        report = report.reports[report.verdict.model]
    own = report.provenance.column_names
    tuned = {k for k, n in enumerate(names) if not n.startswith(TERMS[0] + "_")}
    out = []
    for f in report.findings:
        if f.severity != "deficiency":
            continue
        for c in f.columns:
            if own is None:
                k = int(c)
            elif c < len(own) and own[c] in names:
                k = names.index(own[c])
            else:  # a column of another regressor: not this model's parameter
                continue
            if k in tuned:
                out.append(k)
    return out
