"""Tests of the IS-MPC QP: constraint rows, optimality, solver agreement, infeasibility (spec §4-§7)."""

import numpy as np
import pytest
from fixtures import straight_plan

from robust_ismpc.control.controller import IsmpcController
from robust_ismpc.core.layout import QpLayout
from robust_ismpc.core.mpc import IsmpcQp, MpcState
from robust_ismpc.core.params import MpcParams, robot_params
from robust_ismpc.core.qp import DaqpSolver, QpsolversSolver
from robust_ismpc.exceptions import InfeasibleMpc


@pytest.fixture
def robot():
    return robot_params("g1")


def _midstep_state(plan, robot):
    """A feasible state inside the single support of step 3: run the controller open loop there."""
    mpc = MpcParams()
    controller = IsmpcController(robot, mpc)
    controller.reset(plan, np.zeros(2))
    t_target = float(plan.ss_start_s[3] + 0.1)
    for k in range(int(round(t_target / mpc.sampling_period_s))):
        controller.step(k * mpc.sampling_period_s)
    t = int(round(t_target / mpc.sampling_period_s)) * mpc.sampling_period_s
    return controller._mpc_state(t, None)


def test_zmp_rows_measure_zmp_minus_box_centre(robot):
    """Row i of the ZMP block applied to (u, f) plus the known offset equals x_z^{k+i+1} - c(t_{k+i+1})."""
    plan = straight_plan(robot, 0.3, duration_s=12.0)
    qp = IsmpcQp(robot, MpcParams())
    state = _midstep_state(plan, robot)
    problems, layout, hf = qp.build(plan, state)
    rng = np.random.default_rng(0)
    u = 0.05 * rng.normal(size=layout.C)
    f = plan.candidate_pos_m[hf.first_free : hf.first_free + layout.F, 0] + 0.01 * rng.normal(size=layout.F)
    z = np.concatenate([np.linalg.solve(qp.zmp_vel_basis, u), f])  # the QP's ZMP variables y: u = basis @ y
    A, lower = problems[0].A, problems[0].lower
    row_value = A[: layout.C] @ z
    # lower = -d/2 - offset  =>  offset = -d/2 - lower
    offset = -0.5 * robot.zmp_box_x_m - lower[: layout.C]
    positions = plan.pos_m.copy()
    positions[hf.first_free : hf.first_free + layout.F, 0] = f
    times = state.t_s + qp.horizon_offsets_s
    zmp = state.zmp_m[0] + qp.dt * np.cumsum(u)
    np.testing.assert_allclose(row_value + offset, zmp - plan.centre(times, positions)[:, 0], atol=1e-12)


def test_zmp_boundary_point_passes_and_outside_fails(robot):
    """A ZMP trajectory on the box edge satisfies the rows; 1 mm further violates them."""
    plan = straight_plan(robot, 0.0, duration_s=12.0)
    qp = IsmpcQp(robot, MpcParams(fix_footsteps=True))
    t = float(plan.ss_start_s[3] + 0.05)
    edge = plan.centre(np.array([t]))[0, 0] + 0.5 * robot.zmp_box_x_m
    problems, layout, _ = qp.build(plan, MpcState(t, np.zeros(2), np.array([edge, 0.0])))
    p = problems[0].copy()
    zmp_rows = slice(0, layout.C)
    u = np.zeros(layout.C)  # ZMP stays on the front edge while the support does not move
    still = np.abs(plan.centre(t + qp.horizon_offsets_s)[:, 0] - plan.centre(np.array([t]))[0, 0]) < 1e-12
    values = p.A[zmp_rows] @ u
    assert np.all(values[still] <= p.upper[zmp_rows][still] + 1e-12)
    assert np.all(values[still] >= p.lower[zmp_rows][still] - 1e-12)
    problems2, _, _ = qp.build(plan, MpcState(t, np.zeros(2), np.array([edge + 1e-3, 0.0])))
    p2 = problems2[0]
    assert np.all(p2.A[zmp_rows][still] @ u > p2.upper[zmp_rows][still])


