"""Objects added to a robot's scene: a payload on a pendulum, a swinging ball, and the rigid
payload of a model mismatch (:class:`~robust_ismpc.robots.mismatch.ModelMismatch`).

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
from ..robots.mismatch import NO_MISMATCH, ModelMismatch
from ..robots.spec import RobotSpec
from ..validation import check_number, check_positive, check_vector
from .forces import Force
from .model import compile_model, scene_spec
from .robot import DISTURBANCE_PREFIX


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
        check_positive("Payload", mass_kg=self.mass_kg, rope_length_m=self.rope_length_m, radius_m=self.radius_m)
        check_number("Payload", allow_inf=True, initial_angle_rad=self.initial_angle_rad, damping_nms=self.damping_nms)
        if self.damping_nms < 0:
            raise ParameterError(f"Payload.damping_nms must be >= 0, got {self.damping_nms}")
        object.__setattr__(self, "attach_offset_m", tuple(check_vector("Payload", "attach_offset_m", self.attach_offset_m, 3).tolist()))


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
    release_s : float
        Time at which the ball is let go [s]. Until then a horizontal force on the ball,
        ``m g tan(release_angle_rad)`` away from the vertical, holds it at rest at the release
        angle (:func:`scene_forces`; a static equilibrium of the rod pendulum). 0: free from the
        start.
    """

    pivot_m: tuple[float, float, float]
    rope_length_m: float
    mass_kg: float
    radius_m: float = 0.08
    release_angle_rad: float = 0.5
    hinge_axis: tuple[float, float, float] = (0.0, 1.0, 0.0)
    name: str = "ball"
    release_s: float = 0.0

    def __post_init__(self) -> None:
        check_positive("SwingingBall", rope_length_m=self.rope_length_m, mass_kg=self.mass_kg, radius_m=self.radius_m)
        check_number("SwingingBall", allow_inf=True, release_angle_rad=self.release_angle_rad, release_s=self.release_s)
        if not (math.isfinite(self.release_s) and self.release_s >= 0):
            raise ParameterError(f"SwingingBall.release_s must be a finite number >= 0, got {self.release_s!r}")
        if self.release_s > 0 and not abs(self.release_angle_rad) < 0.5 * math.pi - 1e-3:
            raise ParameterError(
                f"SwingingBall.release_angle_rad must be within (-pi/2, pi/2) to be held until release_s, "
                f"got {self.release_angle_rad!r}"
            )
        object.__setattr__(self, "pivot_m", tuple(check_vector("SwingingBall", "pivot_m", self.pivot_m, 3).tolist()))
        axis = np.asarray(tuple(check_vector("SwingingBall", "hinge_axis", self.hinge_axis, 3).tolist()))
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


def _add_rope_and_bob(body, rope_length_m: float, rope_radius_m: float, bob_radius_m: float,
                      bob_mass_kg: float, rgba: list[float], collides: bool) -> None:
    """A massless, non-colliding rope hanging down from ``body``'s origin and a sphere at its end.

    ``collides`` decides whether the sphere collides (a ball hitting the robot) or not (a bag).
    """
    body.add_geom(
        type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, 0, 0, -rope_length_m], size=[rope_radius_m, 0, 0],
        mass=0.0, contype=0, conaffinity=0, rgba=[0.3, 0.3, 0.3, 1],
    )
    bob = body.add_geom(
        type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=[0, 0, -rope_length_m], size=[bob_radius_m, 0, 0],
        mass=bob_mass_kg, rgba=rgba,
    )
    if not collides:
        bob.contype = 0
        bob.conaffinity = 0


#: Body name of a model mismatch's payload.
LOAD_BODY = f"{DISTURBANCE_PREFIX}load"


