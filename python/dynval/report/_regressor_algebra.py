"""The regressor's linear algebra that the report's sections share: which of each joint's columns
are zero, each joint's Gram matrix, the residual's projection on each joint's columns (the
spectrum's), and the R factors and base columns of the design section's excitation.

All of it is exact under scaling by powers of two (contract §1.3) and depends on the regressor
alone but for the residual's projection itself, so a prepared regressor keeps it (``memo``).
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import scipy.linalg
    import scipy.linalg.lapack
else:
    from .._lazy import scipy

from ..statistics._columns import ROW_BLOCK
from ..statistics._columns import exponents as _exponents
from ..statistics._columns import largest_abs as _column_largest
from ..statistics._columns import pow2_exponents as _pow2_exponents
from ..statistics._columns import scale_pow2 as _scale_pow2
from ._prepared import Memo, compute_now

Factor = tuple[np.ndarray, np.ndarray]
"""The column-scaled normal equations' matrix and the columns' norms (:func:`_normal_factor`)."""


def column_largest(reg3: np.ndarray, memo: Memo[Any] = compute_now) -> np.ndarray:
    """Each joint column's largest |x|, (m, p): zero exactly for a column of zeros (common: a
    link's parameters do not act on the joints before it). One contiguous pass, kept by a
    prepared regressor; the Gram matrices, the projection's blocks, the columns'
    autocorrelations and the excitation's factor all leave the zero columns out."""
    n, m, p = reg3.shape
    largest: np.ndarray = memo(("column_largest", reg3.shape),
                               lambda: _largest_of(reg3.reshape(n, m * p), memo).reshape(m, p))
    return largest


def _largest_of(x: np.ndarray, memo: Memo[Any]) -> np.ndarray:
    """Each column's largest |x|: from the compiled core's moments of the regressor when it is
    there (each column's min and max, exact; kept under the key the cross-correlation kernel reads
    them from, so the one pass serves both), else numpy's max and min. The same values either way."""
    from ..kernels._backend import available, get_backend  # here: the core is imported once, by the backends

    # the compiled module, where it imports (the reference kernels have no moments)
    core: Any = get_backend("cpp") if "cpp" in available() else None
    if (core is None or not hasattr(getattr(core, "RegressorMoments", None), "column_max")
            or not (x.dtype == np.float64 and x.flags.c_contiguous) or x.shape[0] == 0):
        return _column_largest(x)
    moments = memo(("regressor_moments", x.shape), lambda: core.regressor_moments(x))
    largest: np.ndarray = np.maximum(np.asarray(moments.column_max), -np.asarray(moments.column_min))
    return largest