def test_kinematic_rows_alternate_sides(robot):
    """The lateral kinematic bounds of successive free footsteps alternate around ±ℓ."""
    plan = straight_plan(robot, 0.2, duration_s=12.0)
    qp = IsmpcQp(robot, MpcParams(control_horizon_s=1.6, preview_horizon_s=2.5))
    state = _midstep_state(plan, robot)
    problems, layout, hf = qp.build(plan, state)
    assert layout.F >= 2
    py = problems[1]
    kin = slice(layout.C, layout.C + layout.F)
    sides = plan.side[hf.first_free : hf.first_free + layout.F]
    # first free footstep: bounds relative to the known support foot
    support_y = plan.pos_m[hf.first_free - 1, 1]
    mid = 0.5 * (py.lower[kin][0] + py.upper[kin][0]) - support_y
    assert mid == pytest.approx(sides[0] * robot.foot_spacing_m)
    mids = 0.5 * (py.lower[kin][1:] + py.upper[kin][1:])
    np.testing.assert_allclose(mids, sides[1:] * robot.foot_spacing_m)
    assert np.all(np.diff(sides) != 0)
    # a footstep exactly on the outer kinematic edge passes, 1 mm beyond fails
    z = np.zeros(layout.n)
    z[layout.footsteps()] = plan.pos_m[hf.first_free - 1, 1] + py.upper[kin][0] - support_y
    z[layout.C + 1 :] = 0.0
    assert py.A[kin][0] @ z <= py.upper[kin][0] + 1e-12
    z[layout.C] += 1e-3
    assert py.A[kin][0] @ z > py.upper[kin][0]


@pytest.mark.parametrize("omega", [0.0, 0.3])
def test_daqp_solution_is_optimal_and_matches_quadprog(robot, omega):
    """DAQP and quadprog return the same minimiser; it satisfies the constraints and beats perturbations."""
    plan = straight_plan(robot, 0.2, omega=omega, duration_s=12.0)
    qp = IsmpcQp(robot, MpcParams())
    state = _midstep_state(plan, robot)
    problems, layout, _ = qp.build(plan, state)
    assert layout.coupled == (omega != 0.0)
    rng = np.random.default_rng(5)
    for p in problems:
        x1 = DaqpSolver().solve(p).x
        x2 = QpsolversSolver("quadprog").solve(p).x
        np.testing.assert_allclose(x1, x2, atol=1e-6)
        assert p.violation(x1) < 1e-8
        # feasible perturbations inside the null space of the equalities cannot lower the cost
        eq = p.A[p.equality]
        _, _, vt = np.linalg.svd(eq)
        null = vt[eq.shape[0] :].T
        for _ in range(20):
            d = null @ rng.normal(size=null.shape[1]) * 1e-4
            if p.violation(x1 + d) == 0.0:
                assert p.objective(x1 + d) >= p.objective(x1) - 1e-12



