"""Every available backend against every golden vector, through the public API.

Test ids are ``<family>-<tcId>`` (plus the backend); a failure shows the vector's
comment and flags so that the reason the vector exists is in front of the reader.
"""

from __future__ import annotations

import pytest

import dynval
from dynval.golden import check_case, iter_cases, run_operation

CASES = list(iter_cases())


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_vector(case, backend):
    try:
        outputs = run_operation(case.operation, case.inputs, case.conventions, backend=backend)
    except dynval.InputError as exc:
        ok, detail = check_case(case, error_kind=exc.kind)
        detail = f"{detail} ({exc})"
    else:
        ok, detail = check_case(case, outputs=outputs)
    assert ok, (f"{case.id} [{case.operation} {case.conventions}] {case.comment} "
                f"flags={list(case.flags)}: {detail}")
