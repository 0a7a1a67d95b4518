"""A regressor prepared once for many :func:`dynval.validate` calls (contract §4, prepared regressor).

Much of ``validate``'s work with a regressor does not depend on the residual: each joint's Gram
matrix, the regressor's half of the colour-aware cross-correlation band (its columns' transforms),
each joint's one R factor (which the excitation section, the spectrum's projection on an
ill-conditioned block and the kinds the model spans without q share), the per-joint column blocks
and solve decisions of the spectrum's projection, the centred columns of the parameter-error
widening, the predictive test's Gram matrix of the model's columns. A :class:`PreparedRegressor`
keeps each of them the first time a call computes it, under a key naming every other input it
depends on, and hands the same result to later calls: :func:`dynval.compare` prepares the shared
regressor once for all its candidates, and a caller validating many predictions on one run can do
the same. Every number is computed by the same code on the same arrays, so the reports are the
ones the plain array gives, bit for bit.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Hashable
from typing import Any, TypeVar, cast

import numpy as np

from ..checks import _validation as v
from ..checks._errors import ShapeMismatch
from ..checks._typing import ArrayLike, FloatArray

__all__ = ["PreparedRegressor", "prepare_regressor", "Memo", "compute_now", "CallMemo", "keeps_across_calls",
           "kept_keys",
           "memo_for", "scan_for", "digest"]

T = TypeVar("T")

#: ``memo(key, compute)``: ``compute()``'s value, kept under ``key`` when the regressor is prepared.
Memo = Callable[[tuple[Hashable, ...], Callable[[], T]], T]


def compute_now(key: tuple[Hashable, ...], compute: Callable[[], T]) -> T:
    """The memo of a plain regressor: nothing is kept (no extra memory per call)."""
    return compute()


class PreparedRegressor:
    """A regressor Y, (N, m, p) or (N*m, p), with the residual-independent work on it kept.

    Made by :func:`dynval.prepare_regressor`; accepted wherever a regressor is (``validate``'s and
    ``compare``'s ``regressor``, a candidate's own). ``array`` is the regressor as float64,
    C-contiguous and read-only. The results kept are tied to its values: do not modify the array
    it was prepared from while the prepared regressor is in use (prepare it again instead).
    ``structure`` is the model's regressor at states that excite every combination its structure
    allows (stacked (K*m, p), read-only), or None: with it the report knows the structural columns
    without the estimation run's regressor.
    """

    __slots__ = ("_cache", "array", "structure")

    def __init__(self, array: FloatArray, structure: FloatArray | None = None) -> None:
        view = array.view()
        view.flags.writeable = False
        self.array: FloatArray = view
        self.structure: FloatArray | None = None
        if structure is not None:
            kept = structure.view()
            kept.flags.writeable = False
            self.structure = kept
        self._cache: dict[tuple[Hashable, ...], Any] = {}

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(self.array.shape)

    def __repr__(self) -> str:
        return f"PreparedRegressor(shape={self.shape}, kept={len(self._cache)})"

    def memo(self, key: tuple[Hashable, ...], compute: Callable[[], T]) -> T:
        """``compute()`` the first time ``key`` is asked for; the kept value afterwards. Arrays are
        kept read-only and mappings handed out as copies, so no caller can change another's."""
        if key not in self._cache:
            self._cache[key] = _frozen(compute())
        value = self._cache[key]
        return cast(T, copy.deepcopy(value)) if isinstance(value, dict) else cast(T, value)


def _frozen(value: T) -> T:
    """``value`` with its arrays read-only: those of a tuple, and the attributes of an object (a
    Gram matrix, a refit); a mapping is handed out as a copy instead."""
    if isinstance(value, np.ndarray):
        value.flags.writeable = False
    elif isinstance(value, tuple):
        for item in value:
            _frozen(item)
    elif hasattr(value, "__dict__") and not isinstance(value, type):
        for item in vars(value).values():
            if isinstance(item, np.ndarray):
                item.flags.writeable = False
    return value


