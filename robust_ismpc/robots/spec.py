"""Robot descriptions: which MJCF model, which feet, how big the soles, how it stands.

A robot is described by one small TOML file (format in ``docs/robots.md``) pointing at an MJCF
model; :func:`robust_ismpc.sim.model.load_robot` reads it, checks it against the model and
measures the model into a frozen :class:`RobotSpec`. This module is data only (no MuJoCo).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from ..core.params import MpcParams, RobotParams
from ..exceptions import ParameterError
from ..validation import check_positive, check_vector

logger = logging.getLogger("robust_ismpc")


#: RobotParams fields that are measured from the model and may not be overridden in ``[gait]``.
MEASURED_FIELDS = ("name", "mass_kg", "com_height_m", "foot_spacing_m", "sole_length_m", "sole_width_m")
#: RobotParams fields that a robot file's ``[gait]`` may set.
GAIT_FIELDS = tuple(sorted(set(f.name for f in fields(RobotParams)) - set(MEASURED_FIELDS)))

_FRAME_TYPES = ("site", "body")


@dataclass(frozen=True)
class RobotSpec:
    """A humanoid model and the facts about it that the gait generator needs.

    The *sole frame* of a foot has the orientation of the foot frame (site or body named by
    ``left_foot`` / ``right_foot``) and its origin at the centre of the sole rectangle, at ground
    level when the foot is flat on the floor. ``*_sole_offset_m`` is that origin expressed in the
    foot frame.

    Attributes
    ----------
    name : str
        Robot identifier.
    model_path : pathlib.Path
        MJCF scene (robot plus floor) [absolute path].
    root_body : str
        Body carrying the free joint (floating base).
    torso_body : str
        Body whose orientation the whole-body IK keeps level (pelvis or torso); pushes are
        applied to it by default, and the inverse dynamics takes the estimated external
        disturbance to act on it.
    left_foot, right_foot : str
        Names of the foot frames in the model.
    foot_frame_type : str
        ``"site"`` or ``"body"``: what kind of element the foot names refer to.
    left_sole_offset_m, right_sole_offset_m : tuple of 3 float
        Sole-frame origin in the foot frame [m].
    sole_length_m, sole_width_m : float
        Sole rectangle side lengths along the sole x and y axes [m].
    leg_joints : tuple of str
        Names of the leg joints (hip to ankle, both legs).
    standing_posture : tuple of (str, float)
        Bent-knee standing posture: joint name and angle [rad] (joints not listed keep the
        model's ``qpos0`` value).
    mass_kg : float
        Total mass of the robot (subtree mass of the root body) [kg], measured.
    com_height_m : float
        CoM height above the floor in the standing posture [m], measured.
    foot_spacing_m : float
        Lateral distance between the sole centres in the standing posture [m], measured.
    base_height_m : float
        Height of the root body origin when standing with both soles on the floor [m], measured.
    gait_overrides : tuple of (str, float)
        Values of :class:`~robust_ismpc.core.params.RobotParams` fields that replace the defaults.
    sole_outline_m : tuple of (float, float)
        Vertices (x, y) of the region where the sole can bear load, in the sole frame [m]
        (convex, e.g. the contact spheres' centres); empty means the ``sole_length_m`` x
        ``sole_width_m`` rectangle. The measured support polygon is built from it.
    sole_sites : tuple of (str, str, tuple of 3 float, tuple of 4 float)
        Sites added to the model when it is compiled: name, body, position [m] and orientation
        (quaternion w, x, y, z) in the body frame. A robot file whose soles are rotated from
        their foot bodies (``left_sole_quat``, ``right_sole_quat``) gets its sole frames as such
        sites (and ``foot_frame_type = "site"``).
    foot_friction : float or None
        Sliding friction of the foot contact geoms in the simulation (None: the model's).
    servo_dynamic_feedforward : bool
        Servo playback only: add the inverse dynamics of the IK motion to the servos' torque
        feedforward (:class:`~robust_ismpc.sim.loop.LoopSettings`).
    physics_step_s : float or None
        MuJoCo's timestep [s], replacing the model's own (``<option timestep>``); None keeps the
        model's. The closed loop takes (control period / physics_step_s) physics steps per control
        period and the torque control solves its inverse dynamics at each, so it must divide the
        MPC's default sampling period (0.01 s): 0.002 s for the built-in robots' models.
    inverse_dynamics_rate_hz : float or None
        Torque control: how often the inverse-dynamics QP is solved [Hz]; its command is held
        by the motor drivers in between (:mod:`robust_ismpc.sim.whole_body.motor_command`). The
        physics step must divide its period. None: at every physics step.
    sensors : tuple of (str, float)
        The robot's own sensors (name of a :class:`~robust_ismpc.robots.sensing.SensingParams`
        sensor field, value), which replace a sensing preset's
        (:func:`~robust_ismpc.robots.sensing.robot_sensing`); the ``ideal`` preset ignores them.
    """

    name: str
    model_path: Path
    root_body: str
    torso_body: str
    left_foot: str
    right_foot: str
    foot_frame_type: str
    left_sole_offset_m: tuple[float, float, float]
    right_sole_offset_m: tuple[float, float, float]
    sole_length_m: float
    sole_width_m: float
    leg_joints: tuple[str, ...]
    standing_posture: tuple[tuple[str, float], ...]
    mass_kg: float
    com_height_m: float
    foot_spacing_m: float
    base_height_m: float
    gait_overrides: tuple[tuple[str, float], ...] = field(default=())
    sole_outline_m: tuple[tuple[float, float], ...] = field(default=())
    sole_sites: tuple[tuple[str, str, tuple[float, float, float], tuple[float, float, float, float]], ...] = ()
    foot_friction: float | None = None
    servo_dynamic_feedforward: bool = False
    physics_step_s: float | None = None
    inverse_dynamics_rate_hz: float | None = None
    sensors: tuple[tuple[str, float], ...] = ()

    def __post_init__(self) -> None:
        owner = f"RobotSpec[{self.name}]"
        if self.inverse_dynamics_rate_hz is not None:
            check_positive(owner, inverse_dynamics_rate_hz=self.inverse_dynamics_rate_hz)
        if self.foot_friction is not None:
            check_positive(owner, foot_friction=self.foot_friction)
        if self.physics_step_s is not None:
            check_positive(owner, physics_step_s=self.physics_step_s)
            period = MpcParams().sampling_period_s
            steps = period / self.physics_step_s
            if steps < 1.0 - 1e-9 or abs(steps - round(steps)) > 1e-6:
                raise ParameterError(f"{owner}.physics_step_s must divide the {period:g} s control period "
                                     f"(0.001, 0.002, 0.005, ...), got {self.physics_step_s!r}")
        if not isinstance(self.servo_dynamic_feedforward, bool):
            raise ParameterError(f"{owner}.servo_dynamic_feedforward must be true or false, "
                                 f"got {self.servo_dynamic_feedforward!r}")
        if not isinstance(self.name, str) or not self.name:
            raise ParameterError(f"RobotSpec.name must be a non-empty string, got {self.name!r}")
        if not isinstance(self.model_path, Path):
            raise ParameterError(f"{owner}.model_path must be a pathlib.Path, got {self.model_path!r}")
        if self.foot_frame_type not in _FRAME_TYPES:
            raise ParameterError(
                f"{owner}.foot_frame_type must be one of {', '.join(_FRAME_TYPES)}; got {self.foot_frame_type!r}"
            )
        for attr in ("root_body", "torso_body", "left_foot", "right_foot"):
            value = getattr(self, attr)
            if not isinstance(value, str) or not value:
                raise ParameterError(f"{owner}.{attr} must be a non-empty string, got {value!r}")
        if self.left_foot == self.right_foot:
            raise ParameterError(f"{owner}: left_foot and right_foot are both {self.left_foot!r}")
        object.__setattr__(self, "left_sole_offset_m", tuple(check_vector(owner, "left_sole_offset_m", self.left_sole_offset_m, 3).tolist()))
        object.__setattr__(
            self, "right_sole_offset_m", tuple(check_vector(owner, "right_sole_offset_m", self.right_sole_offset_m, 3).tolist())
        )
        for attr in ("sole_length_m", "sole_width_m", "mass_kg", "com_height_m", "foot_spacing_m", "base_height_m"):
            check_positive(owner, **{attr: getattr(self, attr)})
        if not self.leg_joints or not all(isinstance(j, str) and j for j in self.leg_joints):
            raise ParameterError(f"{owner}.leg_joints must be a non-empty sequence of joint names")
        for joint, value in self.standing_posture:
            if not isinstance(joint, str) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ParameterError(
                    f"{owner}.standing_posture entries must be (joint name, finite angle), got {(joint, value)!r}"
                )
        outline = np.asarray(self.sole_outline_m, dtype=float).reshape(-1, 2) if self.sole_outline_m else np.zeros((0, 2))
        if self.sole_outline_m and (len(outline) < 3 or not np.all(np.isfinite(outline))):
            raise ParameterError(f"{owner}.sole_outline_m must be at least 3 finite (x, y) vertices [m]")
        object.__setattr__(self, "sole_outline_m", tuple((float(x), float(y)) for x, y in outline))
        for key, _ in self.gait_overrides:
            if key not in GAIT_FIELDS:
                raise ParameterError(
                    f"{owner}.gait_overrides: {key!r} cannot be set; allowed: {', '.join(GAIT_FIELDS)}"
                )

    @property
    def standing_joint_angles(self) -> dict[str, float]:
        """Standing posture as a dict joint name -> angle [rad]."""
        return dict(self.standing_posture)

    def sole_outline(self) -> np.ndarray:
        """Load-bearing region of a sole in the sole frame, shape (k, 2) [m] (the rectangle by default)."""
        if self.sole_outline_m:
            return np.array(self.sole_outline_m)
        half = np.array([0.5 * self.sole_length_m, 0.5 * self.sole_width_m])
        return np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * half

    def sole_offset_m(self, side: str) -> np.ndarray:
        """Sole-frame origin in the foot frame for ``side`` in (``"left"``, ``"right"``), shape (3,) [m]."""
        if side == "left":
            return np.array(self.left_sole_offset_m)
        if side == "right":
            return np.array(self.right_sole_offset_m)
        raise ParameterError(f"side must be 'left' or 'right', got {side!r}")

    def foot_name(self, side: str) -> str:
        """Name of the foot frame of ``side`` (``"left"`` or ``"right"``)."""
        if side == "left":
            return self.left_foot
        if side == "right":
            return self.right_foot
        raise ParameterError(f"side must be 'left' or 'right', got {side!r}")

    def params(self) -> RobotParams:
        """Reduced-model parameters of this robot.

        The gait values (ZMP and kinematic boxes, timing, swing height, yaw step) are defaults
        scaled on the measured geometry, replaced by ``gait_overrides`` (the file's ``[gait]``),
        for built-in and user robots alike. Mass, CoM height, sole size and foot spacing are the
        measured values. The ZMP box is shrunk to fit in the sole if needed.
        """
        values = scaled_gait_defaults(self.com_height_m, self.sole_length_m, self.sole_width_m, self.foot_spacing_m)
        values.update(dict(self.gait_overrides))
        values.update(
            name=self.name,
            mass_kg=self.mass_kg,
            com_height_m=self.com_height_m,
            foot_spacing_m=self.foot_spacing_m,
            sole_length_m=self.sole_length_m,
            sole_width_m=self.sole_width_m,
        )
        values["zmp_box_x_m"] = min(values["zmp_box_x_m"], self.sole_length_m)
        values["zmp_box_y_m"] = min(values["zmp_box_y_m"], self.sole_width_m)
        return RobotParams(**values)


def scaled_gait_defaults(com_height_m: float, sole_length_m: float, sole_width_m: float,
                         foot_spacing_m: float) -> dict[str, Any]:
    """Gait values (``RobotParams`` fields) scaled on a robot's size, the defaults of ``[gait]``."""
    h = com_height_m
    return dict(
        zmp_box_x_m=0.5 * sole_length_m,
        zmp_box_y_m=0.5 * sole_width_m,
        kin_box_x_m=0.5 * h,
        kin_box_y_m=max(0.5 * foot_spacing_m, 0.02),
        max_yaw_step_rad=0.3,
        T_ss_s=round(max(0.25, 0.8 * math.sqrt(h / 1.0)), 2),
        T_ds_s=round(max(0.1, 0.3 * math.sqrt(h / 1.0)), 2),
        swing_height_m=round(0.08 * h, 3),
    )
