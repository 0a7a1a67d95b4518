"""Type stub of the compiled backend ``dynval._core`` (cpp/bindings/*.cpp).

The kernels of docs/contract.md §5.1, with the signatures of ``dynval._reference``. Array
arguments are anything numpy converts to a float64 matrix (C-contiguous float64 binds without a
copy). Parameters are checked by the core, so a wrong kind raises InvalidParameter rather than
TypeError; string options are typed ``str`` because the core, not the caller, checks them against
the contract's options (the facade's functions take the Literal types of ``dynval._typing``).
tests/test_typing.py checks that this stub and the module define the same names and arguments.
"""

from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

_Int = int | np.integer[Any]
_Real = float | np.floating[Any] | np.integer[Any]
_Bool = bool | np.bool_
_Starts = ArrayLike | None

__version__: str
CONTRACT_VERSION: str
EIGEN_VERSION: str

# register_errors.cpp
def first_nonfinite(a: ArrayLike) -> tuple[int, int, float] | None: ...

# register_norms.cpp
def residuals(meas: ArrayLike, pred: ArrayLike) -> NDArray[np.float64]: ...
def sse(meas: ArrayLike, pred: ArrayLike, multioutput: str) -> float | NDArray[np.float64]: ...
def max_abs_error(meas: ArrayLike, pred: ArrayLike, multioutput: str) -> float | NDArray[np.float64]: ...
def rmse(
    meas: ArrayLike,
    pred: ArrayLike,
    multioutput: str,
    convention: str | None,
) -> float | NDArray[np.float64]: ...

# register_normalized_fit.cpp
def vaf(meas: ArrayLike, pred: ArrayLike, multioutput: str) -> float | NDArray[np.float64]: ...
def fit_percent(meas: ArrayLike, pred: ArrayLike, multioutput: str) -> float | NDArray[np.float64]: ...
def r2(meas: ArrayLike, pred: ArrayLike, multioutput: str) -> float | NDArray[np.float64]: ...

# register_residual_statistics.cpp
def residual_mean(e: ArrayLike) -> NDArray[np.float64]: ...
def residual_variance(e: ArrayLike, ddof: _Int) -> NDArray[np.float64]: ...
def compute_metrics(
    meas: ArrayLike, pred: ArrayLike, n_params: _Int, ddof: _Int, noise_model: str
) -> dict[str, Any]: ...

# register_correlation.cpp
def autocorrelation(e: ArrayLike, max_lag: _Int, adjusted: _Bool, starts: _Starts) -> NDArray[np.float64]: ...
def cross_correlation(
    e: ArrayLike, Y: ArrayLike, n_columns: _Int, max_lag: _Int, adjusted: _Bool, starts: _Starts
) -> dict[str, Any]: ...

# register_portmanteau.cpp
def portmanteau(
    e: ArrayLike,
    lags: _Int | Sequence[_Int] | NDArray[np.integer[Any]],
    model_df: _Int,
    starts: _Starts,
    test: str,
) -> dict[str, Any]: ...

# register_information_criteria.cpp
def information_criteria(rss: _Real, n_obs: _Int, n_params: _Int) -> dict[str, Any]: ...
def criteria(meas: ArrayLike, pred: ArrayLike, n_params: _Int, noise_model: str) -> dict[str, Any]: ...

# register_testing.cpp: the submodule dynval._core._testing (probes for the test suite, not a
# public API). A one-file stub cannot declare a submodule, so its functions are typed as the
# members of a protocol that the module object satisfies.
class _TestingModule(Protocol):
    def data_address(self, a: ArrayLike) -> int: ...
    def chi2_sf(self, q: ArrayLike, df: ArrayLike) -> float | NDArray[np.float64]: ...
    def chi2_logsf(self, q: ArrayLike, df: ArrayLike) -> float | NDArray[np.float64]: ...
    def normal_quantile(self, p: ArrayLike) -> float | NDArray[np.float64]: ...
    def confidence_band(self, n: _Int, level: _Real) -> float: ...

_testing: _TestingModule
