"""Versions, paths and the tolerance scale shared by every builder."""

from __future__ import annotations

import pathlib

from mpmath import mp

CORPUS_VERSION = "1.0.0"
SCHEMA_NAME = "corpus_v1.schema.json"
MPMATH_VERSION = "1.3.0"
DPS = 50
#: The golden/ directory: data/, vectors/ and operations.json live there.
GOLDEN = pathlib.Path(__file__).resolve().parent.parent
#: What every group's source.generator says (the command that writes the files).
GENERATOR = "golden/generate.py"
FAMILIES = (
    "norms",
    "normalized_fit",
    "residual_statistics",
    "autocorrelation",
    "portmanteau",
    "cross_correlation",
    "information_criteria",
    "errors",
    "streaming",
)

# Relative size of every tolerance: absolute tolerance = RTOL * natural size of the
# quantity (see golden/README.md). Two-pass float64 formulas stay far below it.
RTOL = 1e-11

mp.dps = DPS