class JointGrams:
    """Each joint's regressor Gram matrix Y_jᵀY_j (m, p, p), from one blocked pass over the rows
    (each joint's nonzero columns only: ``largest`` from :func:`column_largest`, computed if not given).

    The residual spectrum's projection (each joint's least squares) and the excitation section
    (the stacked regressor's Gram matrix is Σ_j Y_jᵀY_j, its column norms the root of its
    diagonal) share it. ``usable`` is False when an entry is not finite, or the diagonal entry of
    a nonzero column is outside [1e-280, 1e280]: then sums of squares may have overflowed or
    underflowed, and both users take their exactly scaled routes instead.
    """

    def __init__(self, reg3: np.ndarray, largest: np.ndarray | None = None, block: int | None = None):
        n, m, p = reg3.shape
        largest = column_largest(reg3) if largest is None else largest
        block = block or max(1, ROW_BLOCK // max(m, 1))
        live = [np.flatnonzero(largest[j] > 0) for j in range(m)]
        compact = [np.zeros((cols.size, cols.size)) for cols in live]
        with np.errstate(over="ignore", under="ignore", invalid="ignore"):
            for i in range(0, n, block):
                rows = reg3[i:i + block]
                for j, cols in enumerate(live):
                    if cols.size:
                        y = rows[:, j, :] if cols.size == p else rows[:, j, cols]
                        compact[j] += y.T @ y
        self.gram = np.zeros((m, p, p))
        for j, cols in enumerate(live):
            self.gram[j][np.ix_(cols, cols)] = compact[j]
        diag = np.concatenate([np.diagonal(g) for g in compact])
        self.usable = bool(all(np.all(np.isfinite(g)) for g in compact)
                           and np.all((diag >= 1e-280) & (diag <= 1e280)))

    def stacked(self) -> np.ndarray:
        """The Gram matrix of the regressor stacked over joints, (p, p)."""
        total: np.ndarray = self.gram.sum(axis=0)
        return total


def _project_out(e: np.ndarray, reg3: np.ndarray, grams: JointGrams | None = None,
                 memo: Memo[Any] = compute_now) -> np.ndarray:
    """The residual less its least-squares projection on each joint's regressor columns.

    What depends on the regressor alone (each joint's live columns, the solve's factor, the
    factorisation of an ill-conditioned block) comes from ``memo``: a prepared regressor computes
    it once for every residual."""
    n, m, p = reg3.shape
    if n < 4 * p:
        return e
    out = np.empty_like(e)
    fast = np.zeros(m, dtype=bool)
    # the joints whose live columns are well conditioned: solved by their normal equations
    solvable = [] if grams is None or not grams.usable else [
        (j, live, factor) for j in range(m)
        for live in [memo(("live_columns", reg3.shape, j), partial(_live_columns, grams, j))]
        for factor in [memo(("live_factor", reg3.shape, j), partial(_live_factor, grams, j, live))]
        if factor is not None]
    if solvable:
        beta = np.zeros((m, p))
        with np.errstate(over="ignore", under="ignore", invalid="ignore"):
            # every joint's Yⱼᵀeⱼ in one contiguous pass over Y (a strided BLAS pass per joint
            # reads Y m times); a zero column's entry is zero and is left out below
            yte = np.einsum("nj,njp->jp", e, reg3)
        for j, live, factor in solvable:
            yb = yte[j, live]
            if np.all(np.isfinite(yb)) and 1e-280 <= _sum_squares(e[:, j]) <= 1e280:
                beta[j, live] = _solve_factored(factor, yb)
                fast[j] = True
        if fast.any():
            with np.errstate(over="ignore", under="ignore", invalid="ignore"):
                fitted = np.einsum("njp,jp->nj", reg3, beta)  # one pass again, for every joint
            out[:, fast] = e[:, fast] - fitted[:, fast]
    for j in np.flatnonzero(~fast).tolist():
        # The projection does not depend on the scale of e or of any column: both are scaled by
        # powers of two near their largest |x| first (exact, contract §1.3), so that subnormal or
        # 1e140 data do not overflow the normal equations.
        y, solver = memo(("scaled_block", reg3.shape, int(j)), partial(_scaled_block, reg3, int(j), memo, grams))
        ej, k = _pow2_columns(e[:, j : j + 1])
        # Below the condition limit the kept normal-equations factor solves it; above, the kept
        # projection on the block's numerical range (lstsq's rank decision) is applied.
        if y is not None:
            rest = ej[:, 0] - y @ _solve_factored(solver, y.T @ ej[:, 0])
        else:
            rest = solver.residual(ej[:, 0])
        out[:, j] = np.ldexp(rest, k[0])
    return out


def _live_columns(grams: JointGrams, j: int) -> np.ndarray:
    """Joint j's columns with a nonzero norm: its zero columns add nothing to its projection."""
    return np.flatnonzero(np.diagonal(grams.gram[j]) > 0)


def _live_factor(grams: JointGrams, j: int, live: np.ndarray) -> Factor | None:
    """:func:`_normal_factor` of joint j's live columns (None without any)."""
    return _normal_factor(grams.gram[j][np.ix_(live, live)]) if live.size else None


def _scaled_block(reg3: np.ndarray, j: int, memo: Memo[Any],
                  grams: JointGrams | None = None) -> tuple[np.ndarray, Factor] | tuple[None, RangeProjection]:
    """Joint j's nonzero columns scaled exactly by powers of two and how to solve on them: (the
    block, the factor of its normal equations) when they are well conditioned, else (None, the
    projection on its numerical range), which no longer needs the block. A zero column adds
    nothing to the range, and a serial arm's joint has many (the parameters of the links before
    it): leaving them out makes the factorisation several times cheaper. The largest |x| of every
    column at once: one contiguous pass instead of a strided one per joint.

    The range projection of a singular block is formed from the joint's one R factor
    (:func:`joint_factor`, taken from this block), which the excitation section and the kinds the
    model spans without q read too: the block is scaled and factored once per joint."""
    y = _scaled_live_block(reg3, j, column_largest(reg3, memo))
    factor = None
    if y.shape[1] and not _gram_says_singular(grams, reg3.shape, j, memo):
        factor = _normal_factor(y.T @ y)
    if factor is not None:
        return y, factor
    r = memo(("joint_factor", reg3.shape, j), partial(_factor_with_library, y)) if y.shape[1] else None
    return None, RangeProjection(y, None if r is None else r[:, :y.shape[1]])


def _gram_says_singular(grams: JointGrams | None, shape: tuple[int, ...], j: int, memo: Memo[Any]) -> bool:
    """Whether joint j's usable Gram matrix already found its live columns beyond the normal
    equations' condition limit (:func:`_project_out`'s first test): the scaled block's own Gram
    matrix, the same up to rounding, is then not formed to be found so again."""
    if grams is None or not grams.usable:
        return False
    live = memo(("live_columns", shape, j), partial(_live_columns, grams, j))
    return bool(live.size) and memo(("live_factor", shape, j), partial(_live_factor, grams, j, live)) is None


def _scaled_live_block(reg3: np.ndarray, j: int, largest: np.ndarray) -> np.ndarray:
    """Joint j's nonzero columns, each scaled by the power of two of its largest |x| (exact)."""
    live = np.flatnonzero(largest[j] > 0)
    if live.size == reg3.shape[2]:
        return _scale_pow2(reg3[:, j, :], _exponents(largest[j]))
    return _scale_pow2(reg3[:, j, :], _exponents(largest[j, live]), live)  # each run of live columns in place


class RangeProjection:
    """The orthogonal projection on the numerical range of an (N, p) block, N ≥ p, as
    ``numpy.linalg.lstsq(y, b, rcond=None)`` decides it: y = QR, R = U S Vᵀ, and the rank r the
    number of singular values above eps·max(N, p)·s_max, lstsq's rule. The range's orthonormal
    basis Q_r = Q U_r (N × r, no larger than the block) is kept, and ``residual(b)`` is
    b − Q_r Q_rᵀ b, what lstsq's b − y β gives up to rounding: two passes over Q_r (O(Nr)) where
    lstsq factors the block again (O(Np²)), so a prepared regressor factors each block once for
    every residual. ``rank`` is r.

    ``r``: an R factor of y already computed (any QR of y, rows of any sign: :func:`joint_factor`).
    When the kept singular values span at most :data:`_BASIS_COND`, the basis is y V_r S_r⁻¹,
    re-orthonormalised (Cholesky QR), with no second factorisation of the block: its span is
    Q U_r's within about eps·s_1/s_r (docs/conventions.md §6, the regressor's shared factorisation).
    Beyond that, or without ``r``, the block's Householder QR gives Q U_r itself.
    """

    def __init__(self, y: np.ndarray, r: np.ndarray | None = None):
        self.rank = 0
        if y.shape[1] == 0:  # no column: nothing to project on
            return
        if r is not None:
            _, s, vt = np.linalg.svd(r, full_matrices=False)
            self.rank = _lstsq_rank(s, y.shape)
            if self.rank and s[0] <= _BASIS_COND * s[self.rank - 1]:
                basis = _orthonormalised(y @ (vt[:self.rank].T / s[:self.rank]))
                if basis is not None:
                    self.basis = basis
                    return
        (reflectors, tau), r = scipy.linalg.qr(y, mode="raw", check_finite=False)
        u, s, _ = np.linalg.svd(r, full_matrices=False)
        self.rank = _lstsq_rank(s, y.shape)
        if self.rank == 0:
            return
        top = np.zeros((y.shape[0], self.rank), order="F")
        top[:u.shape[0]] = u[:, :self.rank]  # the range in Q's coordinates
        self.basis, _, info = scipy.linalg.lapack.dormqr("L", "N", reflectors, tau, top, max(1, 64 * self.rank),
                                                         overwrite_c=1)
        if info:  # an argument LAPACK refused: a bug here, not bad input
            raise RuntimeError(f"dormqr failed (info {info})")

    def residual(self, b: np.ndarray) -> np.ndarray:
        """b less its least-squares fit on the block, (N,)."""
        rest: np.ndarray = b.copy() if self.rank == 0 else b - self.basis @ (self.basis.T @ b)
        return rest


_BASIS_COND = 1e6
"""The largest s_1/s_r of a block's kept singular values for which its range basis is taken as
y V_r S_r⁻¹ from an R factor already computed (its rounding grows with s_1/s_r): the projected
residual is then within 1e-11 of ‖b‖ of the exact projection (measured: 1.5e-12 at a span of 1e6,
6e-15 on the KUKA LWR4+ blocks, whose kept singular values span ≤ 1e4; 2e-9 at 1e9, which the
Householder QR of the block takes instead). docs/conventions.md §6."""


def _lstsq_rank(s: np.ndarray, shape: tuple[int, ...]) -> int:
    """The rank ``numpy.linalg.lstsq(rcond=None)`` takes: singular values above eps·max(N, p)·s_max."""
    tol = np.finfo(np.float64).eps * max(shape) * (s[0] if s.size else 0.0)
    return int(np.count_nonzero(s > tol))


def _orthonormalised(x: np.ndarray) -> np.ndarray | None:
    """x (N × r, nearly orthonormal columns) made orthonormal by a Cholesky QR: x C⁻¹, CᵀC = xᵀx;
    None when xᵀx is not numerically positive definite (then the caller factors the block itself)."""
    try:
        c = np.linalg.cholesky(x.T @ x).T
    except np.linalg.LinAlgError:
        return None
    # C is within rounding of the identity: x times its inverse is one product, not N solves
    inverse = scipy.linalg.solve_triangular(c, np.eye(c.shape[0]), lower=False, check_finite=False)
    q: np.ndarray = x @ inverse
    return q


# Below this condition number the normal equations lose at most about 1e-8 of the fit
# (relative error ~ eps·cond²); above it the slower orthogonal factorisations are used.
_NORMAL_EQUATIONS_COND = 1e4


def _sum_squares(x: np.ndarray) -> float:
    with np.errstate(over="ignore", under="ignore"):
        return float(x @ x)


def _normal_factor(g: np.ndarray) -> Factor | None:
    """(gs, d) of the column-scaled normal equations gs = g/(d dᵀ), d = √diag g, when their
    condition number is below _NORMAL_EQUATIONS_COND (and no column is zero); else None. It depends
    on the regressor alone: a prepared regressor keeps it."""
    d = np.sqrt(np.diag(g))
    if not np.all(d > 0):
        return None
    gs = g / np.outer(d, d)  # the condition number of the column-scaled problem decides
    w = np.linalg.eigvalsh(gs)
    if w[0] > 0 and np.sqrt(w[-1] / w[0]) < _NORMAL_EQUATIONS_COND:
        return gs, d
    return None


def _solve_factored(factor: Factor | None, yb: np.ndarray) -> np.ndarray | None:
    """β from the normal equations of :func:`_normal_factor`, or None without a factor."""
    if factor is None:
        return None
    gs, d = factor
    return np.linalg.solve(gs, yb / d) / d


def _solve_normal_equations(g: np.ndarray, yb: np.ndarray) -> np.ndarray | None:
    """β from the normal equations gβ = yb of the column-scaled problem, or None when the scaled
    condition number reaches _NORMAL_EQUATIONS_COND (or a column is zero)."""
    return _solve_factored(_normal_factor(g), yb)


def _least_squares(y: np.ndarray, b: np.ndarray) -> np.ndarray:
    """argmin ‖yβ − b‖: by the normal equations (one BLAS pass) when y is well conditioned."""
    beta = _solve_normal_equations(y.T @ y, y.T @ b)
    return beta if beta is not None else np.linalg.lstsq(y, b, rcond=None)[0]


def _pow2_columns(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x·2^-k, k) per column, k the exponent of the column's largest |x| (0 for zeros)."""
    k = _pow2_exponents(x)
    return _scale_pow2(x, k), k


# Rows per QR update of :func:`_r_factor`: LAPACK's QR of a tall block runs at a fraction of the
# speed of its small panels, so many short updates of R beat a few long ones (140,756 × 91 KUKA
# regressor, one BLAS thread: 0.17 s in blocks of 1,024 rows, 0.57 s in one call).
_QR_ROWS = 1 << 10


def _r_factor(x: np.ndarray, columns: np.ndarray, k: np.ndarray | None = None, block: int = _QR_ROWS,
              extra: np.ndarray | None = None) -> np.ndarray:
    """The triangular factor R of x[:, columns]·2^-k = QR (k: an exact column scaling by powers of
    two, none by default), p × p at most: each block of rows is stacked under the R so far and
    factored again, in one Fortran-ordered buffer (no copy of x). ``extra`` (rows × e): columns
    appended after x's (R of [x[:, columns]·2^-k, extra], (p + e) × (p + e) at most)."""
    p = columns.size + (0 if extra is None else extra.shape[1])
    every = columns.size == x.shape[1]  # a slice is a view; indexing by columns copies only the block
    scale = np.ldexp(1.0, -k) if k is not None and np.all(np.abs(k) < 1000) else None
    buf = np.empty((block + p, p), order="F")
    top = 0  # rows of R at the top of buf
    for i in range(0, x.shape[0], block):
        rows = x[i:i + block] if every else x[i:i + block, columns]
        end = top + rows.shape[0]
        mine = buf[top:end, :columns.size]
        if k is None:
            mine[:] = rows
        elif scale is not None:  # 2^-k is a normal number: the same exact products as ldexp
            np.multiply(rows, scale, out=mine)
        else:
            mine[:] = np.ldexp(rows, -k)
        if extra is not None:
            buf[top:end, columns.size:] = extra[i:i + block]
        r = scipy.linalg.qr(buf[:end], mode="r", overwrite_a=True, check_finite=False)[0]
        top = min(end, p)
        buf[:top] = np.triu(r[:top])
    return np.array(buf[:top])


def _singular_values(x: np.ndarray, live: np.ndarray, norms: np.ndarray,
                     gram: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Singular values of x[:, live], raw and with unit-norm columns, without copying x.

    From the Gram matrix (one BLAS pass) while both condition numbers stay below
    _NORMAL_EQUATIONS_COND²/100 = 1e6, where its eigenvalues still give σ_min to about 1e-4;
    beyond, from the p × p factor R of a blockwise QR (X = QR and XD = Q(RD): R's singular values
    are X's), which is exact to rounding but several times slower.
    """
    if gram is not None:
        g = gram[np.ix_(live, live)]
    else:
        g = np.zeros((live.size, live.size))
        every = live.size == x.shape[1]  # a slice is a view; indexing by live would copy each block
        for i in range(0, x.shape[0], ROW_BLOCK):
            block = x[i:i + ROW_BLOCK] if every else x[i:i + ROW_BLOCK, live]
            g += block.T @ block
    d = norms[live]
    # squares of 1e-170 or 1e150 data underflow or overflow in g: the QR route scales itself
    if np.all(np.isfinite(g)) and np.all((d > 1e-140) & (d < 1e140)):
        raw = np.sqrt(np.clip(np.linalg.eigvalsh(g)[::-1], 0.0, None))
        scaled = np.sqrt(np.clip(np.linalg.eigvalsh(g / np.outer(d, d))[::-1], 0.0, None))
        limit = _NORMAL_EQUATIONS_COND**2 / 100
        if raw[-1] > 0 and scaled[-1] > 0 and raw[0] / raw[-1] < limit and scaled[0] / scaled[-1] < limit:
            return raw, scaled
    r = _r_factor(x, live)
    return np.linalg.svd(r, compute_uv=False), np.linalg.svd(r / d, compute_uv=False)


_RANK_TOL = 1e-9
"""Dependent columns of the design section (conventions §5.6): a column that, scaled to unit norm,
lies within 1e-9 of the span of the columns kept before it (zero columns:
:func:`dynval.statistics._columns.zero_columns`). Roundoff of a dependency stands near 1e-15 (KUKA
LWR4+: at most 3e-15, while its weakest identifiable combination stands at 1e-2); a real column this
weak would mean a condition number of 1e9."""


def _gram_singular_values(gram: np.ndarray | None, norms: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Raw and column-scaled singular values from the Gram matrix when it decides them (every
    column nonzero, both condition numbers below _NORMAL_EQUATIONS_COND²/100 = 1e6), else None."""
    if gram is None or not np.all(np.isfinite(gram)) or not np.all((norms > 1e-140) & (norms < 1e140)):
        return None
    raw = np.sqrt(np.clip(np.linalg.eigvalsh(gram)[::-1], 0.0, None))
    scaled = np.sqrt(np.clip(np.linalg.eigvalsh(gram / np.outer(norms, norms))[::-1], 0.0, None))
    limit = _NORMAL_EQUATIONS_COND**2 / 100
    if raw[-1] > 0 and scaled[-1] > 0 and raw[0] / raw[-1] < limit and scaled[0] / scaled[-1] < limit:
        return raw, scaled
    return None


def _stacked_r(reg3: np.ndarray, k: np.ndarray, memo: Memo[Any] = compute_now) -> np.ndarray:
    """R of the regressor stacked over joints, Y·2^-k ((N·m) × p, k an exact column scaling), p × p
    at most: each joint's nonzero columns are factored alone (Y_j·2^-k_j = Q_j R_j, k_j from
    :func:`column_largest`; kept by a prepared regressor), their R_j·2^(k_j − k) stacked and
    factored again. The stacked QR's R up to rounding (a tall-skinny QR), without the work on
    each joint's zero columns: on a serial arm's regressor a fraction of the stacked QR."""
    _, m, p = reg3.shape
    largest = column_largest(reg3, memo)
    pieces = []
    for j in range(m):
        live = np.flatnonzero(largest[j] > 0)
        if live.size:
            r_j = _joint_r(reg3, j, largest, memo)
            piece = np.zeros((r_j.shape[0], p))
            piece[:, live] = np.ldexp(r_j, _exponents(largest[j, live]) - k[live])
            pieces.append(piece)
    if not pieces:
        return np.zeros((0, p))
    stacked = np.vstack(pieces)
    r = scipy.linalg.qr(stacked, mode="r", overwrite_a=True, check_finite=False)[0]
    return np.array(r[:min(stacked.shape[0], p)])


def _joint_r(reg3: np.ndarray, j: int, largest: np.ndarray, memo: Memo[Any] = compute_now) -> np.ndarray:
    """R of joint j's nonzero columns scaled by powers of two (:func:`_scaled_live_block`): the
    leading block of :func:`joint_factor`."""
    k = int(np.count_nonzero(largest[j] > 0))
    r = joint_factor(reg3, j, memo)
    return np.array(r[:min(k, r.shape[0]), :k])


def joint_factor(reg3: np.ndarray, j: int, memo: Memo[Any] = compute_now) -> np.ndarray:
    """Joint j's one R factor, kept by a prepared regressor: R of [Y_j·2^-k_j, L], Y_j·2^-k_j the
    joint's nonzero columns scaled by powers of two (:func:`_scaled_live_block`) and L the library's
    columns without q (:func:`library_without_q`: an offset and a drift, the same on every joint).
    Its leading block is the R of the joint's columns that the excitation section stacks and the
    range projection of a singular block decomposes; the whole is what the kinds the model spans
    without q are read from (the span's inner products are R's). Rows of either sign: only RᵀR,
    which QR fixes up to rounding, is used."""
    r: np.ndarray = memo(("joint_factor", reg3.shape, j),
                         lambda: _factor_with_library(_scaled_live_block(reg3, j, column_largest(reg3, memo))))
    return r


def _factor_with_library(y: np.ndarray) -> np.ndarray:
    """R of [y, L] (:func:`joint_factor`), by :func:`_r_factor`'s short updates."""
    return _r_factor(y, np.arange(y.shape[1]), extra=library_without_q(y.shape[0]))


def library_without_q(n: int) -> np.ndarray:
    """The physics library's columns without q (``dynval.statistics._physics.library``: the
    offset's and the drift's, unit RMS), (n, 3): they do not depend on the joint."""
    from ..statistics import _model_terms  # here: the report's sections need it only with a regressor

    lib = _model_terms.library_for(0, None, None, None, n, None)
    return np.column_stack(list(lib.values()))


def kinds_without_q(reg3: np.ndarray, cols: Sequence[int], declared: Sequence[set[str]] | None,
                    memo: Memo[Any] = compute_now) -> list[dict[str, bool]]:
    """Per joint, which of the library's groups without q (offset, drift) the model's columns
    ``cols`` span: ``dynval.statistics._model_terms.kinds_present`` of :func:`span_coordinates`,
    whose norms and inner products are those of the N rows: the same fractions up to rounding
    (docs/conventions.md §6) without another pass over the rows."""
    from ..statistics import _model_terms

    m = reg3.shape[1]
    return [_model_terms.kinds_present(j, *span_coordinates(reg3, j, cols, memo), m, declared[j] if declared else set())
            for j in range(m)]


def span_coordinates(reg3: np.ndarray, j: int, cols: Sequence[int],
                     memo: Memo[Any] = compute_now) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The model's columns ``cols`` that are not zero on joint j, and the library's groups without
    q by name, as their coordinates in the joint's R factor (:func:`joint_factor`; the columns
    unscaled again): (rows × k, {group: rows × width}), rows ≤ k + 3. Y = Q R with Q's columns
    orthonormal, so every norm, inner product and projection of them is the N rows' own."""
    from ..statistics import _model_terms

    p = reg3.shape[2]
    largest = column_largest(reg3, memo)
    wanted = np.zeros(p, dtype=bool)
    wanted[np.asarray(cols, dtype=np.intp)] = True
    live = np.flatnonzero(largest[j] > 0)
    r = joint_factor(reg3, j, memo)
    mine = np.flatnonzero(wanted[live])
    y_j = np.ldexp(r[:, mine], _exponents(largest[j, live[mine]]))
    lib, at = {}, live.size
    for g, c in _model_terms.library_for(0, None, None, None, 1, None).items():  # the groups' names and widths
        lib[g] = r[:, at:at + c.shape[1]]
        at += c.shape[1]
    return y_j, lib


def _leading_base(a: np.ndarray, tol: float) -> np.ndarray:
    """The columns of ``a`` (rows × q, or any matrix with its R factor) that are independent of
    the columns kept before them, in index order: with every column scaled to unit norm, column
    k is kept when its distance from the span of the kept columns exceeds ``tol``; a column whose
    norm is at most ``tol`` of the largest is never kept. Of an exactly dependent set the last
    columns are the dependent ones, whatever the rounding (a pivoted QR chooses among columns of
    equal norm by rounding, conventions §5.6). The distance is from the kept columns only: a
    dependent column's roundoff would otherwise add a direction to the span."""
    norms = np.sqrt(np.einsum("ij,ij->j", a, a))
    nonzero = np.flatnonzero(norms > tol * norms.max(initial=0.0))
    x = a[:, nonzero] / norms[nonzero]
    basis = np.zeros((x.shape[0], 0))
    keep = []
    for i in range(x.shape[1]):
        v = x[:, i].copy()
        for _ in range(2):  # Gram–Schmidt twice keeps the basis orthonormal to rounding
            v -= basis @ (basis.T @ v)
        distance = float(np.linalg.norm(v))
        if distance > tol:
            keep.append(i)
            basis = np.column_stack([basis, v / distance])
    return nonzero[np.asarray(keep, dtype=np.intp)]
