"""Canonical fixtures shared by the test modules (import from here; no setup pasted between files)."""

from __future__ import annotations

import numpy as np

from robust_ismpc.control.controller import IsmpcController
from robust_ismpc.core.params import MpcParams, RobotParams, robot_params
from robust_ismpc.core.planner import WalkCommand, plan_footsteps


def straight_plan(robot: RobotParams, vx: float = 0.2, vy: float = 0.0, omega: float = 0.0, duration_s: float = 12.0):
    """Candidate plan for a walk from rest with feet ℓ apart about the origin."""
    left = np.array([0.0, 0.5 * robot.foot_spacing_m])
    return plan_footsteps(robot, WalkCommand(vx, vy, omega), duration_s, left, -left)


def walking_controller(name: str = "g1", vx: float = 0.2, vy: float = 0.0, omega: float = 0.0,
                       duration_s: float = 10.0, mpc: MpcParams | None = None, robot: RobotParams | None = None):
    """A nominal controller reset at rest on a plan long enough for ``duration_s`` plus the preview."""
    robot = robot if robot is not None else robot_params(name)
    mpc = mpc if mpc is not None else MpcParams()
    plan = straight_plan(robot, vx, vy, omega, duration_s + mpc.preview_horizon_s + 1.0)
    controller = IsmpcController(robot, mpc)
    controller.reset(plan, np.zeros(2))
    return controller
