"""Robust IS-MPC: nominal IS-MPC plus any subset of the three robustness modules (spec §11-§14).

* ``observer``: the disturbance ŵ is measured directly, as the CoM acceleration the contact
  forces do not explain (:class:`~robust_ismpc.estimation.estimator.DisturbanceEstimator`); its persistent
  part is the floor of the mid-range target, the fresh estimate enters as far as
  the shifted DCM stays feasible (:mod:`robust_ismpc.estimation.governor`); a mid-range filter saturates and
  rate-limits the target into w̃, which enters the stability constraint through the shifted DCM
  x̄_u = x_u + w̃/η² and the reference integration (+E_d w̃). An infeasible QP is retried with w̃
  moved half-way, then all the way, to the persistent part.
* ``restriction``: the ZMP boxes of the horizon shrink by R_i = r (i+1) δ, with r computed from
  the deviation bound Δmax (:mod:`robust_ismpc.core.restriction`).
* ``timing``: before the QP, the feasibility region of the shifted DCM is computed as a function
  of the current step's touchdown time; if the DCM is near or beyond it, QP-STA chooses a new
  touchdown (:mod:`robust_ismpc.control.step_timing`), the plan is re-timed (later steps shift, the
  anticipative tail and the swing foot follow). An infeasible QP also triggers an adaptation
  attempt before the fallback of :class:`~robust_ismpc.control.controller.IsmpcController`.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from functools import partial

import numpy as np

from ..core.feasibility import feasibility_bounds_at_axes, zmp_row_weights
from ..core.mpc import MpcPlan, MpcState
from ..core.params import MpcParams, RobotParams
from ..core.qp import QpSolver
from ..core.reference import Measurement
from ..core.restriction import checked_restriction_rate, max_tolerable_deviation, restriction_profile
from ..estimation.estimator import DisturbanceEstimator
from ..estimation.filters import MidrangeFilter, MidrangeParams, PersistenceFilter
from ..estimation.governor import interval_unchecked, target_unchecked
from ..exceptions import InfeasibleMpc
from .controller import IsmpcController
from .modules import MODULES, check_modules
from .retiming import first_feasible, next_single_support_durations, start_timings
from .robust_params import RobustParams
from .step_timing import StaParams, TimingRecord, should_adapt, solve_sta, support_feasibility_inputs

#: How many standard deviations of its sensor noise ŵ may differ from w̃ for an infeasible QP to be
#: taken as noise rather than a new disturbance (:meth:`RobustIsmpcController._plan_within_noise`).
NOISE_GATE_SIGMAS = 3.0


class RobustIsmpcController(IsmpcController):
    """IS-MPC with the observer, restriction and timing modules selectable.

    Parameters
    ----------
    robot : RobotParams
    mpc : MpcParams, optional
    modules : sequence of str
        Any subset of ``observer``, ``restriction``, ``timing``.
    delta_max_mps2 : float, optional
        Overrides ``params.delta_max_mps2``.
    solver : QpSolver, optional
    params : RobustParams, optional
    **controller_options
        ``replan_on_landing``, ``estimator`` (see the base class).

    Raises
    ------
    ParameterError
        For unknown modules, or a Δmax that the restriction cannot guarantee with this foot and
        horizon (the message gives the largest one that can be).
    """

    def __init__(
        self,
        robot: RobotParams,
        mpc: MpcParams | None = None,
        modules=MODULES,
        delta_max_mps2: float | None = None,
        solver: QpSolver | None = None,
        params: RobustParams | None = None,
        **controller_options,
    ):
        super().__init__(robot, mpc, solver=solver, **controller_options)
        self.modules = frozenset(check_modules(modules))
        params = params if params is not None else RobustParams()
        if delta_max_mps2 is not None:
            params = replace(params, delta_max_mps2=delta_max_mps2)
        self.robust_params = params
        mpc_p = self.mpc_params
        box = min(robot.zmp_box_x_m, robot.zmp_box_y_m)
        self.restriction_rate_mps = 0.0
        self.delta_max_mps2 = 0.0
        self._restriction_m: np.ndarray | None = None
        if "restriction" in self.modules:
            dmax = params.delta_max_mps2
            if dmax is None:
                dmax = params.delta_max_fraction * max_tolerable_deviation(
                    box, self.eta, self.dt, mpc_p.control_horizon_s
                )
            reach = math.hypot(0.5 * robot.kin_box_x_m, robot.foot_spacing_m + 0.5 * robot.kin_box_y_m)
            self.restriction_rate_mps = checked_restriction_rate(
                dmax, self.eta, self.dt, mpc_p.control_horizon_s, robot.zmp_box_x_m, robot.zmp_box_y_m,
                preview_horizon_s=mpc_p.preview_horizon_s, max_zmp_speed_mps=reach / robot.T_ds_s,
            )
            self.delta_max_mps2 = float(dmax)
            self._restriction_m = restriction_profile(self.restriction_rate_mps, self.dt, mpc_p.C)
        self.sta_params = params.sta if params.sta is not None else StaParams(margin_m=box / 16)
        self.observer: DisturbanceEstimator | None = None
        self.midrange: MidrangeFilter | None = None
        if "observer" in self.modules:
            noise = self.estimator.params
            self.observer = DisturbanceEstimator(params.disturbance_time_constant_s, self.dt,
                                                 noise.sensor_vel_noise_mps, noise.sensor_contact_acc_noise_mps2)
            self.midrange = MidrangeFilter(MidrangeParams(max_change_mps2=params.midrange_rate_mps3 * self.dt))
            self.persistence = PersistenceFilter(max(1, int(round(params.persistence_s / self.dt))))
            eta_t = self.eta * params.transient_time_constant_s
            self.transient_weight = 1.0 if math.isinf(eta_t) else eta_t / (1.0 + eta_t)
        self.persistent_disturbance_mps2 = np.zeros(2)
        self.fresh_disturbance_mps2 = np.zeros(2)
        self.disturbance_retries = 0
        self._noise_checked_t_s: float | None = None
        self.timing = TimingRecord()
        self._row_weights = zmp_row_weights(self.eta, self.dt, mpc_p.control_horizon_s)

    # ------------------------------------------------------------------------------------
    def reset(self, plan, com_pos_m, com_vel_mps=None, left_foot_m=None, right_foot_m=None, t_s: float = 0.0) -> None:
        super().reset(plan, com_pos_m, com_vel_mps, left_foot_m, right_foot_m, t_s)
        self.nominal_T_ss_s = plan.T_ss_s.copy()
        # the first touchdown is delayed by at most one step (plan_duration_s covers it)
        self._latest_first_touchdown_s = float(plan.touchdown_s[2]) + self.robot.T_step_s
        self.timing = TimingRecord()
        self._bounds_cache = None
        self._bounds_now = None
        if self.observer is not None:
            self.observer.reset()
            self.midrange.reset(0.0)
            self.persistence.reset()
        self.persistent_disturbance_mps2 = np.zeros(2)
        self.fresh_disturbance_mps2 = np.zeros(2)
        self.disturbance_retries = 0
        self._noise_checked_t_s = None

    def plan_duration_s(self, run_s: float) -> float:
        """As the nominal controller's, stretched so that the plan still covers the run when every
        single support is re-timed to its shortest (re-timing pulls the later steps earlier), and
        when the first step is delayed by one step (:meth:`_retime_start`)."""
        length = super().plan_duration_s(run_s)
        if "timing" not in self.modules:
            return length
        robot = self.robot
        shortest_step_s = self.sta_params.ss_limits(robot.T_ss_s)[0] + robot.T_ds_s
        return length * max(1.0, robot.T_step_s / shortest_step_s) + robot.T_step_s

    @property
    def timing_adaptations(self) -> int:
        """Number of cycles in which the step timing was adapted."""
        return self.timing.adaptations

    @property
    def timing_returns(self) -> int:
        """Number of cycles in which a re-timed touchdown moved back to its nominal one."""
        return self.timing.returns

    def _restriction(self) -> np.ndarray | None:
        return self._restriction_m

    def _before_cycle(self, t_s: float, measurement: Measurement | None) -> None:
        self.info.observer_time_s = 0.0
        if self.observer is None or measurement is None:
            return
        start = time.perf_counter()
        w_hat = self.observer.update(t_s, measurement.com_vel_mps, measurement.contact_acc_mps2,
                                     measurement.external_moment_acc_mps2)
        self.disturbance_estimate_mps2 = w_hat
        self.disturbance_moment_estimate_mps2 = self.observer.moment_estimate_mps2.copy()
        self.persistent_disturbance_mps2 = self.persistence.update(w_hat)
        # the fresh part, expected to decay with transient_time_constant_s; w̃ follows in _mpc_state
        persistent = self.persistent_disturbance_mps2
        self.fresh_disturbance_mps2 = persistent + self.transient_weight * (w_hat - persistent)
        self.info.observer_time_s = time.perf_counter() - start

    def _mpc_state(self, t_s: float, measurement: Measurement | None) -> MpcState:
        state = super()._mpc_state(t_s, measurement)
        if self.observer is None or measurement is None:  # no new estimate this cycle
            return state
        start = time.perf_counter()
        dcm = state.dcm_m - self.disturbance_mps2 / self.eta**2  # x_u, unshifted
        self.disturbance_mps2 = self.midrange.update(self._disturbance_target(t_s, dcm, state))
        self.info.observer_time_s += time.perf_counter() - start
        return MpcState(t_s=state.t_s, dcm_m=dcm + self.disturbance_mps2 / self.eta**2, zmp_m=state.zmp_m)

    def _disturbance_target(self, t_s: float, dcm_m: np.ndarray, state: MpcState) -> np.ndarray:
        """Mid-range target (world frame). In single support: the persistent part, plus the fresh
        estimate as far as the governor admits it (the exact feasibility region of the current
        timing). In double support, where no closed-form region is computed: the fresh estimate,
        which :meth:`_solve_qp` moves half-way, then all the way, back to the persistent part when
        the QP is infeasible (the QP itself is the feasibility test there). In the initial stance
        (step 1): the whole estimate ŵ, not the fresh part's decaying share, because no touchdown
        is coming that would absorb what that share leaves out; when the QP is infeasible the
        first step is brought forward (:meth:`_retime_start`) before the estimate is moved back.
        Standing and starting under a force depend on this: with the persistent part alone the
        estimate reached the MPC a persistence window late, and the DCM drifted by what the lag
        let through."""
        persistent = self.persistent_disturbance_mps2
        if not self.robust_params.governor:
            return persistent
        plan = self.plan
        j = plan.step_at(t_s)
        if j < 2:
            return self.disturbance_estimate_mps2
        if t_s >= plan.touchdown_s[j] - 1e-9:
            return self.fresh_disturbance_mps2
        bx, by, R, origin = self._current_bounds(t_s, j, state, plan.touchdown_s[j] - t_s)
        low, high = interval_unchecked(
            R.T @ (dcm_m - origin), np.array([bx[0], by[0]]), np.array([bx[1], by[1]]), self.eta**2
        )
        return R @ target_unchecked(R.T @ persistent, R.T @ self.fresh_disturbance_mps2, low, high)

    # ------------------------------------------------------------------------------------
    def feasibility_inputs(self, t_s: float, j: int, state: MpcState, zmp_m: np.ndarray | None = None):
        """Per-axis feasibility inputs in the frame of the current support footstep j-1
        (:func:`~robust_ismpc.control.step_timing.support_feasibility_inputs`); ``zmp_m`` overrides
        the ZMP of ``state`` (world frame) when given."""
        return support_feasibility_inputs(
            self.plan, self.robot, self.mpc_params, t_s, j, state.zmp_m if zmp_m is None else zmp_m,
            frozen=self._landing_footstep_frozen(t_s, j), restriction_rate_mps=self.restriction_rate_mps,
            eta=self.eta, sampling_period_s=self.dt,
        )

    def _landing_footstep_frozen(self, t_s: float, j: int) -> bool:
        """True once the QP holds footstep j fixed (the last ``footstep_freeze_s`` before touchdown)."""
        return self.plan.is_frozen(j, t_s, self.mpc_params.footstep_freeze_s)

    def _current_bounds(self, t: float, j: int, state: MpcState, remaining: float):
        """Exact feasibility bounds for the current timing, in the support frame.

        The bounds depend on the current ZMP only through the affine term w_0 x_z^k
        (derivations §3.1), so the inputs are built once per step and plan change with the ZMP
        at the support origin, the ZMP-free bounds once per cycle (the governor and the timing
        check ask for the same ones), and the ZMP term is added at each call.
        """
        td = self.plan.touchdown_s
        n = int(np.count_nonzero(td[j:] < t + self.mpc_params.preview_horizon_s - 1e-9))
        key = (j, n, self._anchored_step, self.timing.adaptations, self.timing.returns,
               self._landing_footstep_frozen(t, j))
        if self._bounds_cache is None or self._bounds_cache[0] != key:
            origin = self.plan.pos_m[j - 1]
            inputs_x, inputs_y, R, origin = self.feasibility_inputs(t, j, state, zmp_m=origin)
            self._bounds_cache = (key, inputs_x, inputs_y, R, origin)
        _, inputs_x, inputs_y, R, origin = self._bounds_cache
        zmp_local = R.T @ (state.zmp_m - origin)
        w0 = inputs_x.zmp_gain
        if self._bounds_now is None or self._bounds_now[0] != (key, remaining):
            self._bounds_now = ((key, remaining), *feasibility_bounds_at_axes(inputs_x, inputs_y, remaining))
        _, (lx, ux), (ly, uy) = self._bounds_now
        # the QP bounds the ZMP plus the swing leg's CoP offset: both bounds move by -Σ κ_i o_i
        cop_shift = R.T @ self._cop_shift_m(t)
        bx = (lx + w0 * zmp_local[0] - cop_shift[0], ux + w0 * zmp_local[0] - cop_shift[0])
        by = (ly + w0 * zmp_local[1] - cop_shift[1], uy + w0 * zmp_local[1] - cop_shift[1])
        return bx, by, R, origin

    def _cop_shift_m(self, t_s: float) -> np.ndarray:
        """``Σ_i κ_i o_i``, world frame [m]: the feasibility bounds move by minus this when the QP
        bounds the ZMP plus the swing leg's CoP offset o_i on its rows
        (:func:`~robust_ismpc.core.feasibility.zmp_row_weights`). Exact for the current timing; zero
        without a swing-leg CoP model (κ = 0, the LIP).
        """
        offset = self._swing_cop_offset(t_s)
        return np.zeros(2) if offset is None else self._row_weights @ offset

    def _adapt_timing(self, state: MpcState, qp_infeasible: bool = False) -> bool:
        """Check feasibility and adapt the current touchdown if needed; True if it changed.

        QP-STA moves the touchdown as little as it can from the step's *nominal* one (spec §13.3),
        and a re-timed step goes back to its nominal touchdown as soon as the shifted DCM is clear
        of that timing's bounds by the trigger's margin (:meth:`_return_to_nominal`): the timing
        follows the DCM, so an estimate that brushes the margin now and then (a noisy velocity, a
        swinging payload) does not move it ever further from the nominal. With noisy sensors the
        margin alone does not re-time while the measurement is within the sensors' noise
        (:meth:`_within_noise`): then only an infeasible QP does (:meth:`_solve_qp_timed`).
        """
        plan, t = self.plan, state.t_s
        j = plan.step_at(t)
        touchdown = plan.touchdown_s[j]
        if j < 2 or t >= touchdown - 1e-9:
            self.timing.bounds_world_m = np.full(4, np.nan)
            return False
        remaining = touchdown - t
        nominal = float(plan.ss_start_s[j] + self.nominal_T_ss_s[j])
        if not qp_infeasible and self._return_to_nominal(state, j, touchdown, nominal):
            return True
        bx, by, R, origin = self._current_bounds(t, j, state, remaining)
        dcm_local = R.T @ (state.dcm_m - origin)
        self._show_bounds(bx, by, origin, j)
        if not should_adapt(
            dcm_local, (float(bx[0]), float(bx[1])), (float(by[0]), float(by[1])), self.sta_params.margin_m,
            in_single_support=True, time_to_touchdown_s=remaining, freeze_s=self.sta_params.freeze_s,
            qp_infeasible=qp_infeasible,
        ):
            return False
        if not qp_infeasible and self._within_noise(state):
            return False  # the margin brushed by the sensors' noise; an infeasible QP still re-times
        inputs_x, inputs_y, _, _ = self.feasibility_inputs(t, j, state)
        # solve_sta's bounds leave out the swing leg's CoP offset; moving the DCM by the offset's
        # shift instead is the same check (the shift is the current timing's, kept for the new one)
        result = solve_sta(
            t, max(nominal, t + self.dt), plan.ss_start_s[j], float(self.nominal_T_ss_s[j]),
            dcm_local + R.T @ self._cop_shift_m(t), inputs_x, inputs_y, self.sta_params,
        )
        if abs(result.touchdown_time_s - touchdown) <= 0.5 * self.dt:
            return False
        plan.retime_touchdown(j, result.touchdown_time_s)
        self.timing.record(result.time_to_touchdown_s)
        self._log.warning(
            "sta", t, f"step timing adapted: touchdown in {result.time_to_touchdown_s:.2f} s (was {remaining:.2f} s)"
        )
        return True

    def _return_to_nominal(self, state: MpcState, j: int, touchdown: float, nominal: float) -> bool:
        """Move the re-timed touchdown of step ``j`` back to its nominal one (``nominal`` [s]) if
        the shifted DCM is clear of the nominal timing's bounds by the margin, outside the freeze
        window; True if it moved."""
        t = state.t_s
        freeze = self.sta_params.freeze_s
        if abs(touchdown - nominal) <= 0.5 * self.dt or min(touchdown, nominal) - t < freeze:
            return False
        bx, by, R, origin = self._current_bounds(t, j, state, nominal - t)
        if should_adapt(R.T @ (state.dcm_m - origin), (float(bx[0]), float(bx[1])), (float(by[0]), float(by[1])),
                        self.sta_params.margin_m, in_single_support=True, time_to_touchdown_s=nominal - t,
                        freeze_s=freeze):
            return False
        self._show_bounds(bx, by, origin, j)
        self.plan.retime_touchdown(j, nominal)
        self.timing.record_return()
        return True

    def _show_bounds(self, bx, by, origin: np.ndarray, j: int) -> None:
        """Record the feasibility bounds of this cycle's timing in the world frame (NaN when the
        support footstep is turned: they are support-frame bounds)."""
        if abs(self.plan.yaw_rad[j - 1]) < 1e-12:
            self.timing.bounds_world_m = np.array([bx[0] + origin[0], bx[1] + origin[0], by[0] + origin[1], by[1] + origin[1]])
        else:
            self.timing.bounds_world_m = np.full(4, np.nan)

    def _adapt(self, state: MpcState) -> None:
        self.timing.new_cycle()
        self.info.timing_time_s = 0.0
        if "timing" in self.modules:
            start = time.perf_counter()
            self._adapt_timing(state)
            self.info.timing_time_s = time.perf_counter() - start

    def _solve_qp_timed(self, state: MpcState) -> MpcPlan:
        try:
            return super()._solve_qp(state)
        except InfeasibleMpc:
            if "timing" not in self.modules:
                raise
            within_noise = self._plan_within_noise(state)
            if within_noise is not None:
                return within_noise
            if self._adapt_timing(state, qp_infeasible=True):
                return super()._solve_qp(state)
            result = self._retime_next_step(state) if self.plan.step_at(state.t_s) >= 2 else self._retime_start(state)
            if result is None:
                raise
            return result

    def _plan_within_noise(self, state: MpcState) -> MpcPlan | None:
        """The first time this cycle's QP is infeasible, walking, with a measurement within the
        sensors' noise (:meth:`_within_noise`): plan from the state moved towards the model's
        prediction (:meth:`_solve_towards_prediction`) instead of re-timing. Returns the plan, or
        None (nothing changed) when the measurement is outside the noise, in the initial stance,
        or when no state towards the prediction is feasible either.
        """
        t = state.t_s
        if self._noise_checked_t_s == t:  # once per cycle: the retries below call again
            return None
        self._noise_checked_t_s = t
        if not self._within_noise(state):
            return None
        return self._solve_towards_prediction(t, super()._solve_qp)

    def _within_noise(self, state: MpcState) -> bool:
        """True when, walking with noisy sensors, what this cycle measured is within what the
        sensors' noise explains, so that it does not re-time a step.

        Within the noise means both: ŵ is within :data:`NOISE_GATE_SIGMAS` standard deviations of
        its sensor noise (:attr:`DisturbanceEstimator.noise_std_mps2`) from the w̃ the MPC plans
        with, and the shifted DCM (estimated state, this cycle's w̃) is within one velocity
        sample's noise in the DCM, σ_v / η, of the model's prediction with the previous cycle's
        w̃. A re-timing is a lasting change of the gait: made on noise, steps shortened one cycle
        after another swing the robot (and pump a load hanging from it). A push moves ŵ away from
        w̃ at once and is re-timed for as before. Without the observer (the timing alone, w̃ = 0)
        the shifted DCM's test alone. False with exact signals (σ = 0), in the initial stance and
        without a prediction this cycle.
        """
        observer = self.observer
        vel_noise_mps = self.estimator.params.sensor_vel_noise_mps
        if (self.plan.step_at(state.t_s) < 2 or self._predicted_state is None
                or (observer.exact if observer is not None else vel_noise_mps == 0)):
            return False
        w = self.disturbance_mps2
        if observer is not None and (np.max(np.abs(self.disturbance_estimate_mps2 - w))
                                     > NOISE_GATE_SIGMAS * observer.noise_std_mps2):
            return False
        predicted = self._predicted_state
        new_dcm = (self._shifted_dcm(self.state[0], self.state[1], w)
                   - self._shifted_dcm(predicted[0], predicted[1], self._previous_disturbance))
        return bool(np.max(np.abs(new_dcm)) <= vel_noise_mps / self.eta)

    def _retime_next_step(self, state: MpcState) -> MpcPlan | None:
        """In double support, when the QP is infeasible: re-time the coming single support to the
        duration nearest its current one, within the step timing limits, for which the QP is
        feasible.

        The analytical feasibility bounds (:meth:`_adapt_timing`) hold in single support only, so
        here the QP itself decides: durations on the
        :data:`~robust_ismpc.control.retiming.DS_RETIMING_FRACTIONS` grid of the
        nominal single support are tried nearest first. Returns the plan, or None (timing left
        as it was) in single support or if no duration is feasible.
        """
        plan, t = self.plan, state.t_s
        j = plan.step_at(t)
        k = j + 1  # the step whose single support comes next
        if j < 2 or t < plan.touchdown_s[j] - 1e-9 or k >= plan.n_footsteps:
            return None
        current = float(plan.T_ss_s[k])
        nominal = float(self.nominal_T_ss_s[k])
        durations = next_single_support_durations(nominal, current, self.sta_params.ss_limits(nominal), self.dt)
        start = float(plan.ss_start_s[k])
        found = first_feasible(durations, lambda duration: plan.retime_touchdown(k, start + duration),
                               partial(super()._solve_qp, state), lambda: plan.retime_touchdown(k, start + current))
        if found is None:
            return None
        duration, result = found
        self.timing.record(start + duration - t)
        self._log.warning("sta", t, f"next single support re-timed in double support: {duration:.2f} s "
                                    f"(was {current:.2f} s)")
        return result

    def _retime_start(self, state: MpcState) -> MpcPlan | None:
        """In the initial stance, when the QP is infeasible: re-time the first step to the first
        timing of :func:`~robust_ismpc.control.retiming.start_timings` for which the QP is
        feasible (earlier touchdowns with the longest single support they allow, later ones while
        the ZMP box is still on the feet's midpoint, then the shortest single support after the
        longest double support).

        A robot that does not step can hold a persistent force only while the DCM's offset w/η²
        fits in its feet; beyond that it must step, and the first footstep is a decision of the
        MPC like every other one. Later: the stance on both feet lasts longer, which is what a
        sideways push towards the second support foot needs (the box would otherwise move to the
        first support foot, away from the DCM). Returns the plan, or None (timing left as it
        was) if no timing is feasible.
        """
        plan, t = self.plan, state.t_s
        current = float(plan.touchdown_s[2])
        nominal = float(self.nominal_T_ss_s[2])
        saved = (plan.T_ss_s.copy(), plan.T_ds_s.copy(), plan.ss_start_s.copy())
        timings = start_timings(
            t, float(saved[2][2]), current, nominal, self.sta_params.ss_limits(nominal)[0], self.robot.T_ds_s,
            self.robot.T_step_s, self.dt, on_midpoint=t < float(plan.touchdown_s[1]) - 1e-9,
            latest_touchdown_s=self._latest_first_touchdown_s,
        )

        def restore() -> None:
            plan.T_ss_s[:], plan.T_ds_s[:], plan.ss_start_s[:] = saved

        def apply(timing) -> None:
            restore()
            if abs(timing.start_s - float(saved[2][2])) > 1e-9:
                plan.retime_start(t, timing.start_s)
            plan.retime_touchdown(2, timing.touchdown_s)

        found = first_feasible(timings, apply, partial(super()._solve_qp, state), restore)
        if found is None:
            return None
        timing, result = found
        self.timing.record(timing.touchdown_s - t)
        self._log.warning("sta", t, f"first step re-timed: touchdown at {timing.touchdown_s:.2f} s "
                                    f"(was {current:.2f} s), single support from {timing.start_s:.2f} s")
        return result

    def _solve_qp(self, state: MpcState) -> MpcPlan:
        """Solve, adapting the timing if infeasible; if still infeasible, retry with w̃ moved
        half-way, then all the way, to the persistent part of the estimate. When the previous
        plan has been replayed for ``max_fallback_cycles`` (the next infeasible cycle ends the
        run), last with w̃ = 0, the disturbance nominal IS-MPC plans with, for this cycle only.

        The governor's feasibility bounds are exact for the nominal gait but optimistic close to
        a re-timed touchdown (g1, measured: the QP accepted 2 cm of a 9 cm interval), so w̃ can
        still be more than the plan absorbs; the persistent part is the safer value. It is not
        always safe: the 30 ms low-pass stretches a 0.1 s push past the persistence window, and
        then the persistent part holds a push that has ended. Planning with w̃ = 0 at once, in
        place of the replay, cost the OP3 with a bag and the G1 under a sideways force in MuJoCo
        (the plan jumps); as the alternative to failing it costs nothing.
        """
        try:
            return self._solve_qp_timed(state)
        except InfeasibleMpc:
            if self.observer is None or not self.robust_params.governor:
                raise
            current = self.disturbance_mps2.copy()
            persistent = self.persistent_disturbance_mps2
            # (w̃, kept for the next cycles): the last resort plans this cycle only, the estimate stays
            candidates = [(current + 0.5 * (persistent - current), True), (persistent, True)]
            if self.last_plan is None or self.fallback_cycles >= self.mpc_params.max_fallback_cycles:
                candidates.append((np.zeros(2), False))  # else the previous plan is replayed
            for w, kept in candidates:
                if np.allclose(w, current):
                    continue
                retry = MpcState(t_s=state.t_s, dcm_m=state.dcm_m + (w - current) / self.eta**2, zmp_m=state.zmp_m)
                try:
                    result = self._solve_qp_timed(retry)
                except InfeasibleMpc:
                    continue
                if kept:
                    self.disturbance_mps2 = w
                    self.midrange.reset(w)
                self.disturbance_retries += 1
                return result
            raise

    def extra_channels(self) -> dict:
        return {
            "feasibility_m": self.timing.bounds_world_m,
            "timing_adapted": float(self.timing.adapted_this_cycle),
            "adapted_time_to_step_s": self.timing.time_to_step_s,
            "observer_ms": 1e3 * self.info.observer_time_s,
            "disturbance_measured_mps2": (self.observer.estimate_mps2 if self.observer is not None
                                          else np.full(2, np.nan)),
            "timing_ms": 1e3 * self.info.timing_time_s,
        }
