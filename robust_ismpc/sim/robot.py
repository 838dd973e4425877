"""What a robot in MuJoCo measures: CoM, sole poses, contact forces and centre of pressure.

:class:`MujocoRobot` wraps a compiled scene (``MjModel`` + ``MjData``) of one
:class:`~robust_ismpc.robots.RobotSpec` and turns its state into typed values, in particular the
:class:`~robust_ismpc.core.reference.Measurement` the controller consumes. It never changes the state.

Conventions: world frame, z up, the floor is the plane z = 0 (geoms of the world body).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from ..core.params import GRAVITY_MPS2
from ..core.reference import Measurement
from ..exceptions import ModelError, ParameterError
from ..robots.spec import RobotSpec
from .model import foot_frame_pose, frame_body, frame_id, standing_qpos
from .polygon import SolePose, convex_hull

SIDES = ("left", "right")
#: Name prefix of bodies added to a scene as disturbances; they are not part of the robot.
DISTURBANCE_PREFIX = "disturbance_"


@dataclass(frozen=True)
class ContactState:
    """Contact forces between the feet and the floor.

    Attributes
    ----------
    left_force_n, right_force_n : float
        Total normal (vertical) force on each foot [N].
    left_in_contact, right_in_contact : bool
        Normal force above the contact threshold.
    left_cop_m, right_cop_m : ndarray, shape (2,), or None
        Centre of pressure of each foot on the floor [m]; None without contact.
    cop_m : ndarray, shape (2,), or None
        Centre of pressure of all foot contacts (the measured ZMP) [m]; None without contact.
    horizontal_force_n : ndarray, shape (2,)
        Sum of the horizontal (x, y) contact forces on both feet [N], world frame.
    force_n : ndarray, shape (3,)
        Sum of the contact forces on both feet [N], world frame.
    moment_origin_nm : ndarray, shape (3,)
        Their moment about the world origin, ``sum p_i x f_i`` [N m].
    """

    left_force_n: float
    right_force_n: float
    left_in_contact: bool
    right_in_contact: bool
    left_cop_m: np.ndarray | None
    right_cop_m: np.ndarray | None
    cop_m: np.ndarray | None
    horizontal_force_n: np.ndarray
    force_n: np.ndarray
    moment_origin_nm: np.ndarray

    def moment_about(self, point_m: np.ndarray) -> np.ndarray:
        """Moment of the contact forces about ``point_m`` (3,) [N m], shape (3,)."""
        px, py, pz = np.asarray(point_m, dtype=float).tolist()
        fx, fy, fz = self.force_n.tolist()
        return self.moment_origin_nm - np.array([py * fz - pz * fy, pz * fx - px * fz, px * fy - py * fx])


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of 3-vectors along the last axis (``np.cross`` without its overhead)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def _yaw_of(rot: np.ndarray) -> float:
    return math.atan2(rot[1, 0], rot[0, 0])


class MujocoRobot:
    """Measurements of one robot in a MuJoCo scene.

    Parameters
    ----------
    spec : RobotSpec
        The robot.
    model : mujoco.MjModel
        Compiled scene containing the robot (possibly with disturbance bodies).
    data : mujoco.MjData
        Its data; measurement methods read it as it is (call ``mj_forward`` first, or use
        :meth:`measure`, which does).
    contact_threshold_n : float, optional
        Normal force above which a foot counts as in contact [N]; default 1 % of the weight.

    Raises
    ------
    ModelError
        A name of ``spec`` is absent from ``model``.
    """

    def __init__(
        self,
        spec: RobotSpec,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        contact_threshold_n: float | None = None,
    ) -> None:
        self.spec = spec
        self.model = model
        self.data = data
        self.root_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, spec.root_body)
        if self.root_id < 0:
            raise ModelError(f"root body {spec.root_body!r} not found in the scene")
        self.torso_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, spec.torso_body)
        if self.torso_id < 0:
            raise ModelError(f"torso body {spec.torso_body!r} not found in the scene")
        jnt = model.body_jntadr[self.root_id]
        self.root_qpos_adr = int(model.jnt_qposadr[jnt])
        self.root_dof_adr = int(model.jnt_dofadr[jnt])
        self._foot_ids = {
            side: frame_id(model, spec.foot_frame_type, spec.foot_name(side), f"{side} foot") for side in SIDES
        }
        self._offsets = {side: spec.sole_offset_m(side) for side in SIDES}

        # Robot bodies: the root's subtree minus bodies added as disturbances (and their subtrees).
        in_robot = np.zeros(model.nbody, dtype=bool)
        for b in range(1, model.nbody):
            parent = b
            chain_ok = True
            while parent != 0 and parent != self.root_id:
                if model.body(parent).name.startswith(DISTURBANCE_PREFIX):
                    chain_ok = False
                    break
                parent = model.body_parentid[parent]
            in_robot[b] = chain_ok and parent == self.root_id
        self.robot_body_ids = np.flatnonzero(in_robot)
        # the masses and inertias the robot is measured with: the model's as built (a simulated
        # model mismatch changes the model afterwards, sim/mismatch.py)
        self._body_mass = model.body_mass[self.robot_body_ids].copy()
        self._body_inertia = model.body_inertia[self.robot_body_ids].copy()
        self.mass_kg = float(self._body_mass.sum())

        # Geoms of each foot (the foot frame's body and its descendants) and of the floor.
        def subtree(body: int) -> set[int]:
            out = {body}
            for b in range(body + 1, model.nbody):
                if model.body_parentid[b] in out:
                    out.add(b)
            return out

        self._foot_geoms = {}
        for side in SIDES:
            bodies = subtree(self.foot_body_id(side))
            self._foot_geoms[side] = np.array([g for g in range(model.ngeom) if model.geom_bodyid[g] in bodies])
        self._ground_geoms = np.array([g for g in range(model.ngeom) if model.geom_bodyid[g] == 0])
        self.contact_threshold_n = (
            0.01 * self.mass_kg * GRAVITY_MPS2 if contact_threshold_n is None else float(contact_threshold_n)
        )
        # per geom: index of the foot side it belongs to (-1: none), and the floor's geoms
        self._geom_side_list = [-1] * model.ngeom
        for i, side in enumerate(SIDES):
            for g in self._foot_geoms[side].tolist():
                self._geom_side_list[g] = i
        self._ground_set = set(self._ground_geoms.tolist())
        self._wrench = np.zeros(6)
        self._outline = spec.sole_outline()

    def foot_geom_ids(self) -> np.ndarray:
        """Ids of the geoms of both feet that can touch the floor (contype or conaffinity set)."""
        m = self.model
        geoms = np.concatenate([self._foot_geoms[side] for side in SIDES]).astype(int)
        return geoms[(m.geom_contype[geoms] != 0) | (m.geom_conaffinity[geoms] != 0)]

    # ------------------------------------------------------------------ kinematics
    def _body_motion(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per robot body: centre of mass ``xipos``, its linear velocity and the angular velocity
        (world frame), each shape (n, 3), from the bodies' spatial velocities ``cvel``."""
        d, m = self.data, self.model
        ids = self.robot_body_ids
        xipos = d.xipos[ids]
        cvel = d.cvel[ids]
        omega = cvel[:, :3]
        return xipos, cvel[:, 3:] + _cross(omega, xipos - d.subtree_com[m.body_rootid[ids]]), omega

    def com(self) -> tuple[np.ndarray, np.ndarray]:
        """Whole-body CoM of the robot (disturbance bodies excluded).

        Returns
        -------
        com_pos_m : ndarray, shape (3,)
            CoM position [m].
        com_vel_mps : ndarray, shape (3,)
            CoM velocity [m/s], from the bodies' spatial velocities ``cvel``.
        """
        xipos, vel_points, _ = self._body_motion()
        return self._com_of(xipos, vel_points)

    def com_position(self) -> np.ndarray:
        """The CoM position of :meth:`com` alone [m], shape (3,) (no velocities computed)."""
        return self._body_mass @ self.data.xipos[self.robot_body_ids] / self.mass_kg

    def _com_of(self, xipos: np.ndarray, vel_points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        mass = self._body_mass
        return mass @ xipos / self.mass_kg, mass @ vel_points / self.mass_kg

    def angular_momentum(self) -> np.ndarray:
        """Angular momentum of the robot about its CoM (disturbance bodies excluded) [kg m^2/s], shape (3,).

        The sum over the robot's bodies of ``m_i (r_i - c) x (v_i - v_c) + I_i w_i``, with
        ``r_i`` and ``v_i`` the body's centre of mass and its velocity, ``I_i`` its inertia in the
        world frame and ``w_i`` its angular velocity (from ``cvel``).
        """
        motion = self._body_motion()
        return self._angular_momentum_of(*motion, *self._com_of(*motion[:2]))

    def _angular_momentum_of(self, xipos, vel_points, omega, com, vel) -> np.ndarray:
        ids = self.robot_body_ids
        orbital = self._body_mass[:, None] * _cross(xipos - com, vel_points - vel)
        rot = self.data.ximat[ids].reshape(-1, 3, 3)
        local = np.einsum("nji,nj->ni", rot, omega) * self._body_inertia
        spin = np.einsum("nij,nj->ni", rot, local)
        return (orbital + spin).sum(axis=0)

    def sole_frame(self, side: str) -> tuple[np.ndarray, np.ndarray]:
        """Sole centre (3,) [m] and sole-frame rotation (3, 3) of ``side`` in the world."""
        pos, rot = foot_frame_pose(self.model, self.data, self.spec.foot_frame_type, self._foot_ids[side])
        return pos + rot @ self._offsets[side], rot

    def foot_body_id(self, side: str) -> int:
        """Body that carries the sole frame of ``side`` (for Jacobians of sole points)."""
        return frame_body(self.model, self.spec.foot_frame_type, self._foot_ids[side])

    def sole_pose(self, side: str) -> SolePose:
        """Sole pose of ``side`` (``"left"`` or ``"right"``) in the world."""
        pos, rot = self.sole_frame(side)
        return SolePose(pos, _yaw_of(rot))

    def sole_rotation(self, side: str) -> np.ndarray:
        """Rotation matrix of the sole frame of ``side``, shape (3, 3)."""
        return self.sole_frame(side)[1].copy()

    def root_height_m(self) -> float:
        """Height of the root body origin [m]."""
        return float(self.data.xpos[self.root_id][2])

    def torso_tilt_rad(self) -> float:
        """Angle between the torso body z axis and the world z axis [rad]."""
        zz = float(self.data.xmat[self.torso_id][8])
        return math.acos(max(-1.0, min(1.0, zz)))

    def base_qpos(self) -> np.ndarray:
        """Free-joint coordinates of the root (position, wxyz quaternion), shape (7,)."""
        return self.data.qpos[self.root_qpos_adr : self.root_qpos_adr + 7].copy()

    # ------------------------------------------------------------------ contacts
    def contacts(self) -> ContactState:
        """Foot-floor contact forces and centres of pressure (see :class:`ContactState`).

        Each contact force is rotated to the world frame and taken as acting on the foot; the
        centre of pressure on the floor plane z = 0 is

        .. math:: c_x = \\frac{\\sum_i p_{x,i} f_{z,i} - p_{z,i} f_{x,i}}{\\sum_i f_{z,i}},\\quad
                  c_y = \\frac{\\sum_i p_{y,i} f_{z,i} - p_{z,i} f_{y,i}}{\\sum_i f_{z,i}}

        per foot and over both feet (the f_z-weighted average of the feet's CoPs).
        """
        m, d = self.model, self.data
        # plain Python floats: a walking robot has about ten foot contacts, where numpy's
        # per-call overhead would dominate
        fz = [0.0, 0.0]
        moment = [[0.0, 0.0], [0.0, 0.0]]  # per side: sum(p_xy f_z - p_z f_xy)
        fx_sum = fy_sum = fz_sum = mx_sum = my_sum = mz_sum = 0.0
        n = d.ncon
        if n:
            con = d.contact
            side_of, ground = self._geom_side_list, self._ground_set
            frames, points = con.frame.tolist(), con.pos.tolist()
            wrench = self._wrench
            for i, (g1, g2) in enumerate(zip(con.geom1.tolist(), con.geom2.tolist())):
                if g1 in ground and side_of[g2] >= 0:
                    side, sign = side_of[g2], 1.0
                elif g2 in ground and side_of[g1] >= 0:
                    side, sign = side_of[g1], -1.0
                else:
                    continue
                mujoco.mj_contactForce(m, d, i, wrench)
                w0, w1, w2 = wrench[:3].tolist()
                f0, f1, f2 = sign * w0, sign * w1, sign * w2
                r = frames[i]  # rows: contact normal and tangents in the world
                fx = f0 * r[0] + f1 * r[3] + f2 * r[6]
                fy = f0 * r[1] + f1 * r[4] + f2 * r[7]
                fzi = f0 * r[2] + f1 * r[5] + f2 * r[8]
                if fzi <= 0.0:
                    continue
                px, py, pz = points[i]
                fz[side] += fzi
                fx_sum += fx
                fy_sum += fy
                fz_sum += fzi
                mx_sum += py * fzi - pz * fy
                my_sum += pz * fx - px * fzi
                mz_sum += px * fy - py * fx
                moment[side][0] += px * fzi - pz * fx
                moment[side][1] += py * fzi - pz * fy
        force_sum = np.array([fx_sum, fy_sum, fz_sum])
        in_contact = [fz[0] > self.contact_threshold_n, fz[1] > self.contact_threshold_n]
        cops: list[np.ndarray | None] = [np.array(moment[s]) / fz[s] if in_contact[s] else None for s in range(2)]
        # over the feet in contact: the sum of their moments over the sum of their normal forces
        total = cop_x = cop_y = 0.0
        for s in range(2):
            if in_contact[s]:
                total += fz[s]
                cop_x += moment[s][0]
                cop_y += moment[s][1]
        cop = np.array([cop_x, cop_y]) / total if total > 0 else None
        return ContactState(
            left_force_n=fz[0],
            right_force_n=fz[1],
            left_in_contact=in_contact[0],
            right_in_contact=in_contact[1],
            left_cop_m=cops[0],
            right_cop_m=cops[1],
            cop_m=cop,
            horizontal_force_n=force_sum[:2].copy(),
            force_n=force_sum,
            moment_origin_nm=np.array([mx_sum, my_sum, mz_sum]),
        )

    def support_polygon(self, contacts: ContactState | None = None) -> np.ndarray:
        """Convex hull of the soles in contact, shape (k, 2) [m] (k = 0 when airborne).

        Each sole contributes its load-bearing outline (:meth:`RobotSpec.sole_outline`).
        """
        contacts = self.contacts() if contacts is None else contacts
        outline = self._outline
        corners = []
        for side, flag in zip(SIDES, (contacts.left_in_contact, contacts.right_in_contact)):
            if flag:
                pose = self.sole_pose(side)
                c, s = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
                corners.append(pose.pos_m[:2] + outline @ np.array([[c, s], [-s, c]]))
        if not corners:
            return np.zeros((0, 2))
        return convex_hull(np.vstack(corners))

    # ------------------------------------------------------------------ measurement
    def measure(self, forward: bool = True, mean_horizontal_force_n: np.ndarray | None = None,
                external_moment_acc_mps2: np.ndarray | None = None,
                mass_kg: float | None = None) -> tuple[Measurement, ContactState]:
        """The controller's measurement and the contact state.

        ``contact_acc_mps2`` is the horizontal contact force per unit mass over the control
        period that just ended: ``mean_horizontal_force_n / m`` when given (the simulation
        averages it over its physics steps, :meth:`MujocoSimulation.advance`), else the current
        contact force's; ``m`` is ``mass_kg`` when given (the weighed mass), else the model's.

        Parameters
        ----------
        forward : bool
            Run ``mj_forward`` first so that positions, velocities and contact forces all refer
            to the current state (cheap; leave True unless the caller just did it).
        mean_horizontal_force_n : ndarray, shape (2,), optional
            Horizontal contact force averaged over the last control period [N] (world frame).
        external_moment_acc_mps2 : ndarray, shape (2,), optional
            Passed on as the measurement's ``external_moment_acc_mps2``
            (:meth:`~robust_ismpc.sim.loop.MujocoSimulation.measure` computes it).
        mass_kg : float, optional
            The mass the contact force accelerates [kg]; the model's when omitted.
        """
        if forward:
            mujoco.mj_forward(self.model, self.data)
        com, vel = self._com_of(*self._body_motion()[:2])
        contacts = self.contacts()
        zmp = None if contacts.cop_m is None else contacts.cop_m.copy()
        force = contacts.horizontal_force_n if mean_horizontal_force_n is None else mean_horizontal_force_n
        contact_acc = np.asarray(force, dtype=float)[:2] / (self.mass_kg if mass_kg is None else mass_kg)
        measurement = Measurement(com_pos_m=com, com_vel_mps=vel, zmp_m=zmp, contact_acc_mps2=contact_acc,
                                  external_moment_acc_mps2=external_moment_acc_mps2)
        return measurement, contacts


@dataclass(frozen=True)
class FallCriteria:
    """When the robot counts as fallen.

    Attributes
    ----------
    min_height_fraction : float
        Fallen when the root body is lower than this fraction of its standing height.
    max_tilt_rad : float
        Fallen when the torso tilts more than this from vertical [rad].
    """

    min_height_fraction: float = 0.6
    max_tilt_rad: float = 0.8

    def __post_init__(self) -> None:
        if not (0.0 < self.min_height_fraction < 1.0):
            raise ParameterError(
                f"FallCriteria.min_height_fraction must be in (0, 1), got {self.min_height_fraction!r}"
            )
        if not (0.0 < self.max_tilt_rad <= math.pi):
            raise ParameterError(f"FallCriteria.max_tilt_rad must be in (0, pi], got {self.max_tilt_rad!r}")

    def has_fallen(self, root_height_m: float, nominal_root_height_m: float, tilt_rad: float) -> bool:
        """True if the root is too low or the torso too tilted."""
        return root_height_m < self.min_height_fraction * nominal_root_height_m or tilt_rad > self.max_tilt_rad


def standing_state(spec: RobotSpec, model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Put the robot of ``data`` in its standing posture, soles on the floor, at rest.

    Extra joints of the scene (disturbances) keep their ``qpos0``; joint velocities are zeroed,
    actuator controls of position servos are set to the posture. Runs ``mj_forward``.
    """
    mujoco.mj_resetData(model, data)
    data.qpos[:] = standing_qpos(spec, model)
    data.qvel[:] = 0.0
    for a in range(model.nu):
        kp = model.actuator_gainprm[a, 0]
        if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT and kp > 0 and model.actuator_biasprm[a, 1] == -kp:
            data.ctrl[a] = data.qpos[model.jnt_qposadr[model.actuator_trnid[a, 0]]]
    mujoco.mj_forward(model, data)