@pytest.mark.parametrize("omega", [0.0, 0.3])
@pytest.mark.parametrize("heading_rad", [0.0, 0.7])
def test_cost_is_velocity_centring_and_footstep_deviation(robot, omega, heading_rad):
    """For random decisions the QP's objective equals, up to a constant, the cost stated in the
    world frame: ½‖Ẋ_z‖² + ½γ‖X_z − X_c‖² + ½β‖X_f − X̂_f‖², with X_c the box centres of the plan's
    footsteps (the free ones where the last optimum put them), on both axes (per-axis problems in
    a rotated frame, and coupled ones)."""
    plan = straight_plan(robot, 0.2, omega=omega, duration_s=12.0)
    if heading_rad:
        c, s = np.cos(heading_rad), np.sin(heading_rad)
        R = np.array([[c, -s], [s, c]])
        plan.pos_m[:] = plan.pos_m @ R.T
        plan.candidate_pos_m[:] = plan.candidate_pos_m @ R.T
        plan.yaw_rad[:] += heading_rad
    mpc = MpcParams()
    qp = IsmpcQp(robot, mpc)
    state = _midstep_state(plan, robot)
    state = MpcState(state.t_s, state.dcm_m, state.zmp_m + np.array([0.004, -0.003]))
    first_free = qp.horizon_footsteps(plan, state.t_s).first_free
    plan.pos_m[first_free:] += 0.01  # the last optimum, away from the candidates
    problems, layout, hf = qp.build(plan, state)
    assert layout.F > 0 and layout.coupled == (omega != 0.0)
    free = np.arange(hf.first_free, hf.first_free + layout.F)
    times = state.t_s + qp.horizon_offsets_s
    rng = np.random.default_rng(3)

    def stated(u_world, f_world):
        zmp = state.zmp_m + qp.dt * np.cumsum(u_world, axis=0)
        off = zmp - plan.centre(times, plan.pos_m)
        dev = f_world - plan.candidate_pos_m[free]
        return 0.5 * np.sum(u_world**2) + 0.5 * mpc.zmp_centring_weight * np.sum(off**2) \
            + 0.5 * mpc.footstep_weight * np.sum(dev**2)

    def objective(u_world, f_world):  # the QP's ZMP variables are y, with Ẋ_z = basis @ y
        if layout.coupled:
            y = np.linalg.solve(qp.zmp_vel_basis, u_world)
            x = np.concatenate([np.concatenate([y[:, a], f_world[:, a]]) for a in range(2)])
            return problems[0].objective(x)
        y, f = np.linalg.solve(qp.zmp_vel_basis, layout.to_frame(u_world)), layout.to_frame(f_world)
        return sum(p.objective(np.concatenate([y[:, a], f[:, a]])) for a, p in enumerate(problems))

    samples = [(0.05 * rng.normal(size=(layout.C, 2)), plan.candidate_pos_m[free] + 0.02 * rng.normal(size=(layout.F, 2)))
               for _ in range(4)]
    differences = [stated(u, f) - objective(u, f) for u, f in samples]
    np.testing.assert_allclose(differences, differences[0], rtol=0, atol=1e-7 * abs(stated(*samples[0])))


def test_infeasible_qp_raises_with_problem(robot):
    """A DCM far outside the feasibility region raises InfeasibleMpc carrying the QP."""
    plan = straight_plan(robot, 0.2, duration_s=12.0)
    qp = IsmpcQp(robot, MpcParams())
    state = _midstep_state(plan, robot)
    bad = MpcState(state.t_s, state.dcm_m + np.array([0.0, 0.5]), state.zmp_m)
    with pytest.raises(InfeasibleMpc) as info:
        qp.solve(plan, bad)
    assert info.value.problem is not None and info.value.problem.A.shape[1] > 0


@pytest.mark.parametrize("heading_rad", [0.4, -2.0, 1e-4])
def test_a_straight_walk_in_any_heading_solves_per_axis_in_its_frame(robot, heading_rad):
    """All boxes of the horizon share one yaw: the QP splits into two per-axis QPs in that frame,
    and its solution is the heading-0 solution rotated (ZMP velocities and footsteps)."""
    from robust_ismpc.core.planner import WalkCommand, plan_footsteps
    from robust_ismpc.exceptions import InfeasibleMpc

    c, s = np.cos(heading_rad), np.sin(heading_rad)
    rot = np.array([[c, -s], [s, c]])
    left = np.array([0.0, 0.5 * robot.foot_spacing_m])
    turned = plan_footsteps(robot, WalkCommand(0.2), 12.0, rot @ left, -(rot @ left), heading_rad)
    straight = plan_footsteps(robot, WalkCommand(0.2), 12.0, left, -left, 0.0)
    qp = IsmpcQp(robot, MpcParams())
    compared = 0
    for t in np.arange(turned.ss_start_s[1], 8.0, 0.037):
        centre = straight.centre(np.array([t]))[0]
        state0 = MpcState(t, centre + np.array([0.01, 0.0]), centre)
        state = MpcState(t, rot @ state0.dcm_m, rot @ state0.zmp_m)
        assert not qp.build(turned, state)[1].coupled
        try:
            expected = qp.solve(straight, state0)
        except InfeasibleMpc:
            continue
        got = qp.solve(turned, state)
        np.testing.assert_allclose(got.zmp_vel_mps, expected.zmp_vel_mps @ rot.T, atol=1e-9)
        np.testing.assert_allclose(got.footsteps_m, expected.footsteps_m @ rot.T, atol=1e-9)
        compared += 1
    assert compared > 50