def build_scene(spec: RobotSpec, items: Sequence[SceneItem] = (), mismatch: ModelMismatch = NO_MISMATCH) -> mujoco.MjModel:
    """Compile the robot scene with disturbance objects added.

    Parameters
    ----------
    spec : RobotSpec
        The robot (its ``model_path`` is the base scene).
    items : sequence of Payload or SwingingBall
    mismatch : ModelMismatch
        Its payload, if any, is a sphere fixed rigidly to the torso (:data:`LOAD_BODY`; a
        disturbance body, so the robot's measured CoM and mass exclude it). Its other fields
        act on the compiled model (:func:`~robust_ismpc.sim.mismatch.apply_mismatch`).

    Returns
    -------
    mujoco.MjModel
        A new model (the cached robot model itself when there is nothing to add: do not mutate it).

    Raises
    ------
    ModelError
        A payload link is absent from the model, or the edited scene does not compile.
    """
    if not items and mismatch.payload_kg == 0:
        return compile_model(spec)
    mj_spec = scene_spec(spec)
    if mismatch.payload_kg > 0:
        torso = mj_spec.body(spec.torso_body)
        load = torso.add_body(name=LOAD_BODY, pos=list(mismatch.payload_offset_m))
        load.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.03, 0, 0], mass=mismatch.payload_kg,
                      contype=0, conaffinity=0, rgba=[0.2, 0.4, 0.9, 1])
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
            _add_rope_and_bob(body, item.rope_length_m, 0.004, item.radius_m, item.mass_kg,
                              rgba=[0.8, 0.5, 0.1, 1], collides=False)
        elif isinstance(item, SwingingBall):
            name = _ball_body_name(item)
            if mj_spec.body(name) is not None:
                raise ParameterError(f"two swinging balls are named {item.name!r}")
            body = mj_spec.worldbody.add_body(name=name, pos=list(item.pivot_m))
            body.add_joint(
                name=f"{name}_joint", type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(item.hinge_axis),
                damping=0.0, armature=0.0, frictionloss=0.0, stiffness=0.0,
            )
            _add_rope_and_bob(body, item.rope_length_m, 0.005, item.radius_m, item.mass_kg,
                              rgba=[0.8, 0.1, 0.1, 1], collides=True)
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
            # The rope's world orientation is the link's times the joint's: the joint turns the
            # link's frame back to the world's, then by the swing (q_joint = q_link⁻¹ q_world).
            body_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, _payload_body_name(index))
            parent = model.body_parentid[body_id]
            parent_quat = np.empty(4)
            mujoco.mju_mat2Quat(parent_quat, data.xmat[parent])
            inv = np.empty(4)
            mujoco.mju_negQuat(inv, parent_quat)
            local = np.empty(4)
            mujoco.mju_mulQuat(local, inv, quat_world)
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


def _ball_hold_direction(ball: SwingingBall) -> np.ndarray:
    """Unit horizontal direction from the vertical below the pivot to the ball at its release angle."""
    axis = np.asarray(ball.hinge_axis)
    down = np.array([0.0, 0.0, -1.0])
    # Rotating the hanging rod by the release angle about the hinge axis (Rodrigues).
    a = ball.release_angle_rad
    rod = down * math.cos(a) + np.cross(axis, down) * math.sin(a) + axis * np.dot(axis, down) * (1 - math.cos(a))
    horizontal = np.array([rod[0], rod[1], 0.0])
    norm = float(np.linalg.norm(horizontal))
    return horizontal / norm if norm > 1e-12 else np.zeros(3)


def scene_forces(items: Sequence[SceneItem], gravity_mps2: float = 9.81) -> list[Force]:
    """Forces that belong to the scene items: the holding force of each ball until its release.

    A rod pendulum of mass m at angle a from the vertical is at rest under a horizontal force of
    magnitude ``m g tan(a)`` pointing away from the vertical; the force ends at ``release_s``
    and the ball starts swinging from rest.

    Parameters
    ----------
    items : sequence of Payload or SwingingBall
    gravity_mps2 : float
        Gravity magnitude of the scene [m/s²].

    Returns
    -------
    list of Force
        With ``body`` naming the ball body (add them to the disturbances of the simulation).
    """
    forces = []
    for item in items:
        if isinstance(item, SwingingBall) and item.release_s > 0 and abs(item.release_angle_rad) > 0:
            direction = _ball_hold_direction(item)
            magnitude = item.mass_kg * gravity_mps2 * math.tan(abs(item.release_angle_rad))
            vec = magnitude * direction
            forces.append(Force(float(vec[0]), float(vec[1]), 0.0, item.release_s, body=_ball_body_name(item)))
    return forces


