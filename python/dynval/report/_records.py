"""The report's sections as typed, frozen records (contract §4).

Each section of a :class:`~dynval.ValidationReport` is a record with one attribute per quantity
(``report.per_joint.r2``), read-only, that is also a read-only mapping of the same names
(``report.per_joint["r2"]``, ``dict(report.per_joint)``, ``"rho" in report.cross_correlation``):
scripts written against the mapping keep working, and a misspelt name fails at once. A quantity a
route does not compute is absent (not a key; its attribute is :data:`ABSENT`), as the contract
lists it: ``information_criteria.n_eff`` only when lags are analysed, ``cross_correlation.rho``
only with ``cross_correlation_detail="full"``, ``bias.parameter_standard_error`` only with the
estimation run. ``to_dict()`` writes the record as the report's JSON does, keys in the order the
section was computed. Nested values (``residuals.zero_mean_test``, ``design.excitation``, the
physics library's per-joint ``tests``) stay plain mappings: their keys are listed in the contract.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, fields
from typing import Any, ClassVar, TypeVar

from ..checks._json import to_jsonable
from ..checks._typing import BoolArray, FloatArray, IntArray

__all__ = ["ABSENT", "Record", "Provenance", "PerJoint", "Pooled", "Aggregates", "Residuals", "Autocorrelation",
           "LjungBox", "CrossCorrelation", "MissingTerms", "InformationCriteria", "Bias", "Whiteness", "Spectrum",
           "Design", "Physics", "Predictive", "Periodic", "Timing", "Segment", "present", "record_or_none"]

_R = TypeVar("_R", bound="Record")
_T = TypeVar("_T")


class _Absent:
    """A quantity this report did not compute (not a key of the section)."""

    _instance: ClassVar[_Absent | None] = None

    def __new__(cls) -> _Absent:
        if cls._instance is None:
            cls._instance = super().__new__(cls)
        return cls._instance

    def __repr__(self) -> str:
        return "ABSENT"

    def __reduce__(self) -> str:
        return "ABSENT"  # the module-level name: one instance across pickling (dask)


ABSENT: Any = _Absent()


@dataclass(frozen=True, eq=False, repr=False)  # equality and repr: the mapping's
class Record(Mapping[str, Any]):
    """A report section: attributes, and a read-only mapping of the quantities present."""

    _order: tuple[str, ...] = ()

    @classmethod
    def of(cls: type[_R], section: Mapping[str, Any]) -> _R:
        """The record of a computed section (a mapping of the contract's names).

        Raises TypeError for a name the record does not declare: a section builder and its record
        disagree, which is a bug of the package, not of the data.
        """
        names = {f.name for f in fields(cls)} - {"_order"}
        unknown = [k for k in section if k not in names]
        if unknown:
            raise TypeError(f"{cls.__name__} has no field {unknown[0]!r}")
        return cls(_order=tuple(section), **section)

    def with_(self: _R, **values: Any) -> _R:
        """This record with ``values`` set: a name it holds keeps its place, a new one comes last (a
        section completed by a later step, as a mapping updated in place would be)."""
        return type(self).of({**{k: getattr(self, k) for k in self._order}, **values})

    def __getitem__(self, key: str) -> Any:
        if key not in self._order:
            raise KeyError(key)
        return getattr(self, key)

    def __iter__(self) -> Iterator[str]:
        return iter(self._order)

    def __len__(self) -> int:
        return len(self._order)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(f'{k}={_short(getattr(self, k))}' for k in self._order)})"

    def _repr_html_(self) -> str:
        """A two-column table, quantity and value (arrays abbreviated as in the repr)."""
        import html

        rows = "".join(f"<tr><th style='text-align:left'>{html.escape(k)}</th>"
                       f"<td style='text-align:left'><code>{html.escape(_short(getattr(self, k)))}</code></td></tr>"
                       for k in self._order)
        return f"<table><caption>{type(self).__name__}</caption><tbody>{rows}</tbody></table>"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary: nested lists, non-finite numbers as strings (contract §4)."""
        out: dict[str, Any] = to_jsonable({k: getattr(self, k) for k in self._order})
        return out


def _short(value: Any) -> str:
    """A value as a reader wants it in a repr: numbers to 4 significant digits, long arrays and
    mappings abbreviated (the full values are the attributes)."""
    import numpy as np

    if isinstance(value, np.ndarray):
        return np.array2string(value, precision=4, threshold=8, edgeitems=3, max_line_width=100,
                               separator=", ").replace("\n", "")
    if isinstance(value, (float, np.floating)):
        return f"{float(value):.4g}"
    if isinstance(value, Mapping):
        keys = list(value)
        shown = ", ".join(str(k) for k in keys[:4]) + (", …" if len(keys) > 4 else "")
        return f"{{{len(keys)} entries: {shown}}}"
    if isinstance(value, (list, tuple)) and len(value) > 8:
        return f"[{', '.join(map(str, value[:3]))}, …, {', '.join(map(str, value[-2:]))}] ({len(value)} items)"
    return repr(value)


def present(value: _T) -> _T | None:
    """A record's attribute, or None where the section does not hold it (:data:`ABSENT`)."""
    return None if value is ABSENT else value


def record_or_none(cls: type[_R], section: Mapping[str, Any] | None) -> _R | None:
    """``cls.of(section)``, or None for a section this report did not compute."""
    return None if section is None else cls.of(section)


@dataclass(frozen=True, eq=False, repr=False)
class Provenance(Record):
    """What the report was computed from and with (contract §4): every convention by name, the units,
    the sizes, the names, the thresholds, the backend and the versions."""

    profile: str = ABSENT
    # Any: the settings by name (numbers, names, None), as the provenance states them
    conventions: dict[str, Any] = ABSENT
    units: dict[str, str] = ABSENT
    n_samples: int = ABSENT
    n_joints: int = ABSENT
    n_params: int = ABSENT
    n_regressor_columns: int | None = ABSENT
    segments: list[int] = ABSENT
    segment_names: list[str] | None = ABSENT
    omitted_rows: int = ABSENT
    joint_names: list[str] = ABSENT
    column_names: list[str] | None = ABSENT
    model_columns: list[int] | None = ABSENT
    sample_rate: float | None = ABSENT
    thresholds: dict[str, float] | None = ABSENT
    backend: str = ABSENT
    streaming: bool = ABSENT  #: present (True) on a streamed report only
    not_tested: list[dict[str, Any]] = ABSENT  #: a streamed report's: the tests left out, by name, and why
    dynval_version: str = ABSENT
    contract_version: str = ABSENT
    report_schema_version: int = ABSENT


@dataclass(frozen=True, eq=False, repr=False)
class PerJoint(Record):
    """Per-joint point metrics, arrays (m,): ``sse``, ``rmse``, ``max_abs_error``, ``vaf``,
    ``fit_percent``, ``r2``, and ``nrmse`` = √(SSE_j/TSS_j) (a fraction)."""

    sse: FloatArray = ABSENT
    rmse: FloatArray = ABSENT
    max_abs_error: FloatArray = ABSENT
    vaf: FloatArray = ABSENT
    fit_percent: FloatArray = ABSENT
    r2: FloatArray = ABSENT
    nrmse: FloatArray = ABSENT


@dataclass(frozen=True, eq=False, repr=False)
class Pooled(Record):
    """All N·m values flattened with one mean (the lesson's form)."""

    sse: float = ABSENT
    rmse_per_element: float = ABSENT  #: √(SSE/(N·m))
    rmse_per_sample: float = ABSENT  #: √(SSE/N)
    max_abs_error: float = ABSENT
    vaf: float = ABSENT
    fit_percent: float = ABSENT
    r2: float = ABSENT


@dataclass(frozen=True, eq=False, repr=False)
class Aggregates(Record):
    """Per-joint values averaged: ``uniform_average`` and ``variance_weighted`` (each ``vaf``,
    ``fit_percent``, ``r2``) and ``rmse_uniform_average``."""

    uniform_average: dict[str, float] = ABSENT
    variance_weighted: dict[str, float] = ABSENT
    rmse_uniform_average: float = ABSENT


@dataclass(frozen=True, eq=False, repr=False)
class Residuals(Record):
    """The residual's ``mean`` and ``variance`` (m,), the variance's ``ddof`` and the
    ``zero_mean_test`` (contract §3.3)."""

    mean: FloatArray = ABSENT
    variance: FloatArray = ABSENT
    ddof: int = ABSENT
    # Any: contract §3.3's test result as a mapping (statistic, p-value arrays and the test's name)
    zero_mean_test: dict[str, Any] = ABSENT


@dataclass(frozen=True, eq=False, repr=False)
class Autocorrelation(Record):
    """The residual's autocorrelation ``rho`` (max_lag+1, m), its ``band`` at ``level``
    (``band_type``), the ``outside`` cells (joint, lag, ρ) and each joint's ``fraction_outside``."""

    max_lag: int = ABSENT
    adjusted: bool = ABSENT
    rho: FloatArray = ABSENT
    band_type: str = ABSENT
    level: float = ABSENT
    band: FloatArray = ABSENT
    # Any: (joint, lag, ρ) triples
    outside: list[Any] = ABSENT
    fraction_outside: FloatArray = ABSENT


@dataclass(frozen=True, eq=False, repr=False)
class LjungBox(Record):
    """The portmanteau ``test`` at ``lags`` (contract §3.5): ``statistic``, ``pvalue``,
    ``log_pvalue``, ``df``, each (len(lags), m)."""

    test: str = ABSENT
    lags: IntArray = ABSENT
    model_df: int = ABSENT
    statistic: FloatArray = ABSENT
    pvalue: FloatArray = ABSENT
    log_pvalue: FloatArray = ABSENT
    df: IntArray = ABSENT


@dataclass(frozen=True, eq=False, repr=False)
class CrossCorrelation(Record):
    """The residual against each regressor column (contract §4): the white ``band`` z/√N and the
    colour-aware summary (``colour_factor``, ``max_abs_rho``, ``lag_of_max``, ``z_max`` (m, p),
    ``top_cells``); ``rho`` and ``sd`` (m, p, L+1) with ``detail="full"``; ``parameter_error``
    with the estimation run; ``missing_terms`` with ``model_columns``; ``pvalue_adjusted`` (m, p),
    each cell's smallest Holm-adjusted p over its lags, when the findings tested the cells."""

    max_lag: int = ABSENT
    adjusted: bool = ABSENT
    constant_mask: BoolArray = ABSENT
    band: float = ABSENT
    level: float = ABSENT
    n_outside_white_band: int = ABSENT
    colour_lags: int = ABSENT
    colour_factor: FloatArray = ABSENT
    max_abs_rho: FloatArray = ABSENT
    lag_of_max: IntArray = ABSENT
    z_max: FloatArray = ABSENT
    # Any: (joint, column, lag, ρ, z) rows, JSON-ready
    top_cells: list[Any] = ABSENT
    detail: str = ABSENT
    # Any: (joint, column, lag, ρ) cells outside the white band
    outside: list[Any] = ABSENT
    rho: FloatArray = ABSENT
    sd: FloatArray = ABSENT
    parameter_error: bool = ABSENT
    # Any: the added-variable section (columns, statistics, p-values, shares), contract §4
    missing_terms: dict[str, Any] = ABSENT
    pvalue_adjusted: FloatArray = ABSENT


@dataclass(frozen=True, eq=False, repr=False)
class MissingTerms(Record):
    """The columns outside ``model_columns`` tested as the model's missing terms: on the validation run
    (``method`` "added_variable": ``statistic`` the correlation ρ, ``sd``, per joint and column (m, q))
    or by the estimation run's refit (``method`` "estimation_refit": ``statistic`` its Wald t per column,
    ``enters`` and ``alone`` (m, q)); ``share`` and ``explains_bias`` (m, q). The record of
    ``cross_correlation.missing_terms``, which the report writes as a mapping (contract §4)."""

    enters: BoolArray = ABSENT
    method: str = ABSENT
    columns: list[int] = ABSENT
    statistic: FloatArray = ABSENT
    sd: FloatArray = ABSENT
    pvalue: FloatArray = ABSENT
    share: FloatArray = ABSENT
    alone: FloatArray = ABSENT
    explains_bias: BoolArray = ABSENT


@dataclass(frozen=True, eq=False, repr=False)
class InformationCriteria(Record):
    """AIC, BIC, AICc, FPE and normalised AIC under ``noise_model`` (contract §3.7); when lags are
    analysed also ``n_eff`` and the criteria with it (``aic_neff``, ``bic_neff``, ``aicc_neff``)."""

    noise_model: str = ABSENT
    constant: str = ABSENT
    n_obs: int = ABSENT
    n_params: int = ABSENT
    aic: float = ABSENT
    bic: float = ABSENT
    aicc: float = ABSENT
    fpe: float = ABSENT
    naic: float = ABSENT
    n_eff: float = ABSENT
    aic_neff: float = ABSENT
    bic_neff: float = ABSENT
    aicc_neff: float = ABSENT


@dataclass(frozen=True, eq=False, repr=False)
class Bias(Record):
    """The residual mean against its coloured-noise standard error, per joint (m,): ``mean``,
    ``std``, ``n_eff``, ``phi``, ``bandwidth``, ``statistic``, ``pvalue``, ``df``, ``effect``
    (|mean|/RMSE), ``standard_error``; with the estimation run ``parameter_standard_error``."""

    method: str = ABSENT
    long_run_variance_method: str = ABSENT
    mean: FloatArray = ABSENT
    std: FloatArray = ABSENT
    n_eff: FloatArray = ABSENT
    phi: FloatArray = ABSENT
    bandwidth: IntArray = ABSENT
    statistic: FloatArray = ABSENT
    pvalue: FloatArray = ABSENT
    df: FloatArray = ABSENT
    effect: FloatArray = ABSENT
    effect_unit: str = ABSENT
    standard_error: FloatArray = ABSENT
    parameter_standard_error: FloatArray = ABSENT


@dataclass(frozen=True, eq=False, repr=False)
class Whiteness(Record):
    """Ljung–Box at the logged rate (``lag``, ``pvalue_raw``, ``log_pvalue_raw``) and at the
    information rate (``decimation``, ``information_band``, ``pvalue_decimated``, ``lag_decimated``,
    ``n_decimated``; None when not decimated); ``bandwidth`` and ``above_bandwidth``."""

    test: str = ABSENT
    lag: int = ABSENT
    pvalue_raw: FloatArray = ABSENT
    log_pvalue_raw: FloatArray = ABSENT
    decimation: int = ABSENT
    information_band: float | None = ABSENT
    information_band_source: str | None = ABSENT
    pvalue_decimated: FloatArray | None = ABSENT
    lag_decimated: int | None = ABSENT
    n_decimated: int | None = ABSENT
    bandwidth: float | None = ABSENT
    above_bandwidth: bool = ABSENT


@dataclass(frozen=True, eq=False, repr=False)
class Spectrum(Record):
    """Welch spectrum of the residual (less what the regressor explains, ``regressor_removed``):
    ``frequency`` (F,), ``power`` (F, m), ``dof``, ``nperseg`` and the strongest tested ``peaks``."""

    frequency: FloatArray = ABSENT
    frequency_unit: str = ABSENT
    power: FloatArray = ABSENT
    dof: float = ABSENT
    nperseg: int = ABSENT
    regressor_removed: bool = ABSENT
    peaks: list[dict[str, Any]] = ABSENT


@dataclass(frozen=True, eq=False, repr=False)
class Design(Record):
    """The validation run's design, each part when its inputs were given: ``repeat`` (distance to
    the estimation run), ``excitation`` (the validation regressor), ``joint_motion_ratio`` (m,),
    ``noise_n_eff`` and ``detectable_share`` (m,)."""

    # Any: the repeat and excitation sections' mappings (conventions §5.6), numbers and column lists
    repeat: dict[str, Any] = ABSENT
    excitation: dict[str, Any] = ABSENT
    joint_motion_ratio: FloatArray = ABSENT
    noise_n_eff: FloatArray = ABSENT
    detectable_share: FloatArray = ABSENT


@dataclass(frozen=True, eq=False, repr=False)
class Physics(Record):
    """Each joint's residual against the library of physical terms (``tests`` per joint;
    ``pvalue``, ``share``, ``n_eff`` (m,)) and the ``delay`` test (contract §4)."""

    naming: str = ABSENT
    method: str = ABSENT
    model_columns: str = ABSENT
    derivatives: str = ABSENT
    derivative_bandwidth_hz: float | None = ABSENT
    derivative_source: str = ABSENT
    estimation_bandwidth_hz: float | None = ABSENT
    model_kinds: list[dict[str, bool]] | None = ABSENT
    simulator_parameters: list[list[dict[str, Any]]] | None = ABSENT
    groups: list[str] = ABSENT
    tests: list[dict[str, Any]] = ABSENT
    pvalue: FloatArray = ABSENT
    share: FloatArray = ABSENT
    n_eff: FloatArray = ABSENT
    # Any: the delay test's mapping (shift, per-joint shares and p-values)
    delay: dict[str, Any] = ABSENT
    # present where the test ran on a decimated log (conventions §5.2): factor, band, rows, rule
    decimation: dict[str, Any] = ABSENT


@dataclass(frozen=True, eq=False, repr=False)
class Predictive(Record):
    """The validation mean square against what the estimation run's noise and Cov(π̂) allow:
    per joint ``ratio``, ``expected_mse``, ``validation_mse``, ``noise_variance_estimation``,
    ``parameter_variance``, ``df`` (m, 2), ``pvalue``."""

    method: str = ABSENT
    ratio: FloatArray = ABSENT
    expected_mse: FloatArray = ABSENT
    validation_mse: FloatArray = ABSENT
    noise_variance_estimation: FloatArray = ABSENT
    parameter_variance: FloatArray = ABSENT
    df: FloatArray = ABSENT
    pvalue: FloatArray = ABSENT


@dataclass(frozen=True, eq=False, repr=False)
class Periodic(Record):
    """A periodic trajectory: the ``period``, the noise measured from the period-to-period variation
    and, per joint, the test of what every period shares (contract §4)."""

    used: bool = ABSENT
    # Any: the period in samples and seconds (None without a rate)
    period: dict[str, Any] = ABSENT
    # list[Any]: per joint, the values as statistics/_periodic.py gives them, JSON-ready (floats, or
    # per-harmonic lists for the spectra and the harmonic tests); effect_net is an array (m,)
    pvalue: list[Any] = ABSENT
    statistic: list[Any] = ABSENT
    dof: int = ABSENT
    phi: list[Any] = ABSENT
    effect: list[Any] = ABSENT
    error_power: list[Any] = ABSENT
    noise_variance: list[Any] = ABSENT
    total_variance: list[Any] = ABSENT
    noise_spectrum: list[Any] = ABSENT
    harmonic_statistic: list[Any] = ABSENT
    harmonic_pvalue: list[Any] = ABSENT
    frequency: list[Any] = ABSENT
    n_periods: int = ABSENT
    samples_per_period: int = ABSENT
    n_harmonics: int = ABSENT
    period_samples: float = ABSENT
    start: int = ABSENT
    method: str = ABSENT
    model_columns_removed: bool = ABSENT
    effect_net: FloatArray = ABSENT
    note: str = ABSENT  # why a period found was not tested (``used`` False)


@dataclass(frozen=True, eq=False, repr=False)
class Timing(Record):
    """What the time stamps say (contract §4): the nominal step and rate, duplicated stamps,
    repeated rows, gaps, irregular steps, jitter and the grid the analyses used."""

    nominal_step: float = ABSENT
    sample_rate: float = ABSENT
    sample_rate_source: str = ABSENT
    n_steps: int = ABSENT
    duplicated_stamps: int = ABSENT
    repeated_rows: int = ABSENT
    gaps: int = ABSENT
    largest_gap: float = ABSENT
    largest_gap_time: float | None = ABSENT
    irregular_steps: int = ABSENT
    jitter_rms: float = ABSENT
    largest_step_deviation: float = ABSENT
    duration: float = ABSENT
    gap_rows: list[int] = ABSENT
    grid: str = ABSENT
    regular: bool = ABSENT


@dataclass(frozen=True, eq=False, repr=False)
class Segment(Record):
    """The metrics of one named segment (``segment_metrics[name]``): ``n_samples`` and, with two
    samples or more, ``start``, ``per_joint``, ``mean`` and ``pooled``."""

    n_samples: int = ABSENT
    start: int = ABSENT
    # Any: the segment's per-joint and pooled metrics by name (arrays and floats)
    per_joint: dict[str, Any] = ABSENT
    mean: FloatArray = ABSENT
    pooled: dict[str, Any] = ABSENT
