"""The per-cycle loop of (robust) IS-MPC (spec §14): ``reset()`` then ``step(t, measurement)``.

Nominal cycle: read the measurement, build the MPC state (measured CoM, model ZMP), solve the
QP, apply the first ZMP velocity to the internal LIP model through the exact discretisation, move
the swing foot, and return a :class:`~robust_ismpc.core.reference.GaitReference`.

Failure policy (when the QP is infeasible or the solver fails): the cycle plays the previous
plan shifted by one more sample, for at most ``MpcParams.max_fallback_cycles`` consecutive
cycles; after that :class:`~robust_ismpc.exceptions.ControllerFailure` is raised. With step
timing adaptation enabled, an infeasible QP first triggers an adaptation attempt.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..core.footsteps import LEFT, FootstepPlan
from ..core.lip import discretise
from ..core.mpc import IsmpcQp, MpcPlan, MpcState
from ..core.params import MpcParams, RobotParams, mpc_params_for
from ..core.qp import QpSolver
from ..core.reference import FootReference, GaitReference, Measurement, Support
from ..core.swing import SwingState, advance_swing
from ..core.swing_cop import swing_cop_offset
from ..estimation.estimator import EstimatorParams, StateEstimator
from ..exceptions import ControllerFailure, InfeasibleMpc, ParameterError, SolverError

LOGGER = logging.getLogger("robust_ismpc")


@dataclass
class CycleInfo:
    """Diagnostics of the last cycle.

    Attributes
    ----------
    build_time_s, solve_time_s, cycle_time_s : float
        QP assembly, solver and whole-step wall-clock times [s].
    infeasible : bool
        The QP of this cycle had no solution (a fallback was played).
    fallback_cycles : int
        Consecutive cycles played from a previous plan.
    dcm_m : ndarray, shape (2,)
        Shifted DCM used by the MPC [m].
    disturbance_mps2 : ndarray, shape (2,)
        Disturbance value used by the MPC (zero for nominal IS-MPC) [m/s^2].
    free_footsteps : int
        Number of footsteps optimised in this cycle.
    observer_time_s, timing_time_s : float
        Wall-clock time of the disturbance observer and of the step timing adaptation (check
        and QP-STA) in this cycle [s] (0 when the module is off).
    """

    build_time_s: float = 0.0
    solve_time_s: float = 0.0
    cycle_time_s: float = 0.0
    infeasible: bool = False
    fallback_cycles: int = 0
    dcm_m: np.ndarray = field(default_factory=lambda: np.zeros(2))
    disturbance_mps2: np.ndarray = field(default_factory=lambda: np.zeros(2))
    free_footsteps: int = 0
    observer_time_s: float = 0.0
    timing_time_s: float = 0.0


def _check_call(where: str, arrays: dict, t_s: float | None = None, previous_t_s: float | None = None) -> None:
    """ParameterError if an array of ``arrays`` (name -> array or None) is not finite, or if
    ``t_s`` does not come after ``previous_t_s`` (the controller's model advances every step)."""
    for name, value in arrays.items():
        if value is not None and not np.all(np.isfinite(np.asarray(value, dtype=float))):
            raise ParameterError(f"{where}: {name} must be finite, got {value!r}")
    if t_s is not None and previous_t_s is not None and not t_s > previous_t_s:
        raise ParameterError(f"{where}: t_s = {t_s!r} s does not come after the previous step ({previous_t_s!r} s); "
                             "step() needs increasing times (reset() starts again)")


class _RateLimitedLog:
    """Log a message at most once per ``period_s`` of controller time, counting the rest."""

    def __init__(self, period_s: float = 1.0):
        self.period_s = period_s
        self._last: dict[str, float] = {}
        self.suppressed = 0

    def warning(self, key: str, t_s: float, message: str) -> None:
        last = self._last.get(key)
        if last is None or t_s - last >= self.period_s:
            self._last[key] = t_s
            LOGGER.warning("t=%.2f s: %s", t_s, message)
        else:
            self.suppressed += 1


class IsmpcController:
    """IS-MPC gait generator with optional robustness modules.

    Parameters
    ----------
    robot : RobotParams
        Robot and gait parameters.
    mpc : MpcParams, optional
        MPC settings (default :func:`~robust_ismpc.core.params.mpc_params_for` the robot).
    solver : QpSolver, optional
        QP solver (defaults to ``mpc.solver``).
    replan_on_landing : bool
        When a footstep lands away from its candidate (the MPC moved it, or the foot landed
        elsewhere), translate every later candidate by the same offset (default True). This is
        what an online planner integrating the command from the current support does (T-RO
        §III); without it, after a push the candidates and the anticipative tail stay behind
        (or beside) the robot and pull the ZMP back.
    estimator : EstimatorParams, optional
        Noise model of the state estimator that corrects the internal model with the measured
        CoM and CoM velocity every cycle (:mod:`robust_ismpc.estimation.estimator`); default: an exact
        measurement, which the MPC starts from as it is. A landed footstep is moved to the
        measured sole when the measurement carries the soles.
    """

    def __init__(
        self,
        robot: RobotParams,
        mpc: MpcParams | None = None,
        solver: QpSolver | None = None,
        replan_on_landing: bool = True,
        estimator: EstimatorParams | None = None,
    ):
        self.robot = robot
        self.mpc_params = mpc if mpc is not None else mpc_params_for(robot)
        if not isinstance(robot, RobotParams):
            raise ParameterError(f"robot must be RobotParams, got {type(robot).__name__}")
        if self.mpc_params.control_horizon_s < robot.T_step_s - 1e-9:
            raise ParameterError(
                f"control horizon {self.mpc_params.control_horizon_s} s is shorter than one step "
                f"({robot.T_step_s} s = T_ss + T_ds of {robot.name}); set MpcParams.control_horizon_s to "
                "at least one step, or leave mpc unset for a horizon fitted to the robot"
            )
        self.qp = IsmpcQp(robot, self.mpc_params, solver)
        self.eta = robot.eta
        self.dt = self.mpc_params.sampling_period_s
        self.lip = discretise(self.eta, self.dt)
        self.replan_on_landing = bool(replan_on_landing)
        self.estimator = StateEstimator(estimator if estimator is not None else EstimatorParams(), self.eta, self.dt)
        self.modules: frozenset[str] = frozenset()
        self.info = CycleInfo()
        self._log = _RateLimitedLog()
        self.plan: FootstepPlan | None = None

    # ------------------------------------------------------------------------------------
    def plan_duration_s(self, run_s: float) -> float:
        """How long the footstep plan of a run of ``run_s`` seconds must be [s]: the run, the
        preview horizon beyond its end and one second more."""
        return run_s + self.mpc_params.preview_horizon_s + 1.0

    def reset(
        self,
        plan: FootstepPlan,
        com_pos_m: np.ndarray,
        com_vel_mps: np.ndarray | None = None,
        left_foot_m: np.ndarray | None = None,
        right_foot_m: np.ndarray | None = None,
        t_s: float = 0.0,
    ) -> None:
        """Start a walk.

        Parameters
        ----------
        plan : FootstepPlan
            Footstep plan (the controller adapts it in place).
        com_pos_m : ndarray, shape (2,) or (3,)
            Initial CoM [m]; the ZMP starts below it.
        com_vel_mps : ndarray, shape (2,) or (3,), optional
            Initial CoM velocity [m/s] (zero).
        left_foot_m, right_foot_m : ndarray, shape (2,), optional
            Initial soles (default: from the plan's first footsteps).
        t_s : float
            Start time [s]; must lie inside the plan.
        """
        com = np.asarray(com_pos_m, dtype=float).reshape(-1)[:2]
        vel = np.zeros(2) if com_vel_mps is None else np.asarray(com_vel_mps, float).reshape(-1)[:2]
        _check_call("reset", {"com_pos_m": com, "com_vel_mps": vel, "left_foot_m": left_foot_m,
                              "right_foot_m": right_foot_m, "plan.pos_m": plan.pos_m})
        self._last_step_t_s = math.nextafter(float(t_s), -math.inf)  # the first step may be at t_s
        self.plan = plan
        plan.step_at(t_s)  # raises PlanError if outside
        self.state = np.vstack([com, vel, com])  # rows x_c, ẋ_c, x_z; columns x, y
        self.disturbance_mps2 = np.zeros(2)
        # the measured external moment's share of the disturbance, as an LIP acceleration (the
        # robust controller's observer sets it; GaitReference.disturbance_moment_mps2)
        self.disturbance_moment_estimate_mps2 = np.zeros(2)
        first = plan.pos_m[1]
        other = 2.0 * plan.pos_m[0] - first  # the other foot, mirrored about the midpoint
        first_is_left = plan.side[1] == LEFT
        left0 = left_foot_m if left_foot_m is not None else (first if first_is_left else other)
        right0 = right_foot_m if right_foot_m is not None else (other if first_is_left else first)
        self.feet = {
            LEFT: SwingState.at_rest(np.asarray(left0, float), plan.yaw_rad[1]),
            -LEFT: SwingState.at_rest(np.asarray(right0, float), plan.yaw_rad[1]),
        }
        self.last_plan: MpcPlan | None = None
        self.last_zmp_vel_mps = np.zeros(2)
        self._anchored_step = 1
        self._swing_step: dict[int, int] = {}
        self._cop_offset_cache: tuple | None = None
        self.fallback_cycles = 0
        self.infeasible_count = 0
        #: Cycles planned from a state moved back towards the model's prediction, with the
        #: previous cycle's w̃ (:meth:`_solve_plannable`): the measurement and the new estimate
        #: were not plannable.
        self.prediction_replans = 0
        self._predicted_state: np.ndarray | None = None
        self.info = CycleInfo()

    # ------------------------------------------------------------------------------------
    def _mpc_state(self, t_s: float, measurement: Measurement | None) -> MpcState:
        self._predicted_state = None
        if measurement is not None:
            com = np.asarray(measurement.com_pos_m, float)[:2]
            vel = np.asarray(measurement.com_vel_mps, float)[:2]
            self._predicted_state = self.state[:2].copy()
            self.state[:2] = self.estimator.correct(self.state[:2], com, vel)
        return self._state_for_mpc(t_s)

    def _state_for_mpc(self, t_s: float) -> MpcState:
        """The MPC's initial state from the model state and the disturbance in use."""
        dcm = self._shifted_dcm(self.state[0], self.state[1], self.disturbance_mps2)
        return MpcState(t_s=t_s, dcm_m=dcm, zmp_m=self.state[2].copy())

    def _shifted_dcm(self, com_pos_m: np.ndarray, com_vel_mps: np.ndarray,
                     disturbance_mps2: np.ndarray) -> np.ndarray:
        """The shifted DCM x̄_u = c + ċ/η + w/η² [m], shape (2,), of a CoM position [m], velocity
        [m/s] and disturbance [m/s²], each shape (2,)."""
        return com_pos_m + com_vel_mps / self.eta + disturbance_mps2 / self.eta**2

    def _solve_qp(self, state: MpcState) -> MpcPlan:
        """Solve this cycle's QP (subclasses may retry, e.g. after adapting the step timing)."""
        return self.qp.solve(self.plan, state, self._restriction(), self._swing_cop_offset(state.t_s))

    def _swing_cop_offset(self, t_s: float) -> np.ndarray | None:
        """Predicted shift of the robot's CoP by the swing leg over the horizon (None on a LIP).

        Shape (C, 2) [m], world frame, for the ZMP rows at t_{k+1} .. t_{k+C}. Computed once per
        cycle and step timing: the robust controller's feasibility checks and QP retries reuse it.
        """
        if self.robot.swing_cop_gain_s2 == 0.0:
            return None
        key = (t_s, self.plan.touchdown_s.tobytes())
        if self._cop_offset_cache is not None and self._cop_offset_cache[0] == key:
            return self._cop_offset_cache[1]
        times = t_s + self.qp.horizon_offsets_s
        offset = swing_cop_offset(self.plan, t_s, times, self.feet, self.robot.swing_cop_gain_s2)
        offset.setflags(write=False)
        self._cop_offset_cache = (key, offset)
        return offset

    def _solve_plannable(self, state: MpcState) -> MpcPlan:
        """Solve from the estimated state; if that QP is infeasible, from the state moved towards
        the model's prediction (:meth:`_solve_towards_prediction`): the measurement is adopted as
        far as the MPC can plan from it; the whole body absorbs the rest. Counted in
        :attr:`prediction_replans`: while a force is beyond what the MPC can plan with, w̃ stays at
        its last plannable value (docs/sweeps.md, "The weakest rightward force cell")."""
        try:
            return self._solve_qp(state)
        except InfeasibleMpc:
            result = self._solve_towards_prediction(state.t_s, self._solve_qp)
            if result is None:
                raise
            return result

    def _solve_towards_prediction(self, t_s: float, solve: Callable[[MpcState], MpcPlan]) -> MpcPlan | None:
        """Solve with ``solve`` from the estimated state moved half-way, then all the way, back to
        the model's prediction, with w̃ moved back by the same fraction to the previous cycle's; the
        plan, or None (state and w̃ left as they were) if neither is feasible, the estimator is
        exact or there is no prediction this cycle."""
        predicted = self._predicted_state
        if predicted is None or self.estimator.params.exact:
            return None
        estimated = self.state[:2].copy()
        disturbance = self.disturbance_mps2.copy()
        previous_w = self._previous_disturbance
        if np.allclose(estimated, predicted) and np.allclose(disturbance, previous_w):
            return None
        for fraction in (0.5, 0.0):
            self.state[:2] = predicted + fraction * (estimated - predicted)
            self.disturbance_mps2 = previous_w + fraction * (disturbance - previous_w)
            retry = self._state_for_mpc(t_s)
            try:
                result = solve(retry)
            except InfeasibleMpc:
                continue
            self.info.dcm_m = retry.dcm_m
            self.prediction_replans += 1
            return result
        self.state[:2] = estimated
        self.disturbance_mps2 = disturbance
        return None

    def _solve(self, state: MpcState) -> tuple[np.ndarray, MpcPlan | None]:
        """First ZMP velocity to apply, and the new plan (None when a fallback was played)."""
        try:
            result = self._solve_plannable(state)
        except (InfeasibleMpc, SolverError) as exc:
            self.infeasible_count += 1
            self.fallback_cycles += 1
            self.info.infeasible = True
            self._log.warning("infeasible", state.t_s, f"{exc}; playing the previous plan")
            if self.last_plan is None or self.fallback_cycles > self.mpc_params.max_fallback_cycles:
                raise ControllerFailure(
                    f"t={state.t_s:.3f} s: IS-MPC infeasible for {self.fallback_cycles} "
                    f"consecutive cycles ({exc})"
                ) from exc
            shifted = self.last_plan.zmp_vel_mps
            idx = min(self.fallback_cycles, shifted.shape[0] - 1)
            return shifted[idx], None
        self.fallback_cycles = 0
        self.info.infeasible = False
        self.info.build_time_s = result.build_time_s
        self.info.solve_time_s = result.solve_time_s
        self.info.free_footsteps = len(result.footstep_indices)
        self.last_plan = result
        if len(result.footstep_indices):
            self.plan.pos_m[result.footstep_indices] = result.footsteps_m
        return result.zmp_vel_mps[0], result

    def _anchor_landed(self, t_s: float, measurement: Measurement | None) -> None:
        """Once per step, at touchdown: place the landed footstep at the measured sole (if
        measured) and translate the later candidates by its offset from its candidate."""
        plan = self.plan
        j = plan.step_at(t_s)
        if j < 2 or j <= self._anchored_step or t_s < plan.touchdown_s[j] - 1e-9:
            return
        self._anchored_step = j
        side = int(plan.side[j])
        sole = None
        if measurement is not None:
            sole = measurement.left_sole_m if side == LEFT else measurement.right_sole_m
        if sole is not None:
            sole = np.asarray(sole, dtype=float)[:2]
            # the model's CoM and ZMP keep their place relative to the new support
            shift = sole - plan.pos_m[j]
            self.state[0] += shift
            self.state[2] += shift
            plan.pos_m[j] = sole
            self.feet[side].pos_m[:2] = plan.pos_m[j]  # the stance-foot reference follows
        if self.replan_on_landing:
            offset = plan.pos_m[j] - plan.candidate_pos_m[j]
            plan.candidate_pos_m[j:] += offset
            plan.pos_m[j + 1 :] += offset

    def _before_cycle(self, t_s: float, measurement: Measurement | None) -> None:
        """Hook run first in every cycle (the robust controller updates its observer here)."""

    def _adapt(self, state: MpcState) -> None:
        """Hook run before the QP (the robust controller adapts the step timing here)."""

    def extra_channels(self) -> dict:
        """Trace channels produced by the robustness modules in the last cycle."""
        return {}

    def _restriction(self) -> np.ndarray | None:
        """ZMP restriction profile (None for nominal IS-MPC)."""
        return None

    # ------------------------------------------------------------------------------------
    def step(self, t_s: float, measurement: Measurement | None = None) -> GaitReference:
        """Run one control cycle at ``t_s`` and return the reference for ``t_s + δ``.

        Parameters
        ----------
        t_s : float
            Current time [s] (a multiple of δ after ``reset``'s time).
        measurement : Measurement, optional
            Robot measurement; without it the controller runs open loop on its internal model.

        Raises
        ------
        ControllerFailure
            If the QP stayed infeasible longer than the fallback allows, or the measurement is
            not finite.
        """
        if self.plan is None:
            raise ParameterError("call reset() before step()")
        if not math.isfinite(t_s):
            raise ParameterError(f"t_s must be finite, got {t_s!r}")
        soles = {} if measurement is None else {"measurement.left_sole_m": measurement.left_sole_m,
                                                  "measurement.right_sole_m": measurement.right_sole_m}
        _check_call("step", soles, t_s, getattr(self, "_last_step_t_s", None))
        self._last_step_t_s = t_s
        start = time.perf_counter()
        self.info.build_time_s = self.info.solve_time_s = 0.0
        if measurement is not None:
            values = [measurement.com_pos_m, measurement.com_vel_mps]
            values += [v for v in (measurement.zmp_m, measurement.contact_acc_mps2, measurement.external_moment_acc_mps2) if v is not None]
            if not np.isfinite(np.concatenate(values)).all():
                raise ControllerFailure(f"t={t_s:.3f} s: measurement contains NaN or inf", reason="bad_measurement")
        self._previous_disturbance = self.disturbance_mps2.copy()
        self._anchor_landed(t_s, measurement)
        self._before_cycle(t_s, measurement)
        state = self._mpc_state(t_s, measurement)
        self._adapt(state)
        self.info.dcm_m = state.dcm_m
        zmp_vel, _ = self._solve(state)
        self.info.disturbance_mps2 = self.disturbance_mps2.copy()  # what the plan used (a retry may move it)
        self.last_zmp_vel_mps = zmp_vel
        self.info.fallback_cycles = self.fallback_cycles
        self.state = self.lip.A @ self.state + np.outer(self.lip.B, zmp_vel) + np.outer(self.lip.E, self.disturbance_mps2)
        reference = self._reference(t_s)
        self.info.cycle_time_s = time.perf_counter() - start
        return reference

    def _reference(self, t_s: float) -> GaitReference:
        plan = self.plan
        t_next = t_s + self.dt
        j = plan.step_at(t_s)
        touchdown = plan.touchdown_s[j]
        swinging = j >= 2 and t_s < touchdown - 1e-9
        if swinging:
            swing_side = int(plan.side[j])
            if self._swing_step.get(swing_side) != j:  # a new swing of this foot: lift off anew
                self._swing_step[swing_side] = j
                self.feet[swing_side].progress = 0.0
            self.feet[swing_side] = advance_swing(
                self.feet[swing_side], plan.pos_m[j], plan.yaw_rad[j], touchdown - t_s, self.dt,
                self.robot.swing_height_m,
            )
            support = Support.RIGHT if swing_side == LEFT else Support.LEFT
        else:
            support = Support.DOUBLE
        feet = {}
        for side, foot in self.feet.items():
            in_contact = not (swinging and side == plan.side[j] and t_next < touchdown - 1e-9)
            feet[side] = FootReference(
                pos_m=foot.pos_m.copy(), yaw_rad=foot.yaw_rad, vel_mps=foot.vel_mps.copy(),
                yaw_rate_radps=foot.yaw_rate_radps, in_contact=in_contact,
            )
        x_c, v_c, x_z = self.state
        acc = self.eta**2 * (x_c - x_z) + self.disturbance_mps2
        h = self.robot.com_height_m
        return GaitReference(
            t_s=t_next,
            com_pos_m=np.array([x_c[0], x_c[1], h]),
            com_vel_mps=np.array([v_c[0], v_c[1], 0.0]),
            com_acc_mps2=np.array([acc[0], acc[1], 0.0]),
            zmp_m=x_z.copy(),
            left_foot=feet[LEFT],
            right_foot=feet[-LEFT],
            torso_yaw_rad=0.5 * (feet[LEFT].yaw_rad + feet[-LEFT].yaw_rad),
            support=support,
            step_index=int(j),
            time_to_step_s=max(0.0, float(touchdown - t_next)) if swinging else 0.0,
            disturbance_mps2=self.disturbance_mps2.copy(),
            # the part of w̃ the measured moment explains, the rest a force
            disturbance_moment_mps2=np.clip(self.disturbance_moment_estimate_mps2,
                                            np.minimum(self.disturbance_mps2, 0.0),
                                            np.maximum(self.disturbance_mps2, 0.0)),
        )