class SceneMonitor:
    """Record what the scene items do during a run (called once per control tick).

    For every :class:`SwingingBall`: the ticks at which it touches the robot, the largest normal
    contact force, and the impulse it delivered, from the change of the ball's horizontal momentum
    between the last tick before the first contact and the first tick after the last contact of
    the first hit (gravity and the rod tension are nearly vertical at the bottom of the swing).
    A hit that starts and ends between two ticks is recognised by the jump of the ball's velocity
    (``max_contact_force_n`` is then 0: no contact was sampled).
    For every :class:`Payload`: the largest swing angle of the rope from the vertical.

    Parameters
    ----------
    model : mujoco.MjModel
        The scene built by :func:`build_scene` from ``items``.
    items : sequence of Payload or SwingingBall
    """

    #: Change of a ball's horizontal velocity within one tick that counts as a hit even when no
    #: contact is seen at the tick (the rope and gravity change it by about 0.2 m/s per 10 ms) [m/s].
    jump_mps = 0.5

    def __init__(self, model: mujoco.MjModel, items: Sequence[SceneItem]) -> None:
        self.model = model
        self.items = tuple(items)
        self._balls = []
        for item in self.items:
            if isinstance(item, SwingingBall):
                body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, _ball_body_name(item))
                geoms = {g for g in range(model.ngeom) if model.geom_bodyid[g] == body}
                self._balls.append({"item": item, "body": body, "geoms": geoms, "contact_t": [],
                                    "max_force_n": 0.0, "vel_before": None, "vel_after": None,
                                    "t_before": None, "t_after": None, "prev_vel": None, "prev_t": None})
        self._robot_geoms = {
            g for g in range(model.ngeom)
            if model.geom_bodyid[g] != 0 and not model.body(model.body_rootid[model.geom_bodyid[g]]).name.startswith(
                DISTURBANCE_PREFIX) and not model.body(model.geom_bodyid[g]).name.startswith(DISTURBANCE_PREFIX)
        }
        self._payloads = [
            (mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name), item.rope_length_m)
            for name, item in zip(payload_body_names(self.items), [i for i in self.items if isinstance(i, Payload)])
        ]
        self._payload_max_angle = [0.0] * len(self._payloads)
        self._payload_angles: list[list[float]] = [[] for _ in self._payloads]
        self._force = np.zeros(6)

    def update(self, data: mujoco.MjData, t_s: float) -> None:
        """Record the state at time ``t_s`` (after a physics step)."""
        for ball in self._balls:
            force = 0.0
            for i in range(data.ncon):
                c = data.contact[i]
                g1, g2 = int(c.geom1), int(c.geom2)
                if (g1 in ball["geoms"] and g2 in self._robot_geoms) or (g2 in ball["geoms"] and g1 in self._robot_geoms):
                    mujoco.mj_contactForce(self.model, data, i, self._force)
                    force += abs(float(self._force[0]))
            vel = self._ball_centre_velocity(data, ball)
            # A hard hit can begin and end between two ticks: also count a jump of the ball's
            # horizontal velocity that the rope and gravity cannot produce in one tick.
            jump = ball["prev_vel"] is not None and float(np.linalg.norm(vel[:2] - ball["prev_vel"][:2])) > self.jump_mps
            if force > 0 or (jump and ball["vel_after"] is None):
                if not ball["contact_t"]:
                    ball["vel_before"], ball["t_before"] = ball["prev_vel"], ball["prev_t"]
                ball["contact_t"].append(t_s)
                ball["max_force_n"] = max(ball["max_force_n"], force)
                if force == 0 and ball["vel_after"] is None:
                    ball["vel_after"], ball["t_after"] = vel, t_s
            elif ball["contact_t"] and ball["vel_after"] is None:
                ball["vel_after"], ball["t_after"] = vel, t_s
            ball["prev_vel"], ball["prev_t"] = vel, t_s
        for k, (body, _length) in enumerate(self._payloads):
            rod = data.xpos[body] - data.xipos[body]  # pivot minus payload centre (rope direction, upwards)
            norm = float(np.linalg.norm(rod))
            angle = math.acos(max(-1.0, min(1.0, rod[2] / norm))) if norm > 1e-9 else 0.0
            self._payload_angles[k].append(angle)
            self._payload_max_angle[k] = max(self._payload_max_angle[k], angle)

    def _ball_centre_velocity(self, data: mujoco.MjData, ball: dict) -> np.ndarray:
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(self.model, data, mujoco.mjtObj.mjOBJ_BODY, ball["body"], vel, 0)
        return vel[3:].copy()  # linear velocity at the body CoM (the ball centre), world frame

    def summary(self) -> dict:
        """JSON-ready summary: per ball the contact window, peak force and impulse; per payload the swing."""
        balls = []
        for ball in self._balls:
            item = ball["item"]
            entry = {
                "name": item.name, "mass_kg": item.mass_kg, "release_s": item.release_s,
                "hit": bool(ball["contact_t"]),
                "first_contact_s": round(ball["contact_t"][0], 4) if ball["contact_t"] else None,
                "last_contact_s": round(ball["contact_t"][-1], 4) if ball["contact_t"] else None,
                "contact_ticks": len(ball["contact_t"]),
                "max_contact_force_n": round(ball["max_force_n"], 4),
                "impulse_ns": None, "impact_speed_mps": None,
            }
            if ball["vel_before"] is not None and ball["vel_after"] is not None:
                dp = -item.mass_kg * (ball["vel_after"][:2] - ball["vel_before"][:2])
                entry["impulse_ns"] = [round(float(v), 5) for v in dp]
                entry["impact_speed_mps"] = round(float(np.linalg.norm(ball["vel_before"])), 4)
            balls.append(entry)
        payloads = [
            {"max_swing_rad": round(a, 4),
             "swing_std_rad": round(float(np.std(angles)), 4) if angles else 0.0}
            for a, angles in zip(self._payload_max_angle, self._payload_angles)
        ]
        return {"balls": balls, "payloads": payloads}
