"""Closed loop in MuJoCo: measurement -> controller -> whole-body IK -> joint servos -> physics.

Every control period (δ = 0.01 s by default) the loop builds a
:class:`~robust_ismpc.reference.Measurement`, calls ``controller.step(t_s, measurement)``, runs
one whole-body IK step on the returned :class:`~robust_ismpc.reference.GaitReference`, and sets
the actuator commands. Between control ticks it steps the physics at the model's timestep,
writing disturbance forces into ``xfrc_applied`` before every step.

Actuators: position servos (``ctrl`` = joint target, as in the G1 and OP3 Menagerie models)
receive the IK joint angles plus a static feedforward ``τ_ff / kp``; torque motors receive
``τ_ff + kp (q_ik - q) - kd q̇`` evaluated at every physics step. ``τ_ff`` holds the IK reference
configuration against gravity with the weight shared between the feet according to the reference
ZMP (:meth:`~robust_ismpc.wbik.WholeBodyIk.static_torques`). Without it the stiff-but-finite
servos sag under load (G1: knees 0.05 rad, pelvis pitched 2.3 deg, CoM 1 cm behind and 7 mm
below the reference) and a lateral CoM shift overshoots by 60 %.

With ``LoopSettings.dynamic_feedforward`` the static torques become the inverse dynamics of the IK
reference motion (joint velocities and accelerations by finite differences of successive IK
configurations) and the servo targets get ``kd q̇_ref / kp`` added, so that the servo damping
``-kd q̇`` no longer brakes the planned motion (G1 first steps: joint tracking errors 0.085 →
0.015 rad, stance-foot tilt 5-10° → below 1°). The IK reference must then be smooth: a CoM
target that jumps every tick with the measurement (``ComStabilizer``) turns the finite-difference
accelerations into a positive feedback and the robot falls within 0.3 s.

With ``LoopSettings.torque_control`` the actuators of a copy of the model become torque motors,
driven at every physics step by an inverse-dynamics QP that tracks the reference with force
feedback (:mod:`robust_ismpc.sim.inverse_dynamics`); the IK configuration is its posture target.
"""

from __future__ import annotations

import copy
import logging
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Protocol

import mujoco
import numpy as np

from ..exceptions import ParameterError
from ..reference import GaitReference, Measurement
from ..robots.spec import RobotSpec
from ..wbik import ActuatorMap, IkSettings, WholeBodyIk
from .disturbances import Disturbance, ForceSchedule, SceneItem, build_scene, set_scene_initial_state
from .inverse_dynamics import InverseDynamicsQp, TorqueControlSettings
from .mujoco_robot import ContactState, FallCriteria, MujocoRobot, SolePose, distance_outside, standing_state
from .video import VideoRecorder, VideoSettings

logger = logging.getLogger("robust_ismpc")


class Controller(Protocol):
    """Anything that turns a measurement into a gait reference once per control period."""

    def step(self, t_s: float, measurement: Measurement) -> GaitReference:
        """Reference for the cycle starting at ``t_s`` [s]."""
        ...


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
        (:meth:`~robust_ismpc.wbik.WholeBodyIk.inverse_dynamics_torques`).
    disturbance_feedforward : bool
        With ``gravity_feedforward``: the torques also hold the disturbance the plan was made for,
        the force ``m ŵ`` acting on the CoM (``GaitReference.disturbance_mps2``; zero for the
        nominal controller). Without it the servos carry that force alone: the robot's CoM
        does not take the lean the robust plan asks for (docs/scenarios.md).
    torque_control : TorqueControlSettings or None
        Drive the joints with torques from an inverse-dynamics QP
        (:mod:`robust_ismpc.sim.inverse_dynamics`), solved at every physics step, instead of
        position targets: the actuators of a copy of the model become torque motors. The IK
        configuration is then the QP's posture reference; ``gravity_feedforward`` and the motor
        gains are unused. None (default): the actuators as the model defines them.
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


