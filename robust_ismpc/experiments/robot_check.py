"""Stand a robot, then walk it, in MuJoCo: the check behind ``ismpc robot check FILE``.

:func:`check_robot` first holds the robot still in double support (torque control, the
standing posture of its file) and then walks it with the nominal controller, and reports what
it measured. A robot file that passes stands and walks with default settings; one that does not
says where it failed.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.params import GRAVITY_MPS2
from ..core.planner import WalkCommand, command_limits
from ..core.reference import FootReference, GaitReference, Support
from ..robots import RobotSpec
from ..runs.run import run
from ..runs.spec import RunResult, RunSpec
from ..sim.diagnostics import ModelDiagnostics, likeliest_causes
from ..sim.loop import LoopSettings, MujocoSimulation, initial_state
from ..sim.model import compile_model, load_robot
from ..sim.model_checks import physics_step_warning
from ..sim.whole_body.inverse_dynamics import TorqueControlSettings

#: Time the standing robot is given to settle before its CoP jitter counts [s].
SETTLE_S = 0.2
#: A robot held still in double support stands when its CoM stays within this fraction of its
#: sole's width of where it started (the built-in robots: at most 0.3 mm; Talos standing on its
#: ankle meshes drifted 25.7 cm without falling).
STAND_DRIFT_SOLE_FRACTION = 0.5


def still_reference(t_s: float, com_pos_m: np.ndarray, left, right) -> GaitReference:
    """A still double-support reference: CoM at ``com_pos_m``, ZMP below it, the soles (SolePose)
    where given."""

    def foot(pose) -> FootReference:
        return FootReference(pos_m=pose.pos_m.copy(), yaw_rad=pose.yaw_rad, vel_mps=np.zeros(3),
                             yaw_rate_radps=0.0, in_contact=True)

    return GaitReference(
        t_s=t_s, com_pos_m=np.asarray(com_pos_m, dtype=float).copy(), com_vel_mps=np.zeros(3), com_acc_mps2=np.zeros(3),
        zmp_m=np.asarray(com_pos_m[:2], dtype=float).copy(), left_foot=foot(left), right_foot=foot(right),
        torso_yaw_rad=0.5 * (left.yaw_rad + right.yaw_rad), support=Support.DOUBLE, step_index=0,
        time_to_step_s=0.0,
    )


def stand(spec: RobotSpec, duration_s: float = 5.0) -> dict:
    """Hold ``spec`` still in double support for ``duration_s`` (torque control).

    Returns
    -------
    dict
        ``stood`` (no fall and the CoM within :data:`STAND_DRIFT_SOLE_FRACTION` of the sole's width
        of where it started), ``fell_at_s``, ``com_drift_m`` (largest horizontal distance of the
        CoM from where it started), ``com_sag_m`` (largest drop of the CoM) and ``diagnostics``
        (:meth:`~robust_ismpc.sim.diagnostics.ModelDiagnostics.summary`; the CoP jitter after the
        first :data:`SETTLE_S`).
    """
    sim = MujocoSimulation(spec, settings=LoopSettings(torque_control=TorqueControlSettings(),
                                                       foot_friction=spec.foot_friction))
    com0, left, right = initial_state(spec)
    period = sim.settings.control_period_s
    diagnostics = ModelDiagnostics(sim.model, sim.robot.robot_body_ids, spec.mass_kg * GRAVITY_MPS2,
                                   settle_samples=int(round(SETTLE_S / period)))
    drift, sag, fell_at = 0.0, 0.0, None
    for _ in range(int(round(duration_s / period))):
        measurement, contacts = sim.measure()
        sim.command(still_reference(float(sim.data.time) + period, com0, left, right))
        sim.advance()
        com = np.asarray(measurement.com_pos_m, dtype=float)
        diagnostics.update(sim.data, com[:2], contacts.cop_m, sim.robot.support_polygon(contacts))
        drift = max(drift, float(np.linalg.norm(com[:2] - com0[:2])))
        sag = max(sag, float(com0[2] - com[2]))
        if sim.has_fallen():
            fell_at = float(sim.data.time)
            break
    still = drift <= STAND_DRIFT_SOLE_FRACTION * spec.sole_width_m
    return {"stood": fell_at is None and still, "fell_at_s": fell_at, "com_drift_m": round(drift, 4), "com_sag_m": round(sag, 4),
            "diagnostics": diagnostics.summary(period)}


def check_robot(robot: str, stand_s: float = 5.0, walk_s: float = 5.0,
                vx_mps: float | None = None) -> tuple[dict, RunResult]:
    """Stand ``robot`` (a built-in name or a robot file) for ``stand_s``, then walk it forward with
    the nominal controller for ``walk_s`` after its first step.

    ``vx_mps`` defaults to half the forward speed its steps allow. Returns the report (``stand``,
    ``walk``: fell, failure, distance, steps, infeasible QPs; ``physics_step_s``, the MuJoCo
    timestep used; ``warnings``, e.g. a physics step coarse for torque control,
    :func:`~robust_ismpc.sim.model_checks.physics_step_warning`; ``causes``, when the check
    failed, :func:`failure_causes`) and the walk's run result.
    """
    spec = load_robot(robot)
    params = spec.params()
    vx = 0.5 * command_limits(params)["vx_mps"][0] if vx_mps is None else vx_mps
    coarse = physics_step_warning(spec)
    report = {"robot": robot, "robot_name": spec.name, "mass_kg": round(spec.mass_kg, 3),
              "com_height_m": round(spec.com_height_m, 3),
              "physics_step_s": float(compile_model(spec).opt.timestep),
              "warnings": [coarse] if coarse else [], "stand": stand(spec, stand_s)}
    start_s = 3.0 * params.T_step_s  # the plan stands two steps and shifts onto a foot in one
    result = run(RunSpec(robot=robot, sim="mujoco", command=WalkCommand(round(vx, 3)),
                         duration_s=math.ceil(start_s + walk_s)))
    s = result.summary
    report["walk"] = {key: s[key] for key in ("fell", "failure", "duration_s", "distance_m", "steps_taken",
                                              "qp_infeasible_count", "cop_outside_s") if key in s}
    report["walk"]["vx_mps"] = round(vx, 3)
    report["passed"] = bool(report["stand"]["stood"] and not s["fell"] and s["qp_infeasible_count"] == 0)
    report["causes"] = [] if report["passed"] else failure_causes(report["stand"]["diagnostics"],
                                                                  s.get("model_diagnostics"), spec.sole_width_m)
    return report, result


def failure_causes(standing: dict, walking: dict | None, sole_width_m: float) -> list[str]:
    """What the stand and the walk measured that can make a robot fall, likeliest first
    (:func:`~robust_ismpc.sim.diagnostics.likeliest_causes`), each sentence prefixed with when;
    the CoP jitter is the stand's only (the CoP moves while walking)."""
    causes = [f"standing: {c}" for c in likeliest_causes(standing, sole_width_m)]
    if walking:
        causes += [f"walking: {c}" for c in likeliest_causes(dict(walking, cop_jitter_m=None), sole_width_m)]
    return causes
