"""The swing leg's CoP shift over the MPC horizon (robust_ismpc.core.swing_cop) and its ZMP constraint."""

from dataclasses import replace

import numpy as np
import pytest
from fixtures import straight_plan

from robust_ismpc.control.controller import IsmpcController
from robust_ismpc.control.robust import RobustIsmpcController
from robust_ismpc.core.footsteps import LEFT
from robust_ismpc.core.mpc import IsmpcQp, MpcState
from robust_ismpc.core.params import MpcParams, robot_params
from robust_ismpc.core.swing import SwingState, quintic_step
from robust_ismpc.core.swing_cop import quintic_acceleration, swing_acceleration, swing_cop_offset
from robust_ismpc.exceptions import InfeasibleMpc, ParameterError

KAPPA_S2 = 0.006  # G1's measured value (docs/robots.md)


@pytest.fixture
def robot():
    return robot_params("g1")


def test_quintic_acceleration_is_the_swing_quintics_second_derivative():
    """Matches swing.quintic_step's acceleration and the finite second difference of its position."""
    p0, v0, a0 = np.array([0.1, -0.2]), np.array([0.3, 0.05]), np.array([-1.0, 2.0])
    p1, T = np.array([0.4, -0.1]), 0.37
    tau = np.linspace(0.0, T - 1e-3, 25)
    acc = quintic_acceleration(p0, v0, a0, p1, T, tau)
    for k, t in enumerate(tau):
        np.testing.assert_allclose(acc[k], quintic_step(p0, v0, a0, p1, T, t)[2], atol=1e-9)
    h = 1e-4
    pos = [quintic_step(p0, v0, a0, p1, T, t)[0] for t in (0.1 - h, 0.1, 0.1 + h)]
    np.testing.assert_allclose(quintic_acceleration(p0, v0, a0, p1, T, np.array([0.1]))[0],
                               (pos[0] - 2 * pos[1] + pos[2]) / h**2, atol=1e-4)
    assert np.all(quintic_acceleration(p0, v0, a0, p1, T, np.array([T, T + 0.1])) == 0.0)


def test_planned_swings_integrate_to_their_footstep_displacement(robot):
    """Later swings are rest-to-rest: zero acceleration in double support, and the acceleration
    integrated twice over each single support equals the footstep two steps back to this one."""
    plan = straight_plan(robot, 0.2, duration_s=12.0)
    feet = {LEFT: SwingState.at_rest(plan.pos_m[1], 0.0), -LEFT: SwingState.at_rest(-plan.pos_m[1], 0.0)}
    dt = 1e-4
    j = 4
    t0 = float(plan.ss_start_s[j])
    times = np.arange(t0, float(plan.touchdown_s[j] + plan.T_ds_s[j]) - 1e-9, dt)
    acc = swing_acceleration(plan, 0.0, times, feet)  # seen from t = 0: step j is a later swing
    in_ds = times >= plan.touchdown_s[j]
    assert np.all(acc[in_ds] == 0.0)
    vel = np.cumsum(acc, axis=0) * dt
    disp = np.sum(vel, axis=0) * dt
    np.testing.assert_allclose(disp, plan.pos_m[j] - plan.pos_m[j - 2], atol=2e-4)
    np.testing.assert_allclose(vel[-1], 0.0, atol=1e-6)


def test_the_swing_under_way_continues_from_the_foots_state(robot):
    """During a swing the prediction is the quintic from the foot's current state to its footstep."""
    plan = straight_plan(robot, 0.2, duration_s=12.0)
    j = 3
    t = float(plan.ss_start_s[j]) + 0.2
    side = int(plan.side[j])
    moving = SwingState(pos_m=np.array([0.05, 0.1, 0.02]), vel_mps=np.array([0.4, 0.0, 0.0]),
                        acc_mps2=np.array([1.5, -0.2, 0.0]), yaw_rad=0.0)
    feet = {side: moving, -side: SwingState.at_rest(plan.pos_m[j - 1], 0.0)}
    times = t + 0.01 * np.arange(1, 11)
    rem = float(plan.touchdown_s[j] - t)
    expected = quintic_acceleration(moving.pos_m[:2], moving.vel_mps[:2], moving.acc_mps2[:2], plan.pos_m[j], rem,
                                    times - t)
    np.testing.assert_allclose(swing_acceleration(plan, t, times, feet), expected, atol=1e-12)