@dataclass(frozen=True)
class PhaseTimes:
    """Wall-clock time spent in each phase of the loop [s]."""

    measure_s: float
    controller_s: float
    ik_s: float
    physics_s: float
    render_s: float
    total_s: float


@dataclass(frozen=True)
class MujocoTrace:
    """Time series of a MuJoCo run, one row per control tick (world frame).

    Attributes
    ----------
    t_s : ndarray, shape (N,)
        Tick times [s].
    com_pos_m, com_vel_mps : ndarray, shape (N, 3)
        Measured CoM position [m] and velocity [m/s].
    zmp_m : ndarray, shape (N, 2)
        Measured centre of pressure [m] (NaN without contact).
    ref_com_pos_m : ndarray, shape (N, 3)
        Reference CoM returned by the controller at the tick [m].
    ref_zmp_m : ndarray, shape (N, 2)
        Reference ZMP [m].
    left_sole_pos_m, right_sole_pos_m : ndarray, shape (N, 3)
        Measured sole positions [m].
    left_sole_yaw_rad, right_sole_yaw_rad : ndarray, shape (N,)
        Measured sole yaws [rad].
    ref_left_sole_pos_m, ref_right_sole_pos_m : ndarray, shape (N, 3)
        Reference sole positions [m].
    left_contact, right_contact : ndarray of bool, shape (N,)
        Feet in contact.
    left_force_n, right_force_n : ndarray, shape (N,)
        Normal force on each foot [N].
    zmp_outside_m : ndarray, shape (N,)
        Distance of the measured CoP outside the support polygon [m] (0 inside, NaN without
        contact).
    applied_force_n : ndarray, shape (N, 3)
        Total disturbance force at the tick [N].
    ik_com_error_m : ndarray, shape (N,)
        CoM error of the IK reference configuration after its step [m].
    fallen : bool
        The robot fell (the trace ends at the fall when ``stop_on_fall``).
    fall_time_s : float or None
        Time of the fall [s].
    sim_time_s : float
        Simulated time covered [s].
    times : PhaseTimes
        Wall-clock time per phase.
    """

    t_s: np.ndarray
    com_pos_m: np.ndarray
    com_vel_mps: np.ndarray
    zmp_m: np.ndarray
    ref_com_pos_m: np.ndarray
    ref_zmp_m: np.ndarray
    left_sole_pos_m: np.ndarray
    right_sole_pos_m: np.ndarray
    left_sole_yaw_rad: np.ndarray
    right_sole_yaw_rad: np.ndarray
    ref_left_sole_pos_m: np.ndarray
    ref_right_sole_pos_m: np.ndarray
    left_contact: np.ndarray
    right_contact: np.ndarray
    left_force_n: np.ndarray
    right_force_n: np.ndarray
    zmp_outside_m: np.ndarray
    applied_force_n: np.ndarray
    ik_com_error_m: np.ndarray
    fallen: bool
    fall_time_s: float | None
    sim_time_s: float
    times: PhaseTimes

    @property
    def realtime_factor(self) -> float:
        """Simulated time divided by wall-clock time of the loop."""
        return self.sim_time_s / self.times.total_s if self.times.total_s > 0 else math.inf

    @property
    def max_zmp_outside_m(self) -> float:
        """Largest distance of the measured CoP outside the support polygon [m]."""
        valid = self.zmp_outside_m[np.isfinite(self.zmp_outside_m)]
        return float(valid.max()) if valid.size else 0.0

    @property
    def ik_ms_per_step(self) -> float:
        """Mean wall time of one IK step [ms]."""
        return 1e3 * self.times.ik_s / max(len(self.t_s), 1)


