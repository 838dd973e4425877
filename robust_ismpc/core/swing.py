r"""Swing-foot trajectories that can be re-timed and re-targeted mid-swing (spec §10).

Horizontal position and yaw follow a quintic that is re-planned every control tick from the
current swing state (position, velocity, acceleration) to the current target at rest at the
current touchdown time. With an unchanged target and touchdown this reproduces one rest-to-rest
quintic exactly (a quintic is determined by its boundary conditions); when the MPC moves the
footstep or step timing adaptation moves the touchdown, the trajectory stays C²-continuous.

The height follows :math:`z = 16 h s^2 (1-s)^2` of a progress variable :math:`s \in [0, 1]` that
advances by :math:`(1-s)\,\Delta t / T_{rem}`, so it reaches 1 exactly at the (possibly
re-timed) touchdown: a shorter step makes the foot come down sooner, continuously.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass
class SwingState:
    """Swing-foot state (world frame).

    Attributes
    ----------
    pos_m : ndarray, shape (3,)
        Horizontal position and height [m].
    vel_mps, acc_mps2 : ndarray, shape (3,)
        Velocity and acceleration [m/s], [m/s^2].
    yaw_rad, yaw_rate_radps, yaw_acc_radps2 : float
        Yaw and its derivatives.
    progress : float
        Height-profile progress s in [0, 1].
    """

    pos_m: np.ndarray
    vel_mps: np.ndarray
    acc_mps2: np.ndarray
    yaw_rad: float
    yaw_rate_radps: float = 0.0
    yaw_acc_radps2: float = 0.0
    progress: float = 0.0

    @classmethod
    def at_rest(cls, pos_xy_m: np.ndarray, yaw_rad: float) -> SwingState:
        """A foot standing at ``pos_xy_m`` (height 0) with ``yaw_rad``."""
        pos = np.zeros(3)
        pos[:2] = pos_xy_m
        return cls(pos_m=pos, vel_mps=np.zeros(3), acc_mps2=np.zeros(3), yaw_rad=float(yaw_rad))


def quintic_step(p0: Any, v0: Any, a0: Any, p1: Any, T_s: float, dt_s: float) -> tuple[Any, Any, Any]:
    """Evaluate at ``dt_s`` the quintic from (p0, v0, a0) to (p1, 0, 0) over ``T_s``.

    The states are floats, or arrays that broadcast elementwise. Returns position, velocity,
    acceleration at ``dt_s``; when ``dt_s >= T_s`` the end state is returned.
    """
    if dt_s >= T_s:
        zero = 0.0 * p0
        return p1 + zero, zero, zero
    T = T_s
    d = p1 - p0 - v0 * T - 0.5 * a0 * T**2
    dv = -v0 - a0 * T
    da = -a0
    c3 = (10 * d - 4 * dv * T + 0.5 * da * T**2) / T**3
    c4 = (-15 * d + 7 * dv * T - da * T**2) / T**4
    c5 = (6 * d - 3 * dv * T + 0.5 * da * T**2) / T**5
    t = dt_s
    pos = p0 + v0 * t + 0.5 * a0 * t**2 + c3 * t**3 + c4 * t**4 + c5 * t**5
    vel = v0 + a0 * t + 3 * c3 * t**2 + 4 * c4 * t**3 + 5 * c5 * t**4
    acc = a0 + 6 * c3 * t + 12 * c4 * t**2 + 20 * c5 * t**3
    return pos, vel, acc


def advance_swing(
    state: SwingState,
    target_xy_m: np.ndarray,
    target_yaw_rad: float,
    time_to_touchdown_s: float,
    dt_s: float,
    height_m: float,
) -> SwingState:
    """Advance a swing foot by ``dt_s`` towards its target landing at ``time_to_touchdown_s``.

    Parameters
    ----------
    state : SwingState
        State at the current tick.
    target_xy_m : ndarray, shape (2,)
        Landing position [m] (may change from tick to tick).
    target_yaw_rad : float
        Landing yaw [rad].
    time_to_touchdown_s : float
        Remaining swing time from the current tick [s] (may change under timing adaptation).
    dt_s : float
        Tick [s].
    height_m : float
        Apex height of the nominal profile [m].
    """
    T_rem = max(time_to_touchdown_s, 0.0)
    if T_rem < dt_s + 1e-9:  # last tick (absorbs rounding of the touchdown time): land exactly
        T_rem = dt_s
    # x, y and yaw: one quintic each, in floats (three-element arrays cost more in numpy calls)
    x, y = (quintic_step(float(state.pos_m[i]), float(state.vel_mps[i]), float(state.acc_mps2[i]),
                         float(target_xy_m[i]), T_rem, dt_s) for i in range(2))
    yaw = quintic_step(state.yaw_rad, state.yaw_rate_radps, state.yaw_acc_radps2, float(target_yaw_rad),
                       T_rem, dt_s)
    p, v, a = zip(x, y, yaw)
    s = 1.0 if dt_s >= T_rem else state.progress + (1.0 - state.progress) * dt_s / T_rem
    z = 16.0 * height_m * s**2 * (1.0 - s) ** 2
    s_rate = 0.0 if dt_s >= T_rem else (1.0 - s) / (T_rem - dt_s)
    dz = 16.0 * height_m * (2 * s * (1 - s) ** 2 - 2 * s**2 * (1 - s)) * s_rate
    return SwingState(
        pos_m=np.array([p[0], p[1], z]), vel_mps=np.array([v[0], v[1], dz]), acc_mps2=np.array([a[0], a[1], 0.0]),
        yaw_rad=float(p[2]), yaw_rate_radps=float(v[2]), yaw_acc_radps2=float(a[2]),
        progress=s,
    )
