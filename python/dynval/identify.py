"""Least-squares identification of the base parameters of ``τ = Y π + ε``.

Users with their own estimator never need this module: dynval validates predictions however
they were made. It exists so that a user who has a regressor and measured torques gets the
usual answer of the identification literature in one call — the identifiable (base) parameter
set, its estimate, standard deviations and relative standard deviations %σ, the condition
number of the base regressor — and can predict the torques of another trajectory.

Method
------
The regressor is stacked sample-major (row ``k·m + j`` is sample k, joint j), every column is
scaled to unit Euclidean norm (so that the rank test does not depend on the parameters' units)
and factored by Householder QR with column pivoting (``scipy.linalg.qr(..., pivoting=True)``,
LAPACK ``dgeqp3``). Pivoting moves the most independent columns first, so ``|R_00| >= |R_11| >= ...``.
The numerical rank ``r`` is the number of diagonal entries with::

    |R_kk| > rcond · |R_00|,    rcond = max(rows, p) · eps   (eps = 2.22e-16, the default)

— the tolerance numpy's ``matrix_rank`` uses for singular values, applied to the pivoted-QR
diagonal, which bounds the singular values from above and below within a factor of the matrix size.
Columns that are identically zero, or whose norm is at most 1e-13 of the median norm of the
nonzero columns (roundoff of a structurally zero column; the rule of the report's design section,
``dynval.statistics._columns.zero_columns``), are never identifiable and are removed before
the factorization. Compared with the median, not the largest, no column's unit changes another
column's status (contract §4). The first ``r`` pivoted columns are the *base columns*; every other column is a
linear combination of them, ``Y_d = Y_b β``, and the quantity that the data determine is the base
parameter ``π_b + β π_d`` (:attr:`IdentificationResult.combination`).

With ``Q1 R11`` the first ``r`` columns of the factorization,

    π̂_b = R11⁻¹ Q1ᵀ τ,    σ² = ‖τ − Y_b π̂_b‖² / (rows − r),    C = σ² (Y_bᵀ Y_b)⁻¹ = σ² R11⁻¹ R11⁻ᵀ

(undone for the column scaling), ``std = √diag C`` and ``%σ = 100 · std / |π̂|``.

Weighting (``weights="per_joint"``): joints whose torques differ in noise level get rows divided
by a per-joint noise standard deviation σ_j, estimated from an ordinary least-squares fit as
σ_j² = ‖τ_j − Y_j π̂‖² / (N − r) (Gautier's weighting); the weighted problem is then solved as
above, and its σ² is close to 1 when the weights are right. An array of ``m`` positive
numbers gives the σ_j directly.

Physical consistency (``physical=True``, the ``physical`` extra: cvxpy): least squares over the
full parameters of a robot that can exist — every link's 4×4 pseudo-inertia positive semidefinite
(which holds mass, positive inertia and the triangle inequalities), every viscous and Coulomb
friction coefficient ≥ 0 — optionally pulled towards a prior (Euclidean, or entropic: each link's
−log det divergence from the prior's pseudo-inertia; small weight), solved as a
semidefinite program (``dynval.report._consistency``; Wensing, Kim & Slotine 2017; Sousa & Cortesão 2014).
The columns must be named as :meth:`dynval.robots.URDFModel.column_names` names them. The result
keeps the base set of the unconstrained fit: :attr:`IdentificationResult.estimate` is the base
combination of the constrained full parameters, and its standard deviations are the unconstrained
fit's covariance ``σ² (Y_bᵀ Y_b)⁻¹`` with σ² of the constrained residual (constraints that bind
only shrink the uncertainty, so they are an upper bound).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

if TYPE_CHECKING:
    import scipy.linalg
    import scipy.stats
else:
    from ._lazy import scipy

from .checks._errors import InvalidShape, ShapeMismatch
from .checks._typing import ArrayLike, FloatArray, IntArray, Integer
from .checks._validation import (
    check_finite,
    check_level,
    check_min_samples,
    check_signal_like,
    format_shape,
    is_integer,
    is_real_number,
    parameter_error,
    promote_signal,
    regressor_shape,
    to_float_array,
)
from .kernels._blas import one_blas_thread
from .report import _consistency
from .statistics import _coverage
from .statistics._columns import zero_columns
from .statistics._coverage import CoverageTest

__all__ = ["CoverageTest", "IdentificationResult", "PredictionInterval", "identify", "default_rcond"]


def default_rcond(rows: int, p: int) -> float:
    """The default rank tolerance ``max(rows, p) · eps`` (relative to the largest pivot)."""
    return float(max(rows, p) * np.finfo(np.float64).eps)


@dataclass(frozen=True)
class PredictionInterval:
    """A prediction with its band (:meth:`IdentificationResult.prediction_interval`).

    Attributes
    ----------
    prediction, lower, upper, std : ndarray (N, m)
        The predicted torque, the band's edges and each sample's standard deviation.
    level : float
        The band's probability; ``quantile`` is the Student-t factor that gives it.
    noise_std : ndarray (m,)
        The joints' noise standard deviations the band includes.
    design : ndarray (N, m, r) or None
        The base regressor rows the band was predicted from, which :meth:`coverage_test` refits to
        tell the parameters' error from a missing term (None for a band built by hand: the test
        then takes every state dependence for a missing term).
    """

    prediction: FloatArray
    lower: FloatArray
    upper: FloatArray
    std: FloatArray
    level: float
    quantile: float
    noise_std: FloatArray
    design: FloatArray | None = field(default=None, repr=False, compare=False)

    def share_inside(self, tau_meas: ArrayLike) -> FloatArray:
        """Per joint, the share of the measured torques inside the band: ``level`` when the model
        and its white noise are right, less when the band is too narrow. A share at or above the
        level clears nothing: a missing term widens the band with its own error (contract §9);
        :meth:`coverage_test` shows where the band misses."""
        meas = promote_signal(to_float_array(tau_meas, "tau_meas"), "tau_meas")
        if meas.shape != self.prediction.shape:
            raise ShapeMismatch(f"tau_meas must have the prediction's shape {format_shape(self.prediction.shape)}, "
                                f"got {format_shape(meas.shape)}")
        check_finite(meas, "tau_meas")  # a NaN would count as outside and lower the share silently
        inside = (meas >= self.lower) & (meas <= self.upper)
        out: FloatArray = inside.mean(axis=0)
        return out

    def coverage_test(self, tau_meas: ArrayLike, *, q: ArrayLike | None = None, dq: ArrayLike | None = None,
                      n_bins: Integer = 4, alpha: float = 0.05) -> CoverageTest:
        """Whether the band's misses depend on the state or cluster in time: a test a missing term fails.

        :meth:`share_inside` cannot show a missing term (the term widened the band too). Per joint,
        the standardised residuals, less what the model's own columns refitted on this run explain,
        are tested for a mean that depends on the state: in bins of the joint's velocity sign (from
        ``dq``, or ``q``'s differences), of its position's and of the prediction's ``n_bins``
        quantiles; and the exceedances by a runs test in time; all with the residual's colour-aware
        effective sample size (docs/conventions.md §5.8). A p-value per joint, Holm's correction
        over the joints.

        Parameters
        ----------
        tau_meas : array_like (N, m)
            The measured torques of the run the band predicts.
        q, dq : array_like (N, m), optional
            The run's joint positions and velocities (without them: the prediction's quantiles and
            time only, and ``q``'s differences stand in for ``dq``).
        n_bins : int
            Quantile bins per state variable, 2 to 20.
        alpha : float
            Significance level of the joints' family, in (0, 1).

        Returns
        -------
        CoverageTest
        """
        meas = promote_signal(to_float_array(tau_meas, "tau_meas"), "tau_meas")
        if meas.shape != self.prediction.shape:
            raise ShapeMismatch(f"tau_meas must have the prediction's shape {format_shape(self.prediction.shape)}, "
                                f"got {format_shape(meas.shape)}")
        check_finite(meas, "tau_meas")
        n, m = meas.shape
        states = {name: None if value is None else check_signal_like(value, name, n, m)
                  for name, value in (("q", q), ("dq", dq))}
        if not is_integer(n_bins) or not 2 <= int(n_bins) <= 20:
            raise parameter_error("n_bins", "an integer with 2 <= n_bins <= 20", n_bins)
        if not is_real_number(alpha) or not 0 < alpha < 1:
            raise parameter_error("alpha", "a number with 0 < alpha < 1", alpha)
        check_min_samples("coverage_test", n, 2 * int(n_bins) * _coverage.MIN_BIN)
        return _coverage.coverage_test(meas, self.prediction, self.std, self.lower, self.upper, self.level,
                                       design=self.design, q=states["q"],
                                       dq=states["dq"], n_bins=int(n_bins), alpha=float(alpha))


@dataclass(frozen=True, repr=False)
class IdentificationResult:
    """Estimate of the base parameters and its statistics.

    Attributes
    ----------
    estimate : ndarray (r,)
        Least-squares estimate of the base parameters, in the order of :attr:`base_columns`.
    std, rel_std_percent : ndarray (r,)
        Standard deviations ``√diag C`` and ``100 · std / |estimate|`` (inf for a zero estimate).
    base_columns : tuple of int
        Indices (ascending) of the regressor columns kept as the base set.
    base_names : tuple of str
        Name of each base parameter: its column name, followed by the dependent columns it
        absorbs (``"ZZ1 + 0.25*m2"``).
    combination : ndarray (r, p)
        ``base = combination @ π`` for the full parameter vector π (identity on the base columns).
    column_names : tuple of str
        Names of all ``p`` regressor columns (``c0``, ``c1``, ... when not given).
    condition_number : float
        2-norm condition number of the (unscaled, weighted if weighting) base regressor.
    rank : int
        Numerical rank ``r``.
    rcond : float
        The rank tolerance used (relative to the largest pivot of the column-scaled regressor).
    sigma2 : float
        Residual variance ``‖τ − Yπ̂‖² / (rows − r)`` (nan when rows == r), of the weighted
        problem when weighting.
    covariance : ndarray (r, r)
        ``σ² (Y_bᵀ Y_b)⁻¹``.
    rows, n_joints : int
        Rows of the stacked system and joints per sample.
    joint_std : ndarray (m,) or None
        The per-joint noise standard deviations used as weights (None without weighting).
    residual_sse : float
        ``‖τ − Y_b π̂‖²`` of the unweighted torques.
    full_parameters : ndarray (p,) or None
        With ``physical=True``: the full parameter vector π̂, in the order of :attr:`column_names`
        (each link's ten parameters, friction, offsets), every link's pseudo-inertia positive
        semidefinite and every friction coefficient ≥ 0; :attr:`estimate` is then its base
        combination ``combination @ full_parameters``. None for the unconstrained fit.
    noise_std : ndarray (m,) or None
        Each joint's noise standard deviation on the estimation run: the root mean square of its
        unweighted residual over its share of the degrees of freedom, ``n·(rows − r)/rows`` (None
        for a result built by hand). :meth:`prediction_interval` uses it.
    colour_std : ndarray (r,) or None
        Standard errors that allow for the residual's colour: √(N · LRV(u_i)), with u_k = C⁻¹-weighted
        score of sample k (``(Y_bᵀY_b)⁻¹ Σ_j y_kjᵀ e_kj``, so that π̂ − π = Σ_k u_k) and LRV the
        prewhitened Newey–West long-run variance the report's bias test uses. Under white noise it
        is close to :attr:`std`; under coloured noise :attr:`std` is too small (None with
        ``physical=True`` or for a result built by hand).
    residual_lag1 : ndarray (m,) or None
        Each joint's lag-1 autocorrelation of the estimation residual; :meth:`summary` calls the
        residual coloured when one of them exceeds 2.576/√N (white noise's 99 % band).
    physical : dict or None
        With ``physical=True``: how the constrained fit was solved and what it cost — ``distance2``
        (the increase of the residual sum of squares over the unconstrained fit's, in units of its
        σ²: the squared Mahalanobis distance of the unconstrained base estimate to the consistent
        set), ``share`` (``distance2 / (rows − r)``: the share of the mean square it adds),
        ``pvalue`` (``P(χ²_r > distance2)``, an upper bound), ``solver``, ``status``,
        ``solve_time`` (s), ``prior_weight``.
    """

    estimate: FloatArray
    std: FloatArray
    rel_std_percent: FloatArray
    base_columns: tuple[int, ...]
    base_names: tuple[str, ...]
    combination: FloatArray
    column_names: tuple[str, ...]
    condition_number: float
    rank: int
    rcond: float
    sigma2: float
    covariance: FloatArray
    rows: int
    n_joints: int
    n_columns: int
    joint_std: FloatArray | None = None
    residual_sse: float = float("nan")
    full_parameters: FloatArray | None = None
    physical: dict[str, Any] | None = None
    noise_std: FloatArray | None = None
    colour_std: FloatArray | None = None
    residual_lag1: FloatArray | None = None
    _meta: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @property
    def n_params(self) -> int:
        """Number of identified parameters (the rank): the ``n_params`` of :func:`dynval.validate`."""
        return self.rank

    def predict(self, regressor: ArrayLike, *, n_joints: Integer | None = None) -> FloatArray:
        """Torques predicted by the estimate on another regressor with the same ``p`` columns.

        ``regressor`` is ``(N, m, p)`` → result ``(N, m)``, or stacked ``(N·m, p)`` → result
        ``(N, m)`` with ``m = n_joints`` (default: the joints of the estimation data).
        """
        y = to_float_array(regressor, "regressor")
        if y.ndim == 3:
            n, m, p = y.shape
            y2 = y.reshape(n * m, p)
        elif y.ndim == 2:
            m = self.n_joints if n_joints is None else int(n_joints)
            if y.shape[0] % m:
                raise ShapeMismatch(f"regressor has {y.shape[0]} rows, which is not a multiple of n_joints={m}")
            n, p = y.shape[0] // m, y.shape[1]
            y2 = y
        else:
            raise InvalidShape(f"regressor must be 3-D (N, m, p) or 2-D (N*m, p), got shape {format_shape(y.shape)}")
        if p != self.n_columns:
            raise ShapeMismatch(f"regressor must have {self.n_columns} columns like the estimation regressor, got {p}")
        check_finite(y2, "regressor")
        return (y2[:, list(self.base_columns)] @ self.estimate).reshape(n, m)

    def prediction_interval(self, regressor: ArrayLike, *, level: float = 0.95,
                            n_joints: Integer | None = None) -> PredictionInterval:
        """The band in which a new measured torque lies with probability ``level``.

        Each sample's variance is the joint's noise (:attr:`noise_std`) plus what the parameters'
        uncertainty adds there, ``y_kᵀ C y_k`` (:attr:`covariance`); the band is the prediction ±
        the Student-t quantile (``rows − r`` degrees of freedom) times its root. It assumes white,
        Gaussian noise as the covariance does: on coloured residuals it is too narrow, which
        :meth:`PredictionInterval.share_inside` shows on a validation run. A missing term widens it
        (the noise level grows with the term), which the share cannot show and
        :meth:`PredictionInterval.coverage_test` can.

        Parameters
        ----------
        regressor : array_like, shape (N, m, p) or (N*m, p)
            As for :meth:`predict`.
        level : float
            Probability of the band, in (0, 1).
        n_joints : int, optional
            As for :meth:`predict`.

        Returns
        -------
        PredictionInterval
        """
        level = check_level(level)
        pred = self.predict(regressor, n_joints=n_joints)
        n, m = pred.shape
        y = to_float_array(regressor, "regressor").reshape(n * m, -1)[:, list(self.base_columns)]
        param_var = np.einsum("ij,jk,ik->i", y, self.covariance, y).reshape(n, m)
        noise = np.full(m, np.sqrt(self.sigma2)) if self.noise_std is None else np.asarray(self.noise_std)
        std = np.sqrt(noise[None, :] ** 2 + np.clip(param_var, 0.0, None))
        dof = self.rows - self.rank
        quantile = float(scipy.stats.t.ppf(0.5 + level / 2.0, dof)) if dof > 0 else float("inf")
        return PredictionInterval(prediction=pred, lower=pred - quantile * std, upper=pred + quantile * std,
                                  std=std, level=level, quantile=quantile, noise_std=noise,
                                  design=y.reshape(n, m, -1))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (arrays as lists; nan and inf as strings as in reports)."""
        from .checks._json import to_jsonable

        out: dict[str, Any] = to_jsonable({
            "method": "pivoted QR (column-scaled), rank tolerance rcond * |R_00|"
                      + ("; full parameters by least squares under physical consistency (SDP)"
                         if self.full_parameters is not None else ""),
            "rank": self.rank,
            "rcond": self.rcond,
            "rows": self.rows,
            "n_joints": self.n_joints,
            "n_columns": self.n_columns,
            "column_names": list(self.column_names),
            "base_columns": list(self.base_columns),
            "base_names": list(self.base_names),
            "estimate": self.estimate,
            "std": self.std,
            "rel_std_percent": self.rel_std_percent,
            "condition_number": self.condition_number,
            "sigma2": self.sigma2,
            "residual_sse": self.residual_sse,
            "covariance": self.covariance,
            "combination": self.combination,
            "joint_std": self.joint_std,
            "noise_std": self.noise_std,
            "full_parameters": self.full_parameters,
            "physical": self.physical,
        })
        return out

    def table(self) -> str:
        """Readable table: base parameter, estimate, standard deviation and %σ."""
        width = max([len("parameter")] + [len(s) for s in self.base_names])
        lines = [f"  {'parameter':<{width}}  {'estimate':>13}  {'std':>11}  {'%σ':>8}"]
        for name, est, sd, rel in zip(self.base_names, self.estimate, self.std, self.rel_std_percent):
            lines.append(f"  {name:<{width}}  {est:>13.6g}  {sd:>11.4g}  {rel:>8.2f}")
        lines.append(f"  rank {self.rank} of {self.n_columns} columns; condition number of the base "
                     f"regressor {self.condition_number:.4g}; σ² = {self.sigma2:.4g}")
        if self.physical is not None:
            lines.append(f"  physically consistent (every pseudo-inertia PSD, friction >= 0): d² = "
                         f"{self.physical['distance2']:.4g} from the unconstrained estimate, "
                         f"{100 * self.physical['share']:.3g} % of its mean square")
        return "\n".join(lines)


    def coloured(self) -> bool:
        """Whether the estimation residual is coloured (:attr:`residual_lag1` beyond white noise's 99 % band)."""
        if self.residual_lag1 is None:
            return False
        n = self.rows // max(self.n_joints, 1)
        return bool(np.any(np.abs(self.residual_lag1) > 2.576 / np.sqrt(max(n, 1))))

    def coefficients(self, *, level: float = 0.95, std: Literal["auto", "white", "colour"] = "auto") -> dict[str, Any]:
        """Per base parameter: estimate, standard error, t, two-sided p-value and the ``level`` interval.

        ``std="white"`` uses :attr:`std` (white noise; Student t with ``rows − r`` degrees of
        freedom), ``"colour"`` uses :attr:`colour_std` (normal quantiles: an asymptotic result),
        ``"auto"`` the latter when the residual is :meth:`coloured` and it is available. The entry
        ``std_kind`` says which was used.
        """
        level = check_level(level)
        if std not in ("auto", "white", "colour"):
            raise parameter_error("std", "'auto', 'white' or 'colour'", std)
        use_colour = self.colour_std is not None and (std == "colour" or (std == "auto" and self.coloured()))
        if std == "colour" and self.colour_std is None:
            raise parameter_error("std", "'white' or 'auto': this result has no colour-robust standard errors "
                                  "(physical=True, or built by hand)", std)
        se = np.asarray(self.colour_std if use_colour else self.std, dtype=np.float64)
        dof = self.rows - self.rank
        dist = scipy.stats.norm if use_colour or dof <= 0 else scipy.stats.t(dof)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = self.estimate / se
        quantile = float(dist.ppf(0.5 + level / 2.0))
        return {"name": list(self.base_names), "estimate": self.estimate, "std_err": se, "t": t,
                "pvalue": 2.0 * dist.sf(np.abs(t)), "lower": self.estimate - quantile * se,
                "upper": self.estimate + quantile * se, "level": level,
                "std_kind": "colour" if use_colour else "white"}

    def to_frame(self, *, level: float = 0.95, std: Literal["auto", "white", "colour"] = "auto") -> Any:
        """The coefficient table of :meth:`summary` as a pandas DataFrame, one row per base parameter."""
        from .checks._json import to_frame

        c = self.coefficients(level=level, std=std)
        return to_frame({k: c[k] for k in ("estimate", "std_err", "t", "pvalue", "lower", "upper")}, c["name"],
                        "parameter", "IdentificationResult.to_frame()")

    def summary(self, *, level: float = 0.95, std: Literal["auto", "white", "colour"] = "auto") -> str:
        """The fit as a statistician reads it first: sizes, σ², conditioning, and per base parameter the
        estimate, standard error, t, p and the ``level`` confidence interval (:meth:`coefficients`),
        with notes on the base parameters and on the standard errors used.

        Examples
        --------
        >>> import numpy as np
        >>> from dynval.identify import identify
        >>> x = np.linspace(-1.0, 1.0, 50)
        >>> fit = identify(np.column_stack([np.ones(50), x]), 2.0 + 0.5 * x + 0.01 * np.cos(40 * x),
        ...                column_names=["offset", "slope"])
        >>> print(fit.summary())  # doctest: +ELLIPSIS
        Identification: least squares on τ = Y π + ε
        ...
        parameter  estimate    std err  ...
        offset     ...
        """
        c = self.coefficients(level=level, std=std)
        width = max([len("parameter")] + [len(s) for s in c["name"]])
        lo, hi = f"[{(1 - c['level']) / 2:.3g}", f"{(1 + c['level']) / 2:.3g}]"
        head = (f"{'parameter':<{width}}  {'estimate':>11}  {'std err':>10}  {'t':>9}  {'P>|t|':>9}  "
                f"{lo:>11}  {hi:>11}")
        rule = "=" * len(head)
        dof = self.rows - self.rank
        n = self.rows // max(self.n_joints, 1)
        lines = ["Identification: least squares on τ = Y π + ε"
                 + (" under physical consistency" if self.full_parameters is not None else ""), rule,
                 f"samples N = {n}, joints m = {self.n_joints}, rows N·m = {self.rows}, columns p = {self.n_columns}",
                 f"rank r = {self.rank}, residual degrees of freedom = {dof}, σ² = {self.sigma2:.4g}"
                 + ("" if self.joint_std is None else " (weighted by each joint's σ)"),
                 f"condition number of the base regressor = {self.condition_number:.4g}, rank tolerance = "
                 f"{self.rcond:.3g}", rule, head, "-" * len(head)]
        for i, name in enumerate(c["name"]):
            lines.append(f"{name:<{width}}  {c['estimate'][i]:>11.5g}  {c['std_err'][i]:>10.4g}  {c['t'][i]:>9.3g}  "
                         f"{c['pvalue'][i]:>9.3g}  {c['lower'][i]:>11.5g}  {c['upper'][i]:>11.5g}")
        lines += [rule, "Notes:"] + [f"[{k}] {note}" for k, note in enumerate(self._summary_notes(c), start=1)]
        return "\n".join(lines)

    def _summary_notes(self, c: dict[str, Any]) -> list[str]:
        notes = []
        dropped = self.n_columns - self.rank
        if dropped:
            notes.append(f"Base parameters: {dropped} of the {self.n_columns} columns are zero or combinations of "
                         "others; each name shows the combination the parameter stands for.")
        lag1 = "" if self.residual_lag1 is None else (
            f" (largest |lag-1 autocorrelation| of a joint's residual: {np.max(np.abs(self.residual_lag1)):.3g})")
        if c["std_kind"] == "colour":
            ratio = np.nanmax(np.asarray(self.colour_std) / self.std) if np.all(self.std > 0) else float("nan")
            notes.append(f"The residual is coloured{lag1}: standard errors, t, p and intervals allow for it "
                         f"(Newey–West long-run variance, normal quantiles); they are up to {ratio:.3g} × the "
                         "white-noise ones (std=\"white\" shows those).")
        elif self.coloured():
            notes.append(f"The residual is coloured{lag1}: the standard errors shown assume white noise and are "
                         "too small" + (" (std=\"auto\" allows for the colour)." if self.colour_std is not None
                                        else "; this result has no colour-robust ones."))
        else:
            notes.append(f"Standard errors assume white noise (Student t, {self.rows - self.rank} degrees of "
                         f"freedom); the residual shows no colour{lag1}.")
        return notes

    def _repr_html_(self) -> str:
        import html

        c = self.coefficients()
        cells = "".join(
            f"<tr><td>{html.escape(name)}</td>" + "".join(
                f"<td style='text-align:right'>{c[k][i]:.4g}</td>"
                for k in ("estimate", "std_err", "t", "pvalue", "lower", "upper")) + "</tr>"
            for i, name in enumerate(c["name"]))
        head = "".join(f"<th>{h}</th>" for h in ("parameter", "estimate", "std err", "t", "P>|t|",
                                                 f"[{(1 - c['level']) / 2:.3g}", f"{(1 + c['level']) / 2:.3g}]"))
        return (f"<p>Identification: rank {self.rank} of {self.n_columns} columns, {self.rows} rows, "
                f"σ² = {self.sigma2:.4g}, {c['std_kind']}-noise standard errors</p>"
                f"<table><thead><tr>{head}</tr></thead><tbody>{cells}</tbody></table>")

    def __repr__(self) -> str:
        return (f"IdentificationResult(rank={self.rank} of {self.n_columns} columns, rows={self.rows}, "
                f"joints={self.n_joints}, sigma2={self.sigma2:.4g}, condition_number={self.condition_number:.4g}"
                + (", physical" if self.full_parameters is not None else "") + ")")


def _stack(regressor: ArrayLike, tau_meas: ArrayLike,
           n_joints: Integer | None) -> tuple[FloatArray, FloatArray, int, int, int]:
    """Check the inputs with the shared checker and return (A, b, N, m, p)."""
    meas = to_float_array(tau_meas, "tau_meas")
    y = to_float_array(regressor, "regressor")
    if y.ndim == 2 and meas.ndim == 1 and meas.shape[0] == y.shape[0]:
        # Stacked torques beside a stacked regressor: one output, or m joints with n_joints=m.
        m = 1 if n_joints is None else n_joints
        if not isinstance(m, (int, np.integer)) or m <= 0 or meas.shape[0] % m:
            raise parameter_error("n_joints", "a positive integer dividing the regressor rows", n_joints)
        km = meas.reshape(-1, int(m))
    else:
        km = promote_signal(meas, "tau_meas")
    n, m = km.shape
    if y.ndim == 2 and n_joints is None:
        n_joints = m
    p = regressor_shape(y, "tau_meas", n, m, n_joints if y.ndim == 2 else None)
    # Rows must exceed the columns, or no residual variance is left.
    check_min_samples("identify", n, minimum=-(-(p + 1) // m))
    check_finite(km, "tau_meas")
    a = np.ascontiguousarray(y.reshape(n * m, p))
    check_finite(a.reshape(n, m * p), "regressor", n_columns=p)
    return a, km.reshape(-1), n, m, p


def _check_column_names(column_names: Sequence[str] | None, p: int) -> tuple[str, ...]:
    if column_names is None:
        return tuple(f"c{i}" for i in range(p))
    names = tuple(column_names)
    if len(names) != p or not all(isinstance(s, str) for s in names):
        raise parameter_error("column_names", f"a sequence of {p} strings (one per regressor column)", column_names)
    return names


def _check_rcond(rcond: float | None, rows: int, p: int) -> float:
    if rcond is None:
        return default_rcond(rows, p)
    if not is_real_number(rcond) or not 0 <= rcond < 1:
        raise parameter_error("rcond", "None or a number with 0 <= rcond < 1", rcond)
    return float(rcond)


_SPLITTER = 134217729.0  # 2**27 + 1: Veltkamp's split of a double into two 26-bit halves


def _two_prod(a: FloatArray, b: FloatArray | float) -> tuple[FloatArray, FloatArray]:
    """Error-free product: a*b = p + e exactly (Dekker), elementwise."""
    prod = a * b
    ca = _SPLITTER * a
    a_hi = ca - (ca - a)
    a_lo = a - a_hi
    cb = _SPLITTER * b
    b_hi = cb - (cb - b)
    b_lo = b - b_hi
    err = a_lo * b_lo - (((prod - a_hi * b_hi) - a_lo * b_hi) - a_hi * b_lo)
    return prod, err


def _two_sum(a: FloatArray, b: FloatArray) -> tuple[FloatArray, FloatArray]:
    s = a + b
    z = s - a
    return s, (a - (s - z)) + (b - z)


def _accurate_residuals(a: FloatArray, x: FloatArray, b: FloatArray,
                        r: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``f = b − r − A x`` (rows) and ``g = −Aᵀ r`` (columns), each as if in twice the working precision.

    Rows: Ogita–Rump–Oishi Dot2, vectorized over rows; columns: exact products summed by
    :func:`math.fsum`. Platform-independent (no reliance on a wider ``long double``).
    """
    import math

    s, c = _two_sum(b, -r)
    for j in range(a.shape[1]):
        p_hi, p_lo = _two_prod(a[:, j], -x[j])
        s, e = _two_sum(s, p_hi)
        c = c + (e + p_lo)
    f = s + c
    p_hi, p_lo = _two_prod(a, -r[:, None])
    g = np.array([math.fsum(np.concatenate([p_hi[:, j], p_lo[:, j]])) for j in range(a.shape[1])])
    return f, g


def _pivoted_qr(a: FloatArray, rcond: float, with_q: bool = True) -> dict[str, Any] | None:
    """The column-scaled pivoted QR of the base-parameter reduction (module notes).

    ``a`` may also be any matrix with the same R factor (e.g. the R of a blockwise QR): the column
    norms and the pivoting are the same. Returns ``scale`` (column norms), ``nonzero`` (the columns
    kept), ``q`` (None unless ``with_q``), ``r``, ``rank``, ``base`` and ``dep`` (column indices of
    ``a``, in pivot order), or None when no column is kept or the rank is 0.
    """
    scale = np.sqrt(np.einsum("ij,ij->j", a, a))
    # A column whose norm is roundoff of a structurally zero column (cos(π/2) = 6e-17 in a
    # kinematic chain) would look independent scaled to unit norm and be "identified" from noise.
    nonzero = np.flatnonzero(~zero_columns(scale))
    if nonzero.size == 0:
        return None
    a_s = a[:, nonzero] / scale[nonzero]
    if with_q:
        q, r, piv = scipy.linalg.qr(a_s, mode="economic", pivoting=True, check_finite=False)
    else:
        q = None
        r, piv = scipy.linalg.qr(a_s, mode="r", pivoting=True, check_finite=False)
        r = r[:min(a_s.shape)]
    diag = np.abs(np.diag(r))
    rank = int(np.sum(diag > rcond * diag[0])) if diag[0] > 0 else 0
    if rank == 0:
        return None
    return {"scale": scale, "nonzero": nonzero, "q": q, "r": r, "rank": rank, "base": nonzero[piv[:rank]],
            "dep": nonzero[piv[rank:]]}


def _combination(r: FloatArray, rank: int, base: IntArray, dep: IntArray, scale: FloatArray,
                 p: int) -> tuple[FloatArray, IntArray]:
    """Each base parameter as a combination of the columns (rows in ascending base order), and
    that order: the dependent columns are Y_d = Y_b β (module notes)."""
    beta_s = scipy.linalg.solve_triangular(r[:rank, :rank], r[:rank, rank:], check_finite=False)
    order = np.argsort(base)
    sb = scale[base]
    beta = beta_s * scale[dep][None, :] / sb[:, None] if dep.size else np.zeros((rank, 0))
    combination = np.zeros((rank, p))
    combination[np.arange(rank), base] = 1.0
    if dep.size:
        combination[:, dep] = beta
    return combination[order], order


def base_set(a: FloatArray, rcond: float) -> dict[str, Any]:
    """The base columns of ``a`` (rows × p, or any matrix with its R factor, such as that R).

    The reduction :func:`identify` makes, without solving: ``rank``, ``base`` (ascending),
    ``dependent`` (nonzero columns that are combinations of the base ones), ``zero`` (zero
    columns: norm 0 or roundoff, ``statistics._columns.zero_columns``), ``combination`` (rank × p: each base
    parameter as a combination of the columns) and ``pivots`` (``|R_kk|`` relative to ``|R_00|``).
    """
    p = a.shape[1]
    f = _pivoted_qr(a, rcond, with_q=False)
    if f is None:
        return {"rank": 0, "base": np.zeros(0, dtype=np.intp), "dependent": np.zeros(0, dtype=np.intp),
                "zero": np.arange(p), "combination": np.zeros((0, p)), "pivots": np.zeros(0)}
    rank, base, dep = f["rank"], f["base"], f["dep"]
    combination, _order = _combination(f["r"], rank, base, dep, f["scale"], p)
    diag = np.abs(np.diag(f["r"]))
    return {"rank": rank, "base": np.sort(base), "dependent": np.sort(dep),
            "zero": np.setdiff1d(np.arange(p), f["nonzero"]), "combination": combination,
            "pivots": diag / diag[0]}


def _solve(a: FloatArray, b: FloatArray, rcond: float) -> dict[str, Any] | None:
    """Column-scaled pivoted QR solve with iterative refinement; the pieces the result needs."""
    _rows, p = a.shape
    fac = _pivoted_qr(a, rcond)
    if fac is None:
        return None
    q, r, rank, base, dep, scale = fac["q"], fac["r"], fac["rank"], fac["base"], fac["dep"], fac["scale"]
    r11 = r[:rank, :rank]
    q1 = q[:, :rank]
    sb = scale[base]
    a_b = a[:, base]

    def tri(rhs: FloatArray, trans: int = 0) -> FloatArray:
        out: FloatArray = scipy.linalg.solve_triangular(r11, rhs, trans=trans, check_finite=False)
        return out

    x_s = tri(q1.T @ b)
    x = x_s / sb
    res = b - a_b @ x
    # Iterative refinement on the augmented system [I A; Aᵀ 0][r; x] = [b; 0] (Björck), with
    # the residuals of both equations computed in twice the working precision: it recovers the
    # digits that the rounding of a large-residual, ill-conditioned problem costs plain QR.
    for _ in range(4):
        f, g = _accurate_residuals(a_b, x, b, res)
        h = tri(g / sb, trans=1)              # R11⁻ᵀ (scaled g)
        qtf = q1.T @ f
        dx_s = tri(qtf - h)
        dres = q1 @ h + f - q1 @ qtf
        x = x + dx_s / sb
        res = res + dres
        if np.max(np.abs(dx_s)) <= np.finfo(np.float64).eps * np.max(np.abs(x * sb)):
            break

    r11_inv = tri(np.eye(rank))
    # Dependent columns in terms of the base ones: Y_d = Y_b β (scaled units first).
    combination, order = _combination(r, rank, base, dep, scale, p)
    cinv = (r11_inv @ r11_inv.T) / np.outer(sb, sb)
    return {
        "rank": rank,
        "base": base[order],
        "estimate": x[order],
        "cinv": cinv[np.ix_(order, order)],
        "combination": combination,
        "residual": res,
    }


def _fit(a: FloatArray, b: FloatArray, rcond: float, p: int) -> tuple[dict[str, Any], FloatArray] | None:
    solved = _solve(a, b, rcond)
    if solved is None:
        return None
    return solved, solved["residual"]


@one_blas_thread
def identify(regressor: ArrayLike, tau_meas: ArrayLike, *, weights: Literal["per_joint"] | ArrayLike | None = None,
             rcond: float | None = None, column_names: Sequence[str] | None = None, n_joints: Integer | None = None,
             name_tolerance: float = 1e-10, physical: bool = False, prior: ArrayLike | None = None,
             prior_weight: float = 1e-6, prior_metric: Literal["euclidean", "entropic"] = "euclidean",
             com_bounds: Any = None) -> IdentificationResult:
    """Least-squares estimate of the base parameters of ``τ = Y π + ε``.

    Parameters
    ----------
    regressor : array_like, shape (N, m, p), or (N·m, p) stacked sample-major
        The regressor (sample, joint, column); a 2-D regressor with ``tau_meas`` of shape (N,)
        and N rows is an ordinary regression with one output.
    tau_meas : array_like, shape (N, m) or (N,)
        Measured torques.
    weights : None, "per_joint" or array_like (m,)
        No weighting; per-joint weights from an ordinary fit (see the module notes); or the
        per-joint noise standard deviations σ_j.
    rcond : float or None
        Rank tolerance relative to the largest pivot of the column-scaled regressor; default
        ``max(rows, p) · eps``.
    column_names : sequence of str or None
        One name per regressor column.
    n_joints : int or None
        Joints per sample for a stacked 2-D regressor (default: the columns of ``tau_meas``).
    name_tolerance : float
        Coefficients of dependent columns below this magnitude are left out of
        :attr:`IdentificationResult.base_names` (never out of ``combination``).
    physical : bool
        Least squares over physically consistent full parameters (module notes): every link's
        pseudo-inertia PSD and friction ≥ 0; needs ``column_names`` as
        :meth:`dynval.robots.URDFModel.column_names` gives them and cvxpy
        (``pip install 'dynval[physical]'``). Sets :attr:`IdentificationResult.full_parameters`.
    prior : array_like (p,) or None
        With ``physical=True``: the parameters to pull towards where the data say little (the URDF's
        a-priori values, :meth:`dynval.robots.URDFModel.parameters`); None pulls towards zero.
    prior_weight : float
        Weight of ``(π_c − prior_c)²`` relative to the curvature of the data term (σ²-scaled) in
        its column's link (the geometric mean of ‖G_c‖² over the link's columns; its own for a
        friction or free column), so that it does not depend on the columns' units: the default
        1e-6 only picks one answer in the directions the data cannot see.
    prior_metric : {"euclidean", "entropic"}
        With ``physical=True``: how the prior pulls. ``"euclidean"``: ``‖π − prior‖²``.
        ``"entropic"``: each link's Bregman divergence of −log det between its pseudo-inertia and the
        prior's, ``tr(J₀⁻¹J) − log det(J₀⁻¹J) − 4`` (Lee & Park 2018; invariant to the frame, it keeps
        J positive definite and penalises a thin, flat or concentrated body more than a Euclidean
        distance does), scaled by ``2‖J₀‖²_F`` so that near the prior both read alike; friction and
        other columns Euclidean. Needs a prior whose links have positive definite pseudo-inertias.
    com_bounds : None, pair or mapping
        With ``physical=True``: a box ``(lower, upper)`` (m, in the link's joint frame) for every
        link's centre of mass, or a mapping link → box.

    Returns
    -------
    IdentificationResult

    Raises
    ------
    dynval.InputError
        The subclasses of the shared input checker: wrong types or shapes, too few rows
        (rows must exceed p), non-finite data, bad keyword values.

    Examples
    --------
    >>> import numpy as np
    >>> from dynval.identify import identify
    >>> x = np.arange(6.0)

    A rank-deficient regressor (its third column repeats the second) is identified on its base
    parameters, whose names say which combination each one is:

    >>> Y = np.column_stack([np.ones(6), x, 2 * x])
    >>> res = identify(Y, 1.0 + 3.0 * x, column_names=["a", "b", "c"])
    >>> res.rank, res.base_names
    (2, ('a', 'b + 2*c'))
    >>> np.round(res.estimate, 12).tolist()
    [1.0, 3.0]
    """
    a, b, n, m, p = _stack(regressor, tau_meas, n_joints)
    names = _check_column_names(column_names, p)
    rows = a.shape[0]
    tol = _check_rcond(rcond, rows, p)
    if not isinstance(physical, (bool, np.bool_)):
        raise parameter_error("physical", "True or False", physical)
    if physical:
        _consistency.import_cvxpy("identify(physical=True)")

    joint_std = None
    if weights is not None:
        if isinstance(weights, str):
            if weights != "per_joint":
                raise parameter_error("weights", "None, 'per_joint' or an array of m positive numbers", weights)
            first = _fit(a, b, tol, p)
            if first is None:
                raise parameter_error("regressor", "a regressor with at least one non-zero column", "all zero")
            solved0, resid0 = first
            dof = n - solved0["rank"] if n > solved0["rank"] else n
            joint_std = np.sqrt(np.sum(resid0.reshape(n, m) ** 2, axis=0) / dof)
            if not np.all(joint_std > 0):
                # An exact fit on some joint: no noise level to weight by, keep those rows unweighted.
                positive = joint_std[joint_std > 0]
                joint_std = np.where(joint_std > 0, joint_std, positive.min() if positive.size else 1.0)
        else:
            w = to_float_array(weights, "weights").reshape(-1)
            if w.shape != (m,) or not np.all(np.isfinite(w)) or not np.all(w > 0):
                raise parameter_error("weights", f"None, 'per_joint' or an array of m={m} positive numbers", weights)
            joint_std = w
        row_w = np.tile(1.0 / joint_std, n)
        a_w, b_w = a * row_w[:, None], b * row_w
    else:
        a_w, b_w = a, b

    fitted = _fit(a_w, b_w, tol, p)
    if fitted is None:
        raise parameter_error("regressor", "a regressor with at least one non-zero column", "all zero")
    solved, resid_w = fitted
    rank = solved["rank"]
    base = solved["base"]
    est = solved["estimate"]
    sse_w = float(resid_w @ resid_w)
    dof = rows - rank
    sigma2 = sse_w / dof if dof > 0 else float("nan")
    full = info = None
    if physical:
        full, est, resid_w, info = _physical_fit(a_w, b_w, sigma2, names, solved, prior, prior_weight, com_bounds,
                                                 prior_metric)
        sse_w = float(resid_w @ resid_w)
        sigma2 = sse_w / dof if dof > 0 else float("nan")
    cov = sigma2 * solved["cinv"]
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = 100.0 * std / np.abs(est)
    cond = float(np.linalg.cond(a_w[:, base])) if rank else float("nan")
    resid = resid_w if joint_std is None else resid_w * np.tile(joint_std, n)

    comb = solved["combination"]
    base_names = []
    for i, c in enumerate(base):
        text = names[c]
        for d in np.flatnonzero(np.abs(comb[i]) > name_tolerance):
            if d == c:
                continue
            coef = comb[i, d]
            sign = "-" if coef < 0 else "+"
            mag = abs(coef)
            term = names[d] if abs(mag - 1.0) < 1e-12 else f"{mag:.6g}*{names[d]}"
            text += f" {sign} {term}"
        base_names.append(text)

    dof_joint = n * dof / rows if rows else 0.0
    noise_std = (np.sqrt(np.sum(resid.reshape(n, m) ** 2, axis=0) / dof_joint) if dof_joint > 0
                 else np.full(m, np.nan))
    return IdentificationResult(
        estimate=est,
        std=std,
        rel_std_percent=rel,
        base_columns=tuple(int(c) for c in base),
        base_names=tuple(base_names),
        combination=comb,
        column_names=names,
        condition_number=cond,
        rank=rank,
        rcond=tol,
        sigma2=sigma2,
        covariance=cov,
        rows=rows,
        n_joints=m,
        n_columns=p,
        joint_std=joint_std,
        residual_sse=float(resid @ resid),
        full_parameters=full,
        physical=info,
        noise_std=noise_std,
        colour_std=None if physical else _colour_std(a_w[:, base], resid_w, solved["cinv"], n, m),
        residual_lag1=_lag1(resid.reshape(n, m)),
    )


def _colour_std(a_b: FloatArray, resid: FloatArray, cinv: FloatArray, n: int, m: int) -> FloatArray:
    """Standard errors robust to the residual's colour (:attr:`IdentificationResult.colour_std`)."""
    from .statistics._stats import long_run_variance

    scores = np.einsum("kjc,kj->kc", a_b.reshape(n, m, -1), resid.reshape(n, m))
    influence = scores @ cinv.T  # π̂ − π = Σ_k influence_k
    lrv = long_run_variance(influence, np.array([0])).long_run_variance
    out: FloatArray = np.sqrt(np.clip(n * lrv, 0.0, None))
    return out


def _lag1(resid: FloatArray) -> FloatArray:
    """Each joint's lag-1 (biased) autocorrelation; 0 for a constant residual."""
    centred = resid - resid.mean(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = np.sum(centred[1:] * centred[:-1], axis=0) / np.sum(centred**2, axis=0)
    out: FloatArray = np.nan_to_num(rho, nan=0.0)
    return out


def _physical_fit(a_w: FloatArray, b_w: FloatArray, sigma2: float, names: tuple[str, ...], solved: dict[str, Any],
                  prior: ArrayLike | None, prior_weight: float, com_bounds: Any,
                  prior_metric: str = "euclidean") -> tuple[FloatArray, FloatArray, FloatArray, dict[str, Any]]:
    """The constrained fit of ``identify(physical=True)``: full parameters, their base combination
    (in the unconstrained fit's base order), the weighted residual and the solver's record."""
    import scipy.stats

    fit = _consistency.constrained_fit(a_w, b_w, sigma2, names, prior=prior, prior_weight=prior_weight,
                                       prior_metric=prior_metric, com_bounds=com_bounds)
    full = fit.pop("pi")
    rank = int(solved["rank"])
    dof = a_w.shape[0] - rank
    resid_ls, resid = solved["residual"], b_w - a_w @ full
    # the squared Mahalanobis distance of the unconstrained base estimate to the consistent set
    d2 = max((float(resid @ resid) - float(resid_ls @ resid_ls)) / sigma2, 0.0) if sigma2 > 0 else float("nan")
    fit.update(distance2=d2, share=d2 / dof if dof > 0 else float("nan"),
               pvalue=float(scipy.stats.chi2.sf(d2, rank)))
    return full, solved["combination"] @ full, resid, fit
