"""Reduced-model closed loop: a LIP "robot" driven by the controller, with external forces.

The simulated robot is a LIP per axis whose ZMP follows the controller's reference ZMP (perfect
ZMP tracking) and whose CoM feels the external forces as an acceleration w = F / m. The exact
discretisation makes the simulation step exact for forces that are constant over a tick.
A run fails when the controller cannot produce a reference (QP infeasible beyond the fallback)
or when the CoM diverges from the ZMP by more than the CoM height.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..control.controller import IsmpcController
from ..control.walk import make_controller, start_walk
from ..core.lip import discretise
from ..core.reference import Measurement
from ..estimation.estimator import EstimatorParams
from ..exceptions import ControllerFailure, ParameterError
from ..robots.sensing import Sensors, sensing_preset
from .forces import ForceWindow, total_force
from .report import summarize
from .spec import RunResult, RunSpec, gait_params, run_meta
from .trace import TraceRecorder, controller_channels

INTERRUPTED = "interrupted"


@dataclass(frozen=True)
class RunOutcome:
    """How a closed-loop run ended.

    Attributes
    ----------
    fell : bool
        True if the run failed (fall, divergence or persistent infeasibility).
    failure : str or None
        Reason, e.g. ``"qp_infeasible: ..."`` or ``"com_diverged"``.
    duration_s : float
        Simulated time actually run [s].
    """

    fell: bool
    failure: str | None
    duration_s: float

    @property
    def interrupted(self) -> bool:
        """True if the user stopped the run (Ctrl-C); what ran until then is kept."""
        return self.failure == INTERRUPTED


def zmp_box_violation(zmp_m: np.ndarray, centre_m: np.ndarray, yaw_rad: float, half_box_m: np.ndarray) -> float:
    """Distance [m] by which ``zmp_m`` lies outside the box (0 inside)."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    d = zmp_m - centre_m
    local = np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])
    excess = np.maximum(np.abs(local) - half_box_m, 0.0)
    return float(np.hypot(excess[0], excess[1]))


