"""Reference kernels in numpy/scipy: the ``python`` backend.

The compiled ``dynval._core`` exposes the same functions with the same signatures, errors and
messages (contract §5.1). Kernels take 2-D float64 arrays and int64 segment starts, check
finiteness and then their parameters, and compute.
"""

from ...checks._validation import first_nonfinite
from .correlation import autocorrelation, cross_correlation
from .fit import fit_percent, r2, vaf
from .information import criteria, information_criteria
from .metrics import compute_metrics
from .norms import max_abs_error, residuals, rmse, sse
from .portmanteau import portmanteau
from .residual_stats import residual_mean, residual_variance

__all__ = [
    "residuals",
    "sse",
    "rmse",
    "max_abs_error",
    "vaf",
    "fit_percent",
    "r2",
    "residual_mean",
    "residual_variance",
    "autocorrelation",
    "portmanteau",
    "cross_correlation",
    "information_criteria",
    "criteria",
    "compute_metrics",
    "first_nonfinite",
]

BACKEND_NAME = "python"
