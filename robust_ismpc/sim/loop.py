"""A robot scene in MuJoCo, stepped one control period at a time.

:class:`MujocoSimulation` holds the model (robot plus scene objects), the measurement, the
whole-body IK and the actuators. The closed loop that uses it, one control period at a time
(:meth:`~MujocoSimulation.measure`, ``controller.step``, :meth:`~MujocoSimulation.command`,
:meth:`~MujocoSimulation.advance`), is :func:`robust_ismpc.runs.mujoco.run_mujoco_spec`;
docs/closed-loop.md describes one cycle.

Actuators, torque control (the default of every run): the actuators of a copy of the model become
torque motors, driven by an inverse-dynamics QP that tracks the reference with force feedback
(:mod:`robust_ismpc.sim.whole_body.inverse_dynamics`), solved at the robot's inverse-dynamics rate
and sent as a per-motor command (q, q̇, kp, kd, τ_ff) that the motor drivers apply at every physics
step (:mod:`robust_ismpc.sim.whole_body.motor_command`); the IK configuration is its posture target.

Servo playback (``whole_body="servo"``): position servos (``ctrl`` = joint target, as in the G1
and OP3 Menagerie models) receive the IK joint angles plus a static feedforward ``τ_ff / kp``
that holds the IK configuration against gravity, the weight shared between the feet according
to the reference ZMP (:meth:`~robust_ismpc.sim.whole_body.ik.WholeBodyIk.static_torques`). With
``LoopSettings.dynamic_feedforward`` the static torques become the inverse dynamics of the IK
reference motion and the servo targets get ``kd q̇_ref / kp`` added, so that the servo damping
no longer brakes the planned motion (G1 first steps: joint tracking errors 0.085 → 0.015 rad).
"""

from __future__ import annotations

import copy
import logging
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import mujoco
import numpy as np

from ..core.reference import GaitReference, Measurement
from ..estimation.weight import weigh
from ..exceptions import ParameterError
from ..robots.mismatch import NO_MISMATCH, ModelMismatch
from ..robots.sensing import SensingParams
from ..robots.spec import RobotSpec
from .forces import Disturbance, ForceSchedule
from .mismatch import apply_mismatch
from .model import compile_model
from .polygon import SolePose
from .robot import SIDES, ContactState, FallCriteria, MujocoRobot, standing_state
from .scene import SceneItem, build_scene, set_scene_initial_state
from .state_estimation import SensedState
from .video import VideoRecorder
from .whole_body.actuators import ActuatorMap, actuator_torque_limits_nm
from .whole_body.ik import IkSettings, WholeBodyIk
from .whole_body.inverse_dynamics import InverseDynamicsQp, TorqueControlSettings
from .whole_body.motor_command import MotorCommand

logger = logging.getLogger("robust_ismpc")


