"""A persistent force present from the first cycle, on the reduced model (issue: stand and start
under a force): the robust controller stands and starts where it used to turn infeasible within
half a second, and the ZMP centring cost is what returns a standing robot's DCM to its feet."""

import math

import numpy as np
import pytest

from robust_ismpc.control.modules import MODULES
from robust_ismpc.control.walk import make_controller, start_walk
from robust_ismpc.core.params import MpcParams, robot_params
from robust_ismpc.core.planner import WalkCommand
from robust_ismpc.runs.forces import ForceWindow, ramped_force, total_force
from robust_ismpc.runs.lip import run_lip

ROBOT = robot_params("g1")


def _stand(forces, modules=MODULES, vx=0.0, duration_s=10.0, centring=None):
    mpc = MpcParams() if centring is None else MpcParams(zmp_centring_weight=centring)
    controller = make_controller(ROBOT, mpc, modules)
    start_walk(controller, WalkCommand(vx), duration_s)
    outcome, recorder = run_lip(controller, duration_s, forces)
    return outcome, recorder.finish(controller.plan, {})


@pytest.mark.parametrize("fx_n, fy_n", [(10.0, 0.0), (-10.0, 0.0), (0.0, 30.0), (0.0, -30.0)])
def test_robust_stands_under_a_force_present_from_the_start(fx_n, fy_n):
    """G1 LIP, --vx 0: a force present from t = 0 (10 N sagittal, 3 % of the weight; 30 N
    lateral) is held for 10 s, and the robot leans against it: over the last two strides (it
    steps in place) the mean ZMP-CoM offset is the force's F/(m η²) within 10 %."""
    outcome, trace = _stand([ForceWindow(fx_n, fy_n)])
    assert not outcome.fell, outcome.failure
    last = trace["t_s"] >= 10.0 - 4 * ROBOT.T_step_s
    lean = np.mean(trace["zmp_m"][last] - trace["com_m"][last, :2], axis=0)
    expected = np.array([fx_n, fy_n]) / (ROBOT.mass_kg * ROBOT.eta**2)
    axis = 0 if fx_n else 1
    assert lean[axis] == pytest.approx(expected[axis], rel=0.1)


@pytest.mark.parametrize("fx_n, fy_n", [(10.0, 0.0), (0.0, 30.0)])
def test_nominal_falls_where_robust_stands(fx_n, fy_n):
    """The same forces turn nominal IS-MPC infeasible: it does not know them and cannot lean."""
    outcome, _ = _stand([ForceWindow(fx_n, fy_n)], modules=())
    assert outcome.fell


@pytest.mark.parametrize("fx_n", [20.0, -20.0])
def test_robust_steps_out_of_its_stance_under_a_force_its_feet_cannot_hold(fx_n):
    """G1 LIP, --vx 0, 20 N sagittal from t = 0: the DCM offset w/η² with the ZMP box's
    restriction leaves no standing solution within reach of the planned first step (2.6 s), so
    the first touchdown is brought forward, and the robot then stands (stepping in place) for
    10 s. Undisturbed, the start keeps its planned timing."""
    controller = make_controller(ROBOT, MpcParams(), MODULES)
    plan = start_walk(controller, WalkCommand(0.0), 10.0)
    planned = float(plan.touchdown_s[2])
    outcome, _ = run_lip(controller, 10.0, [ForceWindow(fx_n, 0.0)])
    assert not outcome.fell, outcome.failure
    assert plan.touchdown_s[2] < planned - 0.5
    undisturbed = make_controller(ROBOT, MpcParams(), MODULES)
    calm = start_walk(undisturbed, WalkCommand(0.0), 4.0)
    outcome, _ = run_lip(undisturbed, 4.0, [])
    assert not outcome.fell and calm.touchdown_s[2] == pytest.approx(planned)
    nominal, _ = _stand([ForceWindow(fx_n, 0.0)], modules=())
    assert nominal.fell


def test_robust_starts_walking_under_a_force_ramped_in_before_the_first_step():
    """G1 LIP at 0.2 m/s, 20 N forward ramped in over 1 s from t = 0.2 s (before the first single
    support at 2.1 s): the walk goes on for 12 s (was infeasible at 2.0 s with 10 N)."""
    outcome, trace = _stand(ramped_force(20.0, 0.0, 0.2, 1.0), vx=0.2, duration_s=12.0)
    assert not outcome.fell, outcome.failure
    assert trace["com_m"][-1, 0] > 1.5  # it walked, not only stood


def test_centring_returns_a_standing_robots_dcm_to_its_feet():
    """Standing under 15 N ramped in over 1 s, the start left as planned (no timing module, so
    the robot cannot step out of its stance): with the ZMP centring cost the ZMP ends within
    1 cm of the centre of the feet; with the paper's cost (γ = 0) the estimate's lag during the
    ramp pushes the DCM to the box edge and the QP turns infeasible."""
    forces = ramped_force(15.0, 0.0, 0.2, 1.0)
    modules = ("observer", "restriction")
    outcome, trace = _stand(forces, modules=modules, duration_s=6.0)
    assert not outcome.fell, outcome.failure
    assert abs(np.mean(trace["zmp_m"][trace["t_s"] >= 5.0, 0])) < 0.01
    unrestored, _ = _stand(forces, modules=modules, duration_s=6.0, centring=0.0)
    assert unrestored.fell and "infeasible" in unrestored.failure


def test_ramped_force_reaches_the_force_linearly():
    """ramped_force: nothing before its start, half of the force half-way, all of it after the
    ramp; a ramp of 0 is the force switched on."""
    windows = ramped_force(20.0, -4.0, 0.2, 1.0)
    np.testing.assert_allclose(total_force(windows, 0.19), [0.0, 0.0])
    np.testing.assert_allclose(total_force(windows, 0.2 + 0.5 - 1e-9), [10.0, -2.0])
    np.testing.assert_allclose(total_force(windows, 1.5), [20.0, -4.0])
    switched = ramped_force(5.0, 0.0, 3.0, 0.0)
    assert len(switched) == 1 and math.isclose(switched[0].t_start_s, 3.0) and switched[0].fx_n == 5.0
