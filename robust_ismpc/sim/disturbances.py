"""Disturbances as real physics: external forces on a body, and objects added to the scene.

Forces (:class:`Force`, :class:`Impulse`) are written into ``data.xfrc_applied`` of a robot body
(the torso by default) at every physics step; they act at the body's centre of mass.
Scene objects (:class:`Payload`, :class:`SwingingBall`) are added with ``mujoco.MjSpec`` before
compiling (:func:`build_scene`); their joints set damping, armature and friction loss explicitly,
so they do not inherit the robot's joint defaults. Added bodies are named with the prefix ``disturbance_`` so
that the robot's measured CoM excludes them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from ..exceptions import ModelError, ParameterError
from ..robots.spec import RobotSpec
from .mujoco_robot import DISTURBANCE_PREFIX


def _finite(owner: str, **values: float) -> None:
    for name, value in values.items():
        if not isinstance(value, (int, float)) or isinstance(value, bool) or math.isnan(value):
            raise ParameterError(f"{owner}.{name} must be a number, got {value!r}")


def _positive(owner: str, **values: float) -> None:
    for name, value in values.items():
        if not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
            raise ParameterError(f"{owner}.{name} must be a finite number > 0, got {value!r}")


def _vec3(owner: str, name: str, value: Sequence[float]) -> tuple[float, float, float]:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ParameterError(f"{owner}.{name} must be 3 finite numbers, got {value!r}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


@dataclass(frozen=True)
class Force:
    """A constant force on a body during [t_start_s, t_end_s).

    Attributes
    ----------
    fx_n, fy_n : float
        Horizontal force components, world frame [N].
    t_start_s : float
        Start time [s].
    t_end_s : float
        End time [s] (``math.inf`` for a force that never stops).
    fz_n : float
        Vertical component [N].
    body : str or None
        Body the force acts on (at its CoM); None means the robot's torso body.
    """

    fx_n: float
    fy_n: float
    t_start_s: float = 0.0
    t_end_s: float = math.inf
    fz_n: float = 0.0
    body: str | None = None

    def __post_init__(self) -> None:
        _finite("Force", fx_n=self.fx_n, fy_n=self.fy_n, fz_n=self.fz_n, t_start_s=self.t_start_s,
                t_end_s=self.t_end_s)
        if not all(math.isfinite(v) for v in (self.fx_n, self.fy_n, self.fz_n, self.t_start_s)):
            raise ParameterError(f"Force components and t_start_s must be finite, got {self}")
        if not self.t_end_s > self.t_start_s:
            raise ParameterError(f"Force.t_end_s ({self.t_end_s}) must be > t_start_s ({self.t_start_s})")

    def vector_n(self) -> np.ndarray:
        """Force vector, shape (3,) [N]."""
        return np.array([self.fx_n, self.fy_n, self.fz_n])

    def is_active(self, t_s: float) -> bool:
        """True while t_start_s <= t_s < t_end_s."""
        return self.t_start_s <= t_s < self.t_end_s

    def as_force(self) -> Force:
        """This force (for uniform handling with :class:`Impulse`)."""
        return self


@dataclass(frozen=True)
class Impulse:
    """A push: momentum delivered by a constant force over a short duration.

    Attributes
    ----------
    px_ns, py_ns : float
        Horizontal impulse components [N s].
    t_s : float
        Start of the push [s].
    duration_s : float
        Duration over which the force ``p / duration_s`` acts [s].
    body : str or None
        Body pushed (at its CoM); None means the robot's torso body.
    """

    px_ns: float
    py_ns: float
    t_s: float
    duration_s: float = 0.1
    body: str | None = None

    def __post_init__(self) -> None:
        _finite("Impulse", px_ns=self.px_ns, py_ns=self.py_ns, t_s=self.t_s)
        if not all(math.isfinite(v) for v in (self.px_ns, self.py_ns, self.t_s)):
            raise ParameterError(f"Impulse components and t_s must be finite, got {self}")
        _positive("Impulse", duration_s=self.duration_s)

    def as_force(self) -> Force:
        """The equivalent windowed :class:`Force`."""
        return Force(
            fx_n=self.px_ns / self.duration_s,
            fy_n=self.py_ns / self.duration_s,
            t_start_s=self.t_s,
            t_end_s=self.t_s + self.duration_s,
            body=self.body,
        )


Disturbance = Force | Impulse


class ForceSchedule:
    """Forces to write into ``data.xfrc_applied`` as time goes.

    Parameters
    ----------
    model : mujoco.MjModel
        Scene model.
    disturbances : sequence of Force or Impulse
    default_body : str
        Body for disturbances whose ``body`` is None (the robot's torso).

    Raises
    ------
    ModelError
        A named body is absent from the model.
    """

    def __init__(self, model: mujoco.MjModel, disturbances: Sequence[Disturbance], default_body: str) -> None:
        self._forces: list[tuple[Force, int]] = []
        for dist in disturbances:
            if not isinstance(dist, (Force, Impulse)):
                raise ParameterError(f"expected Force or Impulse, got {dist!r}")
            force = dist.as_force()
            name = force.body or default_body
            body_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
            if body_id < 0:
                raise ModelError(f"disturbance body {name!r} not found in the model")
            self._forces.append((force, body_id))
        self._bodies = sorted({b for _, b in self._forces})

    def apply(self, data: mujoco.MjData, t_s: float) -> np.ndarray:
        """Write the forces active at ``t_s`` (and zero the others); returns the total force (3,) [N]."""
        total = np.zeros(3)
        for b in self._bodies:
            data.xfrc_applied[b, :] = 0.0
        for force, b in self._forces:
            if force.is_active(t_s):
                vec = force.vector_n()
                data.xfrc_applied[b, :3] += vec
                total += vec
        return total

    def __len__(self) -> int:
        return len(self._forces)


@dataclass(frozen=True)
class Payload:
    """A mass hanging from a robot link on a rope (rigid massless rod with a ball joint).

    Attributes
    ----------
    mass_kg : float
        Payload mass [kg].
    rope_length_m : float
        Distance from the attachment point to the payload centre [m].
    link : str or None
        Body it hangs from; None means the robot's torso body.
    attach_offset_m : tuple of 3 float
        Attachment point in the link frame [m].
    radius_m : float
        Radius of the payload sphere [m] (visual; it does not collide).
    initial_angle_rad : float
        Initial swing angle about the world y axis [rad] (0: hanging straight down).
    damping_nms : float
        Damping of the ball joint [N m s/rad].
    """

    mass_kg: float
    rope_length_m: float
    link: str | None = None
    attach_offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    radius_m: float = 0.04
    initial_angle_rad: float = 0.0
    damping_nms: float = 0.0

    def __post_init__(self) -> None:
        _positive("Payload", mass_kg=self.mass_kg, rope_length_m=self.rope_length_m, radius_m=self.radius_m)
        _finite("Payload", initial_angle_rad=self.initial_angle_rad, damping_nms=self.damping_nms)
        if self.damping_nms < 0:
            raise ParameterError(f"Payload.damping_nms must be >= 0, got {self.damping_nms}")
        object.__setattr__(self, "attach_offset_m", _vec3("Payload", "attach_offset_m", self.attach_offset_m))


@dataclass(frozen=True)
class SwingingBall:
    """A ball on a rope hanging from a fixed pivot, released from an angle (a wrecking ball).

    The rope is a rigid massless rod on a hinge at the pivot. At rest the ball hangs at
    ``pivot_m - (0, 0, rope_length_m)``; it is released at ``release_angle_rad`` about
    ``hinge_axis``: with the default axis (0, 1, 0) and a positive angle it starts on the -x side
    and swings towards +x.

    Attributes
    ----------
    pivot_m : tuple of 3 float
        Pivot position, world frame [m].
    rope_length_m : float
        Pivot-to-ball-centre distance [m].
    mass_kg : float
        Ball mass [kg].
    radius_m : float
        Ball radius [m]; the ball collides with the robot.
    release_angle_rad : float
        Initial angle from the vertical [rad].
    hinge_axis : tuple of 3 float
        Hinge axis, world frame (normalised).
    name : str
        Suffix of the body name (several balls need distinct names).
    """

    pivot_m: tuple[float, float, float]
    rope_length_m: float
    mass_kg: float
    radius_m: float = 0.08
    release_angle_rad: float = 0.5
    hinge_axis: tuple[float, float, float] = (0.0, 1.0, 0.0)
    name: str = "ball"

    def __post_init__(self) -> None:
        _positive("SwingingBall", rope_length_m=self.rope_length_m, mass_kg=self.mass_kg, radius_m=self.radius_m)
        _finite("SwingingBall", release_angle_rad=self.release_angle_rad)
        object.__setattr__(self, "pivot_m", _vec3("SwingingBall", "pivot_m", self.pivot_m))
        axis = np.asarray(_vec3("SwingingBall", "hinge_axis", self.hinge_axis))
        norm = float(np.linalg.norm(axis))
        if norm < 1e-9:
            raise ParameterError("SwingingBall.hinge_axis must be non-zero")
        object.__setattr__(self, "hinge_axis", tuple(float(v) for v in axis / norm))
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise ParameterError(f"SwingingBall.name must be an identifier, got {self.name!r}")


SceneItem = Payload | SwingingBall


def _payload_body_name(index: int) -> str:
    return f"{DISTURBANCE_PREFIX}payload_{index}"


def _ball_body_name(ball: SwingingBall) -> str:
    return f"{DISTURBANCE_PREFIX}{ball.name}"


def build_scene(spec: RobotSpec, items: Sequence[SceneItem] = ()) -> mujoco.MjModel:
    """Compile the robot scene with disturbance objects added.

    Parameters
    ----------
    spec : RobotSpec
        The robot (its ``model_path`` is the base scene).
    items : sequence of Payload or SwingingBall

    Returns
    -------
    mujoco.MjModel
        A new model (the cached robot model itself when ``items`` is empty: do not mutate it).

    Raises
    ------
    ModelError
        A payload link is absent from the model, or the edited scene does not compile.
    """
    if not items:
        return spec.load_model()
    mj_spec = mujoco.MjSpec.from_file(str(spec.model_path))
    for index, item in enumerate(items):
        if isinstance(item, Payload):
            link_name = item.link or spec.torso_body
            link = mj_spec.body(link_name)
            if link is None:
                raise ModelError(f"payload link {link_name!r} not found in the model")
            body = link.add_body(name=_payload_body_name(index), pos=list(item.attach_offset_m))
            body.add_joint(
                name=f"{_payload_body_name(index)}_joint",
                type=mujoco.mjtJoint.mjJNT_BALL,
                damping=item.damping_nms,
                armature=0.0,
                frictionloss=0.0,
                stiffness=0.0,
            )
            body.add_geom(
                type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                fromto=[0, 0, 0, 0, 0, -item.rope_length_m],
                size=[0.004, 0, 0],
                mass=0.0,
                contype=0,
                conaffinity=0,
                rgba=[0.3, 0.3, 0.3, 1],
            )
            body.add_geom(
                type=mujoco.mjtGeom.mjGEOM_SPHERE,
                pos=[0, 0, -item.rope_length_m],
                size=[item.radius_m, 0, 0],
                mass=item.mass_kg,
                contype=0,
                conaffinity=0,
                rgba=[0.8, 0.5, 0.1, 1],
            )
        elif isinstance(item, SwingingBall):
            name = _ball_body_name(item)
            if mj_spec.body(name) is not None:
                raise ParameterError(f"two swinging balls are named {item.name!r}")
            body = mj_spec.worldbody.add_body(name=name, pos=list(item.pivot_m))
            body.add_joint(
                name=f"{name}_joint", type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(item.hinge_axis),
                damping=0.0, armature=0.0, frictionloss=0.0, stiffness=0.0,
            )
            body.add_geom(
                type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                fromto=[0, 0, 0, 0, 0, -item.rope_length_m],
                size=[0.005, 0, 0],
                mass=0.0,
                contype=0,
                conaffinity=0,
                rgba=[0.3, 0.3, 0.3, 1],
            )
            body.add_geom(
                type=mujoco.mjtGeom.mjGEOM_SPHERE,
                pos=[0, 0, -item.rope_length_m],
                size=[item.radius_m, 0, 0],
                mass=item.mass_kg,
                rgba=[0.8, 0.1, 0.1, 1],
            )
        else:
            raise ParameterError(f"expected Payload or SwingingBall, got {item!r}")
    try:
        return mj_spec.compile()
    except ValueError as exc:
        raise ModelError(f"the scene with disturbances does not compile: {exc}") from None


def set_scene_initial_state(model: mujoco.MjModel, data: mujoco.MjData, items: Sequence[SceneItem]) -> None:
    """Set the initial angles of payloads and balls in ``data.qpos`` (call after the robot's state)."""
    for index, item in enumerate(items):
        if isinstance(item, Payload):
            jname = f"{_payload_body_name(index)}_joint"
            half = 0.5 * item.initial_angle_rad
            quat_world = np.array([math.cos(half), 0.0, math.sin(half), 0.0])
            # Express the world-frame swing in the parent link frame so the rope starts at the angle.
            body_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, _payload_body_name(index))
            parent = model.body_parentid[body_id]
            parent_quat = np.empty(4)
            mujoco.mju_mat2Quat(parent_quat, data.xmat[parent])
            inv = np.empty(4)
            mujoco.mju_negQuat(inv, parent_quat)
            tmp = np.empty(4)
            mujoco.mju_mulQuat(tmp, inv, quat_world)
            local = np.empty(4)
            mujoco.mju_mulQuat(local, tmp, parent_quat)
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, jname)
            data.qpos[model.jnt_qposadr[jid] : model.jnt_qposadr[jid] + 4] = local
        elif isinstance(item, SwingingBall):
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, f"{_ball_body_name(item)}_joint")
            data.qpos[model.jnt_qposadr[jid]] = item.release_angle_rad
    mujoco.mj_forward(model, data)


def payload_body_names(items: Sequence[SceneItem]) -> list[str]:
    """Body names of the payloads of ``items``, in order."""
    return [_payload_body_name(i) for i, item in enumerate(items) if isinstance(item, Payload)]


def ball_body_names(items: Sequence[SceneItem]) -> list[str]:
    """Body names of the swinging balls of ``items``, in order."""
    return [_ball_body_name(item) for item in items if isinstance(item, SwingingBall)]
