r"""Torque control of a full robot: an inverse-dynamics QP that realises the gait reference.

With ``LoopSettings.torque_control`` the joint actuators become torque motors and, at the robot
file's inverse-dynamics rate (every physics step by default), one QP over the joint
accelerations :math:`\ddot q` (floating base included) and the two sole wrenches
:math:`W_L, W_R` (force and moment about the sole centre, world frame)

.. math::

    \min \sum_k w_k \lVert A_k \ddot q - b_k \rVert^2 + \epsilon \lVert x \rVert^2
    \quad\text{s.t.}\quad
    M_b \ddot q + h_b = J_{L,b}^T W_L + J_{R,b}^T W_R,\quad
    J_s \ddot q + \dot J_s \dot q = -k_c v_s \ (\text{soles in contact}),

:math:`W = 0` for a swinging sole, each contact wrench inside its cone (normal force
>= ``min_normal_force_n``, friction pyramid, centre of pressure inside the sole rectangle shrunk
by ``cop_margin``, bounded torsion) and the joint torques
:math:`\tau = (M\ddot q + h - J_L^T W_L - J_R^T W_R)_j` within the joints' limits. The tasks are
the CoM acceleration (reference acceleration plus PD on the measured CoM), the swinging sole's
pose, the root orientation, and a low-weight posture task towards the whole-body IK
configuration (which carries the arms, the torso and the leg geometry of the reference). Task
targets are placed relative to the measured stance sole(s), so the drift of the real feet from
the plan does not enter. The solution goes to the motors as the robot's own command, per motor
(q, q̇, kp, kd, τ_ff), which their drivers apply at the physics rate until the next solve
(:mod:`robust_ismpc.sim.whole_body.motor_command`).

Unlike the position servos playing back the IK joints, this controller moves the centre of
pressure to keep the CoM on its reference: it is the balance feedback the servo loop lacks
(docs/robots.md, "Torque control"). The QP is dense (nv + 12 variables) and solved with DAQP.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, fields

import daqp
import mujoco
import numpy as np

from ...core.params import GRAVITY_MPS2
from ...core.reference import GaitReference
from ...exceptions import ParameterError, SolverError
from ...validation import check_nonnegative
from ..model import compile_model
from ..robot import SIDES, MujocoRobot
from ..state_estimation import RobotState, TrueState
from .actuators import ActuatorMap, actuator_torque_limits_nm, as_slice
from .motor_command import MotorCommand, held_command
from .qp_rows import NO_BOUND, QpRows, contact_cone


@dataclass(frozen=True)
class TorqueControlSettings:
    """Gains and weights of the inverse-dynamics QP.

    Attributes
    ----------
    com_kp, com_kd : float
        PD gains of the CoM task [1/s²], [1/s] (measured CoM against the reference).
    foot_kp, foot_kd : float
        PD gains of the swinging sole's position and orientation [1/s²], [1/s]; the sole's
        reference acceleration (a finite difference of the reference velocities of successive
        control ticks) is fed forward.
    root_kp, root_kd : float
        PD gains of the root orientation towards the IK configuration's [1/s²], [1/s].
    posture_kp, posture_kd : float
        PD gains of the joints towards the IK configuration [1/s²], [1/s].
    contact_damping : float
        k_c: a sole in contact is asked for the acceleration ``-k_c v`` [1/s].
    com_weight, foot_weight, root_weight, posture_weight : float
        Task weights (the CoM and the swinging sole dominate).
    friction : float
        Friction coefficient of the contact pyramid.
    cop_margin : float
        Fraction of the sole half-length and half-width the centre of pressure may use, in (0, 1].
    torsion_m : float
        Largest |moment about the sole normal| per newton of normal force [m].
    min_normal_force_n : float
        Smallest normal force of a sole in contact [N].
    regularisation : float
        ε, small weight on every variable.
    friction_smoothing_radps : float
        The joints' dry friction (MuJoCo ``frictionloss``, which the QP's dynamics leave out) is
        compensated by ``τ_f tanh(v / v_s)`` with ``v`` the joint velocity the solution reaches
        at the end of the physics step and ``v_s`` this value [rad/s]; 0 switches the
        compensation off. Without it G1's 0.3 N m joint friction left 40 % of a small lateral
        CoM acceleration unrealised in double support, and a closed loop on the measured CoM
        drifted to the edge of the ZMP box within 1.4 s (docs/closed-loop.md).
    momentum_weight : float
        Weight of the centroidal angular-momentum task; 0 switches it off. The task asks for the
        rate ``-momentum_damping * L`` and is scaled by ``1 / (m g)``, so that its error reads as
        the shift of the centre of pressure it causes [m]. Without it OP3 had 14 infeasible MPC
        cycles in 20 s of undisturbed walking, with it none (docs/closed-loop.md).
    momentum_damping : float
        Rate at which the task damps the centroidal angular momentum [1/s].
    joint_bandwidth_radps : float
        ω of the motor drivers' PD around the state the solution reaches when the next command
        comes (:mod:`robust_ismpc.sim.whole_body.motor_command`) [rad/s]; 0: the torques alone.
    """

    com_kp: float = 50.0
    com_kd: float = 14.0
    foot_kp: float = 400.0
    foot_kd: float = 40.0
    root_kp: float = 100.0
    root_kd: float = 20.0
    posture_kp: float = 400.0
    posture_kd: float = 40.0
    contact_damping: float = 10.0
    com_weight: float = 1000.0
    foot_weight: float = 10.0
    root_weight: float = 1.0
    posture_weight: float = 0.1
    friction: float = 0.7
    cop_margin: float = 0.9
    torsion_m: float = 0.02
    min_normal_force_n: float = 1.0
    regularisation: float = 1e-6
    friction_smoothing_radps: float = 0.02
    momentum_weight: float = 1e4
    momentum_damping: float = 10.0
    joint_bandwidth_radps: float = 0.0

    def __post_init__(self) -> None:
        check_nonnegative("TorqueControlSettings", **{f.name: getattr(self, f.name) for f in fields(self)})
        if self.friction <= 0:
            raise ParameterError(f"TorqueControlSettings.friction must be > 0, got {self.friction!r}")
        if not 0 < self.cop_margin <= 1:
            raise ParameterError(f"TorqueControlSettings.cop_margin must be in (0, 1], got {self.cop_margin!r}")


def _rotation_error(target: np.ndarray, current: np.ndarray) -> np.ndarray:
    """Rotation vector (world frame) that turns ``current`` into ``target`` (3x3 matrices)."""
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, (target @ current.T).reshape(-1))
    vec = np.empty(3)
    mujoco.mju_quat2Vel(vec, quat, 1.0)
    return vec


def _back_in_time(pos: np.ndarray, vel: np.ndarray, acc: np.ndarray, lead_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Position and velocity ``lead_s`` before a reference point, at constant acceleration."""
    return pos - lead_s * vel + 0.5 * lead_s**2 * acc, vel - lead_s * acc


