"""Table-driven bad input through the Python API: each raises our own exception naming the value."""

import math

import numpy as np
import pytest

from robust_ismpc.control.controller import IsmpcController
from robust_ismpc.control.robust import RobustIsmpcController, RobustParams
from robust_ismpc.core.params import MpcParams, robot_params
from robust_ismpc.core.planner import WalkCommand, plan_footsteps
from robust_ismpc.core.reference import Measurement
from robust_ismpc.exceptions import ControllerFailure, IsmpcError, ParameterError
from robust_ismpc.runs.forces import ForceWindow, parse_force, parse_push
from robust_ismpc.runs.spec import RunSpec

G1 = robot_params("g1")

CASES = [
    ("NaN CoM height", lambda: G1.with_values(com_height_m=math.nan), "com_height_m"),
    ("zero CoM height", lambda: G1.with_values(com_height_m=0.0), "com_height_m"),
    ("negative mass", lambda: G1.with_values(mass_kg=-1.0), "mass_kg"),
    ("zero foot size", lambda: G1.with_values(sole_length_m=0.0), "sole_length_m"),
    ("ZMP box larger than sole", lambda: G1.with_values(zmp_box_x_m=0.5), "must fit inside the sole"),
    ("negative single support", lambda: G1.with_values(T_ss_s=-0.1), "T_ss_s"),
    ("zero double support", lambda: G1.with_values(T_ds_s=0.0), "T_ds_s"),
    ("NaN sampling period", lambda: MpcParams(sampling_period_s=math.nan), "sampling_period_s"),
    ("preview shorter than control horizon", lambda: MpcParams(preview_horizon_s=0.5), "preview_horizon_s"),
    ("horizon not a multiple of δ", lambda: MpcParams(control_horizon_s=1.005), "whole multiple"),
    ("unknown tail", lambda: MpcParams(tail="magic"), "anticipative"),
    ("control horizon shorter than one step",
     lambda: IsmpcController(G1, MpcParams(control_horizon_s=0.5, preview_horizon_s=2.0)), "shorter than one step"),
    ("estimator of the wrong type", lambda: IsmpcController(G1, estimator=(0.01, 0.1, 1.0)), "estimator"),
    ("unguaranteeable Δmax", lambda: RobustIsmpcController(G1, modules=("restriction",), delta_max_mps2=2.0),
     "largest guaranteed delta_max"),
    ("unknown module", lambda: RobustIsmpcController(G1, modules=("telepathy",)), "unknown module 'telepathy'"),
    ("unknown robot", lambda: robot_params("asimo"), "built-in robots are: g1, hrp4, nao, op3"),
    ("unknown simulator", lambda: RunSpec(sim="gazebo"), "unknown simulator"),
    ("negative duration", lambda: RunSpec(duration_s=-1.0), "duration"),
    ("negative seed", lambda: RunSpec(seed=-3), "seed"),
    ("NaN command", lambda: WalkCommand(0.1, math.nan), "vy_mps"),
    ("non-positive plan duration", lambda: plan_footsteps(G1, WalkCommand(), 0.0, np.zeros(2), np.zeros(2)), "duration_s"),
    ("force with one number", lambda: parse_force("10"), "expected 2"),
    ("force with text", lambda: parse_force("a,b@1:2"), "not a list of numbers"),
    ("force window reversed", lambda: parse_force("1,0@3:2"), "after its start"),
    ("push without duration", lambda: parse_push("1,0@3"), "FX,FY@T:DUR"),
    ("push with zero duration", lambda: parse_push("1,0@3:0"), "duration must be > 0"),
    ("force starting before 0", lambda: ForceWindow(1.0, 0.0, -1.0, 1.0), "t_start_s"),
    ("step before reset", lambda: IsmpcController(G1).step(0.0), "reset()"),
    ("negative disturbance time constant", lambda: RobustParams(disturbance_time_constant_s=-1.0),
     "disturbance_time_constant_s"),
]


@pytest.mark.parametrize("name,make,message", CASES, ids=[c[0] for c in CASES])
def test_bad_value_raises_our_exception(name, make, message):
    """The call raises an IsmpcError (ParameterError) whose one-line message names the problem."""
    with pytest.raises(IsmpcError) as info:
        make()
    assert isinstance(info.value, ParameterError)
    text = str(info.value)
    assert message in text and "\n" not in text


def test_nan_measurement_is_a_reported_controller_failure():
    """A NaN in the measurement stops the controller with reason 'bad_measurement'."""
    controller = IsmpcController(G1)
    left = np.array([0.0, 0.1])
    controller.reset(plan_footsteps(G1, WalkCommand(0.1), 8.0, left, -left), np.zeros(2))
    with pytest.raises(ControllerFailure) as info:
        controller.step(0.0, Measurement(np.array([np.nan, 0.0, 0.6]), np.zeros(3), np.zeros(2)))
    assert info.value.reason == "bad_measurement"
