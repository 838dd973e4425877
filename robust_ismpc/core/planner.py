r"""Candidate footsteps from a velocity command (spec §9).

A unicycle-like template (spec eq. 2) is integrated under the commanded velocities
:math:`(v_x, v_y, \omega)` (in the template's own frame). Footstep yaws come from the
orientation QP of §9.3 and positions from the position QP of §9.4. Both QPs are separable in
the increments :math:`\theta^j-\theta^{j-1}` and :math:`p^j-p^{j-1}` (each increment appears in
one cost term and one constraint), so their exact solutions are the clipped increments: for the
orientation, clip to :math:`\pm\theta_{max}`; for the positions, rotate the desired increment
into the previous footstep's frame, clip it to the kinematic box and rotate back (a rotation is an
isometry, so this is the Euclidean projection). ``tests/test_planner.py`` checks this against a
generic QP solver.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..exceptions import ParameterError
from .footsteps import LEFT, RIGHT, VIRTUAL, FootstepPlan
from .params import RobotParams

VelocityCommand = Callable[[float], tuple[float, float, float]]


@dataclass(frozen=True)
class WalkCommand:
    """A constant velocity command.

    Attributes
    ----------
    vx_mps, vy_mps : float
        Forward and lateral speed in the walking frame [m/s].
    omega_radps : float
        Turning rate [rad/s].
    """

    vx_mps: float = 0.0
    vy_mps: float = 0.0
    omega_radps: float = 0.0

    def __post_init__(self) -> None:
        for name in ("vx_mps", "vy_mps", "omega_radps"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ParameterError(f"WalkCommand.{name} must be a finite number, got {value!r}")

    def __call__(self, t_s: float) -> tuple[float, float, float]:
        return (self.vx_mps, self.vy_mps, self.omega_radps)


def rotation(yaw_rad: float | np.ndarray) -> np.ndarray:
    """2-D rotation matrix (or stack of them, shape (..., 2, 2)) for ``yaw_rad``."""
    if isinstance(yaw_rad, float):  # one angle (the per-cycle case): no stacking
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        return np.array([[c, -s], [s, c]])
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


#: Least lateral gap between the inner edges of the two soles that a footstep may leave [m].
SOLE_CLEARANCE_M = 0.01


def kinematic_box(robot: RobotParams, side: int) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of footstep j relative to footstep j-1, in footstep j-1's frame (spec §5).

    The box of side lengths (``kin_box_x_m``, ``kin_box_y_m``) centred ℓ to the side, with its
    inner lateral side moved out, if needed, so that the sole centres are at least
    ``sole_width_m + SOLE_CLEARANCE_M`` apart (at most ℓ): a step that crosses or touches the
    other foot collides with it on a real robot.

    Parameters
    ----------
    side : int
        +1 if footstep j is a left foot, -1 if right.

    Returns
    -------
    lower, upper : ndarray, shape (2,)
    """
    lower = np.array([-0.5 * robot.kin_box_x_m, robot.foot_spacing_m - 0.5 * robot.kin_box_y_m])
    upper = np.array([0.5 * robot.kin_box_x_m, robot.foot_spacing_m + 0.5 * robot.kin_box_y_m])
    # the soles must not overlap: inner edges at least SOLE_CLEARANCE_M apart (never more than ℓ)
    lower[1] = max(lower[1], min(robot.foot_spacing_m, robot.sole_width_m + SOLE_CLEARANCE_M))
    if side < 0:  # mirror the lateral bounds for a right foot
        lower[1], upper[1] = -upper[1], -lower[1]
    return lower, upper


