"""Type aliases of the public API and the protocol of the kernel modules.

The string options are the contract's (docs/contract.md §2.1 lists each requirement): a value
outside them still reaches the function and raises InvalidParameter, the Literal types only let a
type checker catch it earlier. ``Kernels`` is the kernel set of contract §5.1, which both
``dynval.kernels._reference`` (the ``python`` backend) and ``dynval._core`` (the ``cpp`` backend, typed by
``_core.pyi``) provide with the same signatures; kernels take options as ``str`` and check them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Literal, Protocol, TypedDict

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "ArrayLike",
    "FloatArray",
    "IntArray",
    "BoolArray",
    "Integer",
    "MultiOutput",
    "Convention",
    "NanPolicy",
    "BackendName",
    "NoiseModel",
    "ProfileName",
    "Detail",
    "Decimate",
    "SegmentsLike",
    "LagsLike",
    "Kernels",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: An integer parameter: Python int or a numpy integer (never bool, never an integral float).
Integer = int | np.integer[Any]

MultiOutput = Literal["pooled", "raw_values", "uniform_average", "variance_weighted"]
Convention = Literal["per_element", "per_sample"]
NanPolicy = Literal["raise", "omit"]
BackendName = Literal["python", "cpp"]
NoiseModel = Literal["pooled", "per_joint", "full"]
ProfileName = Literal["lesson", "matlab", "statsmodels", "sklearn"]
Detail = Literal["top", "full"]
#: ``validate(decimate=)``: "auto", None (never) or a factor >= 1.
Decimate = Literal["auto"] | Integer | None

#: Segments (contract §1.1): lengths or starts; ``validate`` also takes named lengths.
SegmentsLike = Sequence[Integer] | NDArray[np.integer[Any]] | None
NamedSegmentsLike = SegmentsLike | Mapping[str, Integer] | Sequence[tuple[str, Integer]]
#: Ljung–Box / Box–Pierce lags: one lag or several.
LagsLike = Integer | Sequence[Integer] | NDArray[np.integer[Any]]

_Starts = ArrayLike | None
_Metric = float | FloatArray


class FusedMetrics(TypedDict):
    """The fused ``compute_metrics`` kernel's result (contract §5.1), one type for its three producers:
    the C++ kernel (``dynval._core``), the numpy reference (``kernels/_reference/metrics.py``) and the
    stream's sums (``stream._fused_metrics``). Per-joint values are arrays (m,), pooled ones numbers."""

    n_samples: int
    n_joints: int
    n_params: int
    sse: FloatArray
    rmse: FloatArray
    max_abs_error: FloatArray
    vaf: FloatArray
    fit_percent: FloatArray
    r2: FloatArray
    residual_mean: FloatArray
    residual_variance: FloatArray
    constant_target: BoolArray
    sse_total: float
    rmse_per_element: float
    rmse_per_sample: float
    max_abs_error_pooled: float
    vaf_pooled: float
    fit_percent_pooled: float
    r2_pooled: float
    constant_target_pooled: bool
    rmse_uniform_average: float
    vaf_uniform_average: float
    fit_percent_uniform_average: float
    r2_uniform_average: float
    vaf_variance_weighted: float
    fit_percent_variance_weighted: float
    r2_variance_weighted: float
    aic: float
    bic: float
    aicc: float
    fpe: float
    naic: float


class Kernels(Protocol):
    """The kernel set of contract §5.1 (the module ``dynval.kernels._reference`` or ``dynval._core``)."""

    def first_nonfinite(self, a: FloatArray) -> tuple[int, int, float] | None: ...
    def residuals(self, meas: ArrayLike, pred: ArrayLike) -> FloatArray: ...
    def sse(self, meas: ArrayLike, pred: ArrayLike, multioutput: str) -> _Metric: ...
    def max_abs_error(self, meas: ArrayLike, pred: ArrayLike, multioutput: str) -> _Metric: ...
    def rmse(
        self,
        meas: ArrayLike,
        pred: ArrayLike,
        multioutput: str,
        convention: str | None,
    ) -> _Metric: ...
    def vaf(self, meas: ArrayLike, pred: ArrayLike, multioutput: str) -> _Metric: ...
    def fit_percent(self, meas: ArrayLike, pred: ArrayLike, multioutput: str) -> _Metric: ...
    def r2(self, meas: ArrayLike, pred: ArrayLike, multioutput: str) -> _Metric: ...
    def residual_mean(self, e: ArrayLike) -> FloatArray: ...
    def residual_variance(self, e: ArrayLike, ddof: Integer) -> FloatArray: ...
    def compute_metrics(
        self, meas: ArrayLike, pred: ArrayLike, n_params: Integer, ddof: Integer, noise_model: str
    ) -> FusedMetrics: ...
    def autocorrelation(
        self, e: ArrayLike, max_lag: Integer, adjusted: bool | np.bool_, starts: _Starts
    ) -> FloatArray: ...
    def cross_correlation(
        self,
        e: ArrayLike,
        Y: ArrayLike,
        n_columns: Integer,
        max_lag: Integer,
        adjusted: bool | np.bool_,
        starts: _Starts,
    ) -> dict[str, Any]: ...
    def portmanteau(
        self,
        e: ArrayLike,
        lags: Integer | Sequence[Integer] | NDArray[np.integer[Any]],
        model_df: Integer,
        starts: _Starts,
        test: str,
    ) -> dict[str, Any]: ...
    def information_criteria(
        self, rss: float | np.floating[Any] | np.integer[Any], n_obs: Integer, n_params: Integer
    ) -> dict[str, Any]: ...
    def criteria(self, meas: ArrayLike, pred: ArrayLike, n_params: Integer, noise_model: str) -> dict[str, Any]: ...


class ReportSections(Protocol):
    """What the plain-language summary reads of a validation report (``ValidationReport`` has it;
    a protocol, so that the wording layer needs no import of the report module)."""

    # read-only: a report's sections are records, which are read-only mappings
    @property
    def provenance(self) -> Mapping[str, Any]: ...

    @property
    def per_joint(self) -> Mapping[str, Any]: ...

    @property
    def pooled(self) -> Mapping[str, Any]: ...

    @property
    def aggregates(self) -> Mapping[str, Any]: ...

    @property
    def residuals(self) -> Mapping[str, Any]: ...

    @property
    def autocorrelation(self) -> Mapping[str, Any] | None: ...

    @property
    def ljung_box(self) -> Mapping[str, Any] | None: ...

    @property
    def cross_correlation(self) -> Mapping[str, Any] | None: ...

    @property
    def information_criteria(self) -> Mapping[str, Any]: ...

    @property
    def bias(self) -> Mapping[str, Any] | None: ...

    @property
    def whiteness(self) -> Mapping[str, Any] | None: ...

    @property
    def design(self) -> Mapping[str, Any] | None: ...

    findings: Any