@pytest.mark.parametrize("vx, vy", [(0.2, 0.0), (0.0, 0.1)], ids=["forward", "sideways"])
def test_cop_offset_is_kappa_times_the_forward_swing_acceleration(robot, vx, vy):
    """Walking forward the offset is κ a along x; walking sideways (lateral swings only) it is 0."""
    plan = straight_plan(robot, vx, vy, duration_s=12.0)
    feet = {LEFT: SwingState.at_rest(plan.pos_m[1], 0.0), -LEFT: SwingState.at_rest(-plan.pos_m[1], 0.0)}
    times = 3.0 + 0.01 * np.arange(1, 101)
    acc = swing_acceleration(plan, 3.0, times, feet)
    offset = swing_cop_offset(plan, 3.0, times, feet, KAPPA_S2)
    assert np.abs(acc).max() > 0.5  # the swing feet do move in this window
    np.testing.assert_allclose(offset[:, 0], KAPPA_S2 * acc[:, 0], atol=1e-12)
    np.testing.assert_allclose(offset[:, 1], 0.0, atol=1e-12)


def test_zmp_offset_moves_the_box_rows_by_the_offset(robot):
    """The box rows bound p + offset - centre: the offset shifts both bounds by -offset."""
    plan = straight_plan(robot, 0.2, duration_s=12.0)
    controller = IsmpcController(robot, MpcParams())
    controller.reset(plan, np.zeros(2))
    state = controller._mpc_state(0.0, None)
    qp = IsmpcQp(robot, MpcParams())
    offset = np.random.default_rng(1).normal(scale=0.01, size=(qp.C, 2))
    plain = [p.copy() for p in qp.build(plan, state)[0]]
    shifted = qp.build(plan, state, zmp_offset_m=offset)[0]
    for axis in range(2):
        np.testing.assert_allclose(shifted[axis].lower[: qp.C], plain[axis].lower[: qp.C] - offset[:, axis])
        np.testing.assert_allclose(shifted[axis].upper[: qp.C], plain[axis].upper[: qp.C] - offset[:, axis])


def test_controller_keeps_the_robots_cop_not_the_lip_zmp_in_the_box(robot):
    """With κ > 0, planned ZMP + κ × swing acceleration stays in the box at every horizon row, and
    the planned ZMP alone leaves it where the swing foot accelerates (the constraint is active)."""
    walking = replace(robot, swing_cop_gain_s2=0.02)  # large κ, so that the box constraint binds
    plan = straight_plan(walking, 0.2, duration_s=10.0)
    controller = IsmpcController(walking, MpcParams())
    controller.reset(plan, np.zeros(2))
    worst_cop = worst_zmp = 0.0
    for k in range(400):
        t = k * 0.01
        state = controller._mpc_state(t, None)
        offset = controller._swing_cop_offset(t)
        result = controller.qp.solve(controller.plan, state, None, offset)
        zmp = state.zmp_m + controller.qp.integrator @ result.zmp_vel_mps
        times = t + controller.qp.horizon_offsets_s
        # The rows' box centres with the optimal footsteps in place.
        positions = controller.plan.pos_m.copy()
        positions[result.footstep_indices] = result.footsteps_m
        centre = controller.plan.centre(times, positions)
        half = controller.plan.box_half(times)
        worst_cop = max(worst_cop, float(np.max(np.abs(zmp + offset - centre) - half)))
        worst_zmp = max(worst_zmp, float(np.max(np.abs(zmp - centre) - half)))
        controller.step(t)
    assert worst_cop < 1e-6
    assert worst_zmp > 0.005


def _qp_feasibility_edge(qp, plan, state, offset, axis, inside_m, outside_m, iterations=32):
    """Bisection for the edge of the QP's feasible DCMs along ``axis`` (world) [m]."""
    for _ in range(iterations):
        middle = 0.5 * (inside_m + outside_m)
        dcm = state.dcm_m.copy()
        dcm[axis] = middle
        try:
            qp.solve(plan, MpcState(t_s=state.t_s, dcm_m=dcm, zmp_m=state.zmp_m), None, offset)
            inside_m = middle
        except InfeasibleMpc:
            outside_m = middle
    return 0.5 * (inside_m + outside_m)