def kinematic_bounds(robot: RobotParams, sides: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`kinematic_box` of each footstep of a sequence.

    Parameters
    ----------
    sides : ndarray, shape (n,)
        +1 for a left footstep, -1 for a right one.

    Returns
    -------
    lower, upper : ndarray, shape (n, 2)
    """
    left = (np.asarray(sides).reshape(-1) > 0)[:, None]
    (left_lo, left_hi), (right_lo, right_hi) = _side_boxes(robot)
    return np.where(left, left_lo, right_lo), np.where(left, left_hi, right_hi)


@functools.lru_cache(maxsize=16)
def _side_boxes(robot: RobotParams) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """:func:`kinematic_box` of a left and of a right footstep, once per robot (read-only: the
    MPC asks for them every cycle)."""
    boxes = (kinematic_box(robot, 1), kinematic_box(robot, -1))
    for box in boxes:
        for bound in box:
            bound.setflags(write=False)
    return boxes


def command_limits(robot: RobotParams) -> dict[str, tuple[float, str]]:
    """Largest |command| per :class:`WalkCommand` field that the footstep planner can realise,
    with the reason.

    The planner clips each step to the kinematic box and each turn to the largest yaw step, so
    faster commands are walked at these speeds.

    Returns
    -------
    dict
        ``vx_mps``, ``vy_mps`` [m/s] and ``omega_radps`` [rad/s] -> (limit, why).
    """
    T = robot.T_step_s
    lower, upper = kinematic_box(robot, 1)
    sideways_m = float(0.5 * (upper[1] - lower[1]))  # per step: the soles may not come closer than the box allows
    return {
        "vx_mps": (0.5 * robot.kin_box_x_m / T, f"{0.5 * robot.kin_box_x_m:g} m forward per {T:g} s step"),
        "vy_mps": (sideways_m / T, f"{sideways_m:.3g} m sideways per {T:g} s step"),
        "omega_radps": (robot.max_yaw_step_rad / T, f"{robot.max_yaw_step_rad:g} rad per {T:g} s step"),
    }


def plan_footsteps(
    robot: RobotParams,
    command: VelocityCommand,
    duration_s: float,
    left_foot_m: np.ndarray,
    right_foot_m: np.ndarray,
    yaw_rad: float = 0.0,
    first_support: int = RIGHT,
    initial_stand_s: float | None = None,
    initial_ds_s: float | None = None,
    integration_step_s: float = 0.01,
) -> FootstepPlan:
    """Candidate footsteps covering at least ``duration_s`` seconds of walking.

    Parameters
    ----------
    robot : RobotParams
        Gait and kinematic parameters.
    command : callable
        t [s] -> (vx [m/s], vy [m/s], ω [rad/s]), the reference velocities of the template.
    duration_s : float
        Time the plan must cover (include the MPC preview horizon) [s].
    left_foot_m, right_foot_m : ndarray, shape (2,)
        Initial sole positions [m]; both feet start with yaw ``yaw_rad``.
    first_support : int
        Which foot (+1 left, -1 right) carries the first single support.
    initial_stand_s : float, optional
        Time the ZMP box stays at the midpoint of the feet before the walk starts (default two
        step durations). Starting from rest needs it: the DCM at the midpoint is outside the
        feasibility region if the box starts moving towards the first support foot at once.
    initial_ds_s : float, optional
        Duration of the initial double support in which the ZMP box moves from the midpoint of
        the feet to the first support foot (default one step duration).
    """
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise ParameterError(f"duration_s must be a finite number > 0, got {duration_s!r}")
    if first_support not in (LEFT, RIGHT):
        raise ParameterError(f"first_support must be +1 (left) or -1 (right), got {first_support!r}")
    left = np.asarray(left_foot_m, dtype=float).reshape(2)
    right = np.asarray(right_foot_m, dtype=float).reshape(2)
    if not (np.all(np.isfinite(left)) and np.all(np.isfinite(right)) and math.isfinite(yaw_rad)):
        raise ParameterError(f"initial soles and yaw must be finite, got {left_foot_m!r}, {right_foot_m!r}, {yaw_rad!r}")
    t_stand = 2.0 * robot.T_step_s if initial_stand_s is None else float(initial_stand_s)
    t_ds0 = robot.T_step_s if initial_ds_s is None else float(initial_ds_s)
    if not (math.isfinite(t_stand) and t_stand >= 0):
        raise ParameterError(f"initial_stand_s must be a finite number >= 0, got {initial_stand_s!r}")
    if not (math.isfinite(t_ds0) and t_ds0 > 0):
        raise ParameterError(f"initial_ds_s must be a finite number > 0, got {initial_ds_s!r}")
    t_start = t_stand + t_ds0

    # Step timing: step 1 = standing on the midpoint, then the initial double support; then
    # regular steps.
    n_regular = int(math.ceil(max(duration_s - t_start, 0.0) / robot.T_step_s)) + 1
    n = n_regular + 2  # virtual footstep 0 and first support footstep 1
    T_ss = np.full(n, robot.T_ss_s)
    T_ds = np.full(n, robot.T_ds_s)
    T_ss[0], T_ds[0] = np.nan, np.nan
    T_ss[1], T_ds[1] = t_stand, t_ds0
    ss_start = np.full(n, -np.inf)
    ss_start[1] = 0.0
    ss_start[2:] = t_start + robot.T_step_s * np.arange(n - 2)

    side = np.empty(n, dtype=int)
    side[0] = VIRTUAL
    side[1:] = first_support * np.where(np.arange(n - 1) % 2 == 0, 1, -1)

    # Template integration (unicycle, spec eq. 2), sampled at the touchdowns. The template starts
    # moving one step period before the first swing foot lands, so that the first step covers
    # v T_step like every other one (not the standing time as well).
    touchdown = ss_start + T_ss
    t_origin = touchdown[2] - robot.T_step_s
    t_grid = np.arange(0.0, float(touchdown[-1] - t_origin) + integration_step_s, integration_step_s)
    vel = np.array([command(float(t + t_origin)) for t in t_grid])
    theta = np.concatenate([[yaw_rad], yaw_rad + np.cumsum(vel[:-1, 2]) * integration_step_s])
    c, s = np.cos(theta), np.sin(theta)
    world_vel = np.stack([vel[:, 0] * c - vel[:, 1] * s, vel[:, 0] * s + vel[:, 1] * c], -1)
    path = np.concatenate([[np.zeros(2)], np.cumsum(world_vel[:-1], 0) * integration_step_s])
    idx = np.clip(np.round((touchdown[1:] - t_origin) / integration_step_s).astype(int), 0, len(t_grid) - 1)
    path_theta = theta[idx]

    # Orientation QP (§9.3): clipped increments.
    yaw = np.empty(n)
    yaw[0] = yaw_rad
    yaw[1] = yaw_rad
    d_theta = np.clip(np.diff(path_theta), -robot.max_yaw_step_rad, robot.max_yaw_step_rad)
    yaw[2:] = yaw_rad + np.cumsum(d_theta)

    # Desired positions: template path offset by ±ℓ/2 sideways (feet ℓ apart, spec §9.4 note).
    midpoint = 0.5 * (left + right)
    path_xy = midpoint + path[idx]
    lateral = np.stack([-np.sin(yaw[1:]), np.cos(yaw[1:])], -1)
    desired = path_xy + 0.5 * robot.foot_spacing_m * side[1:, None] * lateral

    # Position QP (§9.4): project each desired increment on the rotated kinematic box.
    pos = np.empty((n, 2))
    pos[0] = midpoint
    pos[1] = right if first_support == RIGHT else left
    for j in range(2, n):
        lower, upper = kinematic_box(robot, int(side[j]))
        R_prev = rotation(yaw[j - 1])
        local = R_prev.T @ (desired[j - 1] - desired[j - 2])
        pos[j] = pos[j - 1] + R_prev @ np.clip(local, lower, upper)

    box_half = np.tile(0.5 * np.array([robot.zmp_box_x_m, robot.zmp_box_y_m]), (n, 1))
    half_gap = 0.5 * np.linalg.norm(left - right)
    box_half[0] = (0.5 * robot.zmp_box_x_m, half_gap + 0.5 * robot.zmp_box_y_m)
    return FootstepPlan(
        pos_m=pos.copy(),
        box_half_m=box_half,
        candidate_pos_m=pos,
        yaw_rad=yaw,
        side=side,
        ss_start_s=ss_start,
        T_ss_s=T_ss,
        T_ds_s=T_ds,
    )
