"""The controller API refuses non-finite soles and times that do not advance (issue 17, case 9)."""

import math

import numpy as np
import pytest
from fixtures import straight_plan, walking_controller

from robust_ismpc.control.controller import IsmpcController
from robust_ismpc.control.robust import RobustIsmpcController
from robust_ismpc.core.params import robot_params
from robust_ismpc.core.planner import WalkCommand, plan_footsteps
from robust_ismpc.core.reference import Measurement
from robust_ismpc.exceptions import ParameterError

G1 = robot_params("g1")
BAD = [math.nan, math.inf, -math.inf]


def _measurement(**soles) -> Measurement:
    return Measurement(np.array([0.0, 0.0, G1.com_height_m]), np.zeros(3), np.zeros(2), **soles)


@pytest.mark.parametrize("bad", BAD)
@pytest.mark.parametrize("side", ["left_foot_m", "right_foot_m"])
def test_reset_refuses_non_finite_soles(bad, side):
    """reset() with a NaN or infinite initial sole raises ParameterError naming it."""
    controller = IsmpcController(G1)
    with pytest.raises(ParameterError, match=side):
        controller.reset(straight_plan(G1), np.zeros(2), **{side: np.array([0.0, bad])})


@pytest.mark.parametrize("bad", BAD)
def test_plan_refuses_non_finite_soles(bad):
    """plan_footsteps() with a NaN or infinite sole raises instead of planning NaN footsteps."""
    with pytest.raises(ParameterError, match="finite"):
        plan_footsteps(G1, WalkCommand(0.2), 5.0, np.array([bad, 0.1]), np.array([0.0, -0.1]))


def test_reset_refuses_a_plan_with_non_finite_footsteps():
    """reset() checks the plan's footsteps too (a plan built elsewhere)."""
    plan = straight_plan(G1)
    plan.pos_m[5, 0] = math.nan
    with pytest.raises(ParameterError, match="plan.pos_m"):
        IsmpcController(G1).reset(plan, np.zeros(2))


@pytest.mark.parametrize("bad", BAD)
@pytest.mark.parametrize("side", ["left_sole_m", "right_sole_m"])
def test_step_refuses_non_finite_measured_soles(bad, side):
    """A Measurement whose sole is NaN or infinite is refused; the model does not advance."""
    controller = walking_controller()
    state = controller.state.copy()
    with pytest.raises(ParameterError, match=side):
        controller.step(0.0, _measurement(**{side: np.array([bad, 0.0])}))
    np.testing.assert_array_equal(controller.state, state)


@pytest.mark.parametrize("cls", [IsmpcController, RobustIsmpcController])
def test_step_refuses_repeated_or_backward_times(cls):
    """step() at the time of the previous step, or before it, raises; the model does not advance."""
    controller = cls(G1)
    controller.reset(straight_plan(G1), np.zeros(2))
    controller.step(0.0)
    controller.step(0.01)
    state = controller.state.copy()
    for t in (0.01, 0.0, -1.0):
        with pytest.raises(ParameterError, match="does not come after"):
            controller.step(t)
    np.testing.assert_array_equal(controller.state, state)
    controller.step(0.02)  # forward again is fine


def test_reset_starts_the_clock_again():
    """After reset(), the first step may be at the reset time, but not before it."""
    controller = walking_controller()
    for k in range(3):
        controller.step(0.01 * k)
    controller.reset(straight_plan(G1), np.zeros(2), t_s=0.0)
    controller.step(0.0)
    controller.reset(straight_plan(G1), np.zeros(2), t_s=1.0)
    with pytest.raises(ParameterError):
        controller.step(0.5)
