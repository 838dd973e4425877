"""A :class:`~robust_ismpc.runs.spec.RunSpec` on a full robot in MuJoCo (``ismpc run --sim mujoco``).

:func:`run_mujoco_spec` builds the robot scene, the footstep plan from the robot's real initial
soles, the controller (nominal or robust, through :func:`robust_ismpc.control.walk.make_controller`) and
runs the closed loop

    measure (CoM, soles, contact CoP) -> controller.step -> whole-body IK -> servos -> physics

once per MPC period, recording the same trace channels as the LIP simulation
(:func:`robust_ismpc.runs.lip.run_lip`) so that ``report``, ``plotting`` and the CLI treat both
simulators alike. On the full robot the channels mean:

- ``com_m``, ``com_vel_mps``: measured whole-body CoM (x, y);
- ``zmp_m``: measured centre of pressure of the foot contact forces (NaN without contact);
- ``zmp_violation_m``: distance of the measured CoP outside the support polygon (convex hull of
  the soles in contact), 0 inside, NaN in flight;
- ``left_foot_m``, ``right_foot_m``: reference soles from the controller (as on the LIP);
- ``disturbance_true_mps2``: the applied external force divided by the simulated mass.

Everything that differs between robots comes from the robot file (``docs/robots.md``): the gait
timing, boxes and swing height from its ``[gait]`` table, the foot friction and the servo
feedforward from its ``[simulation]`` table. :class:`WalkSettings` holds the settings shared by
every robot (estimator noise, IK weights, fall criteria, inverse-dynamics gains).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..control.walk import make_controller, start_walk
from ..core.params import GRAVITY_MPS2
from ..estimation.estimator import EstimatorParams
from ..exceptions import ControllerFailure, ParameterError, SolverError
from ..robots.sensing import Sensors, robot_sensing
from ..sim.diagnostics import ModelDiagnostics
from ..sim.forces import Force
from ..sim.instability import simulation_failure
from ..sim.loop import LoopSettings, MujocoSimulation, initial_state
from ..sim.model import load_robot
from ..sim.polygon import distance_outside
from ..sim.robot import FallCriteria
from ..sim.scene import SceneMonitor, scene_forces
from ..sim.video import open_frame_sink
from ..sim.whole_body.ik import IkSettings
from ..sim.whole_body.inverse_dynamics import TorqueControlSettings
from .lip import INTERRUPTED
from .report import summarize
from .spec import RunResult, RunSpec, run_meta
from .trace import TraceRecorder, controller_channels

logger = logging.getLogger("robust_ismpc")

#: Distance outside the support polygon below which the CoP counts as inside [m]: the contact
#: points of spheres or box edges move by about this much when a foot tilts slightly.
COP_TOLERANCE_M = 1e-3



#: Measurement noise of the state estimator on a simulated robot: σ_p = 5 mm, σ_v = 5 cm/s,
#: σ_a = 0.5 m/s² (docs/closed-loop.md).
ROBOT_ESTIMATOR = EstimatorParams(com_pos_noise_m=0.005, com_vel_noise_mps=0.05, acc_noise_mps2=0.5)


@dataclass(frozen=True)
class WalkSettings:
    """Closed-loop settings of a robot walking in MuJoCo, the same for every robot.

    Both controllers' MPC starts every cycle from the state estimator's CoM and CoM velocity
    (:mod:`robust_ismpc.estimation.estimator`), and every landed footstep is moved to the measured sole.
    What differs between robots is in the robot file (:class:`~robust_ismpc.robots.RobotSpec`).

    Attributes
    ----------
    estimator : EstimatorParams
        Noise model of the state estimator (default :data:`ROBOT_ESTIMATOR`).
    disturbance_feedforward : bool
        Servo playback only: servo torque feedforward of the planned disturbance force ``m ŵ``
        (:attr:`~robust_ismpc.sim.loop.LoopSettings.disturbance_feedforward`).
    ik : IkSettings
        Whole-body IK weights (the posture reference of both whole-body controls).
    fall : FallCriteria
        When the robot counts as fallen.
    torque_control : TorqueControlSettings
        Gains of the inverse-dynamics QP (``RunSpec.whole_body = "torque"``, the default).
    """

    estimator: EstimatorParams = ROBOT_ESTIMATOR
    disturbance_feedforward: bool = True
    ik: IkSettings = field(default_factory=IkSettings)
    fall: FallCriteria = field(default_factory=FallCriteria)
    torque_control: TorqueControlSettings = field(default_factory=TorqueControlSettings)

    def __post_init__(self) -> None:
        if not isinstance(self.estimator, EstimatorParams):
            raise ParameterError(f"WalkSettings.estimator must be EstimatorParams, got {type(self.estimator).__name__}")


@dataclass(frozen=True)
class TickTimes:
    """Wall-clock time spent per phase over a run [s]."""

    measure_s: float = 0.0
    controller_s: float = 0.0
    ik_s: float = 0.0
    physics_s: float = 0.0
    record_s: float = 0.0
    render_s: float = 0.0

    def per_tick_ms(self, ticks: int) -> dict[str, float]:
        """Mean milliseconds per control tick of each phase."""
        n = max(ticks, 1)
        return {
            "measure": round(1e3 * self.measure_s / n, 4),
            "controller": round(1e3 * self.controller_s / n, 4),
            "ik": round(1e3 * self.ik_s / n, 4),
            "physics": round(1e3 * self.physics_s / n, 4),
            "record": round(1e3 * self.record_s / n, 4),
            "render": round(1e3 * self.render_s / n, 4),
        }


def run_mujoco_spec(
    spec: RunSpec,
    progress=None,
    video_path=None,
    settings: WalkSettings | None = None,
    scene_items=(),
    viewer: bool = False,
) -> RunResult:
    """Run ``spec`` on the full robot in MuJoCo and return its summary and trace.

    Parameters
    ----------
    spec : RunSpec
        The run (``spec.sim`` is ignored: this is the MuJoCo runner).
    progress : callable, optional
        ``progress(t_s)`` called about once per simulated second.
    video_path : path, optional
        Write an mp4 of the run there (offscreen rendering, see :mod:`robust_ismpc.sim.video`).
    settings : WalkSettings, optional
        Closed-loop settings shared by every robot (default ``WalkSettings()``).
    scene_items : sequence of Payload or SwingingBall, optional
        Objects added to the scene (:mod:`robust_ismpc.sim.scene`); their holding forces
        are added to the disturbances and ``summary["scene"]`` reports what they did
        (:class:`~robust_ismpc.sim.scene.SceneMonitor`).
    viewer : bool
        Show the run in MuJoCo's interactive viewer (:func:`~robust_ismpc.sim.video.open_frame_sink`).

    Returns
    -------
    RunResult
        ``summary`` (``report.summarize``, with ``physics_step_s`` the MuJoCo timestep the run
        used and, under torque control, ``inverse_dynamics_rate_hz`` the rate of its QP, plus
        ``time_per_tick_ms``, the wall time per phase,
        ``model_diagnostics``, what the run measured of the model's defects
        (:meth:`~robust_ismpc.sim.diagnostics.ModelDiagnostics.summary`: self-contacts, joints at
        their torque or range limits, CoP jitter, the CoM outside the soles),
        ``cop_outside_s``, the time the measured CoP spent more than :data:`COP_TOLERANCE_M`
        outside the support polygon, and
        ``render_fps`` with a video) and the trace.

    Raises
    ------
    ParameterError
        ``spec.robot`` is neither a robot with a MuJoCo model nor a robot file, or the file is invalid.
    ModelError
        The robot file's model is missing or does not match the file.
    """
    settings = settings if settings is not None else WalkSettings()
    robot_spec = load_robot(spec.robot)
    params = robot_spec.params()
    dt = spec.mpc.sampling_period_s

    com0, left0, right0 = initial_state(robot_spec)
    yaw0 = 0.5 * (left0.yaw_rad + right0.yaw_rad)
    sensing = robot_sensing(spec.sensing, robot_spec.sensors)
    controller = make_controller(params, spec.mpc, spec.modules, spec.delta_max_mps2,
                                 estimator=sensing.estimator_params(settings.estimator))
    start_walk(controller, spec.command, spec.duration_s, left0.pos_m[:2], right0.pos_m[:2], yaw0, com0[:2])

    forces = [Force(f.fx_n, f.fy_n, f.t_start_s, f.t_end_s) for f in spec.forces]
    # with the encoders and the IMU modelled the simulation estimates the state from them; the
    # signal model then adds what the estimate does not make (CoM bias, force noise, latency)
    sensors = Sensors(sensing.for_estimated_state() if sensing.models_sensors else sensing, dt, params.eta, spec.seed)
    loop = LoopSettings(
        control_period_s=dt, ik=settings.ik, fall=settings.fall, foot_friction=robot_spec.foot_friction,
        dynamic_feedforward=robot_spec.servo_dynamic_feedforward,
        disturbance_feedforward=settings.disturbance_feedforward,
        torque_control=settings.torque_control if spec.whole_body == "torque" else None,
        com_model_error_m=(float(sensors.com_bias_m[0]), float(sensors.com_bias_m[1])),
    )
    forces += scene_forces(scene_items)
    sim = MujocoSimulation(robot_spec, disturbances=forces, scene_items=scene_items, settings=loop,
                          mismatch=spec.mismatch, sensing=sensing, sensing_seed=spec.seed)
    monitor = SceneMonitor(sim.model, scene_items) if scene_items else None
    mass = sim.robot.mass_kg
    diagnostics = ModelDiagnostics(sim.model, sim.robot.robot_body_ids, mass * GRAVITY_MPS2)
    robot = sim.robot

    n_ticks = int(math.floor(spec.duration_s / dt + 1e-9))
    recorder = TraceRecorder(n_ticks + 2)
    video = None
    if video_path is not None or viewer:
        video = open_frame_sink(sim.model, robot_spec.root_body, video_path, viewer, spec.controller_label)
    failure: str | None = None
    fell = False
    t_meas = t_ctrl = t_ik = t_phys = t_rec = t_render = 0.0
    outside_ticks = 0
    progress_every = max(1, int(round(1.0 / dt)))
    t_s = 0.0
    ticks = 0
    wall_start = time.perf_counter()
    try:
        for k in range(n_ticks):
            t_s = k * dt
            a = time.perf_counter()
            measurement, contacts = sim.measure()
            left_sole, right_sole = sim.sensed_robot.sole_pose("left"), sim.sensed_robot.sole_pose("right")
            measurement = replace(measurement, left_sole_m=left_sole.pos_m[:2], right_sole_m=right_sole.pos_m[:2])
            reading = sensors.read(measurement)
            if sim.estimator is not None:  # the record keeps the truth beside what was read
                true_com, true_vel = robot.com()
                zmp_true = contacts.cop_m
                left_sole, right_sole = robot.sole_pose("left"), robot.sole_pose("right")
                measurement = replace(measurement, com_pos_m=true_com, com_vel_mps=true_vel, zmp_m=zmp_true)
            polygon = robot.support_polygon(contacts)
            violation = math.nan if contacts.cop_m is None else distance_outside(contacts.cop_m, polygon)
            b = time.perf_counter()
            try:
                reference = controller.step(t_s, reading)
            except ControllerFailure as exc:
                failure = f"{exc.reason}: {exc}"
                break
            c = time.perf_counter()
            try:
                sim.command(reference)
            except SolverError as exc:
                failure = f"ik_failed: {exc}"
                break
            d = time.perf_counter()
            force, render_s = sim.advance(video)
            if (failure := simulation_failure(sim.data, t_s + dt)) is not None:
                break
            if monitor is not None:
                monitor.update(sim.data, float(sim.data.time))
            diagnostics.update(sim.data, measurement.com_pos_m[:2], contacts.cop_m, polygon)
            e = time.perf_counter()

            zmp = measurement.zmp_m if measurement.zmp_m is not None else np.full(2, np.nan)
            if violation > COP_TOLERANCE_M:
                outside_ticks += 1
            recorder.record(
                t_s=t_s, com_m=measurement.com_pos_m[:2], com_vel_mps=measurement.com_vel_mps[:2], zmp_m=zmp,
                zmp_violation_m=violation, disturbance_true_mps2=force[:2] / mass,
                com_read_m=reading.com_pos_m[:2], com_vel_read_mps=reading.com_vel_mps[:2],
                sole_meas_m=np.concatenate([left_sole.pos_m[:2], right_sole.pos_m[:2]]),
                sole_meas_yaw_rad=(left_sole.yaw_rad, right_sole.yaw_rad),
                **controller_channels(controller, reference, t_s),
            )
            f = time.perf_counter()
            t_meas += b - a
            t_ctrl += c - b
            t_ik += d - c
            t_phys += e - d - render_s
            t_render += render_s
            t_rec += f - e
            ticks = k + 1
            if sim.has_fallen():
                fell = True
                failure = (
                    f"fell: root at {robot.root_height_m():.3f} m, torso tilt "
                    f"{math.degrees(robot.torso_tilt_rad()):.0f} deg at t = {sim.data.time:.2f} s"
                )
                break
            if progress is not None and k % progress_every == 0:
                progress(t_s)
    except KeyboardInterrupt:  # Ctrl-C (raised by progress at a tick boundary): keep what ran
        failure = INTERRUPTED
    finally:
        if video is not None:
            video.close()
    wall = time.perf_counter() - wall_start
    duration = float(sim.data.time)
    fell = fell or (failure is not None and failure != INTERRUPTED)
    meta = run_meta(spec, params)
    meta["sensing"] = sensing.as_dict()  # with the robot's own sensors
    meta["fell"] = fell
    meta["timing_adaptations"] = getattr(controller, "timing_adaptations", 0)
    meta["timing_returns"] = getattr(controller, "timing_returns", 0)
    meta["prediction_replans"] = controller.prediction_replans
    meta["mass_kg"] = mass
    meta["physics_step_s"] = float(sim.model.opt.timestep)
    if sim.inverse_dynamics is not None:  # the rate the torque control's QP ran at
        meta["inverse_dynamics_rate_hz"] = 1.0 / (sim.inverse_dynamics_steps * float(sim.model.opt.timestep))
    trace = recorder.finish(controller.plan, meta)
    summary = summarize(trace, fell, failure, duration, wall)
    times = TickTimes(t_meas, t_ctrl, t_ik, t_phys, t_rec, t_render)
    summary["time_per_tick_ms"] = times.per_tick_ms(ticks)
    summary["cop_outside_s"] = round(outside_ticks * dt, 4)
    summary["model_diagnostics"] = diagnostics.summary(dt)
    if monitor is not None:
        summary["scene"] = monitor.summary()
    if video is not None:
        summary["render_fps"] = round(video.frames_per_second, 2)
        summary["video_frames"] = video.frame_count
    return RunResult(summary=summary, trace=trace)


__all__ = ["COP_TOLERANCE_M", "ROBOT_ESTIMATOR", "TickTimes", "WalkSettings", "run_mujoco_spec"]
