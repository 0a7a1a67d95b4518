"""dynval's own threads (kernels/_threads.py): how many, and the map that runs independent work on them.

Mutations caught: results returned in completion order instead of the items' order; an exception in
a thread swallowed (a missing result); the caller's numpy error state not carried into the threads
(a warning the caller silenced comes back); threads taken for work below the minimum or against
DYNVAL_NUM_THREADS=1.
"""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from dynval.kernels import _threads

BIG = _threads.MIN_PARALLEL_VALUES


def test_results_come_back_in_the_items_order(monkeypatch):
    monkeypatch.setenv("DYNVAL_NUM_THREADS", "2")

    def slow_first(i):
        time.sleep(0.05 if i == 0 else 0.0)  # the first item ends last
        return i * i

    assert _threads.thread_map(slow_first, 5, values=BIG) == [0, 1, 4, 9, 16]


def test_work_runs_on_threads_only_above_the_minimum_and_as_allowed(monkeypatch):
    names: list[str] = []

    def who(i):
        names.append(threading.current_thread().name)
        return i

    monkeypatch.setenv("DYNVAL_NUM_THREADS", "2")
    _threads.thread_map(who, 4, values=BIG - 1)
    assert set(names) == {threading.current_thread().name}
    names.clear()
    _threads.thread_map(who, 4, values=BIG)
    assert all(name.startswith("dynval") for name in names)
    names.clear()
    monkeypatch.setenv("DYNVAL_NUM_THREADS", "1")
    _threads.thread_map(who, 4, values=BIG)
    assert set(names) == {threading.current_thread().name}


def test_an_exception_in_a_thread_reaches_the_caller(monkeypatch):
    monkeypatch.setenv("DYNVAL_NUM_THREADS", "2")

    def fails_on_two(i):
        if i == 2:
            raise ValueError("item 2")
        return i

    with pytest.raises(ValueError, match="item 2"):
        _threads.thread_map(fails_on_two, 4, values=BIG)


def test_the_callers_numpy_error_state_holds_in_the_threads(monkeypatch):
    monkeypatch.setenv("DYNVAL_NUM_THREADS", "2")

    def divide(i):
        return float(np.float64(1.0) / np.float64(0.0))

    with np.errstate(divide="raise"), pytest.raises(FloatingPointError):
        _threads.thread_map(divide, 2, values=BIG)
    with np.errstate(divide="ignore"):
        assert _threads.thread_map(divide, 2, values=BIG) == [np.inf, np.inf]