def _yaw_matrix(yaw_rad: float) -> np.ndarray:
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class InverseDynamicsQp:
    """Joint torques that realise a gait reference on a torque-controlled MuJoCo robot.

    The QP uses a model of the robot alone (the robot file's), whose state is copied from the
    simulated scene at every call: like a controller on a real robot it does not know the
    objects of the scene (a bag hanging from an arm, a ball), which reach it only through the
    disturbance estimate of the reference.

    That estimate ``w`` (per unit mass, the LIP's) acts on the torso body: the part the measured
    external moment explains (``reference.disturbance_moment_mps2``) as the moment
    ``(τ_y, -τ_x) = m h w_moment``, which moves the centre of pressure without pushing the CoM,
    and the rest as a force ``m w_force`` applied at the CoM's height. Pushes and carried loads
    act on the trunk, and the joints must carry them from there. (As a uniform field on every
    link, the force the legs and arms would get for free: under a 26 N forward push on G1 the CoM
    accelerated 0.1 m/s² more than planned; and a payload's weight off-centre, a moment, taken as
    a force pushed the robust G1 off its path. docs/closed-loop.md.)

    Parameters
    ----------
    robot : MujocoRobot
        The robot in a simulation whose actuators are torque motors (``ctrl`` = torque).
    actuators : ActuatorMap
        Actuator ↔ joint indices of the simulation and IK models (the actuators' order is the
        order of the returned torques).
    settings : TorqueControlSettings
    com_model_error_m : tuple of float
        Horizontal offset (x, y) [m] of the CoM the controller's mass model computes from the
        true one (:attr:`~robust_ismpc.sim.loop.LoopSettings.com_model_error_m`). The QP's model
        shares that error: it believes the robot's weight acts at the CoM plus the offset, the
        moment ``e × m g`` about the true CoM, which it applies to the torso body as it does the
        measured external moment. That one holds the opposite
        moment (the true weight about the model's CoM), so the two cancel in the QP, as on a robot
        whose controller and whole body use one mass model; without it the QP would push the
        robot with a moment no body exerts.
    state : TrueState or SensedState, optional
        Where the QP reads the robot's configuration and velocity
        (:mod:`robust_ismpc.sim.state_estimation`); the simulator's state by default.
    """

    def __init__(self, robot: MujocoRobot, actuators: ActuatorMap, settings: TorqueControlSettings,
                 com_model_error_m: tuple[float, float] = (0.0, 0.0), state: RobotState | None = None) -> None:
        self.settings = settings
        self.scene_data = robot.data
        self.model = copy.deepcopy(compile_model(robot.spec))
        # the QP needs the mass matrix, bias forces and Jacobians only: no collision detection or
        # constraint assembly in its mj_forward
        self.model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
        self.data = mujoco.MjData(self.model)
        self.robot = MujocoRobot(robot.spec, self.model, self.data)
        self.state: RobotState = TrueState(self.model, robot.model, robot.data) if state is None else state
        self.actuators = actuators
        model = self.model
        own = ActuatorMap(model, model)  # the same actuators, indexed in the robot's own model
        if own.sim_dof_index.shape != actuators.sim_dof_index.shape:
            raise ParameterError("the simulated scene and the robot model have different actuators")
        self._body = {s: self.robot.foot_body_id(s) for s in SIDES}  # ids in the QP's own model
        self._half_length = 0.5 * robot.spec.sole_length_m * settings.cop_margin
        self._half_width = 0.5 * robot.spec.sole_width_m * settings.cop_margin
        self._root = self.robot.root_id
        self._n_motors = len(own.sim_dof_index)
        # the motors' dofs and qpos entries, and their dofs and qpos entries in the IK model: slices
        # where they are runs (views instead of copies)
        self._dof = as_slice(own.sim_dof_index)
        self._qpos_index = as_slice(own.sim_qpos_index)
        self._ik_dof = as_slice(actuators.ik_dof_index)
        self._ik_qpos = as_slice(actuators.ik_qpos_index)
        self._friction_nm = model.dof_frictionloss[self._dof].copy()
        self._limits = actuator_torque_limits_nm(model)  # rows in actuator order, as self._dof
        self._timestep_s = float(model.opt.timestep)  # of the QP's own model, which nothing changes
        nv = model.nv
        self._M = np.zeros((nv, nv))
        self._jac = np.zeros((2, 6, nv))  # per sole: translation and rotation rows of its Jacobian
        self._jac_dot = np.zeros((2, 6, nv))
        self._jac_torso = np.zeros((3, nv))
        self._jac_torso_rot = np.zeros((3, nv))
        self._jac_load = np.zeros((3, nv))
        self._torso_point = np.zeros(3)
        error = np.asarray(com_model_error_m, dtype=float)
        weight_n = self.robot.mass_kg * GRAVITY_MPS2
        # e × (0, 0, -m g): the model's weight at c + e, as a moment about the true CoM
        self._model_error_moment_nm = weight_n * np.array([-error[1], error[0], 0.0])
        self._has_model_error = bool(np.any(self._model_error_moment_nm))
        # the Hessian's constant part: the regularisation, the posture task (a selection of q̈)
        # and the root orientation task (Rᵀ R = I for the root's rotation R)
        self._H_const = settings.regularisation * np.eye(nv + 12)
        self._H_const[own.sim_dof_index, own.sim_dof_index] += settings.posture_weight
        self._H_const[3:6, 3:6] += settings.root_weight * np.eye(3)
        # rows of a sole in contact, on its wrench in the sole frame (f, m): normal force >= its
        # minimum; then each of f_x, f_y, m_x, m_y, m_z within ± its limit times the normal force
        self._contact_rows, self._contact_lower, self._contact_upper = contact_cone(
            settings.friction, self._half_width, self._half_length, settings.torsion_m, settings.min_normal_force_n)
        self._rows: dict[tuple[bool, bool], QpRows] = {}  # per pair of soles in contact
        self._jac_com_prev: np.ndarray | None = None
        self._ang_prev: np.ndarray | None = None
        self._previous_solve_s: float | None = None  # time of the previous solve, for J̇ by differences
        # reference sole velocities (left, right) of the previous control tick, for the swing acceleration
        self._foot_ref: tuple[float, tuple[np.ndarray, np.ndarray]] | None = None
        self._foot_acc = (np.zeros(3), np.zeros(3))
        self.failures = 0
        #: Cycles whose QP had no solution within the torque limits and was solved without them.
        self.limit_relaxations = 0
        self.last_torques_nm = np.zeros(self._n_motors)
        #: The last solution: joint accelerations (nv,) and sole wrenches {side: (6,)} (world frame,
        #: force then moment about the sole centre), for inspection and tests.
        self.last_qacc: np.ndarray | None = None
        #: QPs solved so far (one per inverse-dynamics period under torque control).
        self.solve_count = 0
        self.last_wrenches: dict[str, np.ndarray] = {}

    def _jacobians(self, side: str, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Jacobian and its time derivative (6, nv) of ``point`` on the sole body of ``side``
        (translation rows, then rotation), in buffers that the next call for ``side`` overwrites."""
        m, d = self.model, self.data
        i = SIDES.index(side)
        jac, jac_dot = self._jac[i], self._jac_dot[i]
        mujoco.mj_jac(m, d, jac[:3], jac[3:], point, self._body[side])
        mujoco.mj_jacDot(m, d, jac_dot[:3], jac_dot[3:], point, self._body[side])
        return jac, jac_dot

    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        """The actuated joints' positions [rad] and velocities [rad/s] as :attr:`state` gives
        them (the encoders, under modelled sensors), each shape (nu,), in actuator order."""
        return self.state.qpos[self._qpos_index].copy(), self.state.qvel[self._dof].copy()

    @property
    def torque_limits_nm(self) -> np.ndarray:
        """Lower and upper torque limit per motor, shape (nu, 2) [N m], in actuator order."""
        return self._limits

    def command(self, reference: GaitReference, ik_qpos: np.ndarray, ik_qvel: np.ndarray, ik_qacc: np.ndarray,
                hold_s: float, weighed_mass_kg: float | None = None) -> MotorCommand:
        """The motor command that holds this state's solution for ``hold_s`` [s], until the next
        one (:func:`~robust_ismpc.sim.whole_body.motor_command.held_command`); arguments as
        :meth:`torques`."""
        tau = self.torques(reference, ik_qpos, ik_qvel, ik_qacc, weighed_mass_kg)
        qacc = np.zeros(self._n_motors) if self.last_qacc is None else self.last_qacc[self._dof]
        # the arrays are this solve's, of one length, and the mass matrix's diagonal is positive
        return held_command(tau, self.data.qpos[self._qpos_index], self.data.qvel[self._dof], qacc,
                            self._M.diagonal()[self._dof], hold_s, self.settings.joint_bandwidth_radps,
                            check=False)

    def _bias(self, reference: GaitReference, weighed_mass_kg: float | None) -> np.ndarray:
        """The bias forces of the QP's dynamics, shape (nv,): gravity, Coriolis and passive forces,
        the load the model lacks and the moments and forces on the torso (:meth:`torques`)."""
        m, d = self.model, self.data
        bias = d.qfrc_bias - d.qfrc_passive
        load_kg = 0.0 if weighed_mass_kg is None else float(weighed_mass_kg) - self.robot.mass_kg
        if load_kg != 0.0:
            # the weight the model lacks (or has in excess), at the CoM: a load, not a moment
            mujoco.mj_jac(m, d, self._jac_load, None, d.subtree_com[self._root], self._root)
            bias = bias + self._jac_load[2] * (load_kg * GRAVITY_MPS2)
        # the moments on the robot act on the torso body, where the measured moment they cancel
        # is applied: the model error's weight moment, then the disturbance the plan was made
        # for, its moment part as a moment (τ_y, -τ_x) = m h w_moment and the rest as a force
        # m w_force at the CoM's height
        disturbed = np.count_nonzero(reference.disturbance_mps2) > 0
        if disturbed or self._has_model_error:
            torso = self.robot.torso_id
            point = self._torso_point
            point[:2] = d.xipos[torso, :2]
            point[2] = d.subtree_com[self._root, 2]
            mujoco.mj_jac(m, d, self._jac_torso, self._jac_torso_rot, point, torso)
        if self._has_model_error:
            bias = bias - self._jac_torso_rot.T @ self._model_error_moment_nm
        if disturbed:
            moment_x, moment_y = float(reference.disturbance_moment_mps2[0]), float(reference.disturbance_moment_mps2[1])
            mass_kg = self.robot.mass_kg
            force_x = float(reference.disturbance_mps2[0]) - moment_x
            force_y = float(reference.disturbance_mps2[1]) - moment_y
            wrench_force = np.array([mass_kg * force_x, mass_kg * force_y, mass_kg * 0.0])
            arm = mass_kg * self.robot.spec.com_height_m
            wrench_moment = np.array([arm * -moment_y, arm * moment_x, arm * 0.0])
            bias = bias - self._jac_torso.T @ wrench_force - self._jac_torso_rot.T @ wrench_moment
        return bias

    def _qp_rows(self, in_contact: tuple[bool, bool]) -> QpRows:
        rows = self._rows.get(in_contact)
        if rows is None:
            rows = self._rows[in_contact] = QpRows(in_contact, self.model.nv, self._n_motors, self._contact_lower,
                                                   self._contact_upper)
        return rows

    def torques(self, reference: GaitReference, ik_qpos: np.ndarray, ik_qvel: np.ndarray,
                ik_qacc: np.ndarray, weighed_mass_kg: float | None = None) -> np.ndarray:
        """Motor torques for the current state, shape (nu,) [N m], in actuator order.

        ``ik_qpos``, ``ik_qvel``, ``ik_qacc`` are the IK reference configuration and its finite-
        difference velocity and acceleration (IK model indexing). ``weighed_mass_kg`` is the mass
        the feet weigh (:func:`~robust_ismpc.estimation.weight.weigh`; the model's when None): the
        weight beyond the model's, a load the robot carries that its model does not know, enters
        the equations of motion as a vertical force at the CoM; where that load hangs is in the
        measured moment (``reference.disturbance_moment_mps2``). Runs ``mj_forward`` first.
        If DAQP reports a failure, the previous torques are returned and ``failures`` counts it.

        Raises
        ------
        SolverError
            After more than 50 failed solves in the run.
        """
        m, d, s = self.model, self.data, self.settings
        self.solve_count += 1
        d.qpos[:] = self.state.qpos
        d.qvel[:] = self.state.qvel
        d.time = self.scene_data.time
        mujoco.mj_forward(m, d)
        nv = m.nv
        dof = self._dof
        mujoco.mj_fullM(m, d, self._M)
        M = self._M
        # CoM Jacobian; J̇ q̇ by a backward difference of the Jacobian
        jac_com = np.zeros((3, nv))
        mujoco.mj_jacSubtreeCom(m, d, jac_com, self._root)
        bias = self._bias(reference, weighed_mass_kg)
        qvel = d.qvel
        feet = (reference.left_foot, reference.right_foot)
        if self._foot_ref is None or reference.t_s != self._foot_ref[0]:  # a new control tick
            if self._foot_ref is not None and reference.t_s > self._foot_ref[0]:
                dt = reference.t_s - self._foot_ref[0]
                self._foot_acc = ((feet[0].vel_mps - self._foot_ref[1][0]) / dt,
                                  (feet[1].vel_mps - self._foot_ref[1][1]) / dt)
            self._foot_ref = (reference.t_s, (feet[0].vel_mps.copy(), feet[1].vel_mps.copy()))
        # the reference is the state at the end of the control period: compare it with the
        # current state at the current time
        lead = max(0.0, reference.t_s - float(d.time))
        soles = [self.robot.sole_frame(side) for side in SIDES]
        jac, jac_dot = zip(*(self._jacobians(side, soles[i][0]) for i, side in enumerate(SIDES)))
        in_contact = (bool(feet[0].in_contact), bool(feet[1].in_contact))
        stance = [i for i in (0, 1) if in_contact[i]] or [0, 1]
        real_anchor = sum(soles[i][0] for i in stance) / len(stance)
        ref_anchor = sum(feet[i].pos_m for i in stance) / len(stance)

        # Variables x = (q̈ (nv), left sole wrench (6), right sole wrench (6)). Every task row acts
        # on q̈ only: its Hessian and gradient terms go into the q̈ block, from one stack of
        # weighted rows √w (J q̈ - b).
        task_J: list[np.ndarray] = []
        task_b: list[np.ndarray] = []
        rows = self._qp_rows(in_contact)
        A, upper_all, lower_all = rows.A, rows.upper, rows.lower
        # floating-base rows of the dynamics
        A[:6, :nv] = M[:6]
        A[:6, nv:nv + 6] = -jac[0][:, :6].T
        A[:6, nv + 6:] = -jac[1][:, :6].T
        upper_all[:6] = -bias[:6]
        row = 6
        for i in (0, 1):
            J, Jdot = jac[i], jac_dot[i]
            velocity = J @ qvel
            if in_contact[i]:
                A[row:row + 6, :nv] = J
                upper_all[row:row + 6] = -Jdot @ qvel - s.contact_damping * velocity
                row += 6
                continue
            foot = feet[i]
            foot_pos, foot_vel = _back_in_time(foot.pos_m, foot.vel_mps, self._foot_acc[i], lead)
            target = real_anchor + (foot_pos - ref_anchor)
            linear = (self._foot_acc[i] + s.foot_kp * (target - soles[i][0])
                      + s.foot_kd * (foot_vel - velocity[:3]))
            angular = (s.foot_kp * _rotation_error(_yaw_matrix(foot.yaw_rad), soles[i][1])
                       - s.foot_kd * velocity[3:])
            w = math.sqrt(s.foot_weight)
            task_J.append(w * J)
            task_b.append(w * (np.concatenate([linear, angular]) - Jdot @ qvel))
        n_eq = rows.n_eq
        lower_all[:n_eq] = upper_all[:n_eq]
        # CoM (relative to the stance soles)
        com = d.subtree_com[self._root]
        com_vel = jac_com @ qvel
        # J̇ by a backward difference over the time since the previous solve
        since = None if self._previous_solve_s is None else float(d.time) - self._previous_solve_s
        self._previous_solve_s = float(d.time)
        if since is not None and not since > 0:
            since = None
        jac_com_dot = np.zeros_like(jac_com) if self._jac_com_prev is None or since is None else (
            (jac_com - self._jac_com_prev) / since)
        self._jac_com_prev = jac_com
        com_pos, com_vel_ref = _back_in_time(reference.com_pos_m, reference.com_vel_mps, reference.com_acc_mps2, lead)
        com_target = real_anchor + (com_pos - ref_anchor)
        com_acc = (reference.com_acc_mps2 + s.com_kp * (com_target - com)
                   + s.com_kd * (com_vel_ref - com_vel))
        w = math.sqrt(s.com_weight)
        task_J.append(w * jac_com)
        task_b.append(w * (com_acc - jac_com_dot @ qvel))
        # centroidal angular momentum: its rate, scaled to the CoP shift it causes [m], damped
        if s.momentum_weight > 0:
            ang = np.zeros((3, nv))
            mujoco.mj_angmomMat(m, d, ang, self._root)
            ang_dot = np.zeros_like(ang) if self._ang_prev is None or since is None else (ang - self._ang_prev) / since
            self._ang_prev = ang
            w = math.sqrt(s.momentum_weight) / (self.robot.mass_kg * 9.81)
            task_J.append(w * ang)
            task_b.append(w * (-s.momentum_damping * (ang @ qvel) - ang_dot @ qvel))
        J_tasks = np.concatenate(task_J)
        H = self._H_const.copy()
        H[:nv, :nv] += J_tasks.T @ J_tasks
        g = np.zeros(nv + 12)
        g[:nv] = -(np.concatenate(task_b) @ J_tasks)
        # root orientation towards the IK configuration's (free joint: angular velocity in the
        # body frame); its Hessian term is constant, in _H_const
        root_rot = d.xmat[self._root].reshape(3, 3)
        target_rot = np.empty(9)
        mujoco.mju_quat2Mat(target_rot, ik_qpos[3:7])
        omega = root_rot @ qvel[3:6]
        root_error = s.root_kp * _rotation_error(target_rot.reshape(3, 3), root_rot) - s.root_kd * omega
        g[3:6] -= s.root_weight * (root_error @ root_rot)
        # posture towards the IK configuration (its Hessian term is constant, in _H_const)
        q = d.qpos[self._qpos_index]
        v = qvel[dof]
        posture = (ik_qacc[self._ik_dof] + s.posture_kp * (ik_qpos[self._ik_qpos] - q)
                   + s.posture_kd * (ik_qvel[self._ik_dof] - v))
        g[dof] -= s.posture_weight * posture

        # inequalities: a sole in contact keeps its force in the friction pyramid and its centre of
        # pressure in the shrunk sole; a sole in the air carries no wrench (rows filled in QpRows)
        for i in (0, 1):
            if in_contact[i]:
                start, first = nv + 6 * i, rows.wrench_row[i]
                RT = soles[i][1].T  # rows: the sole's axes in the world
                A[first:first + 11, start:start + 3] = self._contact_rows[:, :3] @ RT
                A[first:first + 11, start + 3:start + 6] = self._contact_rows[:, 3:] @ RT
        row = rows.torque_row
        torque_rows = A[row:]
        torque_rows[:, :nv] = M[dof]
        torque_rows[:, nv:nv + 6] = -jac[0][:, dof].T
        torque_rows[:, nv + 6:] = -jac[1][:, dof].T
        torque_bias = bias[dof]
        np.minimum(self._limits[:, 1] - torque_bias, NO_BOUND, out=upper_all[row:])
        np.maximum(self._limits[:, 0] - torque_bias, -NO_BOUND, out=lower_all[row:])
        sense = rows.sense
        x, _, flag, _ = daqp.solve(H, g, A, upper_all, lower_all, sense)
        if flag < 0 and np.isfinite(self._limits).any():
            # no motion within the torque limits meets the contacts: take the unlimited solution
            # (the motors saturate, as they would with any controller) rather than none
            self.limit_relaxations += 1
            upper_all[row:], lower_all[row:] = NO_BOUND, -NO_BOUND  # the torque rows
            x, _, flag, _ = daqp.solve(H, g, A, upper_all, lower_all, sense)
        if flag < 0:
            self.failures += 1
            if self.failures > 50:
                raise SolverError(f"inverse-dynamics QP failed {self.failures} times (DAQP exit flag {flag})")
            return self.last_torques_nm
        self.last_torques_nm = torque_rows @ x + torque_bias
        if s.friction_smoothing_radps > 0:
            velocity_next = qvel[dof] + self._timestep_s * x[:nv][dof]
            self.last_torques_nm = self.last_torques_nm + self._friction_nm * np.tanh(
                velocity_next / s.friction_smoothing_radps)
        self.last_qacc = x[:nv].copy()
        self.last_wrenches = {"left": x[nv:nv + 6].copy(), "right": x[nv + 6:].copy()}
        return self.last_torques_nm
