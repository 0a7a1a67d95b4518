"""The physics test of :mod:`._physics` from chunks: its sufficient statistics summed as rows arrive.

The in-memory test (docs/conventions.md §5.2) solves every fit on R of a QR of each joint's
whitened stack [residual, model columns, library] and reads the rows only for the raw residual's
sums of squares, the AR model and the HC1 meat. A stream keeps, per joint:

* the first block (:data:`FIRST_BLOCK` rows) whole, until it is complete: on it the in-memory
  procedure fixes the prewhitening filter (the AR(≤ 2) model of the residual, refitted to what the
  selected groups leave), the Coulomb shapes' velocity scale, the ratio N_eff/N of what the library
  leaves, and the GLS fit of the model's columns and the selected groups (the drift left out);
* R of the raw stack and R of the stack whitened by that filter (carried across chunks), updated
  chunk by chunk (:func:`_r_update`): every basis, selection step, share and coefficient of the
  test is solved on them, as in memory;
* for the HC1 meat, the whitened rows while there are at most :data:`MEAT_ROWS` of them (the meat of
  each step's own residual, as in memory); past them Σ w_t w_tᵀ r_t², r_t the whitened residual of the
  first block's fit: the meat of a step needs each row's residual after a projection known only once
  the whole log is summed, and one fixed residual makes the meat a sum of the rows' weighted outer
  products (a sample of the rows missed the few that carry a direction, and blocks of rows gave a
  batch-means meat that colour left in the whitened residual shrinks: F 13 and 1.6 for 1.15).

The library's columns are summed unscaled, the drift as (u, u²) of the row index: the unit-RMS
scaling, the centring of t² and the model columns' unit norm are linear maps of the columns, applied
to the sums once the log's length and each column's norm are known (:meth:`_JointSums.test`). A
stream does not decimate: the in-memory test decimates a log longer than 40,000 rows to at most
40,000 (and towards the information band where it allows, conventions §5.2), the stream tests every
row. On a log of at most FIRST_BLOCK rows the stream's test is the in-memory one at the logged rate
(``validate(decimate=None)``), to rounding. The state is O(width²) numbers per joint, and the first block and the
kept rows while the log is short, whatever its length.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import scipy.linalg
    import scipy.signal
else:
    from .._lazy import scipy

from . import _physics as ph
from ._columns import zero_columns

__all__ = ["FIRST_BLOCK", "MEAT_ROWS", "PhysicsSums"]

FIRST_BLOCK = 40_000
"""Rows that fix the prewhitening filter, the Coulomb velocity scale and N_eff/N (the in-memory
test's largest undecimated run)."""
MEAT_ROWS = 40_000
"""Most whitened rows kept for the HC1 meat; past them, the meat comes from blocks of rows."""
_INDEX_SCALE = 2.0 ** -20  # the drift's row index u = i·2⁻²⁰ (exact): u² stays near 1 on an hour at 1 kHz
_PRECONDITIONED = 1e-8  # R preconditions a chunk's update when no diagonal is below this ratio of the largest column


def _r_update(r, x):
    """R of the rows [r; x] (r: the R so far, or None).

    Once r is square and not near singular, x is expressed in r's basis, y = x r⁻¹, and the new R is
    chol(I + yᵀy)·r: [r; x] = [I; y]·r, whose Gram matrix I + yᵀy is conditioned as 1 + ‖y‖² (near
    1 when the chunk is like the rows before it), so no condition number is squared; a product with
    r⁻¹ and a Gram matrix instead of a Householder QR of the chunk (25 times faster on 54 columns).
    Otherwise, or when the Cholesky factorisation fails, the QR of the stacked rows."""
    if x.shape[0] == 0:
        return r
    if r is None:
        # one Householder QR of the first rows, the rest by the update: a QR of many rows is slow
        head = 4 * x.shape[1]
        r = np.linalg.qr(x[:head], mode="r")
        x = x[head:]
        if x.shape[0] == 0:
            return r
    w = r.shape[1]
    if r.shape[0] == w and w:
        # columns zero so far and in the chunk (a model column inactive on the joint) stay out of the
        # factor, which is triangular again on the others
        live = (np.sum(r * r, axis=0) > 0) | np.any(x != 0, axis=0)
        sub = r if live.all() else np.linalg.qr(r[:, live], mode="r")
        d = np.abs(np.diag(sub)) if sub.shape[0] == sub.shape[1] else np.zeros(1)
        if d.size and d.min() > _PRECONDITIONED * np.sqrt(np.sum(sub * sub, axis=0)).max():
            # x r⁻¹ as a product with r's inverse (w³ once a chunk): twice as fast as a triangular solve
            # with a right-hand side per row, and as accurate where r passes the test above
            inverse = scipy.linalg.solve_triangular(sub, np.eye(sub.shape[0]), check_finite=False)
            y = (x if live.all() else x[:, live]) @ inverse
            try:
                new = np.linalg.cholesky(y.T @ y + np.eye(y.shape[1])).T @ sub
            except np.linalg.LinAlgError:
                pass
            else:
                if live.all():
                    return new
                out = np.zeros((w, w))
                out[np.ix_(np.flatnonzero(live), np.flatnonzero(live))] = new
                return out
    return ph._tall_r(np.vstack([r, x]))


class _Differentiator:
    """q̇ and q̈ of a stream of q by the in-memory Savitzky–Golay filter (:func:`._physics.derivatives`):
    the rows leave once the filter's window lies inside the log (the last half window waits for the
    log's end, where the filter fits its polynomial to the last window, as on the whole log)."""

    def __init__(self, sample_rate, want_dq: bool, want_ddq: bool):
        fs = 1.0 if sample_rate is None else float(sample_rate)
        self.fs, self.want = fs, (want_dq, want_ddq)
        self.window = max(0.1, 7.0 / fs)
        self.length = 0  # the filter's window in rows, once known
        self.pending: list[dict[str, np.ndarray]] = []  # rows not yet handed on, by field
        self.context = np.zeros((0, 0))  # q of the rows before them (at most one window)
        self.started = False
        self.method: str | None = None
        self.bandwidth: float | None = None

    def push(self, rows: dict[str, np.ndarray], final: bool = False) -> dict[str, np.ndarray] | None:
        """Add rows (fields ``e``, ``q``, ``dq``/``ddq`` when given, ``nz``); the rows whose
        derivatives are final, or None."""
        if rows["q"].shape[0]:
            self.pending.append(rows)
        if not self.pending:
            return None
        waiting = sum(p["q"].shape[0] for p in self.pending)
        if not self.started:
            if not self.length:
                from ._derivatives import checked_differentiate

                probe = max(int(round(self.window * self.fs)) + 2, 8)
                self.length = int(checked_differentiate(np.zeros((probe, 1)), self.fs,
                                                window=self.window).settings["window_samples"])
            need = max(self.length, int(round(self.window * self.fs)) + 2) + self.length
            if waiting < need and not final:
                return None
            if final and waiting < need:
                return self._whole()
        half = self.length // 2
        rows = {k: np.concatenate([p[k] for p in self.pending]) for k in self.pending[0]}
        q = rows["q"] if not self.started else np.vstack([self.context, rows["q"]])
        lead = 0 if not self.started else self.context.shape[0]
        stop = q.shape[0] if final else q.shape[0] - half
        kw = dict(window_length=self.length, polyorder=4, delta=1.0 / self.fs, axis=0, mode="interp")
        out = {k: x[:stop - lead] for k, x in rows.items()}
        for k, deriv, want in (("dq", 1, self.want[0]), ("ddq", 2, self.want[1])):
            if want:
                out[k] = scipy.signal.savgol_filter(q, deriv=deriv, **kw)[lead:stop]
        self.pending = [] if final else [{k: x[stop - lead:] for k, x in rows.items()}]
        self.context = q[max(0, stop - self.length):stop]
        if not self.started:
            self.method = f"Savitzky–Golay, {self.window:g} s window, degree 4"
            from ._derivatives import checked_differentiate

            self.bandwidth = float(checked_differentiate(np.zeros((self.length + 2, 1)), self.fs,
                                                 window=self.window).bandwidth_hz)
        self.started = True
        return out

    def _whole(self) -> dict[str, np.ndarray]:
        """A log too short for the stream's filter: the in-memory derivatives of all of it."""
        rows = {k: np.concatenate([p[k] for p in self.pending]) for k in self.pending[0]}
        d = ph._derived(rows["q"], self.fs, rows.get("dq"), rows.get("ddq"))
        rows["dq"], rows["ddq"] = d.dq, d.ddq
        self.method, self.bandwidth = d.method, d.bandwidth_hz
        self.pending = []
        self.started = True
        return rows


class PhysicsSums:
    """The missing-physics test of an m-joint log given chunk by chunk (module docstring).

    ``update(e, q, dq, ddq, nuisance)`` adds rows: the residual (c, m), q (c, m), q̇ and q̈ (c, m)
    or None (derived from q, the same on every chunk), the model's columns (c, m, p) or None;
    :meth:`tests` gives :func:`._physics.physics_test`'s list of :class:`._physics.PhysicsTest`."""

    def __init__(self, m: int, *, sample_rate=None, alpha: float = 0.05, first_block: int = FIRST_BLOCK,
                 meat_rows: int = MEAT_ROWS):
        self.m, self.sample_rate, self.alpha = int(m), sample_rate, float(alpha)
        self.first_block, self.meat_rows = int(first_block), int(meat_rows)
        self.n = 0  # rows handed on (in the first block or summed)
        self._block: list[dict[str, np.ndarray]] = []
        self._block_rows = 0
        self._joints: list[_JointSums] | None = None
        self._diff: _Differentiator | None = None
        self._given: tuple[bool, bool, bool] | None = None  # dq, ddq, nuisance given
        self._q_lo = np.full(self.m, np.inf)
        self._q_hi = np.full(self.m, -np.inf)

    def update(self, e, q, dq=None, ddq=None, nuisance=None) -> None:
        given = (dq is not None, ddq is not None, nuisance is not None)
        if self._given is None:
            self._given = given
            if not (given[0] and given[1]):
                self._diff = _Differentiator(self.sample_rate, not given[0], not given[1])
        rows = {"e": np.asarray(e, float), "q": np.asarray(q, float)}
        for name, x in (("dq", dq), ("ddq", ddq)):
            if x is not None:
                rows[name] = np.asarray(x, float)
        if nuisance is not None:
            rows["nz"] = np.asarray(nuisance, float)
        if rows["q"].shape[0]:
            self._q_lo = np.minimum(self._q_lo, rows["q"].min(axis=0))
            self._q_hi = np.maximum(self._q_hi, rows["q"].max(axis=0))
        ready = rows if self._diff is None else self._diff.push(rows)
        if ready is not None:
            self._take(ready)

    def _take(self, rows: dict[str, np.ndarray]) -> None:
        c = rows["e"].shape[0]
        if self._joints is not None:
            self._sum(rows, self.n)
            self.n += c
            return
        self._block.append(rows)
        self._block_rows += c
        self.n += c
        if self._block_rows >= self.first_block:
            self._start()

    def _start(self) -> None:
        """Fix the filter, the velocity scale and N_eff/N on the first block, then sum it."""
        pieces = [len(p["e"]) for p in self._block]
        block = {k: np.concatenate([p[k] for p in self._block]) for k in self._block[0]}
        self._block, self._block_rows = [], 0
        n = block["e"].shape[0]
        dq, ddq = block["dq"].copy(), block["ddq"].copy()
        if self._diff is not None:  # a joint at rest in the block: its derived q̇, q̈ are zero, as in memory
            rest = np.ptp(block["q"], axis=0) == 0
            for x, derived in ((dq, not self._given[0]), (ddq, not self._given[1])):
                if derived:
                    x[:, rest] = 0.0
        block["dq"], block["ddq"] = dq, ddq
        self._joints = []
        for j in range(self.m):
            lib = ph.library(j, block["q"], dq, ddq, np.zeros(n), self.sample_rate)
            nz = None if "nz" not in block else _unit_norm(block["nz"][:, j, :])
            n_nz = 0 if "nz" not in block else block["nz"].shape[2]
            vs = ph._scale(dq[:, j])
            raw = ph.library(j, block["q"], dq, ddq, np.zeros(n), self.sample_rate, velocity_scale=vs,
                             row_index=np.arange(n) * _INDEX_SCALE)
            scales = {g: np.array([ph._scale(c) for c in x.T]) for g, x in raw.items()}
            self._joints.append(_JointSums.first(j, block["e"][:, j], lib, nz, n_nz, vs, self.alpha, self.meat_rows,
                                                 scales))
        # summed as the chunks came: the same sums as every later chunk's
        for lo, hi in zip(np.cumsum([0] + pieces[:-1]), np.cumsum(pieces)):
            self._sum({k: x[lo:hi] for k, x in block.items()}, int(lo))

    def _sum(self, rows: dict[str, np.ndarray], start: int) -> None:
        assert self._joints is not None
        c = rows["e"].shape[0]
        u = (start + np.arange(c)) * _INDEX_SCALE
        chains: dict = {}
        for j, js in enumerate(self._joints):
            lib = ph.library(j, rows["q"], rows["dq"], rows["ddq"], np.zeros(c), self.sample_rate,
                             velocity_scale=js.velocity_scale, row_index=u, chains=chains)
            parts = [rows["e"][:, j:j + 1]] + ([rows["nz"][:, j, :]] if "nz" in rows else []) + list(lib.values())
            js.add(np.hstack(parts))

    def tests(self) -> list[ph.PhysicsTest]:
        """Each joint's test on the rows summed (the log's end: its last rows are differentiated)."""
        if self._diff is not None:
            ready = self._diff.push({"e": np.zeros((0, self.m)), "q": np.zeros((0, self.m))}, final=True)
            if ready is not None:
                self._take(ready)
        if self._joints is None and self._block:
            self._start()
        if self._joints is None:
            return [ph._nan_result(j) for j in range(self.m)]
        rest = self._q_hi - self._q_lo == 0
        return [js.test(self.n, rest, self._given) for js in self._joints]

    def derivative_method(self) -> tuple[str, float | None]:
        """The derivatives' method in the in-memory words, and the filter's bandwidth."""
        if self._diff is None:
            return "given", None
        method = self._diff.method or "Savitzky–Golay"
        rest = [j for j in range(self.m) if self._q_hi[j] - self._q_lo[j] == 0]
        if rest:
            joints = ", ".join(str(j + 1) for j in rest)
            method += (f"; joint{'s' if len(rest) > 1 else ''} {joints} at rest (q constant): no velocity or "
                       "acceleration of theirs tested")
        return method, self._diff.bandwidth


def _unit_norm(x):
    """The model's columns at unit norm, zero columns left out (the in-memory nuisance's scaling);
    with which columns are kept and the norms."""
    from ._columns import column_norms

    norms = column_norms(x)
    keep = ~zero_columns(norms)
    return x[:, keep] / norms[keep], keep, norms


class _JointSums:
    """One joint's sums: R of the raw and of the whitened stack, the kept whitened rows."""

    def __init__(self, j, widths: dict[str, int], n_nz: int, a, velocity_scale: float, n_eff_ratio: float,
                 alpha: float, meat_rows: int, null):
        self.j, self.widths, self.n_nz, self.a = j, widths, n_nz, np.asarray(a, float)
        self.velocity_scale, self.n_eff_ratio = velocity_scale, n_eff_ratio
        self.alpha, self.meat_rows = alpha, meat_rows
        self.r_raw: np.ndarray | None = None
        self.r_w: np.ndarray | None = None
        self.tail: np.ndarray | None = None  # the last raw rows, which the filter needs for the next chunk
        self.kept: list[np.ndarray] = []  # the whitened rows, while at most meat_rows
        self.kept_rows = 0
        self.null = np.asarray(null, float)  # the residual under the null: e less the model's columns' fit
        self.omega: np.ndarray | None = None  # Σ w_t w_tᵀ r0_t², r0 = w_t·null
        self.n_w = 0  # whitened rows seen

    @classmethod
    def first(cls, j, e, lib, nz, n_nz, velocity_scale, alpha, meat_rows, raw_scales) -> _JointSums:
        """The in-memory procedure on the first block: its final filter and N_eff/N (``nz``: the
        model's columns at unit norm on the block; ``n_nz``: the model's columns summed)."""
        n = e.shape[0]
        a, ratio = np.zeros(0), 1.0
        null = np.zeros(1 + n_nz + sum(x.shape[1] for x in lib.values()))
        null[0] = 1.0
        if float(e @ e) > 0 and n >= 50:
            scaled = None if nz is None else nz[0]
            stack = ph._Stack(e, np.zeros((n, 0)) if scaled is None else scaled, lib)
            a, problem, fit = ph._filtered_fit(stack, alpha)
            cols = stack.columns(["nz"] + ([] if fit is None else fit["names"]))
            left = e if cols.size == 0 else e - stack.times(cols, problem.lstsq(cols, stack.index["e"]))
            ratio = ph._ar_prewhitener(left, min(ph._MAX_AR, n // 50))[1] / n
            # the residual the meat weighs: of the GLS fit on the block of the model's columns and the
            # groups selected there (the drift, a polynomial of time, is not carried past the block)
            kept = [] if fit is None else [fit["names"][i] for i in fit["selected"] if fit["names"][i] != "drift"]
            cols = stack.columns(["nz"] + kept)
            if cols.size:
                coef = dict(zip(cols.tolist(), problem.lstsq(cols, stack.index["e"])))
                raw = np.cumsum([1 + n_nz] + [x.shape[1] for x in lib.values()])
                if scaled is not None:
                    for i, c in zip(np.flatnonzero(nz[1]), stack.index["nz"]):
                        null[1 + i] = -coef[int(c)] / nz[2][i]
                for g, lo in zip(lib, raw[:-1]):
                    if g in kept:
                        for i, c in enumerate(stack.index[g]):
                            null[lo + i] = -coef[int(c)] / raw_scales[g][i]
        return cls(j, {g: x.shape[1] for g, x in lib.items()}, n_nz, a, velocity_scale, ratio, alpha, meat_rows,
                   null)

    def add(self, z: np.ndarray) -> None:
        """Sum a chunk's raw stacked rows."""
        self.r_raw = _r_update(self.r_raw, z)
        p = self.a.size
        zz = z if self.tail is None else np.vstack([self.tail, z])
        if p:
            w = zz[p:].copy()
            for i in range(1, p + 1):
                w -= self.a[i - 1] * zz[p - i:zz.shape[0] - i]
            self.tail = zz[-p:]
        else:
            w = zz
        if w.shape[0] == 0:
            return
        self.r_w = _r_update(self.r_w, w)
        self.n_w += w.shape[0]
        h = w * (w @ self.null)[:, None]
        self.omega = h.T @ h if self.omega is None else self.omega + h.T @ h
        if self.kept_rows <= self.meat_rows:
            self.kept.append(w)
            self.kept_rows += w.shape[0]
            if self.kept_rows > self.meat_rows:
                self.kept = []

    def _map(self, n: int, rest, given) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """The linear map from the summed columns to the in-memory stack's, and that stack's index."""
        assert self.r_raw is not None
        widths = {"e": 1, "nz": self.n_nz, **self.widths}
        edges = np.cumsum([0] + list(widths.values()))
        raw = {name: np.arange(edges[i], edges[i + 1]) for i, name in enumerate(widths)}
        width = int(edges[-1])
        norms = np.sqrt(np.sum(self.r_raw ** 2, axis=0))
        nz_keep = raw["nz"][~zero_columns(norms[raw["nz"]])] if self.n_nz else raw["nz"]
        pieces: list[tuple[str, np.ndarray]] = [("e", np.eye(width)[:, raw["e"]]),
                                                ("nz", np.eye(width)[:, nz_keep] / norms[nz_keep])]
        for g in self.widths:
            m = np.eye(width)[:, raw[g]]
            if g == "drift":
                m = self._drift(n, raw["offset"][0], raw["drift"], width)
            m = m * self._zeroed(g, rest, given)
            rms = np.sqrt(np.sum((self.r_raw @ m) ** 2, axis=0) / n)
            m = m / np.array([s if s > 0 and math.isfinite(s) else 1.0 for s in rms])
            pieces.append((g, m))
        out_edges = np.cumsum([0] + [x.shape[1] for _, x in pieces])
        index = {name: np.arange(out_edges[i], out_edges[i + 1]) for i, (name, _) in enumerate(pieces)}
        return np.hstack([x for _, x in pieces]), index

    @staticmethod
    def _drift(n: int, offset: int, drift: np.ndarray, width: int) -> np.ndarray:
        """t and t² − mean(t²) of the in-memory library from (1, u, u²), u = i·2⁻²⁰."""
        alpha = 1.0 / max(n - 1, 1)
        beta = -0.5 * (n - 1) * alpha
        mean_t2 = alpha * alpha * (n - 1) * (2 * n - 1) / 6.0 + alpha * beta * (n - 1) + beta * beta
        au = alpha / _INDEX_SCALE
        m = np.zeros((width, 2))
        m[offset, 0], m[drift[0], 0] = beta, au
        m[offset, 1], m[drift[0], 1], m[drift[1], 1] = beta * beta - mean_t2, 2.0 * au * beta, au * au
        return m

    def _zeroed(self, g: str, rest, given) -> np.ndarray:
        """1, or 0 for the columns of derived q̇, q̈ of a joint at rest over the whole log (in memory
        exactly zero; summed here, rounding noise)."""
        ones = np.ones(self.widths[g])
        if g in ("coulomb", "viscous", "velocity_squared") and not given[0] and rest[self.j]:
            return ones * 0.0
        if g == "inertia" and not given[1]:
            return (~np.asarray(rest)).astype(float)
        return ones

    def test(self, n: int, rest, given) -> ph.PhysicsTest:
        """The joint's test from its sums (``n`` the log's rows)."""
        if self.r_raw is None or self.r_w is None or n < 50:
            return ph._nan_result(self.j)
        m, index = self._map(n, rest, given)
        rows = np.vstack(self.kept) @ m if self.kept else None
        omega = None if rows is not None or self.omega is None else m.T @ self.omega @ m
        problem = _Summed(index, [g for g in self.widths], self.r_raw @ m, self.r_w @ m, rows, omega, self.n_w)
        total = float(np.sum(problem.r_raw[:, 0] ** 2))
        if not total > 0:
            return ph._nan_result(self.j)
        fit = ph._whitened_fit(problem, self.alpha)
        if fit is None:
            return ph._nan_result(self.j)

        def raw_sse(cols, coef):
            v = np.zeros(problem.r_raw.shape[1])
            v[0] = 1.0
            v[cols] -= coef
            return float(np.sum((problem.r_raw @ v) ** 2))

        def n_eff(cols, coef):
            return float(np.clip(self.n_eff_ratio * n, 2.0, n))

        return ph._conclude(self.j, problem, fit, total, lambda fits: [raw_sse(c, k) for c, k in fits], n_eff,
                            self.widths, int(self.a.size))


class _Index:
    """The stacked columns' names (:class:`._physics._Stack`'s ``index``, ``groups``, ``columns``)."""

    def __init__(self, index: dict[str, np.ndarray], groups: list[str]):
        self.index, self.groups = index, groups

    def columns(self, names):
        got = [self.index[x] for x in names if x in self.index]
        return np.concatenate(got) if got else np.zeros(0, dtype=int)


class _Summed(ph._Compressed):
    """The compressed problem (:class:`._physics._Compressed`) from a stream's sums: R of the raw and
    whitened stacks, and for the meat the kept whitened rows, or Σ w_t w_tᵀ r0_t² past MEAT_ROWS."""

    def __init__(self, index, groups, r_raw, r_w, rows, omega, n_w):  # no super().__init__: no rows
        self.stack: Any = _Index(index, groups)
        self.r_raw = np.linalg.qr(r_raw, mode="r")
        self.r = np.linalg.qr(r_w, mode="r")
        self.rows, self.omega, self.g_rows, self.n = rows, omega, None, int(n_w)

    def tests(self, x_r, y_r, row_map, cov_p=None):
        if self.omega is None:
            return super().tests(x_r, y_r, row_map, cov_p)
        return _NullMeatTests(x_r, y_r, row_map.T @ self.omega @ row_map, self.n)


class _NullMeatTests(ph._Tests):
    """:class:`._physics._Tests` with the HC meat X̃ᵀ diag(r0²) X̃ of the residual under the null
    (the whitened residual less the model's columns' fit on the first block), from its weighted Gram
    matrix ``omega`` of the blocks' columns and the residual (the last): the same for every step."""

    def __init__(self, x_r, y_r, omega, n):
        super().__init__(x_r, y_r, None, None, n)
        self.omega = omega
        self.width = omega.shape[0]

    def _project(self, base, every, c_y, c_all):
        self._base_cols, self._every, self._c_all = base, every, c_all

    def _meat(self, piece, beta):
        cx = np.eye(self.width)[:, self._every[piece]]
        if self._c_all is not None:
            cx[self._base_cols] -= self._c_all[:, piece]
        return cx.T @ self.omega @ cx