@pytest.mark.parametrize("fix_footsteps", [False, True], ids=["free footsteps", "fixed footsteps"])
def test_robust_feasibility_bounds_are_the_qps_with_the_swing_cop_offset(robot, fix_footsteps):
    """With κ > 0 the QP bounds p + κ a, and the feasibility bounds that the governor and the
    timing check use move with it: they equal the DCMs for which the QP (with the offset) has a
    solution, found by bisection, to 1e-7 m, also in the last ``footstep_freeze_s`` before
    touchdown, where the QP holds the landing footstep fixed; the bounds without the move are off
    by over 5 mm. Likewise with every footstep fixed (``MpcParams.fix_footsteps``)."""
    walking = replace(robot, swing_cop_gain_s2=KAPPA_S2, zmp_box_x_m=0.12)  # G1's [gait] values
    plan = straight_plan(walking, 0.2, duration_s=12.0)
    mpc = MpcParams(fix_footsteps=fix_footsteps)
    controller = RobustIsmpcController(walking, mpc, modules=("timing",))
    controller.reset(plan, np.zeros(2))
    probe = IsmpcQp(walking, mpc)  # its own solver: infeasible probes do not touch the controller's
    worst = worst_unshifted = 0.0
    checked = frozen = 0
    t = 0.0
    for k in range(560):
        controller.step(t)
        t = round(t + 0.01, 9)
        j = plan.step_at(t)
        if k < 250 or k % 9 or t >= plan.touchdown_s[j] - 1e-9:
            continue  # single support of steps 4-7, every 9th tick (the phase drifts by 0.02 s per step)
        state = controller._mpc_state(t, None)
        bounds_x, bounds_y, _, origin = controller._current_bounds(t, j, state, plan.touchdown_s[j] - t)
        offset = controller._swing_cop_offset(t)
        shift = controller._cop_shift_m(t)
        for axis, bounds in enumerate((bounds_x, bounds_y)):
            for side, bound in zip((-1.0, 1.0), bounds):
                edge = _qp_feasibility_edge(probe, plan, state, offset, axis, state.dcm_m[axis],
                                            origin[axis] + bound + side * 0.05) - origin[axis]
                worst = max(worst, abs(edge - bound))
                worst_unshifted = max(worst_unshifted, abs(edge - (bound + shift[axis])))
        checked += 1
        frozen += controller._landing_footstep_frozen(t, j)
    assert checked >= 15 and frozen >= 2
    assert worst < 1e-7
    assert worst_unshifted > 0.005


def test_negative_swing_cop_gain_is_refused(robot):
    with pytest.raises(ParameterError, match="swing_cop_gain_s2"):
        replace(robot, swing_cop_gain_s2=-0.01)


def test_g1s_swing_cop_gain_is_a_robot_constant():
    """Measured on G1's whole-body reference motion (inverse dynamics, no physics): the forward CoP
    deviation from the LIP's ZMP is mostly κ × the swing foot's acceleration, and κ does not depend
    on the walking speed (the value in g1.toml)."""
    pytest.importorskip("mujoco")
    pytest.importorskip("mink")
    from robust_ismpc.core.planner import WalkCommand
    from robust_ismpc.sim.calibrate import fit_swing_cop_gain
    from robust_ismpc.sim.model import load_robot

    fast = fit_swing_cop_gain("g1", WalkCommand(0.2))
    slow = fit_swing_cop_gain("g1", WalkCommand(0.1))
    assert fast.rms_before_m > 0.02  # the swing leg moves the CoP by centimetres
    assert fast.rms_after_m < 0.3 * fast.rms_before_m
    assert slow.gain_s2 == pytest.approx(fast.gain_s2, rel=0.1)
    assert load_robot("g1").params().swing_cop_gain_s2 == pytest.approx(fast.gain_s2, rel=0.1)


def test_calibration_refuses_a_walk_without_forward_swings():
    """Stepping in place gives no forward swing acceleration to fit κ on: a clear error, no κ."""
    pytest.importorskip("mujoco")
    pytest.importorskip("mink")
    from robust_ismpc.core.planner import WalkCommand
    from robust_ismpc.sim.calibrate import fit_swing_cop_gain

    with pytest.raises(ParameterError, match="no forward swing motion"):
        fit_swing_cop_gain("g1", WalkCommand(0.0), duration_s=4.0)
    with pytest.raises(ParameterError, match="duration_s > settle_s"):
        fit_swing_cop_gain("g1", duration_s=0.5, settle_s=1.0)
