"""Tests of the candidate footstep planner (spec §9)."""

import numpy as np
import pytest
import qpsolvers
from fixtures import straight_plan

from robust_ismpc.core.params import robot_params
from robust_ismpc.core.planner import SOLE_CLEARANCE_M, WalkCommand, kinematic_box, plan_footsteps, rotation
from robust_ismpc.exceptions import ParameterError


@pytest.mark.parametrize("cmd", [(0.3, 0.0, 0.0), (0.0, 0.05, 0.0), (0.1, 0.0, 0.4), (-0.2, 0.0, 0.0)])
def test_candidates_satisfy_kinematic_and_yaw_limits(cmd):
    """Every candidate increment lies in the rotated kinematic box and |Δθ| <= θ_max."""
    robot = robot_params("hrp4")
    plan = straight_plan(robot, *cmd, duration_s=10.0)
    assert np.all(np.abs(np.diff(plan.yaw_rad[1:])) <= robot.max_yaw_step_rad + 1e-12)
    for j in range(2, plan.n_footsteps):
        lo, hi = kinematic_box(robot, int(plan.side[j]))
        local = rotation(plan.yaw_rad[j - 1]).T @ (plan.candidate_pos_m[j] - plan.candidate_pos_m[j - 1])
        assert np.all(local >= lo - 1e-12) and np.all(local <= hi + 1e-12)


@pytest.mark.parametrize("name", ["op3", "nao", "g1"])
def test_footsteps_never_bring_the_soles_closer_than_their_width(name):
    """Walking sideways both ways, consecutive candidate soles stay at least a sole width plus
    SOLE_CLEARANCE_M apart laterally (or ℓ, if that is less), and the kinematic box of a
    right foot mirrors the left one."""
    robot = robot_params(name)
    least = min(robot.foot_spacing_m, robot.sole_width_m + SOLE_CLEARANCE_M)
    for vy in (0.05, -0.05):
        plan = straight_plan(robot, 0.0, vy, duration_s=6.0)
        gaps = np.abs(np.diff(plan.candidate_pos_m[1:, 1]))
        assert gaps.min() >= least - 1e-12
    lo_left, hi_left = kinematic_box(robot, 1)
    lo_right, hi_right = kinematic_box(robot, -1)
    np.testing.assert_allclose([lo_right[1], hi_right[1]], [-hi_left[1], -lo_left[1]])
    assert lo_left[1] >= least - 1e-12


def test_walking_speed_is_reproduced_when_feasible():
    """At a speed within the kinematic limits the candidates advance v·T_step per step."""
    robot = robot_params("g1")
    plan = straight_plan(robot, 0.2, duration_s=10.0)
    steps = np.diff(plan.candidate_pos_m[2:, 0])
    np.testing.assert_allclose(steps, 0.2 * robot.T_step_s, atol=1e-9)


def test_position_projection_equals_generic_qp():
    """The clipped-increment solution equals the position QP of §9.4 solved by a QP solver."""
    robot = robot_params("hrp4")
    left = np.array([0.0, 0.09])
    plan = plan_footsteps(robot, WalkCommand(0.5, 0.1, 0.3), 5.0, left, -left)
    j = 5
    lo, hi = kinematic_box(robot, int(plan.side[j]))
    R = rotation(plan.yaw_rad[j - 1])
    # desired increment reconstructed from a deliberately infeasible one
    desired = R @ (hi + np.array([0.1, 0.05]))
    x = qpsolvers.solve_qp(np.eye(2), -desired, np.vstack([R.T, -R.T]), np.concatenate([hi, -lo]), solver="quadprog")
    np.testing.assert_allclose(x, R @ np.clip(R.T @ desired, lo, hi), atol=1e-9)


def test_planner_rejects_bad_input():
    """Non-finite commands and non-positive durations raise ParameterError."""
    robot = robot_params("g1")
    with pytest.raises(ParameterError):
        WalkCommand(float("nan"), 0.0, 0.0)
    with pytest.raises(ParameterError):
        plan_footsteps(robot, WalkCommand(0.1), -1.0, np.zeros(2), np.zeros(2))


def test_rotation_of_one_angle_and_of_many_agree():
    """``rotation`` of one yaw (the per-cycle fast path, also for numpy scalars) equals the same
    angle's matrix in a stack, turns x onto (cos, sin) and is orthonormal."""
    yaws = np.array([-3.0, -0.4, 0.0, 1e-4, 1.2, 3.1])
    stack = rotation(yaws)
    assert stack.shape == (6, 2, 2)
    for yaw, expected in zip(yaws, stack):
        for one in (float(yaw), yaw):  # a float and a numpy float64
            matrix = rotation(one)
            assert matrix.shape == (2, 2)
            np.testing.assert_allclose(matrix, expected, atol=1e-15)
            np.testing.assert_allclose(matrix @ [1.0, 0.0], [np.cos(yaw), np.sin(yaw)], atol=1e-15)
            np.testing.assert_allclose(matrix.T @ matrix, np.eye(2), atol=1e-15)