@dataclass(frozen=True)
class LoopSettings:
    """Settings of the MuJoCo closed loop.

    Attributes
    ----------
    control_period_s : float
        δ, period of measurement, controller and IK [s]; a whole multiple of the model timestep.
    ik : IkSettings
        Whole-body IK weights.
    fall : FallCriteria
        When the robot counts as fallen.
    stop_on_fall : bool
        End the run at the first tick where the robot has fallen.
    contact_threshold_n : float or None
        Normal force above which a foot is in contact [N]; None: 1 % of the weight.
    motor_kp, motor_kd : float
        PD gains for torque-motor actuators [N m/rad], [N m s/rad] (unused for position servos).
    gravity_feedforward : bool
        Add the static joint torques of the reference configuration to the servo commands.
    foot_friction : float or None
        Simulation setting: sliding friction coefficient of the foot contact geoms (None keeps
        the model's). The contact uses the foot's value when the foot geoms have the higher
        ``priority`` (G1) and the larger of foot and floor otherwise (OP3).
    dynamic_feedforward : bool
        With ``gravity_feedforward``: use the inverse dynamics of the IK reference motion
        (velocity and acceleration by finite differences of the IK configurations) instead of
        the static torques, and add the servo damping times the reference joint velocity, so
        that a position servo's ``-kd q̇`` does not brake the planned motion
        (:meth:`~robust_ismpc.sim.whole_body.ik.WholeBodyIk.inverse_dynamics_torques`).
    disturbance_feedforward : bool
        With ``gravity_feedforward``: the torques also hold the disturbance the plan was made for,
        the force ``m ŵ`` acting on the CoM (``GaitReference.disturbance_mps2``; zero for the
        nominal controller). Without it the servos carry that force alone: the robot's CoM
        does not take the lean the robust plan asks for (docs/scenarios.md).
    torque_control : TorqueControlSettings or None
        Drive the joints with torques from an inverse-dynamics QP
        (:mod:`robust_ismpc.sim.whole_body.inverse_dynamics`), solved at the robot's
        ``inverse_dynamics_rate_hz`` (every physics step by default) and held by the motor drivers
        in between (:mod:`robust_ismpc.sim.whole_body.motor_command`), instead of
        position targets: the actuators of a copy of the model become torque motors. The IK
        configuration is then the QP's posture reference; ``gravity_feedforward`` and the motor
        gains are unused. None (default): the actuators as the model defines them.
    com_model_error_m : tuple of float
        Horizontal offset (x, y) [m] of the CoM the controller's model computes from the true one
        (a mass-model error; :attr:`~robust_ismpc.robots.sensing.Sensors.com_bias_m`). The whole
        body then tracks the reference with that CoM, as the planner reads it: the robot's true
        CoM follows the reference shifted by minus the offset; and the inverse dynamics' model
        has the same error (:class:`~robust_ismpc.sim.whole_body.inverse_dynamics.InverseDynamicsQp`).
        Zero by default.
    """

    control_period_s: float = 0.01
    ik: IkSettings = field(default_factory=IkSettings)
    fall: FallCriteria = field(default_factory=FallCriteria)
    stop_on_fall: bool = True
    contact_threshold_n: float | None = None
    motor_kp: float = 200.0
    motor_kd: float = 5.0
    gravity_feedforward: bool = True
    foot_friction: float | None = None
    dynamic_feedforward: bool = False
    disturbance_feedforward: bool = True
    torque_control: TorqueControlSettings | None = None
    com_model_error_m: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        if not isinstance(self.control_period_s, (int, float)) or not self.control_period_s > 0:
            raise ParameterError(f"LoopSettings.control_period_s must be > 0, got {self.control_period_s!r}")
        if self.motor_kp < 0 or self.motor_kd < 0:
            raise ParameterError("LoopSettings.motor_kp and motor_kd must be >= 0")
        if self.foot_friction is not None and not (
            isinstance(self.foot_friction, (int, float)) and math.isfinite(self.foot_friction) and self.foot_friction > 0
        ):
            raise ParameterError(f"LoopSettings.foot_friction must be a finite number > 0 or None, got {self.foot_friction!r}")
        if self.torque_control is not None and not isinstance(self.torque_control, TorqueControlSettings):
            raise ParameterError(
                f"LoopSettings.torque_control must be TorqueControlSettings or None, got {type(self.torque_control).__name__}"
            )
        error = np.asarray(self.com_model_error_m, dtype=float)
        if error.shape != (2,) or not np.all(np.isfinite(error)):
            raise ParameterError(f"LoopSettings.com_model_error_m must be two finite numbers, got {self.com_model_error_m!r}")


def _make_torque_motors(model: mujoco.MjModel) -> None:
    """Turn every actuator of ``model`` into a torque motor (``ctrl`` = joint torque), in place.

    Each motor keeps the torque limits of the actuator it replaces
    (:func:`~robust_ismpc.sim.whole_body.actuators.actuator_torque_limits_nm`: force range, a motor's
    control range and gear, the joint's actuator force range), as a force range with gear 1.
    """
    limits = actuator_torque_limits_nm(model)
    model.actuator_gaintype[:] = mujoco.mjtGain.mjGAIN_FIXED
    model.actuator_biastype[:] = mujoco.mjtBias.mjBIAS_NONE
    model.actuator_gainprm[:, :] = 0.0
    model.actuator_gainprm[:, 0] = 1.0
    model.actuator_biasprm[:, :] = 0.0
    model.actuator_gear[:, :] = 0.0
    model.actuator_gear[:, 0] = 1.0
    model.actuator_ctrllimited[:] = 0
    bounded = np.all(np.isfinite(limits), axis=1)
    model.actuator_forcelimited[:] = bounded
    model.actuator_forcerange[bounded] = limits[bounded]


