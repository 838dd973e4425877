"""Reference implementations for the feasibility tests, written from the QP's definition.

:func:`build_axis_program` writes the per-axis IS-MPC constraint set as an LP and
:func:`feasibility_bounds_lp` solves it with scipy/HiGHS, independently of the closed form of
:mod:`robust_ismpc.core.feasibility`, so that the two can be compared; :func:`straight_gait_inputs`
builds the inputs of a straight walk.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.optimize

from robust_ismpc.core.feasibility import _CLASSIFY_TOL_S, AxisFeasibilityInputs
from robust_ismpc.exceptions import ParameterError, SolverError


@dataclass(frozen=True)
class AxisProgram:
    """The per-axis IS-MPC constraint set at one timing, in LP form (for verification).

    Variables v = (ẋ_z^k … ẋ_z^{k+C−1} [m/s], positions of the D decision footsteps [m]).

    Attributes
    ----------
    A_ub : ndarray, shape (2C + 2D, C + D)
    b_ub : ndarray, shape (2C + 2D,)
        ZMP rows (both sides, restricted) and kinematic rows: ``A_ub v <= b_ub``.
    dcm_row : ndarray, shape (C + D,)
    dcm_offset_m : float
        The stability constraint reads ``x̄_u = dcm_row @ v + dcm_offset_m``.
    num_zmp_vel : int
        C.
    decision_index : ndarray of int, shape (D,)
        Indices (0-based, footstep j = index + 1) of the decision footsteps.
    """

    A_ub: np.ndarray
    b_ub: np.ndarray
    dcm_row: np.ndarray
    dcm_offset_m: float
    num_zmp_vel: int
    decision_index: np.ndarray


def build_axis_program(
    inputs: AxisFeasibilityInputs, first_ramp_start_s: float, zmp_offset_m: np.ndarray | None = None
) -> AxisProgram:
    """Build the per-axis QP constraint set (sampled rows, position-form stability) as an LP.

    Written from the QP's definition (spec §2.3, §3.2, §4, §5, §6.3), not from the closed
    form, so that the two can be compared.

    Parameters
    ----------
    inputs : AxisFeasibilityInputs
    first_ramp_start_s : float
        a_1 = t_s − t_k [s].
    zmp_offset_m : ndarray, shape (C,), optional
        Offset o_i of the constrained point from the ZMP on the rows at t_{k+1} .. t_{k+C}
        [m]: the box bounds x_z + o (as ``IsmpcQp.build``'s ``zmp_offset_m`` on one axis).
    """
    d = inputs.sampling_period_s
    eta = inputs.eta
    C, P = inputs.C, inputs.P
    N = inputs.num_footsteps
    a = float(first_ramp_start_s) + inputs.ramp_offsets_s
    decision = np.flatnonzero((a > 0.0) & (a < inputs.control_horizon_s - _CLASSIFY_TOL_S))
    D = decision.size
    # Footstep positions p_0..p_N as affine functions of the decision positions q: p = P0 + Pq q.
    P0 = np.zeros(N + 1)
    Pq = np.zeros((N + 1, D))
    P0[0] = inputs.support_pos_m
    candidates = inputs.support_pos_m + np.concatenate(([0.0], np.cumsum(inputs.disp_nominal_m)))
    last_dec = int(decision[-1]) + 1 if D else N + 1  # footstep number of the last decision
    for j in range(1, N + 1):
        if D and decision[0] + 1 <= j <= last_dec:
            Pq[j, j - 1 - int(decision[0])] = 1.0
        elif j > last_dec and inputs.tail_anchor == "candidate":
            P0[j] = candidates[j]
        else:  # landed footsteps, plans without decisions, tails anchored to the decision
            P0[j] = P0[j - 1] + inputs.disp_nominal_m[j - 1]
            Pq[j] = Pq[j - 1]
    # Centre at sample times t_{k+i}, i = 0..P: c = p_0 + sum_j rho_j(t) (p_j - p_{j-1}).
    t = d * np.arange(P + 1)
    rho = np.clip((t[:, None] - a[None, :]) / inputs.T_ds_s, 0.0, 1.0)  # (P+1, N)
    c0 = P0[0] + rho @ np.diff(P0)  # (P+1,)
    cq = rho @ np.diff(Pq, axis=0)  # (P+1, D)
    # ZMP rows at t_{k+i+1}: z = x_z + d * L u.
    L = d * np.tril(np.ones((C, C)))
    half = inputs.zmp_half_width_m - inputs.restriction_rate_mps * d * np.arange(1, C + 1)
    A_zmp_up = np.hstack((L, -cq[1:C + 1]))
    b_zmp_up = half + c0[1:C + 1] - inputs.zmp_pos_m
    A_zmp_dn = np.hstack((-L, cq[1:C + 1]))
    b_zmp_dn = half - c0[1:C + 1] + inputs.zmp_pos_m
    if zmp_offset_m is not None:
        offset = np.asarray(zmp_offset_m, dtype=float)
        if offset.shape != (C,) or not np.all(np.isfinite(offset)):
            raise ParameterError(f"zmp_offset_m must be a finite array of shape ({C},), got shape {offset.shape}")
        b_zmp_up = b_zmp_up - offset
        b_zmp_dn = b_zmp_dn + offset
    # Kinematic rows: lo_j <= p_j - p_{j-1} <= hi_j for decision footsteps.
    A_kin, b_kin = [], []
    for j0 in decision.tolist():
        j = j0 + 1
        row = np.concatenate((np.zeros(C), Pq[j] - Pq[j - 1]))
        off = P0[j] - P0[j - 1]
        A_kin += [row, -row]
        b_kin += [inputs.disp_hi_m[j0] - off, -(inputs.disp_lo_m[j0] - off)]
    A_ub = np.vstack([A_zmp_up, A_zmp_dn] + ([np.array(A_kin)] if A_kin else []))
    b_ub = np.concatenate([b_zmp_up, b_zmp_dn, np.array(b_kin)])
    # Stability (spec §6.3): x̄_u = (1 − λ^C) x_z^k + Σ_i [(1−λ)λ^i/η − δλ^C] u_i + T.
    lam = math.exp(-eta * d)
    coef_u = (1 - lam) * lam ** np.arange(C) / eta - d * lam**C
    i = np.arange(C, P)
    beta = (1 - lam) / (eta * d) - lam
    # T = Σ_{i=C}^{P−1} λ^i [(1−λ) x̃^i + β (x̃^{i+1} − x̃^i)] + λ^P x̃^P, x̃^i = c0_i + cq_i q.
    wt = np.zeros(P + 1)
    wt[i] += lam**i * (1 - lam - beta)
    wt[i + 1] += lam**i * beta
    wt[P] += lam**P
    dcm_row = np.concatenate((coef_u, wt @ cq))
    dcm_offset = (1 - lam**C) * inputs.zmp_pos_m + float(wt @ c0)
    return AxisProgram(A_ub=A_ub, b_ub=b_ub, dcm_row=dcm_row, dcm_offset_m=dcm_offset, num_zmp_vel=C,
                       decision_index=decision)


def feasibility_bounds_lp(
    inputs: AxisFeasibilityInputs, first_ramp_start_s: float, zmp_offset_m: np.ndarray | None = None
) -> tuple[float, float]:
    """Feasibility bounds by linear programming on :func:`build_axis_program` (verification;
    ``zmp_offset_m`` as there).

    Returns
    -------
    lower, upper : float
        min and max of the shifted DCM over the QP's constraint set [m].

    Raises
    ------
    SolverError
        If the LP solver fails (e.g. the restricted box is empty).
    """
    prog = build_axis_program(inputs, first_ramp_start_s, zmp_offset_m)
    out = []
    for sign in (1.0, -1.0):
        res = scipy.optimize.linprog(sign * prog.dcm_row, A_ub=prog.A_ub, b_ub=prog.b_ub,
                                     bounds=(None, None), method="highs",
                                     options={"primal_feasibility_tolerance": 1e-10,
                                              "dual_feasibility_tolerance": 1e-10})
        if res.status != 0:
            raise SolverError(f"feasibility LP failed: {res.message}", problem=prog, exitflag=res.status)
        out.append(sign * res.fun + prog.dcm_offset_m)
    return out[0], out[1]


def straight_gait_inputs(
    axis: str,
    *,
    eta: float,
    sampling_period_s: float,
    control_horizon_s: float,
    preview_horizon_s: float,
    T_ss_s: float,
    T_ds_s: float,
    num_footsteps: int,
    zmp_box_m: float,
    kin_box_m: float,
    step_length_m: float = 0.0,
    foot_spacing_m: float = 0.0,
    next_foot_sign: int = 1,
    support_pos_m: float = 0.0,
    zmp_pos_m: float | None = None,
    restriction_rate_mps: float = 0.0,
    tail_anchor: str = "candidate",
) -> AxisFeasibilityInputs:
    """Inputs for a regular straight gait along one axis (θ ≡ 0), in the support-foot frame.

    Sagittal (``axis="x"``): every candidate displacement is ``step_length_m`` and the
    kinematic bounds are ±``kin_box_m``/2 (spec §5). Coronal (``axis="y"``): footstep j
    has side s_j = ``next_foot_sign`` · (−1)^{j−1} (+1 left), candidate displacement s_j ℓ and
    bounds s_j ℓ ∓ ``kin_box_m``/2.

    Parameters
    ----------
    axis : str
        ``"x"`` or ``"y"``.
    eta, sampling_period_s, control_horizon_s, preview_horizon_s : float
        η [1/s], δ, T_c, T_p [s].
    T_ss_s, T_ds_s : float
        Nominal single and double support [s] of the later steps.
    num_footsteps : int
        N, footsteps after the current support.
    zmp_box_m, kin_box_m : float
        Full sides d_z and d_a along the axis [m].
    step_length_m : float
        Sagittal candidate displacement [m] (x only).
    foot_spacing_m : float
        ℓ [m] (y only).
    next_foot_sign : int
        +1 if footstep 1 (the swing foot) is a left foot, −1 if right (y only).
    support_pos_m : float
        p_0 [m].
    zmp_pos_m : float, optional
        x_z^k [m]; default the support position.
    restriction_rate_mps : float
        r [m/s].
    tail_anchor : str
        See :class:`AxisFeasibilityInputs`.
    """
    if axis not in ("x", "y"):
        raise ParameterError(f"axis must be 'x' or 'y', got {axis!r}")
    if not isinstance(num_footsteps, (int, np.integer)) or num_footsteps < 1:
        raise ParameterError(f"num_footsteps must be an integer >= 1, got {num_footsteps!r}")
    if next_foot_sign not in (1, -1):
        raise ParameterError(f"next_foot_sign must be +1 or -1, got {next_foot_sign!r}")
    if axis == "x":
        nominal: np.ndarray = np.full(num_footsteps, float(step_length_m))
        centre = np.zeros(num_footsteps)
    else:
        sides = next_foot_sign * (-1.0) ** np.arange(num_footsteps)
        nominal = np.asarray(sides * foot_spacing_m, dtype=float)
        centre = nominal
    return AxisFeasibilityInputs(
        support_pos_m=support_pos_m,
        zmp_pos_m=support_pos_m if zmp_pos_m is None else zmp_pos_m,
        zmp_half_width_m=zmp_box_m / 2,
        restriction_rate_mps=restriction_rate_mps,
        disp_lo_m=centre - kin_box_m / 2,
        disp_hi_m=centre + kin_box_m / 2,
        disp_nominal_m=nominal,
        T_ds_s=T_ds_s,
        step_periods_s=T_ss_s + T_ds_s,
        eta=eta,
        sampling_period_s=sampling_period_s,
        control_horizon_s=control_horizon_s,
        preview_horizon_s=preview_horizon_s,
        tail_anchor=tail_anchor,
    )