def run_lip(
    controller: IsmpcController,
    duration_s: float,
    forces: Sequence[ForceWindow] = (),
    recorder: TraceRecorder | None = None,
    divergence_m: float | None = None,
    progress=None,
    start_com_m: np.ndarray | None = None,
    sensors: Sensors | None = None,
) -> tuple[RunOutcome, TraceRecorder]:
    """Close the loop between ``controller`` (already ``reset``) and a LIP.

    Parameters
    ----------
    controller : IsmpcController
        Controller after ``reset`` (:func:`~robust_ismpc.control.walk.start_walk`).
    duration_s : float
        Simulated time [s].
    forces : sequence of ForceWindow
        External forces on the CoM [N].
    recorder : TraceRecorder, optional
        Where ticks are recorded (a new one by default).
    divergence_m : float, optional
        |CoM - ZMP| beyond which the run is declared diverged (default: the CoM height).
    progress : callable, optional
        Called as ``progress(t_s)`` every simulated second.
    start_com_m : ndarray, shape (2,), optional
        The LIP starts at rest with its CoM and ZMP here [m] (default: the origin, where
        :func:`~robust_ismpc.control.walk.start_walk` puts a reduced-model walk's CoM).
    sensors : Sensors, optional
        What the controller reads of the LIP's true state (default: the true state).
    """
    if not (isinstance(duration_s, (int, float)) and math.isfinite(duration_s) and duration_s > 0):
        raise ParameterError(f"duration_s must be a finite number > 0, got {duration_s!r}")
    robot = controller.robot
    dt = controller.dt
    disc = discretise(robot.eta, dt)
    limit = robot.com_height_m if divergence_m is None else divergence_m
    com0 = np.zeros(2) if start_com_m is None else np.asarray(start_com_m, float).reshape(2)
    true_state = np.vstack([com0, np.zeros(2), com0])  # rows x_c, ẋ_c, x_z; columns x, y
    recorder = recorder if recorder is not None else TraceRecorder(int(duration_s / dt) + 2)
    plan = controller.plan
    n_ticks = int(round(duration_s / dt))
    failure = None
    t = 0.0
    # η² (x_c - x_z) averaged over the period that just ended (the contact force per unit mass);
    # the first tick has no period behind it and reads the current value
    contact_acc = robot.eta**2 * (true_state[0] - true_state[2])
    for k in range(n_ticks):
        t = k * dt
        w = total_force(forces, t) / robot.mass_kg
        meas = Measurement(
            com_pos_m=np.array([*true_state[0], robot.com_height_m]),
            com_vel_mps=np.array([*true_state[1], 0.0]),
            zmp_m=true_state[2].copy(),
            contact_acc_mps2=contact_acc,
            external_moment_acc_mps2=np.zeros(2),  # a point mass has no moment about its CoM
        )
        if sensors is not None:
            meas = sensors.read(meas)
        centre, half_box, yaw = plan.box_at(t)
        violation = zmp_box_violation(true_state[2], centre, yaw, half_box)
        try:
            ref = controller.step(t, meas)
        except ControllerFailure as exc:
            failure = f"{exc.reason}: {exc}"
            break
        except KeyboardInterrupt:
            failure = INTERRUPTED
            break
        recorder.record(
            t_s=t, com_m=true_state[0], com_vel_mps=true_state[1], zmp_m=true_state[2],
            zmp_violation_m=violation, disturbance_true_mps2=w, com_read_m=meas.com_pos_m[:2],
            com_vel_read_mps=meas.com_vel_mps[:2],
            **controller_channels(controller, ref, t),
        )
        zmp_vel = (ref.zmp_m - true_state[2]) / dt
        previous_vel = true_state[1]
        true_state = disc.A @ true_state + np.outer(disc.B, zmp_vel) + np.outer(disc.E, w)
        contact_acc = (true_state[1] - previous_vel) / dt - w
        if not np.all(np.isfinite(true_state)) or np.max(np.abs(true_state[0] - true_state[2])) > limit:
            failure = "com_diverged"
            t += dt
            break
        if progress is not None and k % int(round(1.0 / dt)) == 0:
            progress(t)
    else:
        t = n_ticks * dt
    fell = failure is not None and failure != INTERRUPTED
    return RunOutcome(fell=fell, failure=failure, duration_s=t), recorder


def run_lip_spec(spec: RunSpec, progress=None) -> RunResult:
    """Run ``spec`` on the LIP (``spec.sim == "lip"``) and return its summary and trace.

    ``progress(t_s)`` is called about once per simulated second; if it raises
    ``KeyboardInterrupt`` the run stops there and returns what ran, with failure ``"interrupted"``.
    """
    robot = gait_params(spec.robot, "lip")
    sensing = sensing_preset(spec.sensing)
    controller = make_controller(robot, spec.mpc, spec.modules, spec.delta_max_mps2,
                                 estimator=sensing.estimator_params(EstimatorParams()))
    start_walk(controller, spec.command, spec.duration_s)
    start = time.perf_counter()
    recorder = TraceRecorder(int(spec.duration_s / controller.dt) + 2)
    try:
        sensors = Sensors(sensing, controller.dt, robot.eta, spec.seed)
        outcome, recorder = run_lip(controller, spec.duration_s, spec.forces, recorder=recorder, progress=progress,
                                    sensors=sensors)
    except KeyboardInterrupt:  # from progress, between ticks: keep the ticks recorded so far
        t = recorder.last_time_s()
        outcome = RunOutcome(fell=False, failure=INTERRUPTED, duration_s=0.0 if t is None else t + controller.dt)
    wall = time.perf_counter() - start
    meta = run_meta(spec, robot)
    meta["fell"] = outcome.fell
    meta["timing_adaptations"] = getattr(controller, "timing_adaptations", 0)
    meta["timing_returns"] = getattr(controller, "timing_returns", 0)
    meta["prediction_replans"] = controller.prediction_replans
    trace = recorder.finish(controller.plan, meta)
    summary = summarize(trace, outcome.fell, outcome.failure, outcome.duration_s, wall)
    return RunResult(summary=summary, trace=trace)
