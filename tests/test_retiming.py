"""Step timings the robust controller tries when its QP is infeasible in double support
(robust_ismpc.control.retiming), and what the first step's timings buy a standing robot."""

import numpy as np
import pytest

from robust_ismpc.control.modules import MODULES
from robust_ismpc.control.retiming import first_feasible, next_single_support_durations, start_timings
from robust_ismpc.control.walk import make_controller, start_walk
from robust_ismpc.core.params import MpcParams, robot_params
from robust_ismpc.core.planner import WalkCommand
from robust_ismpc.exceptions import InfeasibleMpc
from robust_ismpc.runs.forces import ForceWindow
from robust_ismpc.runs.lip import run_lip

G1 = robot_params("g1")
DT = 0.01


def _g1_start(t_s=0.05, on_midpoint=True):
    """G1's planned start: first single support 2.1-2.6 s, shortest single support 0.25 s."""
    return start_timings(t_s, 2.1, 2.6, 0.5, 0.25, G1.T_ds_s, G1.T_step_s, DT, on_midpoint=on_midpoint,
                         latest_touchdown_s=2.6 + G1.T_step_s)


def _timed_solver(feasible_timings):
    """A plan's timing, and a QP that is feasible only for the timings given."""
    timing = {"now": 0.5}

    def solve():
        if timing["now"] not in feasible_timings:
            raise InfeasibleMpc("infeasible")
        return f"plan at {timing['now']}"

    return timing, solve


def test_first_feasible_keeps_the_first_timing_whose_qp_solves():
    timing, solve = _timed_solver({0.4, 0.3})
    found = first_feasible([0.45, 0.4, 0.3], lambda t: timing.update(now=t), solve, lambda: timing.update(now=0.5))
    assert found == (0.4, "plan at 0.4") and timing["now"] == 0.4


def test_first_feasible_puts_the_timing_back_when_none_solves_or_the_solver_fails():
    timing, solve = _timed_solver(set())
    assert first_feasible([0.45, 0.4], lambda t: timing.update(now=t), solve, lambda: timing.update(now=0.5)) is None
    assert timing["now"] == 0.5

    def broken():
        raise ValueError("solver crashed")

    with pytest.raises(ValueError):
        first_feasible([0.45], lambda t: timing.update(now=t), broken, lambda: timing.update(now=0.5))
    assert timing["now"] == 0.5


def test_next_single_support_durations_nearest_first_within_limits():
    durations = next_single_support_durations(0.5, 0.5, (0.25, 0.75), DT)
    assert 0.5 not in durations
    assert all(0.25 - 1e-9 <= d <= 0.75 + 1e-9 for d in durations)
    gaps = np.abs(np.array(durations) - 0.5)
    assert np.all(np.diff(gaps) >= -1e-12)
    assert durations[-1] == pytest.approx(0.25) or durations[-1] == pytest.approx(0.75)


@pytest.mark.parametrize("on_midpoint", [True, False])
def test_start_timings_respect_the_double_and_single_support_limits(on_midpoint):
    """Every candidate leaves at least T_ds for the weight shift, keeps the single support
    between its shortest and its nominal length (a later touchdown keeps the current one), and
    differs from the current timing; none is listed twice."""
    t = 0.05
    timings = _g1_start(t, on_midpoint)
    pairs = [(round(c.start_s, 9), round(c.touchdown_s, 9)) for c in timings]
    assert len(set(pairs)) == len(pairs)
    for c in timings:
        assert c.start_s >= t + G1.T_ds_s - 1e-9
        assert 0.25 - 1e-9 <= c.touchdown_s - c.start_s <= 0.5 + 1e-9
        assert (c.start_s, c.touchdown_s) != pytest.approx((2.1, 2.6))
    later = [c for c in timings if c.touchdown_s > 2.6]
    assert bool(later) == on_midpoint


def test_start_timings_try_the_longest_single_supports_nearest_first_then_the_shortest_earliest_first():
    """The first part brings the touchdown forward (or back) nearest first with the longest single
    support; the rest is the shortest single support after ever longer double supports, one
    sampling period apart from the earliest start on, over at most one step."""
    timings = _g1_start()
    shortest = [c for c in timings if c.touchdown_s - c.start_s == pytest.approx(0.25)]
    first_shortest = timings.index(shortest[0])
    head, tail = timings[:first_shortest + 1], timings[first_shortest + 1:]
    distances = [abs(c.touchdown_s - 2.6) for c in head]
    assert distances == sorted(distances)
    assert head[-1].start_s == pytest.approx(0.05 + G1.T_ds_s)  # the earliest of the first part
    assert all(c.touchdown_s - c.start_s == pytest.approx(0.25) for c in tail)
    starts = np.array([c.start_s for c in tail])
    np.testing.assert_allclose(np.diff(starts), DT)
    assert starts[0] == pytest.approx(head[-1].start_s + DT)
    assert starts[-1] <= head[-1].start_s + G1.T_step_s + 1e-9


def test_start_timings_once_the_start_is_near():
    """Less than T_ds before the planned start, the start stays (the weight shift is under way)
    and only the single support is shortened, down to its shortest."""
    timings = start_timings(1.95, 2.1, 2.6, 0.5, 0.25, G1.T_ds_s, G1.T_step_s, DT, on_midpoint=False,
                            latest_touchdown_s=3.3)
    assert timings and all(c.start_s == pytest.approx(2.1) for c in timings)
    assert all(2.35 - 1e-9 <= c.touchdown_s < 2.6 for c in timings)


@pytest.mark.parametrize("fx_n", [28.0, -28.0])
def test_robust_stands_under_a_sagittal_force_beyond_its_feet_from_the_start(fx_n):
    """G1 LIP, --vx 0, 28 N sagittal switched on at t = 0 (0.8 of the weakest force it holds
    switched on while walking backward, docs/results.md): no first step with the longest single
    support is feasible once the estimate arrives; the shortest one after a longer weight shift
    is, and the robot stands (stepping in place) for 10 s."""
    controller = make_controller(G1, MpcParams(), MODULES)
    plan = start_walk(controller, WalkCommand(0.0), 10.0)
    outcome, _ = run_lip(controller, 10.0, [ForceWindow(fx_n, 0.0)])
    assert not outcome.fell, outcome.failure
    assert controller.timing_adaptations > 0 and plan.touchdown_s[2] < 1.0
    shortest = controller.sta_params.ss_limits(G1.T_ss_s)[0]
    assert plan.T_ss_s[2] == pytest.approx(shortest)  # the first step is the shortest one
