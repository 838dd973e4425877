r"""Feasibility region of the IS-MPC QP per axis, as a function of the step timing (spec §8, §13).

The QP (per horizontal axis, at t_k, sampling δ, C = T_c/δ, P = T_p/δ) has ZMP velocities
:math:`\dot x_z^{k..k+C-1}` as decisions, ZMP rows at :math:`t_{k+i+1}`
(:math:`|x_z^{k+i+1} - c(t_{k+i+1})| \le d_z/2 - r(i+1)\delta`), footsteps whose double-support
ramp starts inside the control horizon as decisions within kinematic displacement bounds, the
anticipative centre tail sampled every δ up to T_p and held afterwards, and the stability
constraint in position form with the shifted DCM. Its feasibility region is the interval
:math:`[x_u^m, x_u^M]` of shifted DCMs for which it has a solution.

Closed form (``docs/derivations.md`` §3; exact when every timing breakpoint lies on the δ grid).
With :math:`a_j` the start of DS ramp j relative to t_k, :math:`\mu_c = e^{-\eta T_c}`,
:math:`w_0 = 1 - (1-\lambda)/(\eta\delta)`, ramp integrals

.. math::

    G_j = \rho_j(0) + \frac{e^{-\eta\max(a_j,0)} - e^{-\eta\min(a_j+T_{ds},\,T_p)}}{\eta T_{ds}}
    \quad(\text{second term only if } \min(a_j+T_{ds},T_p) > \max(a_j,0)),

the centre integral :math:`\eta\int_0^\infty e^{-\eta\tau}\tilde c(\tau)d\tau = p_0 + \sum_j G_j Δ_j`
and

.. math::

    x_u^M = p_0 + \sum_j G_j\hat Δ_j + \sum_{j\in D}\gamma_j(Δ^+_j - \hat Δ_j)
            + w_0(x_z^k - c_0 - \tfrac{d_z}{2}) + \tfrac{d_z}{2}(1-\mu_c)
            - r\big[\tfrac{1-\mu_c}{\eta} - T_c\mu_c\big],

:math:`x_u^m` likewise with :math:`Δ^-_j` and the signs of the :math:`d_z` and r terms flipped.
D is the set of decision footsteps (0 < a_j < T_c); :math:`\gamma_j = G_j` when the later
(tail) footsteps are placed relative to the last decision footstep, and
:math:`\gamma_j = G_j - G_{next}` (G of the first footstep after D) when they are the planner's
absolute candidate positions.

For step timing adaptation the touchdown of the current step is encoded as
:math:`Δλ = e^{-\eta(t_s - t_k)}`, i.e. :math:`a_1 = -\ln(Δλ)/\eta`, and every later ramp keeps
its offset from the first one. The bounds are piecewise affine in Δλ with jumps where a footstep
enters the control horizon; :func:`affine_inner_estimate` fits the tightest line that stays
inside them on an interval.

A known offset :math:`o_i` of the constrained point from the ZMP on row i (the QP bounds
:math:`x_z^{k+i} + o_i` instead of :math:`x_z^{k+i}`, e.g. the CoP a swing leg adds,
:mod:`robust_ismpc.core.swing_cop`) moves both bounds by :math:`-\sum_i \kappa_i o_i`, with the row
weights of :func:`zmp_row_weights` (``docs/derivations.md`` §5).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..exceptions import ParameterError
from ..validation import check_number, check_positive

__all__ = [
    "AxisFeasibilityInputs",
    "AffineFeasibility",
    "feasibility_bounds_at",
    "feasibility_bounds",
    "feasibility_breakpoints",
    "affine_inner_estimate",
    "zmp_row_weights",
]

TAIL_ANCHORS = ("candidate", "decision")
# A footstep is a decision variable iff its ramp starts strictly before T_c; a ramp starting
# within this tolerance of T_c counts as starting at T_c (a candidate). 1 ns is far below any
# sampling period, so on a δ grid the classification equals "start sample index < C".
_CLASSIFY_TOL_S = 1e-9
# Lines returned by the affine estimate are lowered by this much so that float rounding can
# never put them outside the exact bounds [m].
_INNER_SAFETY_M = 1e-12


@dataclass(frozen=True)
class AxisFeasibilityInputs:
    """Everything the feasibility bounds of one axis depend on, besides the touchdown time.

    Positions are along one horizontal axis of the current support-foot frame (orientation
    changes inside the horizon are ignored). Footstep j = 1..N is the one landing at the end of
    the j-th single support from now (j = 1: the current swing foot).

    Attributes
    ----------
    support_pos_m : float
        p_0, the current support footstep [m].
    zmp_pos_m : float
        x_z^k, the ZMP at t_k (the MPC's initial state) [m].
    zmp_half_width_m : float
        d_z/2 along this axis [m].
    restriction_rate_mps : float
        r [m/s] (0: no restriction).
    disp_lo_m, disp_hi_m : ndarray, shape (N,)
        Kinematic bounds on the displacement p_j − p_{j−1} of each footstep [m]; for y,
        s_j ℓ ∓ d_ay/2.
    disp_nominal_m : ndarray, shape (N,)
        Candidate displacements p̂_j − p̂_{j−1} [m]; candidate positions are
        p_0 + cumsum(disp_nominal_m). A footstep that has already landed (its ramp started at or
        before t_k) is fixed at its nominal displacement: pass its actual one.
    T_ds_s : float
        Double-support duration T_ds [s] (> 0).
    step_periods_s : ndarray, shape (N−1,)
        Time between consecutive ramp starts a_{j+1} − a_j = T_ds + T_ss of step j+1 [s]
        (each >= T_ds). A scalar is broadcast.
    eta : float
        η [1/s].
    sampling_period_s : float
        δ [s].
    control_horizon_s, preview_horizon_s : float
        T_c, T_p [s], whole multiples of δ, T_p >= T_c.
    tail_anchor : str
        ``"candidate"`` (default): footsteps after the decision ones are the planner's absolute
        candidate positions. ``"decision"``: they keep their nominal displacements from the last
        decision footstep (spec §13.1's verified formula).
    """

    support_pos_m: float
    zmp_pos_m: float
    zmp_half_width_m: float
    restriction_rate_mps: float
    disp_lo_m: np.ndarray
    disp_hi_m: np.ndarray
    disp_nominal_m: np.ndarray
    T_ds_s: float
    step_periods_s: np.ndarray | float
    eta: float
    sampling_period_s: float
    control_horizon_s: float
    preview_horizon_s: float
    tail_anchor: str = "candidate"

    def __post_init__(self) -> None:
        owner = "AxisFeasibilityInputs"
        check_number(owner, support_pos_m=self.support_pos_m, zmp_pos_m=self.zmp_pos_m)
        check_positive(
            owner,
            zmp_half_width_m=self.zmp_half_width_m,
            T_ds_s=self.T_ds_s,
            eta=self.eta,
            sampling_period_s=self.sampling_period_s,
            control_horizon_s=self.control_horizon_s,
            preview_horizon_s=self.preview_horizon_s,
        )
        check_number(owner, restriction_rate_mps=self.restriction_rate_mps)
        if self.restriction_rate_mps < 0:
            raise ParameterError(f"{owner}.restriction_rate_mps must be >= 0, got {self.restriction_rate_mps}")
        arrays = {}
        for name in ("disp_lo_m", "disp_hi_m", "disp_nominal_m"):
            arr = np.array(getattr(self, name), dtype=float, ndmin=1)
            if arr.ndim != 1 or arr.size == 0 or not np.all(np.isfinite(arr)):
                raise ParameterError(f"{owner}.{name} must be a non-empty finite 1-D array, got {getattr(self, name)!r}")
            arrays[name] = arr
        n = arrays["disp_lo_m"].size
        if arrays["disp_hi_m"].size != n or arrays["disp_nominal_m"].size != n:
            raise ParameterError(
                f"{owner}: disp_lo_m, disp_hi_m, disp_nominal_m must have the same length, got "
                f"{n}, {arrays['disp_hi_m'].size}, {arrays['disp_nominal_m'].size}"
            )
        if np.any(arrays["disp_lo_m"] > arrays["disp_hi_m"]):
            raise ParameterError(f"{owner}: disp_lo_m must be <= disp_hi_m element-wise")
        periods = np.array(self.step_periods_s, dtype=float, ndmin=1)
        if periods.size == 1 and n != 2:
            periods = np.full(n - 1, periods[0])
        if periods.shape != (n - 1,) or not np.all(np.isfinite(periods)):
            raise ParameterError(f"{owner}.step_periods_s must be a scalar or have shape ({n - 1},), got {self.step_periods_s!r}")
        if np.any(periods < self.T_ds_s - 1e-12):
            raise ParameterError(f"{owner}.step_periods_s must all be >= T_ds_s ({self.T_ds_s}), got {periods}")
        if self.preview_horizon_s < self.control_horizon_s - 1e-12:
            raise ParameterError(
                f"{owner}.preview_horizon_s ({self.preview_horizon_s}) must be >= control_horizon_s ({self.control_horizon_s})"
            )
        for name in ("control_horizon_s", "preview_horizon_s"):
            ratio = getattr(self, name) / self.sampling_period_s
            if abs(ratio - round(ratio)) > 1e-6 or round(ratio) < 1:
                raise ParameterError(
                    f"{owner}.{name} ({getattr(self, name)}) must be a whole multiple of sampling_period_s ({self.sampling_period_s})"
                )
        if self.tail_anchor not in TAIL_ANCHORS:
            raise ParameterError(f"{owner}.tail_anchor must be one of {', '.join(TAIL_ANCHORS)}; got {self.tail_anchor!r}")
        for name, arr in arrays.items():
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        periods.setflags(write=False)
        object.__setattr__(self, "step_periods_s", periods)
        offsets = np.concatenate(([0.0], np.cumsum(periods)))
        offsets.setflags(write=False)
        object.__setattr__(self, "_ramp_offsets_s", offsets)
        object.__setattr__(self, "_reach_hi", arrays["disp_hi_m"] - arrays["disp_nominal_m"])
        object.__setattr__(self, "_reach_lo", arrays["disp_lo_m"] - arrays["disp_nominal_m"])
        eta, T_c, h = self.eta, self.control_horizon_s, self.zmp_half_width_m
        lam = math.exp(-eta * self.sampling_period_s)
        w0 = 1.0 - (1.0 - lam) / (eta * self.sampling_period_s)
        mu_c = math.exp(-eta * T_c)
        box = h * (1.0 - mu_c) - self.restriction_rate_mps * ((1.0 - mu_c) / eta - T_c * mu_c)
        # Constant parts of x_u^M and x_u^m: p_0 + w0 (x_z^k - p_0 -/+ h) +/- box.
        p0, xz = self.support_pos_m, self.zmp_pos_m
        consts = {"w0": w0, "upper": p0 + w0 * (xz - p0 - h) + box, "lower": p0 + w0 * (xz - p0 + h) - box}
        object.__setattr__(self, "_consts", consts)

    @property
    def zmp_gain(self) -> float:
        """w_0, the coefficient of the current ZMP in both bounds (derivations §3.1): the bounds
        move by ``w_0 Δx_z`` when the ZMP moves by Δx_z."""
        return float(self._consts["w0"])  # type: ignore[attr-defined]

    @property
    def num_footsteps(self) -> int:
        """N, the number of footsteps described."""
        return int(self.disp_lo_m.size)

    @property
    def ramp_offsets_s(self) -> np.ndarray:
        """a_j − a_1 [s], shape (N,)."""
        return self._ramp_offsets_s  # type: ignore[attr-defined]

    @property
    def C(self) -> int:
        """Number of control-horizon samples."""
        return int(round(self.control_horizon_s / self.sampling_period_s))

    @property
    def P(self) -> int:
        """Number of preview samples."""
        return int(round(self.preview_horizon_s / self.sampling_period_s))


def _ramp_weights(
    inp: AxisFeasibilityInputs, first_ramp_start_s: np.ndarray, cutoff_s: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """The timing part of the bounds, common to both axes: G (M, N), γ (M, N) and, once footstep 1
    has landed (some a_1 < 0), ρ_j(0) (M, N) (None before)."""
    eta, T_ds = inp.eta, inp.T_ds_s
    a = first_ramp_start_s[:, None] + inp.ramp_offsets_s  # (M, N)
    # G_j = rho_j(0) + (e^{-eta max(a,0)} - e^{-eta min(a+T_ds, T_p)})_+ / (eta T_ds)
    G = np.exp(-eta * np.maximum(a, 0.0))
    G -= np.exp(-eta * np.minimum(a + T_ds, inp.preview_horizon_s))
    np.maximum(G, 0.0, out=G)
    G *= 1.0 / (eta * T_ds)
    rho0 = None
    if first_ramp_start_s.min() < 0.0:
        rho0 = np.clip(a * (-1.0 / T_ds), 0.0, 1.0)
        G += rho0
    cut = cutoff_s[:, None]
    decision = (a > 0.0) & (a < cut)
    if inp.tail_anchor == "candidate":
        # G of the first footstep at or after the cut-off (0 if none; G is non-increasing in j):
        # it carries the jump from the last decision footstep to the first absolute candidate.
        G_next = np.max(np.where(a >= cut, G, 0.0), axis=1, keepdims=True)
        gamma = np.where(decision, G - G_next, 0.0)
    else:
        gamma = np.where(decision, G, 0.0)
    return G, gamma, rho0


def _axis_bounds(
    inp: AxisFeasibilityInputs, G: np.ndarray, gamma: np.ndarray, rho0: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray]:
    """One axis's bounds (M,) from the ramp weights of :func:`_ramp_weights`."""
    nominal = inp.disp_nominal_m
    k = inp._consts  # type: ignore[attr-defined]
    centre = G @ nominal
    if rho0 is not None:
        centre -= k["w0"] * (rho0 @ nominal)  # c_0 = p_0 + sum_j rho_j(0) Δ_j
    upper = centre + gamma @ inp._reach_hi + k["upper"]  # type: ignore[attr-defined]
    lower = centre + gamma @ inp._reach_lo + k["lower"]  # type: ignore[attr-defined]
    return lower, upper


def _bounds_core(
    inp: AxisFeasibilityInputs, first_ramp_start_s: np.ndarray, cutoff_s: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form bounds for first-ramp starts a_1 (M,) and decision cut-offs (M,)."""
    return _axis_bounds(inp, *_ramp_weights(inp, first_ramp_start_s, cutoff_s))


def _check_ramp_starts(first_ramp_start_s: np.ndarray | float) -> np.ndarray:
    a1 = np.atleast_1d(np.asarray(first_ramp_start_s, dtype=float))
    if a1.ndim != 1 or not np.all(np.isfinite(a1)):
        raise ParameterError(f"first_ramp_start_s must be finite, scalar or 1-D, got {first_ramp_start_s!r}")
    return a1


def feasibility_bounds_at(
    inputs: AxisFeasibilityInputs, first_ramp_start_s: np.ndarray | float
) -> tuple[Any, Any]:
    """Exact feasibility bounds (x_u^m, x_u^M) for given start times of the first DS ramp.

    Parameters
    ----------
    inputs : AxisFeasibilityInputs
    first_ramp_start_s : float or ndarray, shape (M,)
        a_1 = t_s − t_k [s], the time from now to the touchdown that starts DS ramp 1. May be
        <= 0 (in double support, footstep 1 landed and fixed). Exact (equal to the QP's region)
        when a_1 and all ramp ends lie on the δ grid; between grid points it is the
        continuous-time interpolation.

    Returns
    -------
    lower, upper : ndarray, shape (M,) (or float for a scalar input)
        x_u^m and x_u^M [m], to be compared with the shifted DCM x_c + ẋ_c/η + w̃/η².
    """
    a1 = _check_ramp_starts(first_ramp_start_s)
    cutoff = np.full(a1.shape, inputs.control_horizon_s - _CLASSIFY_TOL_S)
    lower, upper = _bounds_core(inputs, a1, cutoff)
    if np.ndim(first_ramp_start_s) == 0:
        return float(lower[0]), float(upper[0])
    return lower, upper


def feasibility_bounds_at_axes(
    inputs_x: AxisFeasibilityInputs, inputs_y: AxisFeasibilityInputs, first_ramp_start_s: float
) -> tuple[tuple[float, float], tuple[float, float]]:
    """:func:`feasibility_bounds_at` of both axes at one a_1, their common timing evaluated once.

    Returns
    -------
    (lower_x, upper_x), (lower_y, upper_y) : floats [m]

    Raises
    ------
    ParameterError
        If the two axes do not describe the same footstep timing.
    """
    if not (inputs_x.ramp_offsets_s.shape == inputs_y.ramp_offsets_s.shape
            and np.array_equal(inputs_x.ramp_offsets_s, inputs_y.ramp_offsets_s)
            and (inputs_x.eta, inputs_x.T_ds_s, inputs_x.preview_horizon_s, inputs_x.control_horizon_s,
                 inputs_x.tail_anchor)
            == (inputs_y.eta, inputs_y.T_ds_s, inputs_y.preview_horizon_s, inputs_y.control_horizon_s,
                inputs_y.tail_anchor)):
        raise ParameterError("feasibility_bounds_at_axes: the x and y inputs describe different timings")
    if np.ndim(first_ramp_start_s) != 0:
        raise ParameterError(f"feasibility_bounds_at_axes takes one first_ramp_start_s, got {first_ramp_start_s!r}")
    a1 = _check_ramp_starts(first_ramp_start_s)
    cutoff = np.full(a1.shape, inputs_x.control_horizon_s - _CLASSIFY_TOL_S)
    weights = _ramp_weights(inputs_x, a1, cutoff)
    (lx, ux), (ly, uy) = _axis_bounds(inputs_x, *weights), _axis_bounds(inputs_y, *weights)
    return (float(lx[0]), float(ux[0])), (float(ly[0]), float(uy[0]))


def feasibility_bounds(
    inputs: AxisFeasibilityInputs, delta_lambda: np.ndarray | float
) -> tuple[Any, Any]:
    """Exact feasibility bounds as functions of Δλ = exp(−η (t_s − t_k)) ∈ (0, 1].

    Parameters
    ----------
    inputs : AxisFeasibilityInputs
    delta_lambda : float or ndarray, shape (M,)
        Encoded time to touchdown (1 means touchdown now).

    Returns
    -------
    lower, upper : ndarray, shape (M,) (float for scalar input)
        x_u^m(Δλ), x_u^M(Δλ) [m].
    """
    dl = np.asarray(delta_lambda, dtype=float)
    if np.any(~np.isfinite(dl)) or np.any(dl <= 0) or np.any(dl > 1):
        raise ParameterError(f"delta_lambda must lie in (0, 1], got {delta_lambda!r}")
    return feasibility_bounds_at(inputs, -np.log(dl) / inputs.eta)


def feasibility_breakpoints(inputs: AxisFeasibilityInputs) -> tuple[np.ndarray, np.ndarray]:
    """Values of Δλ where the bounds change slope or jump.

    Returns
    -------
    jumps : ndarray
        Δλ at which a footstep's ramp starts exactly at T_c (it becomes a decision variable for
        larger Δλ); the bounds jump there.
    kinks : ndarray
        Δλ at which a ramp start or end crosses T_p (slope changes).
    All values in (0, 1]; unsorted.
    """
    o = inputs.ramp_offsets_s
    eta = inputs.eta
    a_jump = inputs.control_horizon_s - o
    a_kink = np.concatenate((inputs.preview_horizon_s - o, inputs.preview_horizon_s - inputs.T_ds_s - o))
    jumps = np.exp(-eta * a_jump[a_jump > 0])
    kinks = np.exp(-eta * a_kink[a_kink > 0])
    return jumps, kinks


@dataclass(frozen=True)
class AffineFeasibility:
    """Affine inner estimate of the feasibility region on [Δλ_min, Δλ_max] (spec §13.2).

    ``lower_offset_m + lower_slope_m Δλ >= x_u^m(Δλ)`` and
    ``upper_offset_m + upper_slope_m Δλ <= x_u^M(Δλ)`` for every Δλ in the interval.
    """

    lower_offset_m: float
    lower_slope_m: float
    upper_offset_m: float
    upper_slope_m: float
    delta_lambda_min: float
    delta_lambda_max: float

    def lower(self, delta_lambda: np.ndarray | float) -> np.ndarray | float:
        """Estimated lower bound [m] at Δλ."""
        return self.lower_offset_m + self.lower_slope_m * np.asarray(delta_lambda)

    def upper(self, delta_lambda: np.ndarray | float) -> np.ndarray | float:
        """Estimated upper bound [m] at Δλ."""
        return self.upper_offset_m + self.upper_slope_m * np.asarray(delta_lambda)


def _best_line_below(x: np.ndarray, y: np.ndarray, anchor: float) -> tuple[float, float]:
    """Line a + b x below all points (x_i, y_i), maximal at ``anchor``.

    That line is the edge of the lower convex hull of the points above ``anchor``; the points
    are few (interval ends and breakpoints), so the hull is built in plain Python.
    """
    pts: dict[float, float] = {}
    for xi, yi in zip(x.tolist(), y.tolist()):
        pts[xi] = min(yi, pts.get(xi, math.inf))
    xs = sorted(pts)
    if len(xs) == 1:
        return pts[xs[0]] - _INNER_SAFETY_M, 0.0
    hull: list[tuple[float, float]] = []
    for xi in xs:
        yi = pts[xi]
        while len(hull) >= 2:
            (x1, y1), (x2, y2) = hull[-2], hull[-1]
            if (x2 - x1) * (yi - y1) - (y2 - y1) * (xi - x1) <= 0.0:  # hull[-1] not strictly below
                hull.pop()
            else:
                break
        hull.append((xi, yi))
    edge = next((i for i in range(len(hull) - 1) if anchor <= hull[i + 1][0]), len(hull) - 2)
    (x1, y1), (x2, y2) = hull[edge], hull[edge + 1]
    b = (y2 - y1) / (x2 - x1)
    a = y1 - b * x1
    # Exactly valid at every point (rounding), with a tiny safety against float noise.
    a -= max(0.0, max(a + b * xi - yi for xi, yi in pts.items())) + _INNER_SAFETY_M
    return a, b


def affine_inner_estimate(
    inputs: AxisFeasibilityInputs,
    delta_lambda_min: float,
    delta_lambda_max: float,
    delta_lambda_anchor: float | None = None,
) -> AffineFeasibility:
    """Tightest affine inner approximation of the feasibility bounds on an interval of Δλ.

    The exact bounds are piecewise affine in Δλ; a line is below x_u^M on the interval iff it
    is below it at the interval ends and at both one-sided limits of every breakpoint inside.
    Among those lines this returns the one that is largest at ``delta_lambda_anchor`` (the
    lower convex hull there), and symmetrically for x_u^m. Cost: one vectorised evaluation of
    the closed form at a handful of points.

    Parameters
    ----------
    inputs : AxisFeasibilityInputs
    delta_lambda_min, delta_lambda_max : float
        Admissible interval, 0 < min <= max <= 1.
    delta_lambda_anchor : float, optional
        Where the estimate should be tightest (e.g. the nominal Δλ); default the midpoint.
        Clipped to the interval.

    Returns
    -------
    AffineFeasibility
    """
    lo, hi = float(delta_lambda_min), float(delta_lambda_max)
    if not (0.0 < lo <= hi <= 1.0):
        raise ParameterError(f"need 0 < delta_lambda_min <= delta_lambda_max <= 1, got {lo}, {hi}")
    anchor = 0.5 * (lo + hi) if delta_lambda_anchor is None else min(max(float(delta_lambda_anchor), lo), hi)
    jumps, kinks = feasibility_breakpoints(inputs)
    jumps = jumps[(jumps >= lo) & (jumps <= hi)]
    kinks = kinks[(kinks > lo) & (kinks < hi)]
    pts = np.concatenate(([lo, hi], kinks, jumps, jumps))
    cut = inputs.control_horizon_s
    cutoff = np.full(pts.shape, cut - _CLASSIFY_TOL_S)
    cutoff[pts.size - jumps.size:] = cut + _CLASSIFY_TOL_S  # right limits: the footstep is a decision
    lower, upper = _bounds_core(inputs, -np.log(pts) / inputs.eta, cutoff)
    a_up, b_up = _best_line_below(pts, upper, anchor)
    a_lo_neg, b_lo_neg = _best_line_below(pts, -lower, anchor)
    return AffineFeasibility(
        lower_offset_m=-a_lo_neg,
        lower_slope_m=-b_lo_neg,
        upper_offset_m=a_up,
        upper_slope_m=b_up,
        delta_lambda_min=lo,
        delta_lambda_max=hi,
    )


def zmp_row_weights(eta: float, sampling_period_s: float, control_horizon_s: float) -> np.ndarray:
    r"""Weight of each ZMP row in the feasibility bounds.

    Written with the ZMPs :math:`z_i = x_z^{k+i}` (i = 1..C) instead of their velocities, the
    stability constraint reads :math:`\bar x_u = \text{const} + \sum_i \kappa_i z_i` with

    .. math::

        \kappa_i = \frac{(1-\lambda)^2\lambda^{i-1}}{\eta\delta}\ (i < C),\qquad
        \kappa_C = \frac{(1-\lambda)\lambda^{C-1}}{\eta\delta} - \lambda^C,

    all >= 0, summing to :math:`1 - w_0 - \mu_c`. A known offset :math:`o_i` of the constrained
    point from row i's ZMP (the box bounds :math:`z_i + o_i`) therefore moves both feasibility
    bounds by :math:`-\sum_i \kappa_i o_i` (``docs/derivations.md`` §5).

    Parameters
    ----------
    eta : float
        η [1/s].
    sampling_period_s, control_horizon_s : float
        δ and T_c [s]; T_c a whole multiple of δ.

    Returns
    -------
    ndarray, shape (C,)
        κ_1 .. κ_C, for the rows at t_{k+1} .. t_{k+C} [-].
    """
    check_positive("zmp_row_weights", eta=eta, sampling_period_s=sampling_period_s, control_horizon_s=control_horizon_s)
    ratio = control_horizon_s / sampling_period_s
    if abs(ratio - round(ratio)) > 1e-6:
        raise ParameterError(
            f"zmp_row_weights: control_horizon_s ({control_horizon_s}) must be a whole multiple of "
            f"sampling_period_s ({sampling_period_s})"
        )
    C = int(round(ratio))
    lam = math.exp(-eta * sampling_period_s)
    scale = (1.0 - lam) / (eta * sampling_period_s)
    weights = scale * (1.0 - lam) * lam ** np.arange(C)
    weights[-1] = scale * lam ** (C - 1) - lam**C
    return weights
