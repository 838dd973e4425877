"""``summary.json`` metrics computed from a :class:`~robust_ismpc.runs.trace.Trace`."""

from __future__ import annotations

import math

import numpy as np

from ..core.planner import rotation
from .trace import Trace


def timing_stats(values_ms: np.ndarray) -> dict:
    """Median, 99th percentile and maximum of a timing series [ms] (NaNs ignored)."""
    v = np.asarray(values_ms, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"median": None, "p99": None, "max": None}
    return {
        "median": round(float(np.median(v)), 4),
        "p99": round(float(np.percentile(v, 99)), 4),
        "max": round(float(np.max(v)), 4),
    }


def _finite_or_none(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def landing_errors_m(trace: Trace) -> np.ndarray:
    """Where each swing sole landed minus where the reference put it, in the landed sole's frame.

    At every touchdown (the first double-support row after a single support) the measured sole
    is compared with the swing foot's reference at the tick before (the reference for the
    touchdown's time). A millimetre lost at every landing is walked on: the planner re-anchors
    the later footsteps to the real foot (docs/scenarios.md, paper-bag). The trace's soles are
    the simulator's, so under non-ideal sensing, where the reference lives in the state
    estimate's world, the errors include that world's drift.

    Returns
    -------
    ndarray, shape (k, 2)
        (forward, left) [m] per touchdown; k = 0 without measured soles (the reduced model).
    """
    support = trace["support"]
    touchdowns = np.flatnonzero((support[1:] == 0) & (support[:-1] != 0)) + 1
    swing = (support[touchdowns - 1] > 0).astype(int)  # support 1: the left foot stands, the right one swings
    soles = trace["sole_meas_m"].reshape(-1, 2, 2)  # rows, (left, right), (x, y)
    reference = np.stack([trace["left_foot_m"][:, :2], trace["right_foot_m"][:, :2]], axis=1)
    error = soles[touchdowns, swing] - reference[touchdowns - 1, swing]
    local = np.einsum("kji,kj->ki", rotation(trace["sole_meas_yaw_rad"][touchdowns, swing]), error)  # Rᵀ e
    return local[np.isfinite(local).all(axis=1)]


def summarize(trace: Trace, fell: bool, failure: str | None, duration_s: float, wall_time_s: float | None = None) -> dict:
    """The run summary (the fields named by the issues, plus run metadata).

    Parameters
    ----------
    trace : Trace
        Recorded run; ``trace.meta`` supplies robot, sim, controller, modules and inputs.
    fell, failure : bool, str or None
        Outcome.
    duration_s : float
        Simulated time actually run [s].
    wall_time_s : float, optional
        Wall-clock time of the loop, for the real-time factor [s].
    """
    meta = trace.meta
    com = trace["com_m"]
    n = len(trace)
    distance = float(np.hypot(*(com[-1] - com[0]))) if n else 0.0
    touchdowns = trace.footstep_touchdown_s[2:]
    steps_taken = int(np.count_nonzero(touchdowns <= duration_s + 1e-9))
    infeasible = trace["infeasible"]
    adapted = trace["timing_adapted"]
    adapted_tts = trace["adapted_time_to_step_s"]
    adapted_mask = (np.nan_to_num(adapted) > 0) & np.isfinite(adapted_tts)
    min_tts = float(np.min(adapted_tts[adapted_mask])) if adapted_mask.any() else None
    w_est = trace["disturbance_est_mps2"]
    violation = trace["zmp_violation_m"]
    summary = {
        "robot": meta.get("robot"),
        "robot_name": meta.get("robot_name", meta.get("robot")),
        "sim": meta.get("sim"),
        "whole_body": meta.get("whole_body", "servo") if meta.get("sim") == "mujoco" else None,
        "physics_step_s": meta.get("physics_step_s"),
        "inverse_dynamics_rate_hz": meta.get("inverse_dynamics_rate_hz"),
        "controller": meta.get("controller"),
        "modules": list(meta.get("modules", [])),
        "fell": bool(fell),
        "failure": failure,
        "duration_s": round(float(duration_s), 6),
        "distance_m": round(distance, 6),
        "steps_taken": steps_taken,
        "qp_infeasible_count": int(np.nansum(infeasible)) if n else 0,
        "max_zmp_violation_m": round(float(np.nanmax(violation)), 6) if n and np.isfinite(violation).any() else None,
        "mpc_solve_ms": timing_stats(trace["solve_ms"]),
        "mpc_build_ms": timing_stats(trace["build_ms"]),
        "cycle_ms": timing_stats(trace["cycle_ms"]),
        "timing_adaptations": int(meta.get("timing_adaptations", int(np.nansum(adapted)) if n else 0)),
        "timing_returns": int(meta.get("timing_returns", 0)),
        "prediction_replans": int(meta.get("prediction_replans", 0)),
        "min_time_to_step_s": None if min_tts is None else round(min_tts, 4),
        "disturbance_estimate_final": [round(float(v), 6) for v in w_est[-1]] if n else [0.0, 0.0],
    }
    sensing = meta.get("sensing")
    ideal = not isinstance(sensing, dict) or sensing.get("name", "ideal") == "ideal"
    landing = landing_errors_m(trace) if ideal else np.zeros((0, 2))
    if len(landing):
        summary["landing_error_mean_m"] = [round(float(v), 6) for v in landing.mean(axis=0)]
        summary["landing_error_max_m"] = [round(float(v), 6) for v in np.abs(landing).max(axis=0)]
    if wall_time_s is not None and wall_time_s > 0:
        summary["wall_time_s"] = round(wall_time_s, 3)
        summary["realtime_factor"] = round(duration_s / wall_time_s, 3)
    for key in ("seed", "sensing", "mismatch", "command", "forces", "pushes", "delta_max_mps2", "scenario"):
        if key in meta:
            summary[key] = meta[key]
    if n and not ideal:
        # what the controller read against the truth: its sensors, state estimate and latency
        error = trace["com_vel_read_mps"] - trace["com_vel_mps"]
        summary["com_vel_read_error_rms_mps"] = [round(float(v), 6) for v in np.sqrt(np.nanmean(error**2, axis=0))]
        error = trace["com_read_m"] - trace["com_m"]
        summary["com_read_error_mean_m"] = [round(float(v), 6) for v in np.nanmean(error, axis=0)]
        summary["com_read_error_std_m"] = [round(float(v), 6) for v in np.nanstd(error, axis=0)]
    return summary
