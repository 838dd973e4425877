"""Closed-loop LIP walks: ZMP inside its box at every sample, CoM bounded, T-RO findings (spec §17)."""

import numpy as np
import pytest
from fixtures import walking_controller

from robust_ismpc.lip_sim import run_lip
from robust_ismpc.params import MpcParams, robot_params

WALKS = [
    ("hrp4", 0.3, 0.0, 0.0),
    ("g1", 0.3, 0.0, 0.0),
    ("hrp4", 0.1, 0.0, 0.3),
    ("g1", 0.1, 0.0, 0.3),
    ("hrp4", 0.0, 0.05, 0.0),
    ("g1", 0.0, 0.05, 0.0),
]


def _bounded_walk(controller, duration_s):
    outcome, rec = run_lip(controller, duration_s)
    trace = rec.finish(controller.plan, {})
    return outcome, trace


@pytest.mark.parametrize("robot,vx,vy,omega", WALKS)
def test_30s_walk_keeps_zmp_in_box_and_com_bounded(robot, vx, vy, omega):
    """30 s of walking: no infeasible QP, ZMP inside its box at every sample, CoM near the ZMP."""
    params = robot_params(robot)
    controller = walking_controller(robot, vx, vy, omega, duration_s=30.0)
    outcome, trace = _bounded_walk(controller, 30.0)
    assert not outcome.fell, outcome.failure
    assert np.nansum(trace["infeasible"]) == 0
    assert np.max(trace["zmp_violation_m"]) < 1e-9
    com_zmp = np.max(np.hypot(*(trace["com_m"] - trace["zmp_m"]).T))
    assert com_zmp < 0.5 * params.foot_spacing_m + params.kin_box_x_m
    # the walk goes where it was told (distance within 15 % of the commanded one for straight walks)
    if omega == 0.0:
        walked = trace["com_m"][-1] - trace["com_m"][0]
        start = controller.plan.ss_start_s[2]
        expected = np.array([vx, vy]) * (30.0 - start)
        assert np.linalg.norm(walked - expected) < 0.15 * np.linalg.norm(expected) + 0.05


def test_truncated_tail_loses_feasibility_where_anticipative_keeps_it():
    """T-RO §V-B3: short horizon, regular gait - truncated tail fails, anticipative tail walks on."""
    common = dict(control_horizon_s=0.5, preview_horizon_s=1.5, fix_footsteps=True)
    truncated = walking_controller("hrp4", 0.3, duration_s=15.0, mpc=MpcParams(tail="truncated", **common))
    out_t, _ = _bounded_walk(truncated, 15.0)
    anticipative = walking_controller("hrp4", 0.3, duration_s=15.0, mpc=MpcParams(tail="anticipative", **common))
    out_a, trace_a = _bounded_walk(anticipative, 15.0)
    assert out_t.fell and "infeasible" in out_t.failure
    assert not out_a.fell
    assert np.max(trace_a["zmp_violation_m"]) < 1e-9


def test_tall_robot_stays_bounded():
    """T-RO §VII: with CoM height 1.6 m IS-MPC keeps the CoM bounded with respect to the ZMP."""
    robot = robot_params("hrp4").with_values(com_height_m=1.6)
    mpc = MpcParams(control_horizon_s=1.5, preview_horizon_s=3.0)
    controller = walking_controller("hrp4", 0.3, duration_s=30.0, mpc=mpc, robot=robot)
    outcome, trace = _bounded_walk(controller, 30.0)
    assert not outcome.fell, outcome.failure
    assert np.max(np.abs(trace["com_m"] - trace["zmp_m"])) < 0.15
    # bounded, not drifting: the CoM-ZMP gap of the last 10 s is no larger than of the first 20 s
    t = trace["t_s"]
    gap = np.abs(trace["com_m"][:, 1] - trace["zmp_m"][:, 1])
    assert gap[t > 20].max() <= gap[t <= 20].max() + 1e-3