def soft_servo_warning(spec: RobotSpec, motor_kp: float | None = None) -> str | None:
    """A warning if servo playback cannot hold ``spec`` up, else None.

    A leg joint held by a position servo of stiffness kp carries the robot like an inverted
    pendulum of its weight on a torsional spring, which stands only if kp > m g h (m the mass, h
    the CoM height). Motors are played back by the loop's PD law (``motor_kp``, default
    :attr:`LoopSettings.motor_kp`).
    """
    motor_kp = LoopSettings().motor_kp if motor_kp is None else motor_kp
    model = compile_model(spec)
    need = spec.mass_kg * 9.81 * spec.com_height_m
    actuators = ActuatorMap(model, model)
    soft = []
    for a in range(model.nu):
        joint = model.joint(int(model.actuator_trnid[a, 0])).name
        kp = float(actuators.kp[a]) if actuators.is_position[a] else motor_kp
        if joint in spec.leg_joints and kp < need:
            soft.append((kp, joint))
    if not soft:
        return None
    kp, joint = min(soft)
    return (f"{spec.name}'s leg servos are too soft for servo playback: {len(soft)} of them are below "
            f"m g h = {need:.0f} N m/rad (the stiffness that holds the robot up), {joint} has {kp:g}; "
            "use --whole-body torque (the default)")


def _inverse_dynamics_steps(spec: RobotSpec, timestep_s: float) -> int:
    """Physics steps per inverse-dynamics solve: 1 without a rate, else the rate's period over the
    physics step, which must be a whole number (ParameterError)."""
    rate = spec.inverse_dynamics_rate_hz
    if rate is None:
        return 1
    steps = 1.0 / (rate * timestep_s)
    if steps < 1.0 - 1e-9 or abs(steps - round(steps)) > 1e-6:
        raise ParameterError(f"{spec.name}: the inverse-dynamics period (1 / {rate:g} Hz) must be a whole multiple "
                             f"of the physics step ({timestep_s:g} s)")
    return int(round(steps))


def initial_state(spec: RobotSpec, model: mujoco.MjModel | None = None) -> tuple[np.ndarray, SolePose, SolePose]:
    """CoM and sole poses of the robot standing at the origin, as given to a controller's reset.

    Returns
    -------
    com_pos_m : ndarray, shape (3,)
        CoM [m].
    left_sole, right_sole : SolePose
        Sole poses [m], [rad].
    """
    model = compile_model(spec) if model is None else model
    data = mujoco.MjData(model)
    standing_state(spec, model, data)
    robot = MujocoRobot(spec, model, data)
    com, _ = robot.com()
    return com, robot.sole_pose("left"), robot.sole_pose("right")


