r"""The swing leg's shift of the centre of pressure, predicted over the MPC horizon.

A LIP has no legs: its ZMP is where the contact force acts. On a multibody robot whose CoM follows
the LIP, the swing leg's acceleration still changes the robot's angular momentum about the CoM,
and the centre of pressure moves by :math:`-\dot L / (m g)` from the LIP's ZMP. Measured on G1
walking (docs/robots.md), this shift is proportional to the swing foot's horizontal acceleration,
:math:`\Delta p \approx \kappa\, a_{swing}` with :math:`\kappa` a robot constant
(:attr:`~robust_ismpc.params.RobotParams.swing_cop_gain_s2`).

The swing trajectories are known in advance: a quintic from where each foot lifts off to its
footstep (:mod:`robust_ismpc.swing`). :func:`swing_acceleration` evaluates their horizontal
acceleration at the MPC's sample times, so that the MPC can keep :math:`p + \kappa a` (what the
robot's feet must carry) inside the ZMP box instead of :math:`p` alone; :func:`swing_cop_offset`
gives that shift along the walking direction, the part the MPC uses.
"""

from __future__ import annotations

import numpy as np

from .footsteps import FootstepPlan
from .swing import SwingState


def quintic_acceleration(
    p0: np.ndarray, v0: np.ndarray, a0: np.ndarray, p1: np.ndarray, T_s: float, tau_s: np.ndarray
) -> np.ndarray:
    """Acceleration of the quintic from (p0, v0, a0) to (p1, 0, 0) over ``T_s``, at times ``tau_s``.

    Parameters
    ----------
    p0, v0, a0, p1 : ndarray, shape (2,)
        Start position [m], velocity [m/s], acceleration [m/s²] and end position [m].
    T_s : float
        Duration [s], > 0.
    tau_s : ndarray, shape (n,)
        Times from the start [s]; 0 acceleration at and after ``T_s`` (the foot has landed).

    Returns
    -------
    ndarray, shape (n, 2)
    """
    T = float(T_s)
    d = p1 - p0 - v0 * T - 0.5 * a0 * T**2
    dv = -v0 - a0 * T
    c3 = (10 * d - 4 * dv * T - 0.5 * a0 * T**2) / T**3
    c4 = (-15 * d + 7 * dv * T + a0 * T**2) / T**4
    c5 = (6 * d - 3 * dv * T - 0.5 * a0 * T**2) / T**5
    t = np.asarray(tau_s, dtype=float)[:, None]
    acc = a0 + 6 * c3 * t + 12 * c4 * t**2 + 20 * c5 * t**3
    return np.where(t < T, acc, 0.0)


def swing_acceleration(
    plan: FootstepPlan, t_s: float, times_s: np.ndarray, feet: dict[int, SwingState]
) -> np.ndarray:
    """Horizontal acceleration of the swing foot at ``times_s`` (0 in double support).

    Parameters
    ----------
    plan : FootstepPlan
        The plan (landed footsteps and the latest optimal ones in ``pos_m``).
    t_s : float
        Current time [s].
    times_s : ndarray, shape (n,)
        Increasing times at or after ``t_s`` [s].
    feet : dict of int -> SwingState
        Current state of each foot (keys ``LEFT`` = +1 and -1), as the controller holds it.

    Returns
    -------
    ndarray, shape (n, 2)
        [m/s²], world frame. The swing under way continues from the foot's current state to its
        footstep at the planned touchdown; later swings are rest-to-rest quintics from the
        footstep two steps back (the foot's current position for its first swing).
    """
    times = np.asarray(times_s, dtype=float)
    acc = np.zeros((times.size, 2))
    j = plan.step_at(times)
    start = plan.ss_start_s[j]
    duration = plan.T_ss_s[j]
    u = (times - start) / duration
    swinging = (u >= 0.0) & (u < 1.0) & (j >= 2)
    j_now = plan.step_at(t_s)
    current = swinging & (j == j_now) & (t_s >= start)
    if np.any(current):
        foot = feet[int(plan.side[j_now])]
        rem = float(plan.touchdown_s[j_now] - t_s)
        if rem > 0.0:
            acc[current] = quintic_acceleration(
                foot.pos_m[:2], foot.vel_mps[:2], foot.acc_mps2[:2], plan.pos_m[j_now], rem, times[current] - t_s
            )
    later = swinging & ~current
    if np.any(later):
        jl = j[later]
        lift = np.where((jl - 2 >= 1)[:, None], plan.pos_m[np.maximum(jl - 2, 1)], np.nan)
        first = jl - 2 < 1
        if np.any(first):
            lift[first] = np.array([feet[int(s)].pos_m[:2] for s in plan.side[jl[first]]])
        ul, T = u[later], duration[later]
        profile = (60.0 * ul - 180.0 * ul**2 + 120.0 * ul**3) / T**2
        acc[later] = (plan.pos_m[jl] - lift) * profile[:, None]
    return acc


def swing_cop_offset(
    plan: FootstepPlan, t_s: float, times_s: np.ndarray, feet: dict[int, SwingState], gain_s2: float
) -> np.ndarray:
    """Predicted CoP shift ``κ a_fwd h`` at ``times_s``, shape (n, 2) [m] (world frame).

    ``a_fwd`` is the swing foot's acceleration along the heading ``h`` of the ZMP box at each
    time (:func:`swing_acceleration`). Only the forward part is used: G1's lateral CoP shift
    is smaller and less regular (walking sideways, κ_y = 0.0049 s² explains 0.92 → 0.70 cm rms
    against 2.6 → 0.6 cm forward), and applying κ laterally too made its 30 s sideways walk fall
    at 24-27 s (docs/robots.md).
    """
    acc = swing_acceleration(plan, t_s, times_s, feet)
    yaw = plan.centre_yaw(np.asarray(times_s, dtype=float))
    heading = np.column_stack([np.cos(yaw), np.sin(yaw)])
    forward = np.sum(acc * heading, axis=1)
    return gain_s2 * forward[:, None] * heading


__all__ = ["quintic_acceleration", "swing_acceleration", "swing_cop_offset"]
