"""Result types of the multi-valued metrics: small frozen dataclasses of floats and arrays."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from ..checks._typing import BoolArray, FloatArray, IntArray

__all__ = ["ZeroMeanTest", "PortmanteauTest", "CrossCorrelation", "InformationCriteria"]


def _plain(value: object) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


class _ToDict:
    if TYPE_CHECKING:  # every subclass is a dataclass
        __dataclass_fields__: ClassVar[dict[str, dataclasses.Field[Any]]]

    def to_dict(self) -> dict[str, Any]:
        """Fields as plain Python values (arrays become nested lists; nan/inf stay floats)."""
        return {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self)}


@dataclass(frozen=True, eq=False)
class ZeroMeanTest(_ToDict):
    """Test of H0: the residual of each joint has zero mean (contract §3.3).

    Arrays are ``(m,)``. The i.i.d. t-test equals ``scipy.stats.ttest_1samp(e, 0)``; the
    autocorrelation-corrected test (Newey–West/Bartlett, bandwidth K) uses an effective sample
    size ``n_eff`` and is the one to read for robot residuals, which are autocorrelated.
    """

    mean: FloatArray
    std: FloatArray
    n_samples: int
    statistic_iid: FloatArray
    pvalue_iid: FloatArray
    df_iid: int
    statistic_eff: FloatArray
    pvalue_eff: FloatArray
    df_eff: FloatArray
    n_eff: FloatArray
    bandwidth: int


@dataclass(frozen=True, eq=False)
class PortmanteauTest(_ToDict):
    """Ljung–Box or Box–Pierce test (contract §3.5).

    ``lags`` and ``df`` are ``(n_lags,)`` integers; ``statistic``, ``pvalue`` and
    ``log_pvalue`` are ``(n_lags, m)``.
    """

    test: str
    lags: IntArray
    model_df: int
    statistic: FloatArray
    pvalue: FloatArray
    log_pvalue: FloatArray
    df: IntArray


@dataclass(frozen=True, eq=False)
class CrossCorrelation(_ToDict):
    """Cross-correlation of residuals with regressor columns (contract §3.6).

    ``rho`` is ``(m, p, max_lag+1)``; ``constant_mask`` ``(m, p)`` marks columns constant on a
    joint (their rows are nan); ``outside`` lists ``(joint, column, lag, rho, ratio)`` with
    ``|rho| > band``, largest ratio ``|rho|/band`` first.
    """

    rho: FloatArray
    constant_mask: BoolArray
    band: float
    level: float
    outside: list[tuple[int, int, int, float, float]]


@dataclass(frozen=True, eq=False)
class InformationCriteria(_ToDict):
    """AIC, BIC, AICc, FPE and normalised AIC, Gaussian constant dropped (contract §3.7)."""

    aic: float
    bic: float
    aicc: float
    fpe: float
    naic: float
    n_obs: int
    n_params: int
    noise_model: str