def prepare_regressor(regressor: ArrayLike | PreparedRegressor, *,
                      structure: ArrayLike | None = None) -> PreparedRegressor:
    """Prepare a regressor for repeated :func:`dynval.validate` calls (and :func:`dynval.compare`).

    Parameters
    ----------
    regressor : array_like, (N, m, p) or (N*m, p)
        The regressor of the validation run, as ``validate`` takes it (the stacked 2-D form still
        needs ``n_joints`` in each call). It is converted to float64 and made C-contiguous once (a
        copy only when it is not already); its shape and values are checked by each call as a
        plain regressor's are.
    structure : array_like, (K, m, p) or (K*m, p), optional
        The same model's regressor at states chosen to excite every combination of columns its
        structure allows (random positions, velocities and accelerations, as base-parameter
        computation uses; :meth:`dynval.robots.URDFModel.prepared_regressor` makes it). The report
        then tells the structural columns (zero or combinations of the others for every motion: the
        parameters of a fixed-base arm's first links no trajectory excites) from columns this
        trajectory leaves unexcited, without the estimation run's regressor (contract §4,
        excitation). Finite real numbers with the regressor's number of columns p.

    Returns
    -------
    PreparedRegressor
        Pass it as ``regressor=``: each call computes only what depends on its residual, and the
        report equals the one the plain array gives.

    Raises
    ------
    InvalidType
        ``regressor`` or ``structure`` is not an array of real numbers.
    ShapeMismatch
        ``structure`` is not 2-D or 3-D with the regressor's number of columns.
    NonFiniteInput
        ``structure`` holds a nan or an infinity.

    Examples
    --------
    >>> import numpy as np, dynval
    >>> rng = np.random.default_rng(1)
    >>> Y = rng.normal(size=(400, 2, 3))
    >>> tau = Y @ np.array([1.0, -2.0, 0.5]) + rng.normal(0.0, 0.1, (400, 2))
    >>> prepared = dynval.prepare_regressor(Y)
    >>> a = dynval.validate(tau, Y @ np.array([1.0, -2.0, 0.4]), n_params=3, regressor=prepared)
    >>> b = dynval.validate(tau, Y @ np.array([1.0, -2.0, 0.4]), n_params=3, regressor=Y)
    >>> a.to_json() == b.to_json()
    True

    With omitted rows (``nan_policy="omit"`` and a nan) the call's regressor is a copy without
    them, so nothing kept is used; the report is still the plain array's:

    >>> tau[5, 0] = np.nan
    >>> c = dynval.validate(tau, Y @ np.array([1.0, -2.0, 0.4]), n_params=3, regressor=prepared, nan_policy="omit")
    >>> c.to_json() == dynval.validate(tau, Y @ np.array([1.0, -2.0, 0.4]), n_params=3, regressor=Y,
    ...                                nan_policy="omit").to_json()
    True
    """
    if isinstance(regressor, PreparedRegressor) and structure is None:
        return regressor
    array = (regressor.array if isinstance(regressor, PreparedRegressor)
             else np.ascontiguousarray(v.to_float_array(regressor, "regressor")))
    return PreparedRegressor(array, None if structure is None else _structure(structure, array))


def _structure(structure: ArrayLike, array: FloatArray) -> FloatArray:
    """The structure's regressor checked against the regressor's columns, stacked (K*m, p)."""
    s = v.to_float_array(structure, "structure")
    p = int(array.shape[-1]) if array.ndim in (2, 3) else -1
    if s.ndim not in (2, 3) or s.shape[-1] != p or s.size == 0:
        raise ShapeMismatch(f"structure must be (K, m, p) or (K*m, p) with the regressor's p = {p} columns, "
                            f"got shape {v.format_shape(s.shape)}")
    stacked = np.ascontiguousarray(s.reshape(-1, p))
    v.check_finite(stacked, "structure")
    return stacked


