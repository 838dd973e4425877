r"""IS-MPC: the QP of one cycle, built from the footstep plan and the current state (spec §4-§7).

Per axis the decision vector is :math:`(y, X_f)` with :math:`\dot X_z = U^{-1} y` (see
:mod:`robust_ismpc.core.layout` and :attr:`IsmpcQp.zmp_vel_basis`). The rows are

* ZMP constraints at :math:`t_{k+i+1}`, :math:`i=0..C-1`, in the frame of the (rotating) ZMP
  box: :math:`|R(\theta_{i+1})^T(p_z^{k+i+1}-c_{i+1})| \le d_z/2 - R_i`;
* kinematic constraints on each free footstep relative to the previous one;
* the stability equality with the chosen tail (anticipative by default).

The cost is :math:`\tfrac12\|\dot X_z\|^2 + \tfrac12\gamma\|X_z - X_c\|^2 +
\tfrac12\beta\|X_f-\hat X_f\|^2`, with :math:`X_z - X_c` the ZMP's offset (plus the swing leg's
CoP offset, when modelled) from its box centre on the ZMP rows. The centres of free footsteps are
taken where the plan has them (the previous cycle's optimum), so the Hessian does not change with
the horizon and only the linear term is updated each cycle; the offset's length does not depend
on the frame. The ZMP-velocity block of that Hessian, :math:`I + \gamma L^TL = U^TU`, is dense;
the QP is posed in :math:`y = U\dot X_z`, where it is the identity, so that the solver's
per-cycle update of the rows (it works with the rows times the inverse Hessian factor) stays a
scaling, as with the paper's diagonal cost. When every orientation in the horizon is zero the two
axes are independent and are solved as two QPs.

Matrices that do not depend on time (the integrator :math:`\delta L`, the stability
coefficients, the Hessian) are built once in :class:`IsmpcQp`; each cycle only computes the
moving-constraint weights and the vectors, with numpy, and assembles the rows.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..exceptions import InfeasibleMpc
from .footsteps import FootstepPlan
from .layout import QpLayout
from .params import MpcParams, RobotParams
from .planner import kinematic_bounds
from .qp import QpProblem, QpSolver, make_solver
from .stability import stability_coefficients


@dataclass(frozen=True)
class MpcState:
    """Per-axis state fed to one MPC cycle (index 0 = x, 1 = y).

    Attributes
    ----------
    t_s : float
        Current time t_k [s].
    dcm_m : ndarray, shape (2,)
        Shifted DCM x̄_u = x_c + ẋ_c/η + w̃/η² [m].
    zmp_m : ndarray, shape (2,)
        Current ZMP x_z^k [m].
    """

    t_s: float
    dcm_m: np.ndarray
    zmp_m: np.ndarray


@dataclass(frozen=True)
class MpcPlan:
    """Solution of one cycle.

    Attributes
    ----------
    zmp_vel_mps : ndarray, shape (C, 2)
        Optimal ZMP velocities over the control horizon [m/s].
    footstep_indices : ndarray of int, shape (F,)
        Plan indices of the free footsteps.
    footsteps_m : ndarray, shape (F, 2)
        Their optimal positions [m].
    build_time_s, solve_time_s : float
        Wall-clock time of the QP assembly and of the solver call(s) [s].
    coupled : bool
        Whether the axes were solved together.
    """

    zmp_vel_mps: np.ndarray
    footstep_indices: np.ndarray
    footsteps_m: np.ndarray
    build_time_s: float
    solve_time_s: float
    coupled: bool


@dataclass(frozen=True)
class HorizonFootsteps:
    """Which footsteps the horizon touches, and which of them are free.

    Attributes
    ----------
    first, last : int
        Range of plan indices touched by the control horizon and the tail.
    first_free : int
        First free footstep index (``first_free .. first_free+F-1`` are decision variables).
    F : int
        Number of free footsteps.
    """

    first: int
    last: int
    first_free: int
    F: int


@dataclass(frozen=True)
class _Structure:
    """Arrays that depend only on the number of free footsteps F (built once per F).

    ``A_axis`` is a buffer whose integrator and footstep-difference blocks are fixed; each cycle
    overwrites only the columns that multiply the free footsteps in the ZMP and stability rows.
    """

    H_axis: np.ndarray  # (C+F, C+F)
    H_coupled: np.ndarray  # (2(C+F), 2(C+F))
    A_axis: np.ndarray  # (C+F+1, C+F): ZMP rows, kinematic rows, stability row
    diff: np.ndarray  # (F, C+F): footstep j minus footstep j-1 (free part)
    equality_axis: np.ndarray
    equality_coupled: np.ndarray


class IsmpcQp:
    """Builds and solves the IS-MPC QP each cycle.

    Parameters
    ----------
    robot : RobotParams
    mpc : MpcParams
    solver : QpSolver, optional
        Defaults to ``make_solver(mpc.solver)``.
    """

    def __init__(self, robot: RobotParams, mpc: MpcParams, solver: QpSolver | None = None):
        self.robot = robot
        self.mpc = mpc
        self.solver = solver if solver is not None else make_solver(mpc.solver)
        self.eta = robot.eta
        C, P, dt = mpc.C, mpc.P, mpc.sampling_period_s
        self.C, self.P, self.dt = C, P, dt
        self.integrator = dt * np.tril(np.ones((C, C)))  # row i: x_z^{k+i+1} - x_z^k
        self.stab = stability_coefficients(self.eta, dt, C, P, mpc.tail)
        self.centring = float(mpc.zmp_centring_weight)
        # The ZMP-velocity block of the cost, I + γ LᵀL = UᵀU, is dense; the QP's ZMP variables are
        # y = U Ẋ_z, in which it is the identity. The solver's per-cycle matrix update (it factors
        # the Hessian into the constraint rows) then stays a scaling, and the ZMP columns of the
        # rows, times U⁻¹, are constant.
        upper = np.linalg.cholesky(np.eye(C) + self.centring * (self.integrator.T @ self.integrator)).T
        self.zmp_vel_basis = np.linalg.inv(upper)  # (C, C): Ẋ_z = basis @ y
        self.zmp_vel_basis[np.tril_indices(C, -1)] = 0.0
        self._zmp_rows = self.integrator @ self.zmp_vel_basis  # the ZMP rows' ZMP columns
        self._stab_zmp = self.stab.zmp_vel @ self.zmp_vel_basis  # the stability row's
        self.horizon_offsets_s = dt * np.arange(1, C + 1)
        self.tail_offsets_s = dt * np.arange(C, P + 1)
        self._preview_offsets_s = dt * np.arange(1, P + 1)  # the horizon's, then the tail's after the shared t_{k+C}
        self._structures: dict[int, _Structure] = {}
        self._builds = 0
        # (t_s, layout, first free footstep) of the last solved QP: maps this cycle's rows onto
        # the previous cycle's for the solver's warm start
        self._previous: tuple[float, QpLayout, int] | None = None

    def _structure(self, F: int) -> _Structure:
        cached = self._structures.get(F)
        if cached is not None:
            return cached
        C = self.C
        layout = QpLayout(C=C, F=F, coupled=False)
        n = layout.n_axis
        H_axis = np.diag(layout.axis_columns(np.ones(C), np.full(F, self.mpc.footstep_weight)))
        H_coupled = np.zeros((2 * n, 2 * n))
        coupled = QpLayout(C=C, F=F, coupled=True)
        for axis in range(2):
            block = slice(coupled.zmp_vel(axis).start, coupled.footsteps(axis).stop)
            H_coupled[block, block] = H_axis
        diff = np.zeros((F, n))
        steps = layout.footsteps()
        diff[:, steps] = np.eye(F) - np.eye(F, k=-1)
        A_axis = np.zeros((C + F + 1, n))
        A_axis[:C, layout.zmp_vel()] = self._zmp_rows
        A_axis[C:C + F] = diff
        A_axis[-1, layout.zmp_vel()] = self._stab_zmp
        eq_axis = np.zeros(C + F + 1, dtype=bool)
        eq_axis[-1] = True
        eq_coupled = np.zeros(2 * (C + F + 1), dtype=bool)
        eq_coupled[-2:] = True
        structure = _Structure(H_axis, H_coupled, A_axis, diff, eq_axis, eq_coupled)
        self._structures[F] = structure
        return structure

    # ------------------------------------------------------------------------------------
    def horizon_footsteps(self, plan: FootstepPlan, t_s: float) -> HorizonFootsteps:
        """Footsteps touched by the horizon at ``t_s`` and the free ones among them."""
        j_now = plan.step_at(t_s)
        t_end = t_s + self.horizon_offsets_s[-1]
        last = plan.step_at(t_s + self.tail_offsets_s[-1])
        touchdown = plan.touchdown_s
        # Landed (or frozen) footsteps are known: footstep j is free while its touchdown is
        # more than footstep_freeze_s away.
        first_free = j_now + 1 if plan.is_frozen(j_now, t_s, self.mpc.footstep_freeze_s) else j_now
        first_free = max(first_free, 2)  # footstep 1 is the initial support foot, on the ground
        if self.mpc.fix_footsteps:
            F = 0
        else:
            # Free footsteps: those whose double-support ramp starts inside the control horizon.
            F = int(np.count_nonzero(touchdown[first_free : last + 1] < t_end - 1e-9))
        return HorizonFootsteps(first=j_now - 1, last=last, first_free=first_free, F=F)

    def build(
        self,
        plan: FootstepPlan,
        state: MpcState,
        restriction_m: np.ndarray | None = None,
        zmp_offset_m: np.ndarray | None = None,
    ) -> tuple[list[QpProblem], QpLayout, HorizonFootsteps]:
        """Assemble the QP(s) of this cycle.

        Parameters
        ----------
        plan : FootstepPlan
            Current plan (free footsteps are read from ``candidate_pos_m``, known ones from
            ``pos_m``).
        state : MpcState
        restriction_m : ndarray, shape (C,), optional
            ZMP constraint restriction R_i for the row at t_{k+i+1} [m] (zeros if omitted).
        zmp_offset_m : ndarray, shape (C, 2), optional
            Predicted offset of the robot's centre of pressure from the model's ZMP at the row
            t_{k+i+1} [m] (world frame); the box then constrains the ZMP plus this offset
            (:mod:`robust_ismpc.core.swing_cop`). Zeros if omitted.

        Returns
        -------
        problems : list of QpProblem
            Two per-axis problems (the axes of ``layout.frame_yaw_rad``) or one coupled problem. Per-axis problems share a
            constraint buffer that the next call overwrites: ``copy()`` a problem to keep it.
        layout : QpLayout
        footsteps : HorizonFootsteps
        """
        C = self.C
        hf = self.horizon_footsteps(plan, state.t_s)
        F = hf.F
        count = hf.last - hf.first + 1
        t_preview = state.t_s + self._preview_offsets_s  # (P,): t_{k+1} .. t_{k+P}
        weights = plan.centre_weights(t_preview)
        W = plan.weight_matrix(t_preview, hf.first, count, weights)
        W_h, W_t = W[:C], W[C - 1:]  # (C, count) at t_{k+1..k+C}, (P-C+1, count) at t_{k+C..k+P}
        weights_h = (weights[0][:C], weights[1][:C])
        free = slice(hf.first_free - hf.first, hf.first_free - hf.first + F)
        # Positions of the non-free footsteps: landed ones from pos_m, later ones candidates.
        fixed_pos = plan.candidate_pos_m[hf.first : hf.last + 1].copy()
        n_known = hf.first_free - hf.first
        fixed_pos[:n_known] = plan.pos_m[hf.first : hf.first_free]
        fixed_pos[free] = 0.0
        centre_fixed = W_h @ fixed_pos  # (C, 2) known part of the box centres
        W_free = W_h[:, free]  # (C, F)
        tail_fixed = self.stab.tail @ (W_t @ fixed_pos)  # (2,)
        tail_free = self.stab.tail @ W_t[:, free]  # (F,)
        R = np.zeros(C) if restriction_m is None else np.asarray(restriction_m, dtype=float)
        half = W_h @ plan.box_half_m[hf.first : hf.last + 1]  # (C, 2) box half sides per row

        st = self._structure(F)
        offset = state.zmp_m[None, :] - centre_fixed  # (C, 2): p_z - centre (known part)
        if zmp_offset_m is not None:
            offset = offset + zmp_offset_m
        # the centring cost's linear term (in y), γ U⁻ᵀLᵀ(x_z^k - c), the free footsteps' centres
        # taken where the plan has them (the last optimum): the Hessian stays the structure's.
        # Per world axis; a rotation of both axes commutes with it (the offset's length is kept).
        centring_offset = offset - W_free @ plan.pos_m[hf.first_free:hf.first_free + F] if F else offset
        centring_g = self._zmp_rows.T @ (self.centring * centring_offset)  # (C, 2)
        stab_rhs = state.dcm_m - self.stab.zmp_now * state.zmp_m - tail_fixed  # (2,)
        free_idx = np.arange(hf.first_free, hf.first_free + F)
        prev_known = np.zeros((F, 2))
        if F:
            prev_known[0] = plan.pos_m[hf.first_free - 1]
        sides = plan.side[free_idx]
        kin_lower, kin_upper = kinematic_bounds(self.robot, sides)
        target = plan.candidate_pos_m[free_idx]  # (F, 2)
        beta = self.mpc.footstep_weight
        yaw_rows = plan.interpolate(plan.yaw_rad, weights_h)
        yaw_kin = plan.yaw_rad[free_idx - 1]
        # one yaw for every box of the horizon (a straight walk in any heading): the axes of
        # that frame decouple, and each is a QP of its own
        frame_yaw = float(yaw_rows[0])
        coupled = bool(np.abs(yaw_rows - frame_yaw).max() > 1e-12
                       or (F > 0 and np.abs(yaw_kin - frame_yaw).max() > 1e-12))
        layout = QpLayout(C=C, F=F, coupled=coupled, frame_yaw_rad=0.0 if coupled else frame_yaw)
        rows = self._previous_rows(state.t_s, layout, hf.first_free)
        self._builds += 1

        if not coupled:
            if frame_yaw != 0.0:
                offset, prev_known = layout.to_frame(offset), layout.to_frame(prev_known)
                centring_g = layout.to_frame(centring_g)
                target, stab_rhs = layout.to_frame(target), layout.to_frame(stab_rhs)
            A = st.A_axis
            A[:C, layout.footsteps()] = -W_free
            A[-1, layout.footsteps()] = tail_free
            problems = []
            for axis in range(2):
                lower = np.concatenate([
                    -half[:, axis] + R - offset[:, axis],
                    kin_lower[:, axis] + prev_known[:, axis],
                    [stab_rhs[axis]],
                ])
                upper = np.concatenate([
                    half[:, axis] - R - offset[:, axis],
                    kin_upper[:, axis] + prev_known[:, axis],
                    [stab_rhs[axis]],
                ])
                g = layout.axis_columns(centring_g[:, axis], -beta * target[:, axis])
                problems.append(QpProblem(st.H_axis, g, A, lower, upper, st.equality_axis, tag="xy"[axis],
                                          previous_rows=rows, matrix_version=self._builds))
            return problems, layout, hf

        # Coupled: rotate the ZMP rows into the box frame and the kinematic rows into the
        # previous footstep's frame.
        zmp_block = layout.axis_columns(self._zmp_rows, -W_free)  # (C, C+F): p_z - centre (free part)
        stab_row = layout.axis_columns(self._stab_zmp, tail_free)
        diff = st.diff
        cz, sz = np.cos(yaw_rows)[:, None], np.sin(yaw_rows)[:, None]
        ck, sk = np.cos(yaw_kin)[:, None], np.sin(yaw_kin)[:, None]
        zero_stab = np.zeros(C + F)
        A = np.vstack([
            layout.both_axes(cz * zmp_block, sz * zmp_block),
            layout.both_axes(-sz * zmp_block, cz * zmp_block),
            layout.both_axes(ck * diff, sk * diff),
            layout.both_axes(-sk * diff, ck * diff),
            layout.both_axes(stab_row, zero_stab),
            layout.both_axes(zero_stab, stab_row),
        ])
        off_a = cz[:, 0] * offset[:, 0] + sz[:, 0] * offset[:, 1]
        off_b = -sz[:, 0] * offset[:, 0] + cz[:, 0] * offset[:, 1]
        prev_a = ck[:, 0] * prev_known[:, 0] + sk[:, 0] * prev_known[:, 1]
        prev_b = -sk[:, 0] * prev_known[:, 0] + ck[:, 0] * prev_known[:, 1]
        lower = np.concatenate([
            -half[:, 0] + R - off_a,
            -half[:, 1] + R - off_b,
            kin_lower[:, 0] + prev_a,
            kin_lower[:, 1] + prev_b,
            stab_rhs,
        ])
        upper = np.concatenate([
            half[:, 0] - R - off_a,
            half[:, 1] - R - off_b,
            kin_upper[:, 0] + prev_a,
            kin_upper[:, 1] + prev_b,
            stab_rhs,
        ])
        g = layout.both_axes(layout.axis_columns(centring_g[:, 0], -beta * target[:, 0]),
                             layout.axis_columns(centring_g[:, 1], -beta * target[:, 1]))
        problem = QpProblem(st.H_coupled, g, A, lower, upper, st.equality_coupled, tag="xy", previous_rows=rows)
        return [problem], layout, hf

    def _previous_rows(self, t_s: float, layout: QpLayout, first_free: int) -> np.ndarray:
        """Row map onto the last solved QP (a warm-start hint; see :meth:`QpLayout.rows_from`).

        All -1 (start cold) when there is none: the first cycle, a time step that is not a whole
        number of samples, or a switch between per-axis and coupled QPs.
        """
        previous = self._previous
        rows = None
        if previous is not None:
            samples = (t_s - previous[0]) / self.dt
            whole = round(samples)
            if abs(samples - whole) < 1e-6:
                rows = layout.rows_from(previous[1], whole, first_free - previous[2])
        return rows if rows is not None else np.full(layout.m, -1, dtype=np.intp)

    def solve(
        self,
        plan: FootstepPlan,
        state: MpcState,
        restriction_m: np.ndarray | None = None,
        zmp_offset_m: np.ndarray | None = None,
    ) -> MpcPlan:
        """Build and solve this cycle's QP (arguments as :meth:`build`).

        Raises
        ------
        InfeasibleMpc
            If the QP has no solution (the exception carries the problem).
        """
        start = time.perf_counter()
        problems, layout, hf = self.build(plan, state, restriction_m, zmp_offset_m)
        build_time = time.perf_counter() - start
        solve_time = 0.0
        zmp_vel = np.empty((self.C, 2))
        steps = np.empty((layout.F, 2))
        if layout.coupled:
            sol = self.solver.solve(problems[0])
            solve_time += sol.solve_time_s
            for axis in range(2):
                zmp_vel[:, axis] = self.zmp_vel_basis @ sol.x[layout.zmp_vel(axis)]
                steps[:, axis] = sol.x[layout.footsteps(axis)]
        else:
            for axis, problem in enumerate(problems):
                try:
                    sol = self.solver.solve(problem)
                except InfeasibleMpc as exc:
                    exc.args = (f"{exc.args[0]} ({'xy'[axis]} axis)",)
                    raise
                solve_time += sol.solve_time_s
                zmp_vel[:, axis] = self.zmp_vel_basis @ sol.x[layout.zmp_vel()]
                steps[:, axis] = sol.x[layout.footsteps()]
            if layout.frame_yaw_rad != 0.0:
                zmp_vel, steps = layout.to_world(zmp_vel), layout.to_world(steps)
        self._previous = (state.t_s, layout, hf.first_free)
        return MpcPlan(
            zmp_vel_mps=zmp_vel,
            footstep_indices=np.arange(hf.first_free, hf.first_free + layout.F),
            footsteps_m=steps,
            build_time_s=build_time,
            solve_time_s=solve_time,
            coupled=layout.coupled,
        )
