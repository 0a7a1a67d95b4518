"""Regressors of a robot described by a URDF, and zero-phase differentiation of logged positions.

The URDF part needs pinocchio (``pip install pin``, the ``dynval[robots]`` extra); it is
imported when a :class:`URDFModel` is built, so :func:`differentiate` works without it.

Joint-torque regressor
----------------------
For each sample, pinocchio's ``computeJointTorqueRegressor(model, data, q, v, a)`` returns the
``(n_v, 10·n_bodies)`` matrix ``Y`` with ``τ = Y π``; per moving body the ten dynamic parameters
are, in pinocchio's order, ``m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz`` — mass, first moment
``m·c`` and the inertia about the joint frame's origin (``I = I_C + m S(c)ᵀS(c)``), in the joint
frame. dynval names the columns ``<link>:<param>`` (``lwr_2_link:mx``) and appends per joint a
viscous ``Fv_<joint>`` (``q̇``), a Coulomb ``Fc_<joint>`` (``sign q̇``) and an offset ``off_<joint>``
(1) column, each non-zero on its own joint only. Most of these columns are not identifiable
separately; :meth:`URDFModel.identify` reduces them to a base set with :func:`dynval.identify.identify`.

A URDF's ``<dynamics damping=… friction=…/>`` are read as viscous and Coulomb coefficients for
:meth:`URDFModel.predict` (the a-priori prediction of the URDF's own parameters); they are removed
before the XML reaches pinocchio, which rejects negative Coulomb values that identified models
sometimes carry.

Physical consistency
--------------------
:func:`physical_consistency` says whether a parameter set is a robot at all (per link mass > 0 and
the pseudo-inertia positive semidefinite, the centre of mass in a box when one is given, friction
≥ 0), and whether identified base parameters come from some robot; :meth:`URDFModel.identify` with
``physical=True`` identifies under those constraints (the ``physical`` extra, cvxpy). The
conditions, the statistics and the solver are described in ``dynval.report._consistency``.

Differentiation
---------------
Velocities and accelerations are often not logged. :func:`differentiate` returns them from
positions with a zero-phase filter — a Savitzky–Golay polynomial fit (centred window) or a
Butterworth low-pass run forward and backward (``filtfilt``) followed by central differences —
and states the filter's -3 dB bandwidth and its delay (zero, by symmetry, except in the few
samples at each end).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .checks._validation import motion_arrays, parameter_error
from .report import _consistency
from .report._consistency import PARAM_NAMES, BaseConsistency, base_consistency
from .report._findings import Finding
from .statistics._derivatives import Derivatives, differentiate

__all__ = [
    "PARAM_NAMES",
    "URDFModel",
    "Derivatives",
    "differentiate",
    "planar_arm_urdf",
    "have_pinocchio",
    "physical_consistency",
    "base_consistency",
    "BaseConsistency",
]


def have_pinocchio() -> bool:
    """True when pinocchio (PyPI ``pin``) can be imported."""
    try:
        import pinocchio  # noqa: F401
    except ImportError:
        return False
    return True


def _import_pinocchio():
    try:
        import pinocchio
    except ImportError as exc:  # pragma: no cover - exercised where pinocchio is absent
        raise ImportError("dynval.robots needs pinocchio: pip install pin (or dynval[robots])") from exc
    return pinocchio


def _read_urdf(urdf):
    """URDF text from a path or an XML string."""
    if isinstance(urdf, Path) or (isinstance(urdf, str) and not urdf.lstrip().startswith("<")):
        return Path(urdf).read_text()
    if isinstance(urdf, str):
        return urdf
    raise parameter_error("urdf", "a path to a URDF file or its XML text", type(urdf).__name__)


class URDFModel:
    """A fixed-base robot from a URDF: regressors, parameters and predictions.

    Parameters
    ----------
    urdf : str or Path
        Path to a URDF file, or its XML text.
    gravity : array_like (3,) or None
        Gravity vector in the world frame (m/s²); default pinocchio's ``(0, 0, -9.81)``.

    Attributes
    ----------
    joint_names : tuple of str
        The moving joints, in the order of ``q`` (one degree of freedom each).
    link_names : tuple of str
        The link moved by each joint (the body whose parameters the regressor's columns hold).
    viscous, coulomb : ndarray (n,)
        The URDF's ``<dynamics damping=… friction=…>`` per joint (0 where absent).
    """

    def __init__(self, urdf, *, gravity=None):
        import xml.etree.ElementTree as ET  # here, not at import dynval: only a URDF needs it

        pin = _import_pinocchio()
        root = ET.fromstring(_read_urdf(urdf))
        dynamics = {}
        for joint in root.iter("joint"):
            for dyn in joint.findall("dynamics"):
                dynamics[joint.get("name")] = (float(dyn.get("damping", 0.0)), float(dyn.get("friction", 0.0)))
                joint.remove(dyn)
        self._pin = pin
        self.model = pin.buildModelFromXML(ET.tostring(root, encoding="unicode"))
        if gravity is not None:
            self.model.gravity.linear = np.asarray(gravity, dtype=float).reshape(3)
        self.data = self.model.createData()
        if self.model.nq != self.model.nv:
            raise parameter_error("urdf", "a model whose joints have one coordinate per degree of freedom "
                                          "(revolute or prismatic; no continuous or floating joints)",
                                  f"nq={self.model.nq}, nv={self.model.nv}")
        self.joint_names = tuple(self.model.names[i] for i in range(1, self.model.njoints))
        links = []
        for j in range(1, self.model.njoints):
            bodies = [f.name for f in self.model.frames if f.parentJoint == j and f.type == pin.FrameType.BODY]
            links.append(bodies[0] if bodies else self.model.names[j])
        self.link_names = tuple(links)
        self.viscous = np.array([dynamics.get(n, (0.0, 0.0))[0] for n in self.joint_names])
        self.coulomb = np.array([dynamics.get(n, (0.0, 0.0))[1] for n in self.joint_names])

    @property
    def n_joints(self) -> int:
        return self.model.nv

    @property
    def inertial_column_names(self) -> tuple:
        return tuple(f"{link}:{p}" for link in self.link_names for p in PARAM_NAMES)

    def column_names(self, *, friction: bool = True, offset: bool = True) -> tuple:
        """Names of the columns of :meth:`regressor` with the same options."""
        names = list(self.inertial_column_names)
        if friction:
            names += [f"Fv_{j}" for j in self.joint_names] + [f"Fc_{j}" for j in self.joint_names]
        if offset:
            names += [f"off_{j}" for j in self.joint_names]
        return tuple(names)

    def inertial_parameters(self) -> np.ndarray:
        """The URDF's own dynamic parameters, ``(10·n,)`` in the order of the inertial columns."""
        return np.concatenate([self.model.inertias[j].toDynamicParameters()
                               for j in range(1, self.model.njoints)])

    def parameters(self, *, friction: bool = True, offset: bool = True) -> np.ndarray:
        """The URDF's parameter vector for :meth:`regressor` (offsets are zero)."""
        parts = [self.inertial_parameters()]
        if friction:
            parts += [self.viscous, self.coulomb]
        if offset:
            parts.append(np.zeros(self.n_joints))
        return np.concatenate(parts)

    def _motion(self, q, dq, ddq):
        return motion_arrays(self.n_joints, q, dq, ddq)

    def regressor(self, q, dq, ddq, *, friction: bool = True, offset: bool = True) -> np.ndarray:
        """Joint-torque regressor ``(N, n, p)`` with the columns of :meth:`column_names`."""
        q, dq, ddq = self._motion(q, dq, ddq)
        n_samples, n = q.shape
        inertial = np.empty((n_samples, n, 10 * n))
        for k in range(n_samples):
            inertial[k] = self._pin.computeJointTorqueRegressor(self.model, self.data, q[k], dq[k], ddq[k])
        parts = [inertial]
        eye = np.eye(n)
        if friction:
            parts.append(dq[:, :, None] * eye)
            parts.append(np.sign(dq)[:, :, None] * eye)
        if offset:
            parts.append(np.broadcast_to(eye, (n_samples, n, n)))
        return np.concatenate(parts, axis=2)

    def structure_states(self, states: int = 256, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``states`` random (q, q̇, q̈), each ``(states, n)``: positions uniform within the joint limits
        (over a turn where a limit is absent or wider), velocities and accelerations standard normal.
        At such states every combination of columns the structure allows is excited: what stays zero
        or dependent there is structural (the base-parameter computation's own device)."""
        rng = np.random.default_rng(seed)
        lo = np.maximum(np.asarray(self.model.lowerPositionLimit, dtype=float), -np.pi)
        hi = np.minimum(np.asarray(self.model.upperPositionLimit, dtype=float), np.pi)
        lo, hi = np.where(hi > lo, lo, -np.pi), np.where(hi > lo, hi, np.pi)
        n = self.n_joints
        return (rng.uniform(lo, hi, size=(states, n)), rng.standard_normal((states, n)),
                rng.standard_normal((states, n)))

    def prepared_regressor(self, q, dq, ddq, *, friction: bool = True, offset: bool = True, states: int = 256,
                           seed: int = 0):
        """:meth:`regressor` prepared for :func:`dynval.validate` with the model's structure
        (:func:`dynval.prepare_regressor`'s ``structure``: the regressor at :meth:`structure_states`),
        so a report on it tells the columns no trajectory excites (structural) from those this one
        leaves unexcited, without the estimation run's regressor."""
        from .report._prepared import prepare_regressor

        structure = self.regressor(*self.structure_states(states, seed), friction=friction, offset=offset)
        return prepare_regressor(self.regressor(q, dq, ddq, friction=friction, offset=offset), structure=structure)

    def predict(self, q, dq, ddq, *, friction: bool = True) -> np.ndarray:
        """The URDF's a-priori torques ``(N, n)``: RNEA on its inertials (+ its friction)."""
        q, dq, ddq = self._motion(q, dq, ddq)
        tau = np.empty_like(q)
        for k in range(q.shape[0]):
            tau[k] = self._pin.rnea(self.model, self.data, q[k], dq[k], ddq[k])
        if friction:
            tau += self.viscous * dq + self.coulomb * np.sign(dq)
        return tau

    def identify(self, q, dq, ddq, tau_meas, *, friction: bool = True, offset: bool = True,
                 physical: bool = False, prior="urdf", **kwargs):
        """Base-parameter estimate from motion and torques (:func:`dynval.identify.identify`).

        With ``physical=True`` the full parameters are identified under physical consistency
        (``.full_parameters``, in the order of :meth:`column_names`), pulled towards ``prior``
        where the data say little: ``"urdf"`` (default) is this URDF's own parameters
        (:meth:`parameters`), None is zero, or an array of one value per column; ``prior_metric``
        (``"euclidean"`` or ``"entropic"``), ``prior_weight`` and ``com_bounds`` go to
        :func:`dynval.identify.identify`.
        """
        from .identify import identify

        y = self.regressor(q, dq, ddq, friction=friction, offset=offset)
        names = self.column_names(friction=friction, offset=offset)
        if physical and isinstance(prior, str) and prior == "urdf":
            prior = self.parameters(friction=friction, offset=offset)
        if physical:
            kwargs["prior"] = prior
        return identify(y, tau_meas, column_names=names, physical=physical, **kwargs)


# a URDF path given where a model is taken (physical_consistency, validate(parameters=...)) is read
# with URDFModel; the report layer, below this one, gets the reader here
_consistency.register_urdf_reader(URDFModel)


# --------------------------------------------------------------------------- physical consistency


def physical_consistency(model_or_parameters: Any, *, column_names: Sequence[str] | None = None,
                         joint_names: Sequence[str] | None = None, com_bounds: Any = None,
                         covariance: Any = None, level: float = 0.95,
                         tolerance: float = _consistency.TOLERANCE) -> list[Finding]:
    """Whether any physically realizable robot has these parameters: one finding per violated condition.

    Per link (its ten parameters in pinocchio's order, about the joint frame): mass > 0, and the
    4×4 pseudo-inertia ``[[½tr(I)·1 − I, m·c], [(m·c)ᵀ, m]]`` positive semidefinite, which is the
    condition for a mass distribution to exist (it holds positive inertia and the triangle
    inequalities; tested as the triangle inequality of the principal moments about the centre of
    mass, whose deficit is the finding's size); the centre of mass inside its box when
    ``com_bounds`` gives one. Per joint: viscous and Coulomb friction ≥ 0 (friction resists).
    Identified *base* parameters (an unconstrained :class:`~dynval.identify.IdentificationResult`)
    are tested for whether some consistent robot maps to them: the distance to the consistent set
    in the metric of their covariance, with a χ² bound on its p-value (needs cvxpy, the ``physical``
    extra).

    Parameters
    ----------
    model_or_parameters : URDFModel, IdentificationResult or array_like
        A URDF model (its inertials and ``<dynamics>`` friction); an identification result (its
        ``full_parameters`` when identified with ``physical=True``, else its base parameters); or a
        parameter vector in the column order of :meth:`URDFModel.column_names` (ten per link, then
        ``Fv_*``, ``Fc_*``, offsets), or ``(n_links, 10)``.
    column_names : sequence of str or None
        Names of a parameter vector's entries (``<link>:<param>``, ``Fv_<joint>``, ``Fc_<joint>``;
        other names are not checked); None for ten inertial parameters per link.
    joint_names : sequence of str or None
        Names of the joints (link k is moved by joint k) for the messages.
    com_bounds : None, pair or mapping
        A box ``(lower, upper)`` (3-vectors, m, in the link's joint frame) for every link's centre
        of mass, or a mapping link name → box.
    covariance : array_like (r, r) or None
        For base parameters: the metric of the distance (default the result's ``covariance``).
    level : float
        For base parameters: the distance is significant when its p-value is at most 1 − level.
    tolerance : float
        A triangle-inequality deficit or a centre-of-mass excursion below this share of the link's
        largest principal moment, about its centre of mass or the joint frame's origin (or of the
        box), is rounding.

    Returns
    -------
    list of Finding
        Kind ``physical_consistency``, severity ``deficiency`` (base parameters: ``note`` when the
        distance is not significant or costs less than 1 % of the mean square); ``joints`` and
        ``columns`` are 0-based, ``effect`` the violation's size in ``effect_unit``, ``details``
        the link or joint, the condition and the numbers.

    Examples
    --------
    >>> from dynval.robots import physical_consistency

    A thin rod (1 kg, 1 m along x from the joint) has zero inertia about its own axis: its
    pseudo-inertia is singular, exactly on the boundary, and it is a robot:

    >>> rod = [1.0, 0.5, 0, 0, 0.0, 0, 1/3, 0, 0, 1/3]
    >>> physical_consistency(rod)
    []

    A negative Coulomb friction, and principal moments 0.1, 0.1, 0.3 kg·m² about the centre of
    mass (no body: 0.1 + 0.1 < 0.3):

    >>> box = [2.0, 0, 0, 0, 0.1, 0, 0.1, 0, 0, 0.3]
    >>> found = physical_consistency(box + [0.5, -0.2], column_names=[f"l1:{p}" for p in
    ...     ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")] + ["Fv_j1", "Fc_j1"])
    >>> [(f.details["condition"], round(f.effect, 6), f.effect_unit) for f in found]
    [('pseudo-inertia positive semidefinite', 0.1, 'kg·m²'), ('Coulomb friction >= 0', 0.2, 'N·m')]
    """
    return _consistency.findings(model_or_parameters, column_names=column_names, joint_names=joint_names,
                                 com_bounds=com_bounds, covariance=covariance, level=level, tolerance=tolerance)


# --------------------------------------------------------------------------- a small URDF


def planar_arm_urdf(arm=None, *, name: str = "dynval_planar_arm") -> str:
    """URDF text of the demo's two-link arm (:mod:`dynval.simulate`), in a vertical plane.

    A fixed joint turns the arm's plane upright (``rpy = (π/2, 0, 0)``: the plane's ``y`` axis
    points up, against pinocchio's default gravity), so that joint angles, parameters and
    torques are those of :func:`dynval.simulate.regressor`. Friction goes into ``<dynamics>``.
    """
    from .simulate import DEFAULT_ARM

    a = DEFAULT_ARM if arm is None else arm

    def link(link_name, m, cx, cy, izz):
        # Any ixx, iyy with izz <= ixx + iyy is physical; the motion in the plane never sees them.
        return (f'  <link name="{link_name}">\n    <inertial>\n      <origin xyz="{cx!r} {cy!r} 0" rpy="0 0 0"/>\n'
                f'      <mass value="{m!r}"/>\n'
                f'      <inertia ixx="{izz!r}" ixy="0" ixz="0" iyy="{izz!r}" iyz="0" izz="{izz!r}"/>\n'
                f'    </inertial>\n  </link>\n')

    return (
        f'<?xml version="1.0"?>\n<robot name="{name}">\n'
        '  <link name="world"/>\n  <link name="plane"/>\n'
        '  <joint name="upright" type="fixed">\n    <parent link="world"/>\n    <child link="plane"/>\n'
        f'    <origin xyz="0 0 0" rpy="{math.pi / 2!r} 0 0"/>\n  </joint>\n'
        '  <joint name="shoulder" type="revolute">\n    <parent link="plane"/>\n    <child link="link1"/>\n'
        '    <origin xyz="0 0 0" rpy="0 0 0"/>\n    <axis xyz="0 0 1"/>\n'
        '    <limit lower="-3.14" upper="3.14" effort="100" velocity="10"/>\n'
        f'    <dynamics damping="{a.fv1!r}" friction="{a.fc1!r}"/>\n  </joint>\n'
        + link("link1", a.m1, a.cx1, a.cy1, a.I1)
        + '  <joint name="elbow" type="revolute">\n    <parent link="link1"/>\n    <child link="link2"/>\n'
        f'    <origin xyz="{a.l1!r} 0 0" rpy="0 0 0"/>\n    <axis xyz="0 0 1"/>\n'
        '    <limit lower="-3.14" upper="3.14" effort="100" velocity="10"/>\n'
        f'    <dynamics damping="{a.fv2!r}" friction="{a.fc2!r}"/>\n  </joint>\n'
        + link("link2", a.m2, a.cx2, a.cy2, a.I2)
        + '</robot>\n'
    )
