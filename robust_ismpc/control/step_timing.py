r"""Feasibility-driven step timing adaptation: trigger and QP-STA (spec §13).

The touchdown time t_s of the current step is encoded as :math:`Δλ = e^{-\eta(t_s - t_k)}`
(larger Δλ = earlier step). With affine inner estimates :math:`a^m + b^mΔλ \le` … of the
feasibility bounds (:func:`robust_ismpc.core.feasibility.affine_inner_estimate`), QP-STA is

.. math::

    \min_{Δλ,\,σ_x,\,σ_y \ge 0}\ (Δλ - Δλ_{nom})^2 + ρ(σ_x^2 + σ_y^2)

    \text{s.t.}\ a^m_x + b^m_xΔλ + m_s - σ_x \le \bar x_u \le a^M_x + b^M_xΔλ - m_s + σ_x
    \ \text{(same for y)},\quad Δλ_{min} \le Δλ \le Δλ_{max}.

The slack is an exact-penalty fallback: when the hard constraints (σ = 0) are satisfiable their
solution is returned (the limit ρ → ∞), otherwise the soft problem with weight ρ is solved.
Being scalar it is solved in closed form: with σ eliminated
(:math:`σ = \max(0, \text{violations})`) the cost is a convex piecewise quadratic in Δλ whose
pieces are delimited by at most six points; each piece is minimised analytically. When the hard
constraints (σ = 0) are satisfiable the result is the projection of Δλ_nom on their interval.
The adapted touchdown is then rounded to the δ grid and re-checked against the exact bounds.

The module also builds the feasibility check's inputs in the support foot's frame
(:func:`support_feasibility_inputs`) and keeps the record of what the adaptation did
(:class:`TimingRecord`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.feasibility import (
    AffineFeasibility,
    AxisFeasibilityInputs,
    affine_inner_estimate,
    feasibility_bounds_at_axes,
)
from ..core.footsteps import FootstepPlan
from ..core.params import MpcParams, RobotParams
from ..core.planner import kinematic_bounds, rotation
from ..exceptions import ParameterError

__all__ = ["StaParams", "StaResult", "TimingRecord", "timing_interval", "solve_sta_qp", "solve_sta", "should_adapt",
           "support_feasibility_inputs"]


@dataclass(frozen=True)
class StaParams:
    """Settings of step timing adaptation.

    Attributes
    ----------
    margin_m : float
        Safety margin m_s [m] kept between the shifted DCM and the estimated bounds, and the
        trigger distance from the nominal-timing bounds (default 0.02, the prototype's value).
    T_ss_min_s, T_ss_max_s : float or None
        Shortest and longest single support [s]. None: ``T_ss_min_factor`` /
        ``T_ss_max_factor`` times the nominal single support of the step.
    T_ss_min_factor, T_ss_max_factor : float
        Used when the absolute limits are None (defaults 0.5 and 1.5, spec §13.3).
    floor_s : float
        The remaining single support is never made shorter than this [s] (default 0.05).
    freeze_s : float
        No adaptation when less than this remains before the nominal touchdown [s] (0.1).
    slack_weight : float
        ρ, weight on the squared slacks σ [1/m²] (default 1e6: a 1 mm violation costs as much
        as a change of 1 in Δλ). Must be > 0.
    """

    margin_m: float = 0.02
    T_ss_min_s: float | None = None
    T_ss_max_s: float | None = None
    T_ss_min_factor: float = 0.5
    T_ss_max_factor: float = 1.5
    floor_s: float = 0.05
    freeze_s: float = 0.1
    slack_weight: float = 1e6

    def __post_init__(self) -> None:
        def check(name: str, value: object, allow_zero: bool) -> None:
            ok = isinstance(value, (int, float)) and math.isfinite(value) and (value >= 0 if allow_zero else value > 0)
            if not ok:
                raise ParameterError(f"StaParams.{name} must be a finite number {'>=' if allow_zero else '>'} 0, got {value!r}")

        check("margin_m", self.margin_m, True)
        check("floor_s", self.floor_s, False)
        check("freeze_s", self.freeze_s, True)
        check("slack_weight", self.slack_weight, False)
        check("T_ss_min_factor", self.T_ss_min_factor, False)
        check("T_ss_max_factor", self.T_ss_max_factor, False)
        if self.T_ss_min_factor > 1.0 or self.T_ss_max_factor < 1.0:
            raise ParameterError(
                f"StaParams: need T_ss_min_factor <= 1 <= T_ss_max_factor, got {self.T_ss_min_factor}, {self.T_ss_max_factor}"
            )
        for name in ("T_ss_min_s", "T_ss_max_s"):
            if getattr(self, name) is not None:
                check(name, getattr(self, name), False)
        if self.T_ss_min_s is not None and self.T_ss_max_s is not None and self.T_ss_min_s > self.T_ss_max_s:
            raise ParameterError(f"StaParams: T_ss_min_s ({self.T_ss_min_s}) must be <= T_ss_max_s ({self.T_ss_max_s})")

    def ss_limits(self, T_ss_nominal_s: float) -> tuple[float, float]:
        """(T_ss,min, T_ss,max) [s] for a step whose nominal single support is ``T_ss_nominal_s``."""
        lo = self.T_ss_min_s if self.T_ss_min_s is not None else self.T_ss_min_factor * T_ss_nominal_s
        hi = self.T_ss_max_s if self.T_ss_max_s is not None else self.T_ss_max_factor * T_ss_nominal_s
        return lo, max(lo, hi)


def timing_interval(params: StaParams, T_ss_nominal_s: float, elapsed_ss_s: float) -> tuple[float, float]:
    """Admissible remaining single-support time [T_rem,min, T_rem,max] [s] (spec §13.3).

    T_rem,min = max(T_ss,min − elapsed, floor); T_rem,max = max(T_ss,max − elapsed, T_rem,min).
    """
    T_min, T_max = params.ss_limits(T_ss_nominal_s)
    rem_min = max(T_min - elapsed_ss_s, params.floor_s)
    return rem_min, max(T_max - elapsed_ss_s, rem_min)


def solve_sta_qp(
    dcm_xy: np.ndarray,
    estimate_x: AffineFeasibility,
    estimate_y: AffineFeasibility,
    delta_lambda_nominal: float,
    margin_m: float,
    slack_weight: float,
) -> tuple[float, bool, tuple[float, float]]:
    """Closed-form solution of the scalar QP-STA on [Δλ_min, Δλ_max] of the estimates.

    If the hard constraints (zero slack) admit a solution, the result is the projection of
    ``delta_lambda_nominal`` on their interval; otherwise the soft problem is minimised.

    Parameters
    ----------
    dcm_xy : array_like, shape (2,)
        Shifted DCM (x̄_u, ȳ_u) [m].
    estimate_x, estimate_y : AffineFeasibility
        Affine inner estimates; both must share the same Δλ interval.
    delta_lambda_nominal : float
        Δλ of the candidate timing.
    margin_m : float
        m_s [m].
    slack_weight : float
        ρ > 0.

    Returns
    -------
    delta_lambda : float
        Optimal Δλ*.
    hard_feasible : bool
        Whether the constraints are satisfiable with zero slack.
    slack_m : tuple of float
        (σ_x, σ_y) at the optimum [m].
    """
    lo, hi = estimate_x.delta_lambda_min, estimate_x.delta_lambda_max
    if abs(estimate_y.delta_lambda_min - lo) > 1e-15 or abs(estimate_y.delta_lambda_max - hi) > 1e-15:
        raise ParameterError("estimate_x and estimate_y must cover the same delta_lambda interval")
    # Each constraint as  c0 + c1 * Δλ <= σ_axis  (violation v(Δλ) = c0 + c1 Δλ).
    cons = []
    for axis, (est, u) in enumerate(((estimate_x, float(dcm_xy[0])), (estimate_y, float(dcm_xy[1])))):
        cons.append((axis, u + margin_m - est.upper_offset_m, -est.upper_slope_m))  # u <= upper - m_s
        cons.append((axis, est.lower_offset_m + margin_m - u, est.lower_slope_m))  # u >= lower + m_s
    # Hard interval.
    h_lo, h_hi = lo, hi
    for _, c0, c1 in cons:
        if c1 > 0:
            h_hi = min(h_hi, -c0 / c1)
        elif c1 < 0:
            h_lo = max(h_lo, -c0 / c1)
        elif c0 > 0:
            h_lo, h_hi = 1.0, 0.0
    if h_lo <= h_hi:
        return min(max(delta_lambda_nominal, h_lo), h_hi), True, (0.0, 0.0)
    # Soft: J(Δλ) = (Δλ − nom)² + ρ Σ_axis max(0, v_a1, v_a2)²; convex piecewise quadratic.
    cuts = {lo, hi}
    for i, (ax_i, c0_i, c1_i) in enumerate(cons):
        if c1_i != 0:
            cuts.add(-c0_i / c1_i)
        for ax_j, c0_j, c1_j in cons[i + 1:]:
            if ax_j == ax_i and c1_i != c1_j:
                cuts.add((c0_j - c0_i) / (c1_i - c1_j))
    knots = sorted(c for c in cuts if lo <= c <= hi)

    def active(x: float) -> list[tuple[float, float]]:
        out = []
        for axis in (0, 1):
            best = max(((c0 + c1 * x, c0, c1) for ax, c0, c1 in cons if ax == axis), key=lambda t: t[0])
            if best[0] > 0:
                out.append((best[1], best[2]))
        return out

    def cost(x: float) -> float:
        return (x - delta_lambda_nominal) ** 2 + slack_weight * sum((c0 + c1 * x) ** 2 for c0, c1 in active(x))

    best_x, best_j = lo, math.inf
    for k0, k1 in zip(knots[:-1], knots[1:]) if len(knots) > 1 else [(lo, hi)]:
        terms = active(0.5 * (k0 + k1))
        # d/dx [(x − nom)² + ρ Σ (c0 + c1 x)²] = 0
        num = delta_lambda_nominal - slack_weight * sum(c0 * c1 for c0, c1 in terms)
        den = 1.0 + slack_weight * sum(c1 * c1 for _, c1 in terms)
        x = min(max(num / den, k0), k1)
        j = cost(x)
        if j < best_j:
            best_x, best_j = x, j
    sigma = [0.0, 0.0]
    for axis in (0, 1):
        sigma[axis] = max(0.0, max(c0 + c1 * best_x for ax, c0, c1 in cons if ax == axis))
    return best_x, False, (sigma[0], sigma[1])


@dataclass(frozen=True)
class StaResult:
    """Outcome of :func:`solve_sta`.

    Attributes
    ----------
    touchdown_time_s : float
        Adapted touchdown t_s [s], on the δ grid (exactly the nominal one when unchanged).
    time_to_touchdown_s : float
        t_s − t_k [s].
    delta_lambda : float
        Δλ of ``touchdown_time_s``.
    delta_lambda_qp : float
        Δλ* returned by QP-STA before rounding.
    changed : bool
        True when the touchdown differs from the nominal one.
    hard_feasible : bool
        QP-STA's constraints (estimated bounds with margin, timing) were satisfiable without slack.
    feasible : bool
        The exact feasibility bounds at the rounded timing contain the shifted DCM on both axes
        (the IS-MPC QP will be feasible), ignoring the margin.
    slack_m : tuple of float
        (σ_x, σ_y) of QP-STA [m].
    bounds_x_m, bounds_y_m : tuple of float
        Exact (lower, upper) feasibility bounds at the returned timing [m].
    """

    touchdown_time_s: float
    time_to_touchdown_s: float
    delta_lambda: float
    delta_lambda_qp: float
    changed: bool
    hard_feasible: bool
    feasible: bool
    slack_m: tuple[float, float]
    bounds_x_m: tuple[float, float]
    bounds_y_m: tuple[float, float]


def solve_sta(
    t_k_s: float,
    touchdown_nominal_s: float,
    ss_start_s: float,
    T_ss_nominal_s: float,
    dcm_xy: np.ndarray,
    inputs_x: AxisFeasibilityInputs,
    inputs_y: AxisFeasibilityInputs,
    params: StaParams | None = None,
) -> StaResult:
    """Adapt the touchdown of the current step so that the MPC stays feasible (QP-STA, §13.3).

    Parameters
    ----------
    t_k_s : float
        Current time t_k [s], on the δ grid.
    touchdown_nominal_s : float
        Candidate touchdown t_s,nom of the current single support [s] (> t_k).
    ss_start_s : float
        Start time of the current single support [s] (for the T_ss limits).
    T_ss_nominal_s : float
        Nominal single-support duration of the current step [s].
    dcm_xy : array_like, shape (2,)
        Shifted DCM (x̄_u, ȳ_u) = CoM + CoM velocity/η + w̃/η² in the frame of the inputs [m].
    inputs_x, inputs_y : AxisFeasibilityInputs
        Per-axis feasibility inputs (the touchdown time is the unknown; later ramps keep their
        offsets). They must share η and δ.
    params : StaParams, optional

    Returns
    -------
    StaResult
    """
    p = params if params is not None else StaParams()
    eta, delta = inputs_x.eta, inputs_x.sampling_period_s
    if abs(inputs_y.eta - eta) > 1e-12 or abs(inputs_y.sampling_period_s - delta) > 1e-15:
        raise ParameterError("inputs_x and inputs_y must share eta and sampling_period_s")
    dcm = np.asarray(dcm_xy, dtype=float)
    if dcm.shape != (2,) or not np.all(np.isfinite(dcm)):
        raise ParameterError(f"dcm_xy must be a finite array of shape (2,), got {dcm_xy!r}")
    rem_nom = touchdown_nominal_s - t_k_s
    if not rem_nom > 0:
        raise ParameterError(f"touchdown_nominal_s ({touchdown_nominal_s}) must be after t_k_s ({t_k_s})")
    rem_min, rem_max = timing_interval(p, T_ss_nominal_s, t_k_s - ss_start_s)
    dl_min, dl_max = math.exp(-eta * rem_max), math.exp(-eta * rem_min)
    dl_nom = math.exp(-eta * rem_nom)
    anchor = min(max(dl_nom, dl_min), dl_max)
    est_x = affine_inner_estimate(inputs_x, dl_min, dl_max, anchor)
    est_y = affine_inner_estimate(inputs_y, dl_min, dl_max, anchor)
    dl_qp, hard, slack = solve_sta_qp(dcm, est_x, est_y, dl_nom, p.margin_m, p.slack_weight)

    def exact(rem: float) -> tuple[tuple[float, float], tuple[float, float], bool, bool]:
        bx, by = feasibility_bounds_at_axes(inputs_x, inputs_y, rem)
        inside = bool(bx[0] <= dcm[0] <= bx[1] and by[0] <= dcm[1] <= by[1])
        m = p.margin_m
        with_margin = bool(bx[0] + m <= dcm[0] <= bx[1] - m and by[0] + m <= dcm[1] <= by[1] - m)
        return bx, by, inside, with_margin

    if dl_qp == dl_nom:
        bx, by, inside, _ = exact(rem_nom)
        return StaResult(touchdown_nominal_s, rem_nom, dl_nom, dl_qp, False, hard, inside, slack, bx, by)
    # Round to the δ grid inside the timing interval, then re-check with the exact bounds.
    rem_qp = -math.log(dl_qp) / eta
    n_lo = math.ceil(rem_min / delta - 1e-9)
    n_hi = max(n_lo, math.floor(rem_max / delta + 1e-9))
    n_star = rem_qp / delta
    options = {min(max(n, n_lo), n_hi) for n in (math.floor(n_star), math.ceil(n_star))}
    scored = []
    for n in options:
        bx, by, inside, with_margin = exact(n * delta)
        scored.append(((not with_margin, not inside, abs(n - n_star)), n, bx, by, inside))
    _, n, bx, by, inside = min(scored, key=lambda s: s[0])
    touchdown = (round(t_k_s / delta) + n) * delta  # on the absolute δ grid (t_k = k δ)
    rem = touchdown - t_k_s
    changed = abs(touchdown - touchdown_nominal_s) > 0.5 * delta
    if not changed:
        touchdown, rem = touchdown_nominal_s, rem_nom
    return StaResult(touchdown, rem, math.exp(-eta * rem), dl_qp, changed, hard, inside, slack, bx, by)


def should_adapt(
    dcm_xy: np.ndarray,
    bounds_x_m: tuple[float, float],
    bounds_y_m: tuple[float, float],
    margin_m: float,
    *,
    in_single_support: bool,
    time_to_touchdown_s: float,
    freeze_s: float,
    qp_infeasible: bool = False,
) -> bool:
    """Trigger of step timing adaptation (spec §13.4).

    True during single support, outside the freeze window before the touchdown, when the shifted
    DCM is within ``margin_m`` of the feasibility bounds computed with the nominal timing (or
    outside them) on either axis, or when the IS-MPC QP was infeasible.

    Parameters
    ----------
    dcm_xy : array_like, shape (2,)
        Shifted DCM [m].
    bounds_x_m, bounds_y_m : (float, float)
        Exact (lower, upper) bounds with the nominal timing [m] (:func:`feasibility_bounds_at`).
    margin_m : float
        m_s [m].
    in_single_support : bool
    time_to_touchdown_s : float
        Nominal time left before touchdown [s].
    freeze_s : float
        Freeze window [s].
    qp_infeasible : bool
        The IS-MPC QP of the previous attempt was infeasible.
    """
    if not in_single_support or time_to_touchdown_s < freeze_s:
        return False
    if qp_infeasible:
        return True
    x, y = float(dcm_xy[0]), float(dcm_xy[1])
    near_x = x > bounds_x_m[1] - margin_m or x < bounds_x_m[0] + margin_m
    near_y = y > bounds_y_m[1] - margin_m or y < bounds_y_m[0] + margin_m
    return near_x or near_y


def support_feasibility_inputs(
    plan: FootstepPlan,
    robot: RobotParams,
    mpc: MpcParams,
    t_s: float,
    j: int,
    zmp_m: np.ndarray,
    *,
    frozen: bool,
    restriction_rate_mps: float,
    eta: float,
    sampling_period_s: float,
) -> tuple[AxisFeasibilityInputs, AxisFeasibilityInputs, np.ndarray, np.ndarray]:
    """Per-axis feasibility inputs of step ``j`` at ``t_s``, in the frame of its support footstep
    j-1.

    As in the IS-MPC QP, the landing footstep j can move within the kinematic box unless it is
    ``frozen`` (held at its planned position, the last ``footstep_freeze_s`` before touchdown),
    and with ``mpc.fix_footsteps`` no footstep moves from its candidate.

    Parameters
    ----------
    plan : FootstepPlan
    robot : RobotParams
    mpc : MpcParams
    t_s : float
        Now [s].
    j : int
        Current step (its single support is the one checked).
    zmp_m : ndarray, shape (2,)
        Current ZMP, world frame [m].
    frozen : bool
        The landing footstep j is held where the QP last put it.
    restriction_rate_mps : float
        ZMP restriction rate r [m/s] (0 without the restriction).
    eta : float
        LIP natural frequency η [1/s].
    sampling_period_s : float
        MPC sampling period δ [s].

    Returns
    -------
    inputs_x, inputs_y : AxisFeasibilityInputs
    rotation_m : ndarray, shape (2, 2)
        Support-frame axes in the world (local = Rᵀ (world - origin)).
    origin_m : ndarray, shape (2,)
        Support footstep position [m].
    """
    origin = plan.pos_m[j - 1]
    R = rotation(plan.yaw_rad[j - 1])
    td = plan.touchdown_s
    n = max(1, int(np.count_nonzero(td[j:] < t_s + mpc.preview_horizon_s - 1e-9)))
    idx = np.arange(j, min(j + n, plan.n_footsteps))
    targets = plan.candidate_pos_m[idx].copy()
    if frozen:  # the QP holds the landing footstep where it last put it
        targets[0] = plan.pos_m[j]
    candidates = (targets - origin) @ R  # rows Rᵀ(p - origin)
    nominal = np.diff(np.vstack([np.zeros(2), candidates]), axis=0)
    sides = plan.side[idx].astype(float)
    zmp_local = R.T @ (zmp_m - origin)
    periods = np.diff(td[idx])
    common = dict(
        support_pos_m=0.0, restriction_rate_mps=restriction_rate_mps, T_ds_s=float(plan.T_ds_s[j]),
        step_periods_s=periods, eta=eta, sampling_period_s=sampling_period_s,
        control_horizon_s=mpc.control_horizon_s, preview_horizon_s=mpc.preview_horizon_s,
    )
    lo, hi = kinematic_bounds(robot, sides)
    if mpc.fix_footsteps:  # no footstep is a decision: each stays at its nominal displacement
        lo, hi = nominal.copy(), nominal.copy()
    elif frozen:
        lo[0] = hi[0] = nominal[0]
    inputs_x = AxisFeasibilityInputs(
        zmp_pos_m=float(zmp_local[0]), zmp_half_width_m=0.5 * robot.zmp_box_x_m,
        disp_lo_m=lo[:, 0], disp_hi_m=hi[:, 0], disp_nominal_m=nominal[:, 0], **common,
    )
    inputs_y = AxisFeasibilityInputs(
        zmp_pos_m=float(zmp_local[1]), zmp_half_width_m=0.5 * robot.zmp_box_y_m,
        disp_lo_m=lo[:, 1], disp_hi_m=hi[:, 1], disp_nominal_m=nominal[:, 1], **common,
    )
    return inputs_x, inputs_y, R, origin


@dataclass
class TimingRecord:
    """What the step timing adaptation did. An adaptation is a change of one step's timing: the
    current single support's touchdown (in single support), the coming single support's
    duration (in double support,
    :meth:`~robust_ismpc.control.robust.RobustIsmpcController._retime_next_step`) or the first
    touchdown (in the initial stance,
    :meth:`~robust_ismpc.control.robust.RobustIsmpcController._retime_start`); its time to step
    is the time from now to the touchdown it set. A re-timed step's return to its nominal
    touchdown is counted apart (``returns``)."""

    adaptations: int = 0
    returns: int = 0  # re-timed touchdowns moved back to their nominal one
    min_time_to_step_s: float = math.inf
    adapted_this_cycle: bool = False
    time_to_step_s: float = math.nan  # of this cycle's last adaptation (NaN: none)
    bounds_world_m: np.ndarray = field(default_factory=lambda: np.full(4, np.nan))

    def new_cycle(self) -> None:
        self.adapted_this_cycle = False
        self.time_to_step_s = math.nan

    def record(self, time_to_touchdown_s: float) -> None:
        """Count one re-timing this cycle, with the time left to the re-timed touchdown [s]."""
        self.adaptations += 1
        self.adapted_this_cycle = True
        self.time_to_step_s = float(time_to_touchdown_s)
        self.min_time_to_step_s = min(self.min_time_to_step_s, time_to_touchdown_s)

    def record_return(self) -> None:
        """Count one re-timed touchdown moved back to its nominal one (not an adaptation)."""
        self.returns += 1
