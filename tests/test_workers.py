"""The experiments' worker processes and task loop, and the bisection's iteration count."""

from __future__ import annotations

import math
import multiprocessing
import operator
import os
import signal
import time

import pytest

from robust_ismpc.exceptions import ParameterError
from robust_ismpc.experiments.sweep.bisection import bisect, iterations_for_resolution
from robust_ismpc.experiments.workers import each_completed


@pytest.mark.parametrize("workers", [1, 2])
def test_each_completed_returns_every_result_and_every_error_with_its_task(workers):
    tasks = [(1.0, 2.0), (1.0, 0.0), (3.0, 4.0)]
    outcomes = {i: (value, exc) for i, value, exc in each_completed(operator.truediv, tasks, workers)}
    assert sorted(outcomes) == [0, 1, 2]
    assert outcomes[0] == (0.5, None) and outcomes[2] == (0.75, None)
    value, exc = outcomes[1]
    assert value is None and isinstance(exc, ZeroDivisionError)


def test_workers_leave_ctrl_c_to_their_parent():
    [(_, handler, exc)] = list(each_completed(signal.getsignal, [(signal.SIGINT,)], 2))
    assert exc is None and handler == signal.SIG_IGN
    [(_, parent, _)] = list(each_completed(os.getppid, [()], 2))
    assert parent == os.getpid()


def test_closing_the_loop_early_stops_the_workers():
    loop = each_completed(time.sleep, [(0.0,), (60.0,), (60.0,)], 2)
    first = next(loop)
    assert first == (0, None, None)
    loop.close()  # what Ctrl-C in the caller's loop does too
    assert multiprocessing.active_children() == []


@pytest.mark.parametrize("workers", [0, -1, 1.5, True])
def test_each_completed_rejects_a_bad_worker_count(workers):
    with pytest.raises(ParameterError, match="workers"):
        list(each_completed(operator.neg, [(1,)], workers))


@pytest.mark.parametrize(("width", "resolution"), [(1.0, 0.05), (100.0, 0.25), (3.0, 0.05), (1.0, 1.0), (2.0, 0.7)])
def test_iterations_for_resolution_is_the_fewest_that_bring_the_bracket_within_it(width, resolution):
    n = iterations_for_resolution(width, resolution)
    threshold = 0.37 * width  # any frontier: the bracket halves whatever the outcomes
    b = bisect(lambda m: m <= threshold, width, n)
    assert b.hi - b.lo <= resolution + 1e-12 or n == 1
    assert width / 2**n <= resolution or n == 1
    if n > 1:
        assert width / 2 ** (n - 1) > resolution
    assert n == max(1, math.ceil(math.log2(width / resolution)))


@pytest.mark.parametrize(("width", "resolution"), [(0.0, 0.1), (1.0, 0.0), (-1.0, 0.1), (1.0, math.nan)])
def test_iterations_for_resolution_rejects_non_positive_input(width, resolution):
    with pytest.raises(ParameterError):
        iterations_for_resolution(width, resolution)