def _is_prepared(prepared: PreparedRegressor | None, a: FloatArray | None) -> bool:
    """Whether ``a`` is the prepared array itself (same memory, every value, any shape)."""
    return (prepared is not None and a is not None and a.ctypes.data == prepared.array.ctypes.data
            and a.size == prepared.array.size and a.flags.c_contiguous)


#: What a call on a plain regressor keeps until it returns: small results that several sections ask
#: for (each joint column's largest value and the compiled kernel's moments of the columns, each a
#: pass over the whole regressor; each joint's R factor; the projection's live columns and solve
#: factor), never anything of the regressor's size.
CALL_KEPT = frozenset({"column_largest", "regressor_moments", "joint_factor", "live_columns", "live_factor"})


class CallMemo:
    """The memo of one call on a plain regressor: the results named in :data:`CALL_KEPT`, computed
    once for the call (the same code on the same array, so the same numbers) and dropped with it;
    every other key is computed each time it is asked for, as by :func:`compute_now`."""

    __slots__ = ("_kept",)

    def __init__(self) -> None:
        self._kept: dict[tuple[Hashable, ...], Any] = {}

    def __call__(self, key: tuple[Hashable, ...], compute: Callable[[], T]) -> T:
        if key[0] not in CALL_KEPT:
            return compute()
        if key not in self._kept:
            self._kept[key] = _frozen(compute())
        return cast(T, self._kept[key])


def keeps_across_calls(memo: Memo[Any]) -> bool:
    """Whether ``memo`` keeps results for later calls (a prepared regressor's): only then do the
    keys need the hashes of the arrays given beside the regressor."""
    return memo is not compute_now and not isinstance(memo, CallMemo)


def kept_keys(memo: Memo[Any], estimation: dict[str, Any] | None,
              meas: FloatArray) -> tuple[tuple[Hashable, ...], tuple[Hashable, ...]]:
    """The parts of a kept result's key that name the arrays given beside the regressor: a hash of
    the estimation run's arrays, and one of the measured torques (none where ``memo`` keeps nothing
    past the call)."""
    if not keeps_across_calls(memo):
        return (), ()
    est = estimation or {}
    return digest(est.get("regressor"), est.get("tau"), est.get("q"), est.get("dq"), est.get("ddq")), digest(meas)


def memo_for(prepared: PreparedRegressor | None, checked: FloatArray | None) -> Memo[Any]:
    """The memo a call may use: the prepared regressor's when the call's checked 2-D regressor is
    the prepared array itself (same memory, every row kept), else a :class:`CallMemo` for this call
    alone."""
    return prepared.memo if prepared is not None and _is_prepared(prepared, checked) else CallMemo()


def scan_for(prepared: PreparedRegressor | None) -> Callable[[FloatArray], tuple[int, int, float] | None]:
    """The search for a call's first non-finite value (:func:`dynval.checks._validation.first_nonfinite`)
    that searches the prepared array once for every call (its values do not change)."""
    if prepared is None:
        return v.first_nonfinite

    def scan(a: FloatArray) -> tuple[int, int, float] | None:
        if _is_prepared(prepared, a):
            return prepared.memo(("first_nonfinite", a.shape), lambda: v.first_nonfinite(a))
        return v.first_nonfinite(a)

    return scan


def digest(*arrays: Any) -> tuple[Hashable, ...]:
    """A key for arrays given beside the regressor (the estimation run's): their shapes and a hash
    of their bytes, so that a kept result is never reused for other values."""
    import hashlib  # here: only a prepared regressor with an estimation run needs it

    out: list[Hashable] = []
    for a in arrays:
        if a is None:
            out.append(None)
            continue
        x = np.ascontiguousarray(a)
        out.append((x.shape, str(x.dtype), hashlib.blake2b(x.data, digest_size=16).hexdigest()))
    return tuple(out)