class MujocoSimulation:
    """A robot scene ready to run: model, data, measurement, IK, actuators, disturbances.

    Parameters
    ----------
    spec : RobotSpec
    disturbances : sequence of Force or Impulse
    scene_items : sequence of Payload or SwingingBall
        Objects added to the scene before compiling.
    settings : LoopSettings
    mismatch : ModelMismatch
        How the simulated robot differs from the model the controller, the whole body and the
        measurement use (:mod:`robust_ismpc.robots.mismatch`); none by default.
    sensing : SensingParams or None
        The robot's sensors. When they model the encoders and the IMU
        (:attr:`~robust_ismpc.robots.sensing.SensingParams.models_sensors`), the measurement, the
        IK's base feedback and the inverse dynamics read the state the robot estimates from them
        (:class:`~robust_ismpc.sim.state_estimation.SensedState`); otherwise (default) the
        simulator's state.
    sensing_seed : int
        Seed of the sensors' noise and biases.
    """

    def __init__(
        self,
        spec: RobotSpec,
        disturbances: Sequence[Disturbance] = (),
        scene_items: Sequence[SceneItem] = (),
        settings: LoopSettings | None = None,
        mismatch: ModelMismatch = NO_MISMATCH,
        sensing: SensingParams | None = None,
        sensing_seed: int = 0,
    ) -> None:
        self.spec = spec
        self.settings = settings or LoopSettings()
        self.mismatch = mismatch
        self.model = build_scene(spec, scene_items, mismatch)
        if (self.settings.foot_friction is not None or self.settings.torque_control is not None
                or not mismatch.is_none):
            self.model = copy.deepcopy(self.model)  # build_scene may return the cached model
        if self.settings.torque_control is not None:
            _make_torque_motors(self.model)
        self.data = mujoco.MjData(self.model)
        timestep = float(self.model.opt.timestep)
        ratio = self.settings.control_period_s / timestep
        if abs(ratio - round(ratio)) > 1e-6 or round(ratio) < 1:
            raise ParameterError(
                f"control_period_s ({self.settings.control_period_s}) must be a whole multiple of the "
                f"model timestep ({timestep})"
            )
        self.substeps = int(round(ratio))
        # the robot measures with the model's masses and inertias: copied here, before the mismatch
        self.robot = MujocoRobot(spec, self.model, self.data, self.settings.contact_threshold_n)
        apply_mismatch(self.model, self.robot.robot_body_ids, mismatch)
        if self.settings.foot_friction is not None:
            for geom in self.robot.foot_geom_ids():
                self.model.geom_friction[geom, 0] = self.settings.foot_friction
        self.ik = WholeBodyIk(spec, self.settings.ik)
        self.actuators = ActuatorMap(self.model, self.ik.model)
        self.forces = ForceSchedule(self.model, disturbances, spec.torso_body)
        self.scene_items = tuple(scene_items)
        #: The state estimate from the robot's sensors (None: the controller reads the simulator's state).
        self.estimator: SensedState | None = None
        if sensing is not None and sensing.models_sensors:
            self.estimator = SensedState(spec, sensing, self.model, self.data, sensing_seed)
        #: The robot as the controller computes it: :attr:`robot` itself, or the estimate's.
        self.sensed_robot = self.robot if self.estimator is None else self.estimator.robot
        self.inverse_dynamics: InverseDynamicsQp | None = None
        #: Physics steps per inverse-dynamics solve (its command is held in between).
        self.inverse_dynamics_steps = _inverse_dynamics_steps(spec, timestep)
        if self.settings.torque_control is not None:
            self.inverse_dynamics = InverseDynamicsQp(self.robot, self.actuators, self.settings.torque_control,
                                                      self.settings.com_model_error_m, self.estimator)
        self.reset()

    def reset(self) -> None:
        """Standing posture, soles on the floor, IK reference at the same posture, time 0."""
        standing_state(self.spec, self.model, self.data)
        set_scene_initial_state(self.model, self.data, self.scene_items)
        if self.estimator is not None:
            self.estimator.reset()
        self.ik.reset()
        self._ik_qpos = self.ik.qpos
        self._ik_qvel = np.zeros(self.ik.model.nv)
        self._ik_qacc = np.zeros(self.ik.model.nv)
        self._reference: GaitReference | None = None  # the last commanded reference (torque control)
        self._motor_command: MotorCommand | None = None  # torque control: what the motor drivers hold
        self._steps_since_command = 0
        self.mean_horizontal_contact_force_n: np.ndarray | None = None  # none before the first period
        self.weighed_mass_kg = self.robot.mass_kg  # the model's until the feet have weighed the robot
        self._mean_contact_moment_nm: np.ndarray | None = None
        self._previous_momentum: np.ndarray | None = None
        self._targets = self.actuators.targets(self.ik.qpos)
        self._target_vel = np.zeros(self.model.nu)
        self._feedforward = np.zeros(self.model.nu)
        if self.settings.gravity_feedforward:
            self._feedforward = self.ik.static_torques(0.5)[self.actuators.ik_dof_index]
        self._apply_targets()

    def _apply_targets(self) -> None:
        if self.inverse_dynamics is not None:
            if self._reference is None:  # before the first command: no torque
                self.data.ctrl[:] = 0.0
                return
            hold = self.inverse_dynamics_steps
            if self._motor_command is None or self._steps_since_command >= hold:
                self._motor_command = self.inverse_dynamics.command(
                    self._reference, self._ik_qpos, self._ik_qvel, self._ik_qacc, hold * float(self.model.opt.timestep),
                    self.weighed_mass_kg)
                self._steps_since_command = 0
            self._steps_since_command += 1
            act = self.actuators
            if self.estimator is None:
                q, dq = self.data.qpos[act.sim_qpos_index], self.data.qvel[act.sim_dof_index]
            else:  # the drivers read the encoders
                q, dq = self.inverse_dynamics.joint_state()
            self.data.ctrl[:] = self._motor_command.torques(q, dq, self.inverse_dynamics.torque_limits_nm)
            return
        act = self.actuators
        targets = self._targets
        if act.is_position.all():
            self.data.ctrl[:] = targets + (self._feedforward + act.kd * self._target_vel) / act.kp
            return
        d = self.data
        q = d.qpos[act.sim_qpos_index]
        qd = d.qvel[act.sim_dof_index]
        torque = self._feedforward + self.settings.motor_kp * (targets - q) + self.settings.motor_kd * (self._target_vel - qd)
        position = targets + (self._feedforward + act.kd * self._target_vel) / np.where(act.is_position, act.kp, 1.0)
        d.ctrl[:] = np.where(act.is_position, position, torque)

    def command(self, reference: GaitReference) -> None:
        """Run one IK step on ``reference`` and set the actuator targets."""
        dt = self.settings.control_period_s
        if any(self.settings.com_model_error_m):  # the whole body reads the CoM as c + e: track c_ref - e
            error = np.array([*self.settings.com_model_error_m, 0.0])
            reference = replace(reference, com_pos_m=np.asarray(reference.com_pos_m, dtype=float) - error)
        qpos = self.ik.step(reference, dt, self.sensed_robot.base_qpos())
        self._targets = self.actuators.targets(qpos)
        qvel = np.empty(self.ik.model.nv)
        mujoco.mj_differentiatePos(self.ik.model, qvel, dt, self._ik_qpos, qpos)
        qacc = (qvel - self._ik_qvel) / dt
        self._ik_qpos, self._ik_qvel, self._ik_qacc = qpos, qvel, qacc
        self._reference = reference
        if self.settings.dynamic_feedforward:
            self._target_vel = qvel[self.actuators.ik_dof_index]
        if self.settings.gravity_feedforward and self.inverse_dynamics is None:
            left, right = reference.left_foot, reference.right_foot
            if left.in_contact and right.in_contact:
                l_xy, r_xy = left.pos_m[:2], right.pos_m[:2]
                span = l_xy - r_xy
                share = float(np.clip(np.dot(reference.zmp_m - r_xy, span) / max(np.dot(span, span), 1e-12), 0, 1))
            else:
                share = 1.0 if left.in_contact else 0.0
            left_contact = left.in_contact or not right.in_contact
            force = None
            if self.settings.disturbance_feedforward:
                force = self.robot.mass_kg * np.array([*reference.disturbance_mps2, 0.0])
            if self.settings.dynamic_feedforward:
                torques = self.ik.inverse_dynamics_torques(qvel, qacc, share, left_contact, right.in_contact, force)
            else:
                torques = self.ik.static_torques(share, left_contact, right.in_contact, force)
            self._feedforward = torques[self.actuators.ik_dof_index]
        if self.actuators.is_position.all():  # motors get their torques at every physics step (advance)
            self._apply_targets()

    def advance(self, recorder: VideoRecorder | None = None) -> tuple[np.ndarray, float]:
        """Step the physics over one control period; returns (last applied force (3,) [N], render time [s]).

        Also sets :attr:`mean_horizontal_contact_force_n`, the horizontal foot-floor contact
        force averaged over the physics steps of the period [N], shape (2,), and updates
        :attr:`weighed_mass_kg` (:func:`weigh`).
        """
        force = np.zeros(3)
        render_s = 0.0
        motors = not self.actuators.is_position.all()
        contact_force = np.zeros(3)
        contact_moment = np.zeros(3)
        for _ in range(self.substeps):
            force = self.forces.apply(self.data, self.data.time)
            if motors:
                self._apply_targets()
            mujoco.mj_step(self.model, self.data)
            # after mj_step the contacts, their forces and the body positions are those of the
            # state the step started from: the forces the step applied, and where
            contacts = self.robot.contacts()
            contact_force += contacts.force_n
            if self.estimator is None:
                contact_moment += contacts.moment_about(self.robot.com_position())
            else:
                self.estimator.update((contacts.left_force_n, contacts.right_force_n))
                # about the estimated CoM, the contacts placed where the estimate puts the soles
                contact_moment += contacts.moment_about(self.sensed_robot.com_position()
                                                        - self._sole_offset_m(contacts))
            if recorder is not None and recorder.due(self.data.time):
                start = time.perf_counter()
                recorder.capture(self.data)
                render_s += time.perf_counter() - start
        mean_force = contact_force / self.substeps
        self.mean_horizontal_contact_force_n = mean_force[:2]
        self.weighed_mass_kg = weigh(self.weighed_mass_kg, float(mean_force[2]), self.robot.mass_kg,
                                     self.settings.control_period_s)
        self._mean_contact_moment_nm = contact_moment / self.substeps
        return force, render_s

    def _sole_offset_m(self, contacts: ContactState) -> np.ndarray:
        """Where the estimate puts the loaded soles minus where they are [m], shape (3,), weighted
        by their normal forces (the root's offset when airborne)."""
        assert self.estimator is not None
        total = contacts.left_force_n + contacts.right_force_n
        if total <= 0.0:
            return self.sensed_robot.base_qpos()[:3] - self.robot.base_qpos()[:3]
        offset = np.zeros(3)
        for side, force in zip(SIDES, (contacts.left_force_n, contacts.right_force_n)):
            if force > 0.0:
                offset += force / total * self.estimator.offset_m(side, self.robot)
        return offset

    def measure(self) -> tuple[Measurement, ContactState]:
        """The controller's measurement at the current state (:meth:`MujocoRobot.measure`) with
        the contact force and the external moment averaged over the period that just ended.

        The external moment about the CoM is ``τ = ΔL / δ - M̄``, the change of the centroidal
        angular momentum over the period minus the mean moment of the contact forces about the
        CoM; the robot's own swinging and spinning are made by the contacts and cancel. It is
        reported as ``(τ_y, -τ_x) / (m h)`` (``Measurement.external_moment_acc_mps2``).

        Both the contact force and the moment are divided by the mass the feet weigh
        (:attr:`weighed_mass_kg`), not the model's: whatever the robot carries rides on the same
        contacts, and the LIP the MPC plans with accelerates the CoM by the contact force over the
        weight those contacts bear.

        With modelled sensors (:attr:`estimator`) the CoM, its velocity and the angular momentum
        are the estimate's, and the centre of pressure and the contact moment are placed where
        the estimate puts the soles; the contacts returned are the simulator's (for the record).
        """
        moment_acc = None
        mass_kg = self.weighed_mass_kg
        measurement, contacts = self.robot.measure(mean_horizontal_force_n=self.mean_horizontal_contact_force_n,
                                                   mass_kg=mass_kg)
        if self.estimator is not None:  # the state the robot estimates, the contacts placed in it
            self.estimator.refresh()
            com, vel = self.sensed_robot.com()
            zmp = measurement.zmp_m
            if zmp is not None:
                zmp = zmp + self._sole_offset_m(contacts)[:2]
            measurement = replace(measurement, com_pos_m=com, com_vel_mps=vel, zmp_m=zmp)
        momentum = self.sensed_robot.angular_momentum()
        if self._previous_momentum is not None and self._mean_contact_moment_nm is not None:
            torque = (momentum - self._previous_momentum) / self.settings.control_period_s - self._mean_contact_moment_nm
            moment_acc = np.array([torque[1], -torque[0]]) / (mass_kg * self.spec.com_height_m)
            measurement = replace(measurement, external_moment_acc_mps2=moment_acc)
        self._previous_momentum = momentum
        return measurement, contacts

    def has_fallen(self) -> bool:
        """Fall criteria on the current state."""
        return self.settings.fall.has_fallen(
            self.robot.root_height_m(), self.spec.base_height_m, self.robot.torso_tilt_rad()
        )
