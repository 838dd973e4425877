"""Typed data exchanged between the controller and whatever executes it.

The controller never touches simulator data: a simulator (LIP or MuJoCo) turns its state into a
:class:`Measurement`, and turns the :class:`GaitReference` it receives into actuator commands.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np


class Support(enum.Enum):
    """Which foot carries the robot."""

    DOUBLE = "double"
    LEFT = "left"
    RIGHT = "right"


@dataclass(frozen=True)
class Measurement:
    """What the robot measures at one control tick (world frame, z up).

    Attributes
    ----------
    com_pos_m : ndarray, shape (3,)
        Centre-of-mass position [m].
    com_vel_mps : ndarray, shape (3,)
        Centre-of-mass velocity [m/s].
    zmp_m : ndarray, shape (2,) or None
        Measured ZMP, i.e. the centre of pressure of the contact forces [m]. ``None`` when no
        foot is in contact or no force sensing is available; the observer then skips its ZMP
        correction.
    left_sole_m, right_sole_m : ndarray, shape (2,) or None
        Measured sole positions (xy) [m], when available. The controller uses them to place a
        footstep where the foot actually landed.
    contact_acc_mps2 : ndarray, shape (2,) or None
        The horizontal contact force per unit mass, ``f_xy / m``, averaged over the control
        period that ends with this measurement [m/s²] (world frame). With the CoM velocity it
        gives the disturbance directly: whatever accelerated the CoM beyond it is the external
        force per unit mass (:class:`~robust_ismpc.estimation.estimator.DisturbanceEstimator`). A multibody
        robot's swinging legs and arms move its centre of pressure but not this force. On the
        LIP it is ``η² (x_c - x_z)`` averaged over the period. ``None``: not measured (the
        disturbance estimate then holds its value).
    external_moment_acc_mps2 : ndarray, shape (2,) or None
        The external moment about the CoM (a push above or below it, a load hanging off the
        robot), averaged over the same period, as the LIP acceleration it is equivalent to:
        ``(τ_y, -τ_x) / (m h)`` [m/s²], with ``τ = dL/dt - M_contact`` (the rate of the centroidal
        angular momentum minus the contact forces' moment about the CoM). The LIP's ZMP must
        move by it over η² just as for a force. ``None``: not measured (0; the LIP has none).
    """

    com_pos_m: np.ndarray
    com_vel_mps: np.ndarray
    zmp_m: np.ndarray | None = None
    left_sole_m: np.ndarray | None = None
    right_sole_m: np.ndarray | None = None
    contact_acc_mps2: np.ndarray | None = None
    external_moment_acc_mps2: np.ndarray | None = None


@dataclass(frozen=True)
class FootReference:
    """Desired pose and velocity of one foot (sole frame origin, world frame).

    Attributes
    ----------
    pos_m : ndarray, shape (3,)
        Sole position [m].
    yaw_rad : float
        Sole yaw about the world z axis [rad].
    vel_mps : ndarray, shape (3,)
        Sole linear velocity [m/s].
    yaw_rate_radps : float
        Sole yaw rate [rad/s].
    in_contact : bool
        True when the foot is planned to be on the ground.
    """

    pos_m: np.ndarray
    yaw_rad: float
    vel_mps: np.ndarray
    yaw_rate_radps: float
    in_contact: bool


@dataclass(frozen=True)
class GaitReference:
    """Output of one controller cycle: what the whole-body layer must realise.

    Attributes
    ----------
    t_s : float
        Time the reference refers to [s] (the end of the cycle that produced it).
    com_pos_m, com_vel_mps, com_acc_mps2 : ndarray, shape (3,)
        Desired CoM position [m], velocity [m/s] and acceleration [m/s^2]; z is the constant
        CoM height.
    zmp_m : ndarray, shape (2,)
        Desired ZMP [m].
    left_foot, right_foot : FootReference
        Desired feet.
    torso_yaw_rad : float
        Desired torso (and pelvis) yaw: the mean of the feet yaws [rad].
    support : Support
        Current support phase.
    step_index : int
        Index in the footstep plan of the step under way.
    time_to_step_s : float
        Remaining single-support time of the current step [s] (0 in double support).
    disturbance_mps2 : ndarray, shape (2,)
        Disturbance (x, y) [m/s^2] the plan was made for, as an acceleration of the CoM (the
        estimate ŵ of the robust controller; zero for the nominal one). A whole-body layer
        with torque feedforward realises ``com_acc_mps2`` with that disturbance acting.
    disturbance_moment_mps2 : ndarray, shape (2,)
        The part of ``disturbance_mps2`` that is an external moment about the CoM (a load
        hanging off an arm, a payload off-centre), as the LIP acceleration ``(τ_y, -τ_x) / (m h)``
        [m/s^2]; the rest is a force. Each component lies between 0 and that of
        ``disturbance_mps2``.
    """

    t_s: float
    com_pos_m: np.ndarray
    com_vel_mps: np.ndarray
    com_acc_mps2: np.ndarray
    zmp_m: np.ndarray
    left_foot: FootReference
    right_foot: FootReference
    torso_yaw_rad: float
    support: Support
    step_index: int
    time_to_step_s: float
    disturbance_mps2: np.ndarray = field(default_factory=lambda: np.zeros(2))
    disturbance_moment_mps2: np.ndarray = field(default_factory=lambda: np.zeros(2))
