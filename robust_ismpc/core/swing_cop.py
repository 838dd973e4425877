r"""The swing leg's shift of the centre of pressure, predicted over the MPC horizon.

A LIP has no legs: its ZMP is where the contact force acts. On a multibody robot whose CoM follows
the LIP, the swing leg's acceleration still changes the robot's angular momentum about the CoM,
and the centre of pressure moves by :math:`-\dot L / (m g)` from the LIP's ZMP. Measured on G1
walking (docs/robots.md), this shift is proportional to the swing foot's horizontal acceleration,
:math:`\Delta p \approx \kappa\, a_{swing}` with :math:`\kappa` a robot constant
(:attr:`~robust_ismpc.core.params.RobotParams.swing_cop_gain_s2`).

The swing trajectories are known in advance: a quintic from where each foot lifts off to its
footstep (:mod:`robust_ismpc.core.swing`). :func:`swing_acceleration` evaluates their horizontal
acceleration at the MPC's sample times, so that the MPC can keep :math:`p + \kappa a` (what the
robot's feet must carry) inside the ZMP box instead of :math:`p` alone; :func:`swing_cop_offset`
gives that shift along the walking direction, the part the MPC uses.
"""

from __future__ import annotations

import numpy as np

from .footsteps import FootstepPlan
from .swing import SwingState


def _rest_to_rest(u: np.ndarray, T_s: np.ndarray | float) -> np.ndarray:
    """Acceleration per metre of a rest-to-rest quintic of duration ``T_s`` at phase ``u`` [1/s²]."""
    return (60.0 * u - 180.0 * u * u + 120.0 * u * u * u) / T_s**2


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
    u = np.asarray(tau_s, dtype=float) / T
    u2, u3 = u * u, u * u * u
    # The quintic's acceleration, written on the three boundary terms (u = τ / T).
    by_displacement = _rest_to_rest(u, T)
    by_velocity = (-36.0 * u + 96.0 * u2 - 60.0 * u3) / T
    by_acceleration = 1.0 - 9.0 * u + 18.0 * u2 - 10.0 * u3
    acc = (np.outer(by_displacement, np.asarray(p1, float) - p0) + np.outer(by_velocity, v0)
           + np.outer(by_acceleration, a0))
    acc[u >= 1.0] = 0.0
    return acc


def _swing_acceleration_and_step(
    plan: FootstepPlan, t_s: float, times_s: np.ndarray, feet: dict[int, SwingState]
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`swing_acceleration` and the step index at each time."""
    times = np.asarray(times_s, dtype=float)
    acc = np.zeros((times.size, 2))
    j = plan.step_at(times)
    start = plan.ss_start_s[j]
    duration = plan.T_ss_s[j]
    u = (times - start) / duration
    swinging = (u >= 0.0) & (u < 1.0) & (j >= 2)
    if not swinging.any():
        return acc, j
    j_now = plan.step_at(t_s)
    current = swinging & (j == j_now) & (t_s >= plan.ss_start_s[j_now])
    if current.any():
        foot = feet[int(plan.side[j_now])]
        rem = float(plan.touchdown_s[j_now] - t_s)
        if rem > 0.0:
            acc[current] = quintic_acceleration(
                foot.pos_m[:2], foot.vel_mps[:2], foot.acc_mps2[:2], plan.pos_m[j_now], rem, times[current] - t_s
            )
    later = swinging & ~current
    if later.any():
        jl = j[later]
        lift = plan.pos_m[np.maximum(jl - 2, 1)]
        first = jl - 2 < 1
        if first.any():
            lift[first] = np.array([feet[int(side)].pos_m[:2] for side in plan.side[jl[first]]])
        ul, T = u[later], duration[later]
        acc[later] = (plan.pos_m[jl] - lift) * _rest_to_rest(ul, T)[:, None]
    return acc, j


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
    return _swing_acceleration_and_step(plan, t_s, times_s, feet)[0]


def swing_cop_offset(
    plan: FootstepPlan, t_s: float, times_s: np.ndarray, feet: dict[int, SwingState], gain_s2: float
) -> np.ndarray:
    """Predicted CoP shift ``κ a_fwd h`` at ``times_s``, shape (n, 2) [m] (world frame).

    ``a_fwd`` is the swing foot's acceleration (:func:`swing_acceleration`) along the heading ``h``
    of the stance footstep, the frame of the single-support ZMP box (the shift is 0 in double
    support). Only the forward part is used: G1's lateral CoP shift is smaller and less regular
    (walking sideways, κ_y = 0.0049 s² explains 0.92 → 0.70 cm rms against 2.6 → 0.6 cm
    forward), and applying κ laterally too made its 30 s sideways walk fall at 24-27 s
    (docs/robots.md).
    """
    acc, j = _swing_acceleration_and_step(plan, t_s, times_s, feet)
    yaw = plan.yaw_rad[np.maximum(j - 1, 0)]
    heading = np.column_stack([np.cos(yaw), np.sin(yaw)])
    forward = np.einsum("ij,ij->i", acc, heading)
    return gain_s2 * forward[:, None] * heading


__all__ = ["quintic_acceleration", "swing_acceleration", "swing_cop_offset"]