_VECTOR_FIELDS = {
    "com_pos_m": 3, "com_vel_mps": 3, "zmp_m": 2, "ref_com_pos_m": 3, "ref_zmp_m": 2,
    "left_sole_pos_m": 3, "right_sole_pos_m": 3, "ref_left_sole_pos_m": 3, "ref_right_sole_pos_m": 3,
    "applied_force_n": 3,
}
_SCALAR_FIELDS = ("t_s", "left_sole_yaw_rad", "right_sole_yaw_rad", "left_force_n", "right_force_n",
                  "zmp_outside_m", "ik_com_error_m")
_BOOL_FIELDS = ("left_contact", "right_contact")


def _make_torque_motors(model: mujoco.MjModel) -> None:
    """Turn every actuator of ``model`` into a torque motor (``ctrl`` = joint torque), in place.

    The joints' own actuator force limits (``actuatorfrcrange``) still bound the torque.
    """
    model.actuator_gainprm[:, :] = 0.0
    model.actuator_gainprm[:, 0] = 1.0
    model.actuator_biasprm[:, :] = 0.0
    model.actuator_ctrllimited[:] = 0


def initial_state(spec: RobotSpec, model: mujoco.MjModel | None = None) -> tuple[np.ndarray, SolePose, SolePose]:
    """CoM and sole poses of the robot standing at the origin, as given to a controller's reset.

    Returns
    -------
    com_pos_m : ndarray, shape (3,)
        CoM [m].
    left_sole, right_sole : SolePose
        Sole poses [m], [rad].
    """
    model = spec.load_model() if model is None else model
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
    """

    def __init__(
        self,
        spec: RobotSpec,
        disturbances: Sequence[Disturbance] = (),
        scene_items: Sequence[SceneItem] = (),
        settings: LoopSettings | None = None,
    ) -> None:
        self.spec = spec
        self.settings = settings or LoopSettings()
        self.model = build_scene(spec, scene_items)
        if self.settings.foot_friction is not None or self.settings.torque_control is not None:
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
        self.robot = MujocoRobot(spec, self.model, self.data, self.settings.contact_threshold_n)
        if self.settings.foot_friction is not None:
            for geom in self.robot.foot_geom_ids():
                self.model.geom_friction[geom, 0] = self.settings.foot_friction
        self.ik = WholeBodyIk(spec, self.settings.ik)
        self.actuators = ActuatorMap(self.model, self.ik.model)
        self.forces = ForceSchedule(self.model, disturbances, spec.torso_body)
        self.scene_items = tuple(scene_items)
        self.inverse_dynamics: InverseDynamicsQp | None = None
        if self.settings.torque_control is not None:
            self.inverse_dynamics = InverseDynamicsQp(self.robot, self.actuators, self.settings.torque_control)
        self.reset()

    def reset(self) -> None:
        """Standing posture, soles on the floor, IK reference at the same posture, time 0."""
        standing_state(self.spec, self.model, self.data)
        set_scene_initial_state(self.model, self.data, self.scene_items)
        self.ik.reset()
        self._ik_qpos = self.ik.qpos
        self._ik_qvel = np.zeros(self.ik.model.nv)
        self._ik_qacc = np.zeros(self.ik.model.nv)
        self._reference: GaitReference | None = None  # the last commanded reference (torque control)
        self.mean_horizontal_contact_force_n: np.ndarray | None = None  # none before the first period
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
            else:
                self.data.ctrl[:] = self.inverse_dynamics.torques(
                    self._reference, self._ik_qpos, self._ik_qvel, self._ik_qacc)
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
        qpos = self.ik.step(reference, dt, self.robot.base_qpos())
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
        self._apply_targets()

    def advance(self, recorder: VideoRecorder | None = None) -> tuple[np.ndarray, float]:
        """Step the physics over one control period; returns (last applied force (3,) [N], render time [s]).

        Also sets :attr:`mean_horizontal_contact_force_n`, the horizontal foot-floor contact
        force averaged over the physics steps of the period [N], shape (2,).
        """
        force = np.zeros(3)
        render_s = 0.0
        motors = not self.actuators.is_position.all()
        contact_force = np.zeros(2)
        contact_moment = np.zeros(3)
        for _ in range(self.substeps):
            force = self.forces.apply(self.data, self.data.time)
            if motors:
                self._apply_targets()
            mujoco.mj_step(self.model, self.data)
            # after mj_step the contacts, their forces and the body positions are those of the
            # state the step started from: the forces the step applied, and where
            contacts = self.robot.contacts()
            contact_force += contacts.horizontal_force_n
            contact_moment += contacts.moment_about(self.robot.com()[0])
            if recorder is not None and recorder.due(self.data.time):
                start = time.perf_counter()
                recorder.capture(self.data)
                render_s += time.perf_counter() - start
        self.mean_horizontal_contact_force_n = contact_force / self.substeps
        self._mean_contact_moment_nm = contact_moment / self.substeps
        return force, render_s

    def measure(self) -> tuple[Measurement, ContactState]:
        """The controller's measurement at the current state (:meth:`MujocoRobot.measure`) with
        the contact force and the external moment averaged over the period that just ended.

        The external moment about the CoM is ``τ = ΔL / δ - M̄``, the change of the centroidal
        angular momentum over the period minus the mean moment of the contact forces about the
        CoM; the robot's own swinging and spinning are made by the contacts and cancel. It is
        reported as ``(τ_y, -τ_x) / (m h)`` (``Measurement.external_moment_acc_mps2``).
        """
        moment_acc = None
        robot = self.robot
        measurement, contacts = robot.measure(mean_horizontal_force_n=self.mean_horizontal_contact_force_n)
        momentum = robot.angular_momentum()
        if self._previous_momentum is not None and self._mean_contact_moment_nm is not None:
            torque = (momentum - self._previous_momentum) / self.settings.control_period_s - self._mean_contact_moment_nm
            moment_acc = np.array([torque[1], -torque[0]]) / (robot.mass_kg * self.spec.com_height_m)
            measurement = replace(measurement, external_moment_acc_mps2=moment_acc)
        self._previous_momentum = momentum
        return measurement, contacts

    def has_fallen(self) -> bool:
        """Fall criteria on the current state."""
        return self.settings.fall.has_fallen(
            self.robot.root_height_m(), self.spec.base_height_m, self.robot.torso_tilt_rad()
        )


def run_mujoco(
    spec: RobotSpec,
    controller: Controller,
    duration_s: float,
    disturbances: Sequence[Disturbance] = (),
    *,
    scene_items: Sequence[SceneItem] = (),
    settings: LoopSettings | None = None,
    video: VideoSettings | None = None,
) -> MujocoTrace:
    """Run a controller on a robot in MuJoCo from the standing posture.

    Parameters
    ----------
    spec : RobotSpec
        The robot.
    controller : Controller
        Object with ``step(t_s, measurement) -> GaitReference``; prepare it (e.g. ``reset``) from
        :func:`initial_state` before calling.
    duration_s : float
        Simulated duration [s].
    disturbances : sequence of Force or Impulse
        Forces on robot bodies.
    scene_items : sequence of Payload or SwingingBall
        Objects added to the scene.
    settings : LoopSettings, optional
    video : VideoSettings, optional
        Record an mp4 with a tracking camera.

    Returns
    -------
    MujocoTrace
        The recorded time series, fall flag and timings.
    """
    if not isinstance(duration_s, (int, float)) or not duration_s > 0 or not math.isfinite(duration_s):
        raise ParameterError(f"duration_s must be a finite number > 0, got {duration_s!r}")
    sim = MujocoSimulation(spec, disturbances, scene_items, settings)
    return run_simulation(sim, controller, duration_s, video=video)


def run_simulation(
    sim: MujocoSimulation,
    controller: Controller,
    duration_s: float,
    *,
    video: VideoSettings | None = None,
) -> MujocoTrace:
    """Run ``controller`` on an already built :class:`MujocoSimulation` from its current state."""
    settings = sim.settings
    period = settings.control_period_s
    n_ticks = int(math.floor(duration_s / period + 1e-9))
    rec: dict[str, np.ndarray] = {k: np.full((n_ticks, n), np.nan) for k, n in _VECTOR_FIELDS.items()}
    rec.update({k: np.full(n_ticks, np.nan) for k in _SCALAR_FIELDS})
    rec.update({k: np.zeros(n_ticks, dtype=bool) for k in _BOOL_FIELDS})
    t_measure = t_ctrl = t_ik = t_phys = t_render = 0.0
    recorder = VideoRecorder(sim.model, video, sim.spec.root_body) if video is not None else None
    fallen, fall_time = False, None
    robot = sim.robot
    t0_sim = sim.data.time
    n_done = 0
    wall_start = time.perf_counter()
    try:
        for k in range(n_ticks):
            t_s = t0_sim + k * period
            a = time.perf_counter()
            measurement, contacts = sim.measure()
            left, right = robot.sole_pose("left"), robot.sole_pose("right")
            polygon = robot.support_polygon(contacts)
            outside = math.nan if contacts.cop_m is None else distance_outside(contacts.cop_m, polygon)
            b = time.perf_counter()
            reference = controller.step(t_s, measurement)
            c = time.perf_counter()
            sim.command(reference)
            d = time.perf_counter()
            force, render_s = sim.advance(recorder)
            e = time.perf_counter()
            t_measure += b - a
            t_ctrl += c - b
            t_ik += d - c
            t_phys += e - d - render_s
            t_render += render_s

            rec["t_s"][k] = t_s
            rec["com_pos_m"][k] = measurement.com_pos_m
            rec["com_vel_mps"][k] = measurement.com_vel_mps
            if measurement.zmp_m is not None:
                rec["zmp_m"][k] = measurement.zmp_m
            rec["ref_com_pos_m"][k] = reference.com_pos_m
            rec["ref_zmp_m"][k] = reference.zmp_m
            rec["left_sole_pos_m"][k] = left.pos_m
            rec["right_sole_pos_m"][k] = right.pos_m
            rec["left_sole_yaw_rad"][k] = left.yaw_rad
            rec["right_sole_yaw_rad"][k] = right.yaw_rad
            rec["ref_left_sole_pos_m"][k] = reference.left_foot.pos_m
            rec["ref_right_sole_pos_m"][k] = reference.right_foot.pos_m
            rec["left_contact"][k] = contacts.left_in_contact
            rec["right_contact"][k] = contacts.right_in_contact
            rec["left_force_n"][k] = contacts.left_force_n
            rec["right_force_n"][k] = contacts.right_force_n
            rec["zmp_outside_m"][k] = outside
            rec["applied_force_n"][k] = force
            rec["ik_com_error_m"][k] = np.linalg.norm(sim.ik.com_m() - reference.com_pos_m)
            n_done = k + 1
            if sim.has_fallen():
                fallen, fall_time = True, float(sim.data.time)
                logger.info("robot %s fell at t = %.2f s", sim.spec.name, fall_time)
                if settings.stop_on_fall:
                    break
    finally:
        if recorder is not None:
            recorder.close()
    total = time.perf_counter() - wall_start
    if recorder is not None and recorder.frame_count:
        logger.info("rendered %d frames at %.1f frames/s", recorder.frame_count, recorder.frames_per_second)
    arrays = {k: v[:n_done] for k, v in rec.items()}
    return MujocoTrace(
        **arrays,
        fallen=fallen,
        fall_time_s=fall_time,
        sim_time_s=float(sim.data.time - t0_sim),
        times=PhaseTimes(
            measure_s=t_measure, controller_s=t_ctrl, ik_s=t_ik, physics_s=t_phys, render_s=t_render, total_s=total
        ),
    )
