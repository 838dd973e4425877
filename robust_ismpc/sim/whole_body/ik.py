"""Whole-body inverse kinematics: from a :class:`~robust_ismpc.core.reference.GaitReference` to joint targets.

This is the only module importing mink. One differential-IK step per control cycle solves

.. math::

    \\min_{\\Delta q} \\sum_i w_i \\lVert J_i \\Delta q + e_i \\rVert^2 + \\mu \\lVert \\Delta q \\rVert^2
    \\quad \\text{s.t. joint limits}

with daqp, over the tasks CoM position, torso orientation (reference yaw, level roll and pitch),
left and right sole poses, and a low-weight posture task towards the standing posture. The
floating base is free in the IK.

Design choice: the IK configuration is an internal *reference* configuration (a kinematic copy
of the robot that integrates its own solution and is not reset to the measured state each
cycle). Its joint angles are sent as position targets, so the targets are smooth and consistent
with the reference; feedback on the real CoM is the MPC's job (it receives the measured CoM).
Re-seeding the IK base from the measured base each cycle (``IkSettings.base_feedback``) is
available; in the standing and 3 cm CoM-shift tests on G1 and OP3 it changed the CoM tracking by
less than 0.5 mm, so it is off by default. What does matter is the servo sag under load, which
the loop removes with :meth:`WholeBodyIk.static_torques` as a feedforward, or with
:meth:`WholeBodyIk.inverse_dynamics_torques` (the same with the reference motion's velocities and
accelerations) when the dynamics of the swing leg matter (G1 walking).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass

import mink
import mujoco
import numpy as np

from ...core.reference import GaitReference
from ...exceptions import ModelError, ParameterError, SolverError
from ...robots.spec import RobotSpec
from ..model import compile_model, foot_frame_pose, frame_body, frame_id, standing_qpos

logger = logging.getLogger("robust_ismpc")


def _yaw_rotation(yaw_rad: float) -> np.ndarray:
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class IkSettings:
    """Weights and solver settings of the whole-body IK.

    Attributes
    ----------
    com_cost : float
        Weight of the CoM position task [1/m].
    foot_position_cost, foot_orientation_cost : float
        Weights of the sole pose tasks [1/m], [1/rad].
    torso_orientation_cost : float
        Weight of the torso orientation task [1/rad].
    posture_cost : float
        Weight of the posture task towards the standing posture on the leg joints [1/rad].
    upper_body_posture_cost : float
        Weight of the posture task on the other joints (waist, arms, head) [1/rad]; higher, so
        that the legs, not the arms, move the CoM.
    damping : float
        Levenberg-Marquardt damping on all velocities.
    iterations : int
        IK iterations per control cycle (1 is usually enough: the reference moves little).
    solver : str
        QP solver passed to mink (``"daqp"``).
    base_feedback : bool
        If true, the IK base pose is reset to the measured base pose before each solve (see the
        module docstring); default false (internal reference configuration).
    """

    com_cost: float = 10.0
    foot_position_cost: float = 10.0
    foot_orientation_cost: float = 5.0
    torso_orientation_cost: float = 2.0
    posture_cost: float = 0.05
    upper_body_posture_cost: float = 1.0
    damping: float = 1e-4
    iterations: int = 1
    solver: str = "daqp"
    base_feedback: bool = False

    def __post_init__(self) -> None:
        for name in ("com_cost", "foot_position_cost", "foot_orientation_cost", "torso_orientation_cost",
                     "posture_cost", "upper_body_posture_cost", "damping"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
                raise ParameterError(f"IkSettings.{name} must be a finite number >= 0, got {value!r}")
        if not isinstance(self.iterations, int) or self.iterations < 1:
            raise ParameterError(f"IkSettings.iterations must be an integer >= 1, got {self.iterations!r}")


@dataclass(frozen=True)
class IkErrors:
    """Task errors of the IK configuration after a step (norms).

    Attributes
    ----------
    com_m : float
        CoM position error [m].
    left_sole_m, right_sole_m : float
        Sole position errors [m].
    left_sole_rad, right_sole_rad : float
        Sole orientation errors [rad].
    torso_rad : float
        Torso orientation error [rad].
    """

    com_m: float
    left_sole_m: float
    right_sole_m: float
    left_sole_rad: float
    right_sole_rad: float
    torso_rad: float

    @property
    def max_position_m(self) -> float:
        """Largest position error [m]."""
        return max(self.com_m, self.left_sole_m, self.right_sole_m)


def _wrench_cop(points: list[np.ndarray], force: np.ndarray) -> np.ndarray | None:
    """Centre of pressure on the floor z = 0 of sole wrenches ``force`` (6 per point: force,
    moment about the point, world frame); None without vertical load."""
    fz = 0.0
    moment = np.zeros(2)
    for i, point in enumerate(points):
        f, tau = force[6 * i : 6 * i + 3], force[6 * i + 3 : 6 * i + 6]
        # moment about the floor point below ``point``: tau + (0, 0, point_z) x f
        mx = tau[0] - point[2] * f[1]
        my = tau[1] + point[2] * f[0]
        fz += f[2]
        moment += np.array([point[0] * f[2] - my, point[1] * f[2] + mx])
    return moment / fz if fz > 1e-9 else None


class WholeBodyIk:
    """Differential IK of one robot, stepping an internal reference configuration.

    Parameters
    ----------
    spec : RobotSpec
        The robot.
    settings : IkSettings, optional
        Weights and solver.

    Notes
    -----
    The IK model is the robot scene of ``spec`` (no disturbance bodies), so that the CoM task
    concerns the robot alone. Body 1 of that model must be the root body.
    """

    def __init__(self, spec: RobotSpec, settings: IkSettings | None = None) -> None:
        self.spec = spec
        self.settings = settings or IkSettings()
        self.model = compile_model(spec)
        root_id = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, spec.root_body)
        if root_id != 1:
            raise ModelError(
                f"the IK needs the root body {spec.root_body!r} to be the first body of the model (id 1), "
                f"it is {root_id}"
            )
        self.standing_qpos = standing_qpos(spec, self.model)
        self.configuration = mink.Configuration(self.model, self.standing_qpos.copy())
        s = self.settings
        self._com_task = mink.ComTask(cost=s.com_cost)
        self._torso_task = mink.FrameTask(
            spec.torso_body, "body", position_cost=0.0, orientation_cost=s.torso_orientation_cost
        )
        self._foot_tasks = {
            side: mink.FrameTask(
                spec.foot_name(side), spec.foot_frame_type,
                position_cost=s.foot_position_cost, orientation_cost=s.foot_orientation_cost,
            )
            for side in ("left", "right")
        }
        posture_cost = np.full(self.model.nv, s.upper_body_posture_cost)
        for joint in spec.leg_joints:
            jid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, joint)
            posture_cost[self.model.jnt_dofadr[jid]] = s.posture_cost
        self._posture_task = mink.PostureTask(self.model, cost=posture_cost)
        self._posture_task.set_target(self.standing_qpos)
        self._tasks = [self._com_task, self._torso_task, *self._foot_tasks.values(), self._posture_task]
        self._limits = [mink.ConfigurationLimit(self.model)]
        self._foot_ids = {
            side: frame_id(self.model, spec.foot_frame_type, spec.foot_name(side), f"{side} foot")
            for side in ("left", "right")
        }
        self._offsets = {side: spec.sole_offset_m(side) for side in ("left", "right")}
        self._foot_bodies = {
            side: frame_body(self.model, spec.foot_frame_type, fid) for side, fid in self._foot_ids.items()
        }
        self._dyn_data = mujoco.MjData(self.model)
        self.last_contact_cop_m: np.ndarray | None = None
        self.last_solve_time_s = 0.0

    # ------------------------------------------------------------------ state
    def reset(self, qpos: np.ndarray | None = None) -> None:
        """Set the reference configuration (default: standing posture), shape (model.nq,)."""
        q = self.standing_qpos if qpos is None else np.asarray(qpos, dtype=float)
        if q.shape != (self.model.nq,):
            raise ParameterError(f"qpos must have shape ({self.model.nq},), got {q.shape}")
        self.configuration.update(q.copy())

    @property
    def qpos(self) -> np.ndarray:
        """Reference configuration, shape (model.nq,) (a copy)."""
        return self.configuration.q.copy()

    def com_m(self) -> np.ndarray:
        """CoM of the reference configuration, shape (3,) [m]."""
        return self.configuration.data.subtree_com[1].copy()

    def sole_pose(self, side: str) -> tuple[np.ndarray, np.ndarray]:
        """Sole frame of the reference configuration: (position (3,) [m], rotation (3, 3))."""
        pos, rot = foot_frame_pose(self.model, self.configuration.data, self.spec.foot_frame_type,
                                   self._foot_ids[side])
        return pos + rot @ self._offsets[side], rot.copy()

    # ------------------------------------------------------------------ targets
    def _foot_target(self, sole_pos_m: np.ndarray, yaw_rad: float, side: str) -> mink.SE3:
        rot = _yaw_rotation(yaw_rad)
        foot_pos = np.asarray(sole_pos_m, dtype=float) - rot @ self._offsets[side]
        return mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(rot), foot_pos)

    def set_targets(
        self,
        com_pos_m: np.ndarray,
        left_sole: tuple[np.ndarray, float],
        right_sole: tuple[np.ndarray, float],
        torso_yaw_rad: float,
    ) -> None:
        """Set the task targets.

        Parameters
        ----------
        com_pos_m : ndarray, shape (3,)
            CoM position [m].
        left_sole, right_sole : (ndarray (3,), float)
            Sole position [m] and yaw [rad].
        torso_yaw_rad : float
            Torso yaw [rad]; roll and pitch targets are zero.
        """
        self._com_task.set_target(np.asarray(com_pos_m, dtype=float))
        self._foot_tasks["left"].set_target(self._foot_target(left_sole[0], left_sole[1], "left"))
        self._foot_tasks["right"].set_target(self._foot_target(right_sole[0], right_sole[1], "right"))
        self._torso_task.set_target(
            mink.SE3.from_rotation_and_translation(
                mink.SO3.from_matrix(_yaw_rotation(torso_yaw_rad)), np.zeros(3)
            )
        )

    def set_reference(self, reference: GaitReference) -> None:
        """Set the task targets from a gait reference."""
        self.set_targets(
            reference.com_pos_m,
            (reference.left_foot.pos_m, reference.left_foot.yaw_rad),
            (reference.right_foot.pos_m, reference.right_foot.yaw_rad),
            reference.torso_yaw_rad,
        )

    # ------------------------------------------------------------------ solve
    def solve(self, dt_s: float, measured_base_qpos: np.ndarray | None = None) -> np.ndarray:
        """Run the IK iterations towards the current targets and integrate.

        Parameters
        ----------
        dt_s : float
            Control period [s] (the velocity solution is integrated over it).
        measured_base_qpos : ndarray, shape (7,), optional
            Measured free-joint coordinates (position, wxyz quaternion); used only with
            ``settings.base_feedback``.

        Returns
        -------
        ndarray, shape (model.nq,)
            Updated reference configuration (a copy).

        Raises
        ------
        SolverError
            If the QP solver finds no solution.
        """
        if not dt_s > 0:
            raise ParameterError(f"dt_s must be > 0, got {dt_s!r}")
        start = time.perf_counter()
        conf = self.configuration
        if self.settings.base_feedback and measured_base_qpos is not None:
            q = conf.q.copy()
            q[:7] = measured_base_qpos
            conf.update(q)
        for _ in range(self.settings.iterations):
            try:
                velocity = mink.solve_ik(
                    conf, self._tasks, dt_s, solver=self.settings.solver,
                    damping=self.settings.damping, limits=self._limits,
                )
            except mink.exceptions.NoSolutionFound as exc:
                raise SolverError(f"whole-body IK: {exc}") from None
            conf.integrate_inplace(velocity, dt_s)
        self.last_solve_time_s = time.perf_counter() - start
        return conf.q.copy()

    def step(self, reference: GaitReference, dt_s: float, measured_base_qpos: np.ndarray | None = None) -> np.ndarray:
        """Set the targets from ``reference`` and solve; returns the configuration, shape (nq,)."""
        self.set_reference(reference)
        return self.solve(dt_s, measured_base_qpos)

    def static_torques(
        self, left_load: float, left_contact: bool = True, right_contact: bool = True,
        com_force_n: np.ndarray | None = None,
    ) -> np.ndarray:
        r"""Generalised forces that hold the reference configuration still under gravity.

        The sole wrenches are the weighted minimum-norm solution of the floating-base
        equilibrium :math:`J_{c,b}^T f = g_b`, with the vertical load shared ``left_load`` :
        ``1 - left_load`` between the feet in contact; the joint torques are then
        :math:`\tau = g_j - J_{c,j}^T f`.

        Parameters
        ----------
        left_load : float
            Share of the weight on the left foot, in [0, 1].
        left_contact, right_contact : bool
            Which feet carry load (at least one).
        com_force_n : ndarray, shape (3,), optional
            External force acting on the CoM [N] (see :meth:`inverse_dynamics_torques`).

        Returns
        -------
        ndarray, shape (model.nv,)
            Torques [N m] (zero on the floating-base coordinates).
        """
        return self.inverse_dynamics_torques(None, None, left_load, left_contact, right_contact, com_force_n)

    def inverse_dynamics_torques(
        self,
        qvel: np.ndarray | None,
        qacc: np.ndarray | None,
        left_load: float,
        left_contact: bool = True,
        right_contact: bool = True,
        com_force_n: np.ndarray | None = None,
    ) -> np.ndarray:
        r"""Joint torques that realise the reference configuration's motion with the feet as contacts.

        As :meth:`static_torques`, with the bias :math:`g` replaced by the inverse dynamics
        :math:`M(q)\ddot q + C(q, \dot q)\dot q + g(q)` of the reference configuration moving with
        ``qvel`` and ``qacc``: the sole wrenches :math:`f` solve the base rows (weighted
        minimum norm in double support, exactly in single support) and
        :math:`\tau = (M\ddot q + h)_j - J_{c,j}^T f`.

        Parameters
        ----------
        qvel, qacc : ndarray, shape (model.nv,), or None
            Velocity and acceleration of the reference configuration (None: zero).
        left_load : float
            Share of the vertical load on the left foot in double support, in [0, 1].
        left_contact, right_contact : bool
            Which feet carry load (at least one; none gives zero torques).
        com_force_n : ndarray, shape (3,), optional
            External force [N] acting on every body in proportion to its mass, i.e. a uniform
            acceleration ``com_force_n / m`` of the whole robot (the LIP's disturbance ``w``
            times the mass). Its generalised force :math:`J_{com}^T F` is subtracted from the
            inverse dynamics: the feet then carry only the rest, and the joints hold the
            posture against the force.

        Returns
        -------
        ndarray, shape (model.nv,)
            Torques [N m] (zero on the floating-base coordinates).
        """
        m = self.model
        if qvel is None and qacc is None:
            d = self.configuration.data
            bias = np.empty(m.nv)
            mujoco.mj_rne(m, d, 0, bias)
        else:
            d = self._dyn_data
            d.qpos[:] = self.configuration.q
            d.qvel[:] = 0.0 if qvel is None else qvel
            d.qacc[:] = 0.0 if qacc is None else qacc
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)
            mujoco.mj_comVel(m, d)
            bias = np.empty(m.nv)
            mujoco.mj_rne(m, d, 1, bias)
        if com_force_n is not None and np.any(com_force_n):
            jac_com = np.empty((3, m.nv))
            mujoco.mj_jacSubtreeCom(m, d, jac_com, 1)
            bias = bias - jac_com.T @ np.asarray(com_force_n, dtype=float)
        sides = [s for s, flag in (("left", left_contact), ("right", right_contact)) if flag]
        if not sides:
            return np.zeros(m.nv)
        jac_rows, weights, points = [], [], []
        jacp, jacr = np.empty((3, m.nv)), np.empty((3, m.nv))
        for side in sides:
            pos, rot = foot_frame_pose(m, d, self.spec.foot_frame_type, self._foot_ids[side])
            points.append(pos + rot @ self._offsets[side])
            mujoco.mj_jac(m, d, jacp, jacr, points[-1], self._foot_bodies[side])
            jac_rows.append(np.vstack([jacp, jacr]))
            share = left_load if side == "left" else 1.0 - left_load
            weights.append(np.full(6, min(max(share, 0.02), 1.0)))
        jac = np.vstack(jac_rows)  # (6 k, nv)
        w = np.concatenate(weights)
        jb = jac[:, :6]  # base columns
        # f = W jb (jb^T W jb)^-1 b_b  (W = diag(load share): heavier foot takes more)
        lhs = jb.T @ (w[:, None] * jb)
        force = w * (jb @ np.linalg.solve(lhs, bias[:6]))
        torque = bias - jac.T @ force
        torque[:6] = 0.0
        self.last_contact_cop_m = _wrench_cop(points, force)
        return torque

    def errors(self) -> IkErrors:
        """Task errors of the current reference configuration."""
        conf = self.configuration
        com = float(np.linalg.norm(self._com_task.compute_error(conf)))
        out = {}
        for side, task in self._foot_tasks.items():
            err = task.compute_error(conf)
            out[f"{side}_sole_m"] = float(np.linalg.norm(err[:3]))
            out[f"{side}_sole_rad"] = float(np.linalg.norm(err[3:]))
        torso = float(np.linalg.norm(self._torso_task.compute_error(conf)[3:]))
        return IkErrors(com_m=com, torso_rad=torso, **out)
