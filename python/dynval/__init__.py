"""dynval: validation metrics for identified robot dynamic models (τ = Yπ + ε).

RMSE, max error, VAF, fit %, R², residual mean/variance, zero-mean test, autocorrelation with
bands, Ljung–Box/Box–Pierce, cross-correlation of residuals with regressor columns and
AIC/BIC/AICc/FPE with explicit noise models; the same numbers from the numpy reference and the
C++ core. ``docs/contract.md`` defines every name, shape, convention and error.

Examples
--------
>>> import dynval
>>> dynval.rmse([1.0, 2.0, 3.0], [1.0, 2.0, 4.0]) ** 2
0.3333333333333333
"""

from . import _startup  # noqa: F401  (first: Ctrl-C while the command line starts exits quietly)
from ._version import CONTRACT_VERSION, __version__
from .checks._errors import (
    ERROR_KINDS,
    InputError,
    InvalidParameter,
    InvalidShape,
    InvalidType,
    NonFiniteInput,
    ShapeMismatch,
    TooFewSamples,
    error_class,
)
from .comparison._compare import ComparisonReport, Decisive, Verdict, compare
from .identify import IdentificationResult, identify
from .kernels._backend import backends, set_backend
from .metrics._api import (
    aic,
    autocorrelation,
    bic,
    box_pierce,
    confidence_band,
    criteria,
    cross_correlation,
    fit_percent,
    information_criteria,
    ljung_box,
    max_abs_error,
    r2,
    residual_mean,
    residual_variance,
    residuals,
    rmse,
    sse,
    vaf,
    zero_mean_test,
)
from .metrics._results import CrossCorrelation, InformationCriteria, PortmanteauTest, ZeroMeanTest
from .report import _display
from .report._findings import KINDS as FINDING_KINDS
from .report._findings import Finding, Thresholds
from .report._prepared import PreparedRegressor, prepare_regressor
from .report._report import ValidationReport, validate
from .robots import physical_consistency

__all__ = [
    "__version__",
    "CONTRACT_VERSION",
    "residuals",
    "sse",
    "rmse",
    "max_abs_error",
    "vaf",
    "fit_percent",
    "r2",
    "residual_mean",
    "residual_variance",
    "zero_mean_test",
    "autocorrelation",
    "confidence_band",
    "ljung_box",
    "box_pierce",
    "cross_correlation",
    "information_criteria",
    "criteria",
    "aic",
    "bic",
    "validate",
    "ValidationReport",
    "prepare_regressor",
    "PreparedRegressor",
    "compare",
    "ComparisonReport",
    "Verdict",
    "Decisive",
    "Finding",
    "Thresholds",
    "FINDING_KINDS",
    "identify",
    "IdentificationResult",
    "physical_consistency",
    "backends",
    "set_backend",
    "ZeroMeanTest",
    "PortmanteauTest",
    "CrossCorrelation",
    "InformationCriteria",
    "InputError",
    "InvalidType",
    "InvalidShape",
    "ShapeMismatch",
    "TooFewSamples",
    "NonFiniteInput",
    "InvalidParameter",
    "ERROR_KINDS",
    "error_class",
]


def _render_html(obj: object) -> str:
    """A report's or a comparison's HTML fragment (dynval.html, imported when a notebook first asks)."""
    from .html import render_fragment

    return render_fragment(obj)


_display.use(_render_html)
