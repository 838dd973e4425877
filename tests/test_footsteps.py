"""Tests of the footstep plan timing, queries, weights and retiming (spec §3)."""

import numpy as np
import pytest
from fixtures import straight_plan

from robust_ismpc.core.footsteps import LEFT, RIGHT
from robust_ismpc.core.params import robot_params
from robust_ismpc.exceptions import ParameterError, PlanError


@pytest.fixture
def plan():
    return straight_plan(robot_params("hrp4"), vx=0.2, duration_s=8.0)


def test_timing_queries(plan):
    """step_at, single-support test and time-to-touchdown agree with the timing table."""
    r = robot_params("hrp4")
    t2 = plan.ss_start_s[2]
    assert plan.step_at(t2 + 1e-3) == 2
    assert plan.in_single_support(t2 + 0.5 * r.T_ss_s)
    assert plan.time_to_touchdown(t2 + 0.1) == pytest.approx(r.T_ss_s - 0.1)
    assert not plan.in_single_support(t2 + r.T_ss_s + 0.01)
    assert plan.time_to_touchdown(t2 + r.T_ss_s + 0.01) == 0.0
    assert plan.step_at(t2 + r.T_step_s + 1e-3) == 3
    with pytest.raises(PlanError):
        plan.step_at(plan.end_s + 1.0)


def test_sides_alternate_and_first_support_is_right(plan):
    """Footstep 1 is the right foot, then sides alternate."""
    assert plan.side[1] == RIGHT
    assert np.all(plan.side[2::2] == LEFT) and np.all(plan.side[3::2] == RIGHT)


def test_centre_weights_are_convex_and_ramp_in_double_support(plan):
    """Weights sum to 1; in DS the centre moves linearly from footstep j-1 to j."""
    j = 3
    td, tds = plan.touchdown_s[j], plan.T_ds_s[j]
    times = np.array([td - 0.05, td, td + 0.25 * tds, td + tds - 1e-9])
    W = plan.weight_matrix(times, j - 1, 2)
    np.testing.assert_allclose(W.sum(axis=1), 1.0)
    np.testing.assert_allclose(W[:, 1], [0.0, 0.0, 0.25, 1.0], atol=1e-6)
    c = plan.centre(times)
    np.testing.assert_allclose(c[2], 0.75 * plan.pos_m[j - 1] + 0.25 * plan.pos_m[j])


def test_retime_shifts_later_steps_and_keeps_durations(plan):
    """Moving one touchdown shifts every later step start by the same amount, T_ds unchanged."""
    j = 4
    before_start = plan.ss_start_s.copy()
    before_ds = plan.T_ds_s.copy()
    new_td = plan.touchdown_s[j] - 0.1
    shift = plan.retime_touchdown(j, new_td)
    assert shift == pytest.approx(-0.1)
    assert plan.touchdown_s[j] == pytest.approx(new_td)
    np.testing.assert_allclose(plan.ss_start_s[j + 1 :], before_start[j + 1 :] - 0.1)
    np.testing.assert_allclose(plan.ss_start_s[: j + 1], before_start[: j + 1])
    np.testing.assert_array_equal(plan.T_ds_s, before_ds)
    with pytest.raises(ParameterError):
        plan.retime_touchdown(j, plan.ss_start_s[j] - 0.01)


@pytest.mark.parametrize("progress", [None, 0.0, 0.4])
def test_retime_start_keeps_the_box_and_shifts_the_walk(plan, progress):
    """Bringing the first single support forward, from the stance on the midpoint (None) or from
    inside the initial double support (its progress 0 or 0.4 at t): the ZMP box at t (centre and
    half sides) is where it was, the initial double support ends at the new start, every later
    step start moves by the same shift and every later duration is kept."""
    td1, tds1 = float(plan.touchdown_s[1]), float(plan.T_ds_s[1])
    t = 0.5 * td1 if progress is None else td1 + progress * tds1
    new_start = t + 0.35 * (plan.ss_start_s[2] - t)
    box_before = plan.box_at(t)
    starts, T_ss, T_ds = plan.ss_start_s.copy(), plan.T_ss_s.copy(), plan.T_ds_s.copy()
    shift = plan.retime_start(t, new_start)
    assert shift == pytest.approx(new_start - starts[2])
    np.testing.assert_allclose(plan.ss_start_s[2:], starts[2:] + shift)
    np.testing.assert_array_equal(plan.T_ss_s[2:], T_ss[2:])
    np.testing.assert_array_equal(plan.T_ds_s[2:], T_ds[2:])
    assert plan.touchdown_s[1] + plan.T_ds_s[1] == pytest.approx(new_start)
    assert plan.T_ds_s[1] <= tds1 + 1e-12
    for now, then in zip(plan.box_at(t), box_before):
        np.testing.assert_allclose(now, then, atol=1e-12)
    plan._check_chained()


def test_retime_start_delays_only_before_the_initial_double_support(plan):
    """A later first single support is possible while the box is still on the midpoint (the
    stance there lasts longer, the double support keeps its duration); once the double support is
    under way it is refused, as are times outside the stance and starts not after now."""
    t2, td1, tds1 = float(plan.ss_start_s[2]), float(plan.touchdown_s[1]), float(plan.T_ds_s[1])
    shift = plan.retime_start(0.5, t2 + 0.3)
    assert shift == pytest.approx(0.3)
    assert plan.touchdown_s[1] == pytest.approx(td1 + 0.3) and plan.T_ds_s[1] == pytest.approx(tds1)
    during = float(plan.touchdown_s[1]) + 0.5 * tds1
    with pytest.raises(ParameterError):
        plan.retime_start(during, float(plan.ss_start_s[2]) + 0.1)
    with pytest.raises(ParameterError):
        plan.retime_start(float(plan.ss_start_s[2]) + 0.01, float(plan.ss_start_s[2]) + 0.1)
    with pytest.raises(ParameterError):
        plan.retime_start(0.5, 0.5)


def test_one_time_queries_match_the_array_queries():
    """step_at on one time and box_at give what the array queries give, on a turning, sideways
    walk, at every sampled time of the plan."""
    from robust_ismpc.core.params import robot_params
    from robust_ismpc.core.planner import WalkCommand, plan_footsteps

    robot = robot_params("g1")
    left = np.array([0.0, 0.5 * robot.foot_spacing_m])
    plan = plan_footsteps(robot, WalkCommand(0.2, 0.05, 0.2), 8.0, left, -left)
    for t in np.linspace(plan.ss_start_s[1], plan.end_s - 1e-6, 801):
        at = np.array([t])
        assert plan.step_at(float(t)) == int(plan.step_at(at)[0])
        centre, half, yaw = plan.box_at(float(t))
        np.testing.assert_allclose(centre, plan.centre(at)[0], atol=1e-12)
        np.testing.assert_allclose(half, plan.box_half(at)[0], atol=1e-12)
        assert yaw == pytest.approx(plan.centre_yaw(at)[0], abs=1e-12)
    with pytest.raises(PlanError):
        plan.step_at(float(plan.end_s))
    with pytest.raises(PlanError):
        plan.step_at(float("nan"))
