"""CSV logs written from arrays, for the tests of dynval.io.read_csv_log and validate-log: the KUKA
runs shipped with dynval with their columns renamed, reordered and in ms, as a mapping declares them."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

SHUFFLED = [3, 1, 0, 2, 6, 5, 4]


def kuka_csv(path: Path, run: Any, rows: Any, *, delimiter: str = ";") -> tuple[Path, dict[str, Any]]:
    """Time in ms, columns ``J{i}_pos`` / ``J{i}_vel`` / ``J{i}_trq`` numbered from 1 in SHUFFLED's
    joint order, every column shuffled in the file, an unmapped column first; and its mapping."""
    rows = np.asarray(rows)
    names, values = ["status"], [np.ones(len(rows))]
    for k, j in enumerate(SHUFFLED):
        for kind, arr in (("pos", run.q), ("vel", run.dq), ("trq", run.tau)):
            names.append(f"J{k + 1}_{kind}")
            values.append(arr[rows, j])
    names.append("t_ms")
    values.append(run.time[rows] * 1000.0)
    order = np.random.default_rng(1).permutation(len(names))
    table = np.column_stack([values[c] for c in order])
    np.savetxt(path, table, fmt="%.17g", delimiter=delimiter, header=delimiter.join(names[c] for c in order),
               comments="")
    mapping = {"time": "t_ms", "time_unit": "ms", "q": "J{i}_pos", "dq": "J{i}_vel", "effort": "J{i}_trq",
               "first_index": 1, "joints": [run.joint_names[j] for j in SHUFFLED], "name": "kuka"}
    return path, mapping
