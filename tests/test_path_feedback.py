"""Feedback of where the feet land (``IsmpcController(path_feedback_gain=...)``).

A robot whose plan runs on the controller's internal model realises each footstep *relative to
its real stance foot*; if it puts every foot a little to one side, the error adds up step after
step. The feedback moves the later footsteps against the lateral landing error.
"""

import numpy as np
import pytest

from robust_ismpc.controller import IsmpcController
from robust_ismpc.exceptions import ParameterError
from robust_ismpc.footsteps import LEFT
from robust_ismpc.params import MpcParams, robot_params
from robust_ismpc.planner import WalkCommand, plan_footsteps
from robust_ismpc.reference import Measurement

ROBOT = robot_params("g1")
BIAS_M = np.array([0.0, 0.015])  # every foot lands 1.5 cm left of where the plan put it, relative to the stance foot


def _biased_walk(gain: float, duration_s: float = 14.0) -> np.ndarray:
    """Walk forward on the internal model while a biased 'robot' places its feet; returns the
    lateral distance [m] of each landed real sole from where the plan put that footstep before
    the feedback moved it (the plan's own footstep choices are not errors)."""
    controller = IsmpcController(ROBOT, MpcParams(), state_feedback_gain=0.0, anchor_landed_footsteps=False,
                                 path_feedback_gain=gain)
    left, right = np.array([0.0, 0.1]), np.array([0.0, -0.1])
    plan = plan_footsteps(ROBOT, WalkCommand(0.2), duration_s + 3.0, left, right)
    controller.reset(plan, np.zeros(2), left_foot_m=left, right_foot_m=right)
    real = {LEFT: left.copy(), -LEFT: right.copy()}
    landed = 1
    errors = []
    for k in range(int(round(duration_s / controller.dt))):
        t = k * controller.dt
        j = plan.step_at(t)
        if j > landed and t >= plan.touchdown_s[j] - 1e-9:
            side = int(plan.side[j])
            # the real foot: the planned step relative to the real stance foot, plus the bias
            real[side] = real[-side] + (plan.pos_m[j] - plan.pos_m[j - 1]) + BIAS_M
            errors.append(real[side][1] - (plan.pos_m[j][1] + controller.path_shift_m[1]))
            landed = j
        x_c, v_c, _ = controller.state
        controller.step(t, Measurement(np.append(x_c, 0.6), np.append(v_c, 0.0),
                                       left_sole_m=real[LEFT].copy(), right_sole_m=real[-LEFT].copy()))
    return np.array(errors)


def test_without_feedback_the_landing_bias_adds_up():
    """Gain 0: after n steps the real feet are about n times the bias off the planned path."""
    errors = _biased_walk(0.0)
    assert len(errors) > 15
    np.testing.assert_allclose(errors, BIAS_M[1] * np.arange(1, len(errors) + 1), atol=1e-9)


@pytest.mark.parametrize("gain", [0.5, 0.7, 1.0])
def test_feedback_holds_the_feet_near_the_path(gain):
    """With the feedback the error settles at bias / gain (the steady state of
    e' = (1 - gain) e + bias), instead of growing."""
    errors = _biased_walk(gain)
    assert np.max(np.abs(errors)) <= BIAS_M[1] / gain + 1e-6
    assert abs(errors[-1] - BIAS_M[1] / gain) < 0.1 * BIAS_M[1] / gain


@pytest.mark.parametrize("kwargs, message", [
    ({"path_feedback_gain": 1.5, "anchor_landed_footsteps": False}, "path_feedback_gain must be in"),
    ({"path_feedback_gain": 0.5, "anchor_landed_footsteps": False, "path_feedback_max_m": 0.0}, "path_feedback_max_m"),
    ({"path_feedback_gain": 0.5}, "needs anchor_landed_footsteps=False"),
])
def test_bad_path_feedback_settings_raise(kwargs, message):
    with pytest.raises(ParameterError, match=message):
        IsmpcController(ROBOT, MpcParams(), **kwargs)
