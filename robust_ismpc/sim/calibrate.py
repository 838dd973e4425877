"""Measure a robot's swing-leg CoP gain κ (:attr:`~robust_ismpc.core.params.RobotParams.swing_cop_gain_s2`).

The robot walks its reference without physics: the nominal IS-MPC runs open loop, the whole-body
IK follows the reference and the inverse dynamics of the IK motion gives, every tick, the centre
of pressure the feet must carry (:attr:`~robust_ismpc.sim.whole_body.ik.WholeBodyIk.last_contact_cop_m`).
In single support its deviation from the LIP's ZMP along the walking direction is regressed on
the swing foot's forward acceleration: the slope is κ.

Usage::

    from robust_ismpc.sim.calibrate import fit_swing_cop_gain
    fit = fit_swing_cop_gain("robots/mybot.toml")
    print(fit.gain_s2)        # put it in the robot's [gait] table as swing_cop_gain_s2
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..control.controller import IsmpcController
from ..control.walk import start_walk
from ..core.footsteps import LEFT
from ..core.params import mpc_params_for
from ..core.planner import WalkCommand
from ..core.reference import Support
from ..exceptions import ParameterError
from ..robots import RobotSpec
from .loop import LoopSettings, MujocoSimulation, initial_state
from .model import load_robot

#: Smallest range of forward swing-foot acceleration [m/s²] to fit κ on. G1 at 0.05 m/s: 3.2;
#: stepping in place: 2e-4 (which fitted κ = -13 s², meaningless).
MIN_SWING_ACCELERATION_RANGE_MPS2 = 0.5


@dataclass(frozen=True)
class SwingCopFit:
    """Result of :func:`fit_swing_cop_gain`.

    Attributes
    ----------
    gain_s2 : float
        κ [s²]: forward CoP shift per m/s² of forward swing-foot acceleration.
    offset_m : float
        Constant part of the forward CoP deviation [m].
    rms_before_m, rms_after_m : float
        RMS of the forward CoP deviation from the ZMP, raw and with ``κ a + offset`` removed [m].
    samples : int
        Single-support ticks used.
    swing_acceleration_mps2, cop_deviation_m : ndarray, shape (samples,)
        The fitted pairs: forward swing-foot acceleration [m/s²] and forward CoP deviation from
        the ZMP [m].
    """

    gain_s2: float
    offset_m: float
    rms_before_m: float
    rms_after_m: float
    samples: int
    swing_acceleration_mps2: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))
    cop_deviation_m: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))

    def summary(self) -> dict:
        """JSON-ready numbers (without the samples)."""
        return {
            "swing_cop_gain_s2": round(self.gain_s2, 6),
            "offset_m": round(self.offset_m, 6),
            "cop_deviation_rms_m": round(self.rms_before_m, 5),
            "residual_rms_m": round(self.rms_after_m, 5),
            "samples": self.samples,
        }


def fit_swing_cop_gain(
    robot: str | RobotSpec,
    command: WalkCommand | None = None,
    duration_s: float = 8.0,
    settle_s: float = 1.0,
) -> SwingCopFit:
    """Walk the reference of ``robot`` (no physics) and fit κ.

    Parameters
    ----------
    robot : str, path or RobotSpec
        Built-in name or TOML path (:func:`~robust_ismpc.sim.model.load_robot`), or a spec.
    command : WalkCommand, optional
        Walking command (default: forward at 0.2 m/s; use a speed the robot walks at, e.g. 0.15
        m/s for OP3).
    duration_s : float
        Walk length [s].
    settle_s : float
        Ticks before this time are not used [s] (the first steps start from rest).

    Raises
    ------
    ParameterError
        Too short a walk to contain single support after ``settle_s``, or a command that does not
        move the feet forward (swing accelerations spanning less than
        :data:`MIN_SWING_ACCELERATION_RANGE_MPS2`; κ is then undetermined).
    """
    spec = robot if isinstance(robot, RobotSpec) else load_robot(robot)
    command = command if command is not None else WalkCommand(0.2)
    if not duration_s > settle_s >= 0.0:
        raise ParameterError(f"need duration_s > settle_s >= 0, got {duration_s!r}, {settle_s!r}")
    params = replace(spec.params(), swing_cop_gain_s2=0.0)  # plan as a LIP
    mpc = mpc_params_for(params)
    com0, left0, right0 = initial_state(spec)
    yaw0 = 0.5 * (left0.yaw_rad + right0.yaw_rad)
    controller = IsmpcController(params, mpc)
    start_walk(controller, command, duration_s, left0.pos_m[:2], right0.pos_m[:2], yaw0, com0[:2])
    sim = MujocoSimulation(spec, settings=LoopSettings(control_period_s=mpc.sampling_period_s,
                                                       dynamic_feedforward=True))
    deviation, acceleration = [], []
    dt = mpc.sampling_period_s
    for k in range(int(round(duration_s / dt))):
        reference = controller.step(k * dt)
        sim.command(reference)
        cop = sim.ik.last_contact_cop_m
        if reference.t_s < settle_s or reference.support == Support.DOUBLE or cop is None:
            continue
        swing = controller.feet[LEFT if reference.support == Support.RIGHT else -LEFT]
        heading = np.array([np.cos(reference.torso_yaw_rad), np.sin(reference.torso_yaw_rad)])
        deviation.append(float((cop[:2] - reference.zmp_m[:2]) @ heading))
        acceleration.append(float(swing.acc_mps2[:2] @ heading))
    dev, acc = np.asarray(deviation), np.asarray(acceleration)
    if dev.size < 10 or np.ptp(acc) < MIN_SWING_ACCELERATION_RANGE_MPS2:
        raise ParameterError(
            f"{spec.name}: no forward swing motion to fit κ on ({dev.size} single-support ticks); "
            "walk forward (vx > 0) for a few seconds"
        )
    design = np.column_stack([acc, np.ones_like(acc)])
    (gain, offset), *_ = np.linalg.lstsq(design, dev, rcond=None)
    residual = dev - design @ np.array([gain, offset])
    return SwingCopFit(
        gain_s2=float(gain), offset_m=float(offset),
        rms_before_m=float(np.sqrt(np.mean(dev**2))), rms_after_m=float(np.sqrt(np.mean(residual**2))),
        samples=int(dev.size), swing_acceleration_mps2=acc, cop_deviation_m=dev,
    )


__all__ = ["MIN_SWING_ACCELERATION_RANGE_MPS2", "SwingCopFit", "fit_swing_cop_gain"]
