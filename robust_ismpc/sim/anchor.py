"""Anchoring the gait reference to the real feet (MuJoCo layer, between controller and IK).

The controller plans in its own frame and runs its LIP model open loop (``state_feedback_gain``
0 on position servos, see :mod:`robust_ismpc.sim.run`). On the full robot the feet land a few
millimetres to centimetres away from the plan and the stance foot may slide or turn; sending the
plan's world-frame targets to the IK as they are then makes the two planted feet pull against
each other in double support (the IK wants them at the planned distance) and lets the CoM drift
away from the real stance foot, step after step.

:class:`ReferenceAnchor` maps the reference into the world through a planar rigid transform
``A(p) = R(ψ) p + t`` that takes the reference sole of the last foot that landed to where that
foot really is (position xy and yaw, measured at touchdown). Per tick it returns a reference in
which

- the feet planted on the floor are held at their **measured** touchdown poses (flat, z = 0), so
  the IK never asks a planted foot to move;
- the CoM, CoM velocity, ZMP and torso yaw are mapped through ``A``: the CoM is realised
  relative to the real stance foot as planned;
- a swing foot follows ``A`` of the reference swing trajectory plus the offset it had at
  lift-off, faded out with a smoothstep over the swing, so it leaves the floor where it really
  is and lands where the plan says relative to the real stance foot.

At each touchdown the transform moves to the new foot's, linearly over the double support, so
the CoM target stays continuous. The controller's plan is not changed here (anchoring its
footsteps is :class:`~robust_ismpc.controller.IsmpcController`'s ``anchor_landed_footsteps``).
Optionally a CoM stabiliser acts on top: the IK CoM target is
``A(c_ref) - K (c - A(c_ref)) - D (ċ - R ċ_ref)`` with the measured CoM ``c``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..reference import FootReference, GaitReference, Measurement

SIDES = ("left", "right")


def _rot(yaw_rad: float) -> np.ndarray:
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return np.array([[c, -s], [s, c]])


def _wrap(angle_rad: float) -> float:
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi


@dataclass(frozen=True)
class PlanarTransform:
    """``p -> R(yaw) p + t`` in the floor plane (yaw [rad], t (2,) [m])."""

    yaw_rad: float = 0.0
    t_m: np.ndarray = field(default_factory=lambda: np.zeros(2))

    def point(self, p_xy: np.ndarray) -> np.ndarray:
        """Map a point, shape (2,) [m]."""
        return _rot(self.yaw_rad) @ np.asarray(p_xy, dtype=float)[:2] + self.t_m

    def vector(self, v_xy: np.ndarray) -> np.ndarray:
        """Rotate a vector, shape (2,)."""
        return _rot(self.yaw_rad) @ np.asarray(v_xy, dtype=float)[:2]

    @staticmethod
    def taking(ref_xy: np.ndarray, ref_yaw_rad: float, real_xy: np.ndarray, real_yaw_rad: float) -> PlanarTransform:
        """The transform that maps the pose (ref_xy, ref_yaw) onto (real_xy, real_yaw)."""
        yaw = _wrap(real_yaw_rad - ref_yaw_rad)
        t = np.asarray(real_xy, dtype=float)[:2] - _rot(yaw) @ np.asarray(ref_xy, dtype=float)[:2]
        return PlanarTransform(yaw, t)

    def blend(self, other: PlanarTransform, s: float) -> PlanarTransform:
        """Linear interpolation towards ``other`` (s = 0: self, 1: other)."""
        yaw = self.yaw_rad + s * _wrap(other.yaw_rad - self.yaw_rad)
        return PlanarTransform(yaw, (1.0 - s) * self.t_m + s * other.t_m)


def _smoothstep(s: float) -> float:
    s = min(max(s, 0.0), 1.0)
    return s * s * (3.0 - 2.0 * s)


@dataclass
class _Swing:
    offset_xy_m: np.ndarray
    offset_yaw_rad: float
    duration_s: float


class ReferenceAnchor:
    """Map a controller reference onto the real feet (see the module docstring).

    Parameters
    ----------
    robot : MujocoRobot
        Measurement source (sole poses).
    com_gain : float
        K of the CoM stabiliser [-] (0: off).
    com_damping_s : float
        D of the CoM stabiliser [s].
    transfer_s : float
        Time over which the transform moves to a newly landed foot [s] (the double support).
    """

    def __init__(self, robot, com_gain: float = 0.0, com_damping_s: float = 0.0, transfer_s: float = 0.1) -> None:
        self.robot = robot
        self.com_gain = float(com_gain)
        self.com_damping_s = float(com_damping_s)
        self.transfer_s = max(float(transfer_s), 1e-9)
        self.transform = PlanarTransform()
        self._from = PlanarTransform()
        self._to = PlanarTransform()
        self._transfer_left_s = 0.0
        self._planted: dict[str, tuple[np.ndarray, float] | None] = {}
        self._swing: dict[str, _Swing | None] = {side: None for side in SIDES}
        for side in SIDES:
            pose = robot.sole_pose(side)
            self._planted[side] = (pose.pos_m[:2].copy(), pose.yaw_rad)
        self._previous: GaitReference | None = None

    # ------------------------------------------------------------------------------------
    def _update_contacts(self, reference: GaitReference, dt_s: float) -> None:
        for side, foot in zip(SIDES, (reference.left_foot, reference.right_foot)):
            if foot.in_contact and self._planted[side] is None:
                pose = self.robot.sole_pose(side)
                self._planted[side] = (pose.pos_m[:2].copy(), pose.yaw_rad)
                self._swing[side] = None
                target = PlanarTransform.taking(foot.pos_m[:2], foot.yaw_rad, pose.pos_m[:2], pose.yaw_rad)
                self._from, self._to = self.transform, target
                self._transfer_left_s = self.transfer_s
            elif not foot.in_contact and self._planted[side] is not None:
                real_xy, real_yaw = self._planted[side]
                # The reference at lift-off is the foot at rest; its image under the transform is
                # where the swing trajectory starts; the difference is faded out over the swing.
                self._swing[side] = _Swing(
                    offset_xy_m=real_xy - self.transform.point(foot.pos_m[:2]),
                    offset_yaw_rad=_wrap(real_yaw - (foot.yaw_rad + self.transform.yaw_rad)),
                    duration_s=max(reference.time_to_step_s + dt_s, dt_s),
                )
                self._planted[side] = None
        if self._transfer_left_s > 0.0:
            self._transfer_left_s = max(self._transfer_left_s - dt_s, 0.0)
            s = 1.0 - self._transfer_left_s / self.transfer_s
            self.transform = self._from.blend(self._to, _smoothstep(s))

    def _foot(self, side: str, foot: FootReference, reference: GaitReference) -> FootReference:
        A = self.transform
        planted = self._planted[side]
        if planted is not None:
            xy, yaw = planted
            return replace(foot, pos_m=np.array([xy[0], xy[1], 0.0]), yaw_rad=yaw, vel_mps=np.zeros(3),
                           yaw_rate_radps=0.0)
        pos = foot.pos_m.copy()
        pos[:2] = A.point(foot.pos_m[:2])
        yaw = foot.yaw_rad + A.yaw_rad
        swing = self._swing[side]
        if swing is not None:
            progress = 1.0 - reference.time_to_step_s / swing.duration_s
            fade = 1.0 - _smoothstep(progress)
            pos[:2] += fade * swing.offset_xy_m
            yaw += fade * swing.offset_yaw_rad
        vel = foot.vel_mps.copy()
        vel[:2] = A.vector(foot.vel_mps[:2])
        return replace(foot, pos_m=pos, yaw_rad=yaw, vel_mps=vel)

    def command(self, reference: GaitReference, measurement: Measurement, dt_s: float) -> GaitReference:
        """The reference to send to the IK this tick."""
        self._update_contacts(reference, dt_s)
        A = self.transform
        com = reference.com_pos_m.copy()
        com[:2] = A.point(reference.com_pos_m[:2])
        vel = reference.com_vel_mps.copy()
        vel[:2] = A.vector(reference.com_vel_mps[:2])
        acc = reference.com_acc_mps2.copy()
        acc[:2] = A.vector(reference.com_acc_mps2[:2])
        previous, self._previous = self._previous, reference
        if previous is not None and (self.com_gain > 0 or self.com_damping_s > 0):
            # The measurement is at the start of the tick, where the previous reference pointed.
            error = measurement.com_pos_m[:2] - A.point(previous.com_pos_m[:2])
            rate = measurement.com_vel_mps[:2] - A.vector(previous.com_vel_mps[:2])
            com[:2] -= self.com_gain * error + self.com_damping_s * rate
        left = self._foot("left", reference.left_foot, reference)
        right = self._foot("right", reference.right_foot, reference)
        return replace(
            reference, com_pos_m=com, com_vel_mps=vel, com_acc_mps2=acc, zmp_m=A.point(reference.zmp_m),
            left_foot=left, right_foot=right, torso_yaw_rad=0.5 * (left.yaw_rad + right.yaw_rad),
        )

    def to_plan_frame(self, world_xy: np.ndarray) -> np.ndarray:
        """Inverse map of a world point into the controller's frame, shape (2,) [m]."""
        A = self.transform
        return _rot(-A.yaw_rad) @ (np.asarray(world_xy, dtype=float)[:2] - A.t_m)