class _CountingSolver(DaqpSolver):
    """DAQP that counts its solves (an operation count: the speed regression check of CI)."""

    def __init__(self):
        super().__init__()
        self.solves = 0

    def solve(self, problem):
        self.solves += 1
        return super().solve(problem)


@pytest.mark.parametrize("omega", [0.0, 0.3])
def test_qp_solves_per_cycle(robot, omega):
    """Each cycle of an undisturbed walk solves two per-axis QPs, or one coupled QP while the
    boxes of its horizon turn; none solves more (no retries, no fallbacks). A straight walk never
    couples its axes."""
    from robust_ismpc.control.walk import make_controller, start_walk
    from robust_ismpc.core.planner import WalkCommand
    from robust_ismpc.runs.lip import run_lip

    solver = _CountingSolver()
    controller = make_controller(robot, MpcParams(), solver=solver)
    start_walk(controller, WalkCommand(0.2, 0.0, omega), 6.0)
    coupled = []
    solve = controller.qp.solve

    def recording_solve(*args, **kwargs):
        plan = solve(*args, **kwargs)
        coupled.append(plan.coupled)
        return plan

    controller.qp.solve = recording_solve
    outcome, _ = run_lip(controller, 6.0)
    assert not outcome.fell
    assert len(coupled) == int(round(6.0 / controller.dt))
    assert solver.solves == sum(1 if c else 2 for c in coupled)
    assert any(coupled) == (omega != 0.0)


@pytest.mark.parametrize("omega", [0.0, 0.3])
def test_built_rows_follow_the_layout(robot, omega):
    """The rows of the built QP are where ``QpLayout`` says (which the warm-start row map relies
    on): ZMP rows act on the ZMP velocities, kinematic rows on the footsteps only, and the
    stability equalities close the matrix; the next cycle's rows map onto these, one sample on."""
    plan = straight_plan(robot, 0.3, omega=omega, duration_s=12.0)
    qp = IsmpcQp(robot, MpcParams())
    state = _midstep_state(plan, robot)
    problems, layout, hf = qp.build(plan, state)
    assert layout.coupled == (omega != 0.0)
    assert layout.F > 0
    for problem in problems:
        A = problem.A
        assert A.shape == (layout.m, layout.n)
        np.testing.assert_array_equal(np.flatnonzero(problem.equality), np.arange(layout.m)[layout.stability_rows()])
        for axis in range(2 if layout.coupled else 1):
            zmp, kin = layout.zmp_rows(axis), layout.kinematic_rows(axis)
            assert np.all(np.abs(A[zmp][:, layout.zmp_vel(0)]).sum(axis=1)
                          + (np.abs(A[zmp][:, layout.zmp_vel(1)]).sum(axis=1) if layout.coupled else 0) > 0)
            for other in range(2 if layout.coupled else 1):
                assert not A[kin][:, layout.zmp_vel(other)].any()
            assert np.all(np.abs(A[kin]).sum(axis=1) > 0)
    rows = layout.rows_from(layout, 1, 0)
    assert rows is not None and rows.shape == (layout.m,)
    zmp = layout.zmp_rows(0)
    np.testing.assert_array_equal(rows[zmp][:-1], np.arange(zmp.start + 1, zmp.stop))
    assert rows[zmp][-1] == -1  # the horizon's new last sample has no predecessor
    np.testing.assert_array_equal(rows[layout.stability_rows()], np.arange(layout.m)[layout.stability_rows()])
    assert layout.rows_from(QpLayout(C=layout.C, F=layout.F, coupled=not layout.coupled), 1, 0) is None
    # the first free footstep moved on by one: kinematic row j continues the previous row j + 1
    moved = layout.rows_from(layout, 1, 1)
    kin = layout.kinematic_rows(0)
    np.testing.assert_array_equal(moved[kin][:-1], np.arange(kin.start + 1, kin.stop))
    assert moved[kin][-1] == -1
