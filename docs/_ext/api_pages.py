"""Writes the API reference's pages (``docs/api/*.rst``) from the package's own ``__all__`` lists at
every build, so that every public name has a page and none is listed by hand.

``PUBLIC_MODULES`` is the list of public modules; ``public_names()`` is what the test of the site
(tests/test_docs.py) checks against the built pages.
"""

from __future__ import annotations

import importlib
from pathlib import Path

# The public modules beside the top-level package, as the README and docs/architecture.md name them.
PUBLIC_MODULES = {
    "dynval.stream": "Streams: validation of logs larger than memory",
    "dynval.dask": "Dask: validation on a cluster",
    "dynval.coverage": "Which test each entry point runs (memory, stream, fleet, dask)",
    "dynval.fleet": "Fleets: many logs of many robots and the drift test",
    "dynval.identify": "Identification and prediction intervals",
    "dynval.io": "A robot's own logs: joint states of ROS bags, MCAP files and vendor CSV logs",
    "dynval.logs": "From a robot's log and its model files to a verdict",
    "dynval.robots": "Robots: URDF regressors, derivatives, physical consistency",
    "dynval.mjcf": "Simulator models: MuJoCo MJCF arms, their terms, the regressor of their joint parameters",
    "dynval.datasets": "Shipped data sets",
    "dynval.plot": "Figures",
    "dynval.html": "HTML reports",
    "dynval.simulate": "The simulated 2-DOF demo arm",
    "dynval.scenarios": "The calibration scenario library",
    "dynval.calibration": "The 2-DOF calibration of the findings",
    "dynval.protocol": "The port protocol",
    "dynval.port": "A complete port (python or cpp backend)",
}

_TOP_SECTIONS = {
    "Metrics": ("residuals", "sse", "rmse", "max_abs_error", "vaf", "fit_percent", "r2", "residual_mean",
                "residual_variance", "zero_mean_test", "autocorrelation", "confidence_band", "ljung_box",
                "box_pierce", "cross_correlation", "information_criteria", "criteria", "aic", "bic"),
    "Validation and comparison": ("validate", "ValidationReport", "prepare_regressor", "PreparedRegressor",
                                  "compare", "ComparisonReport", "Verdict", "Decisive", "Finding", "Thresholds",
                                  "FINDING_KINDS"),
    "Identification and physical consistency": ("identify", "IdentificationResult", "physical_consistency"),
    "Result types": ("ZeroMeanTest", "PortmanteauTest", "CrossCorrelation", "InformationCriteria"),
    "Backends": ("backends", "set_backend"),
    "Errors": ("InputError", "InvalidType", "InvalidShape", "ShapeMismatch", "TooFewSamples", "NonFiniteInput",
               "InvalidParameter", "ERROR_KINDS", "error_class"),
    "Versions": ("__version__", "CONTRACT_VERSION"),
}


def public_names() -> dict[str, list[str]]:
    """Every public name by module: ``dynval``'s ``__all__`` and each public module's."""
    import dynval

    names = {"dynval": list(dynval.__all__)}
    for module in PUBLIC_MODULES:
        names[module] = list(importlib.import_module(module).__all__)
    return names


def _autosummary(module: str, names: list[str]) -> str:
    lines = [f".. currentmodule:: {module}", "", ".. autosummary::", "   :toctree: generated", ""]
    lines += [f"   {name}" for name in names if not name.startswith("__")]
    return "\n".join(lines) + "\n"


def _top_page(names: list[str]) -> str:
    listed = [n for section in _TOP_SECTIONS.values() for n in section]
    missing = sorted(set(names) - set(listed))
    if missing:  # a new public name must be given its section here
        raise RuntimeError(f"docs/_ext/api_pages.py: dynval.__all__ names without a section: {missing}")
    out = ["``dynval``", "==========", "", ".. automodule:: dynval", "   :no-members:", "   :no-index:", ""]
    for title, section in _TOP_SECTIONS.items():
        out += [title, "-" * len(title), "", _autosummary("dynval", [n for n in section if n in names])]
    out += ["``dynval.__version__`` is the package's version and ``dynval.CONTRACT_VERSION`` the contract's",
            "(docs/contract.md).", ""]
    return "\n".join(out)


def _module_page(module: str, title: str, names: list[str]) -> str:
    heading = f"``{module}``: {title}"
    lines = [heading, "=" * len(heading), "", f".. automodule:: {module}", "   :no-members:", "   :no-index:", ""]
    return "\n".join([*lines, _autosummary(module, names)])


def write_pages(api_dir: Path) -> list[Path]:
    """(Re)write the reference's pages; an unchanged page is not touched (Sphinx rereads only changes)."""
    api_dir.mkdir(parents=True, exist_ok=True)
    names = public_names()
    pages = {"dynval.rst": _top_page(names["dynval"])}
    for module, title in PUBLIC_MODULES.items():
        pages[f"{module}.rst"] = _module_page(module, title, names[module])
    toc = ["API reference", "=============", "",
           "Every public name of the package, one page each, from its docstring.", "",
           ".. toctree::", "   :maxdepth: 1", "", "   dynval"]
    toc += [f"   {module}" for module in PUBLIC_MODULES]
    pages["index.rst"] = "\n".join(toc) + "\n"
    written = []
    for name, text in pages.items():
        path = api_dir / name
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")
        written.append(path)
    return written


def _on_config_inited(app, config) -> None:
    # before autosummary reads the pages at builder-inited
    write_pages(Path(app.srcdir) / "api")


def setup(app):
    app.connect("config-inited", _on_config_inited)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
