"""Running a scenario's nominal and robust controllers side by side, and the comparison metrics."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ...core.planner import WalkCommand
from ...robots.mismatch import NO_MISMATCH, ModelMismatch
from ...runs.forces import ForceWindow
from ...runs.spec import RunResult
from .catalogue import Scenario, get_scenario
from .realise import ScenarioRun, realise

#: Criterion of ``expect="deviates"``: the robust path deviation must stay below this (it keeps
#: the planned path), and the nominal one, unless it falls, must be at least this large and at
#: least :data:`DEVIATION_RATIO` times the robust one (stride-averaged CoM, see
#: :func:`path_deviation`).
DEVIATION_MIN_M = 0.03
DEVIATION_RATIO = 2.0


def path_deviation(trace, command: WalkCommand) -> dict:
    """Lateral distance of the CoM from the commanded straight path (the x axis through the start).

    The raw CoM sways by about a foot spacing every stride, so the deviation is also given for the
    CoM averaged over a sliding window of one stride (two steps): that is the "path" of Fig. 2.
    The windows start at the walk's first touchdown or later: before it the robot stands and
    shifts its weight onto its first stance foot, which an average over that time reads as a
    lateral offset of the path (the undisturbed G1: 4.8 cm) while the robot is on its line.

    Returns
    -------
    dict
        ``max_m``, ``final_m`` (stride-averaged, absolute), ``final_signed_m`` (+ left),
        ``raw_max_m`` (raw CoM) [m]; None entries for a run that did not walk one stride after
        its first touchdown.
    """
    com = trace["com_m"]
    t = trace["t_s"]
    if len(t) < 2:
        return {"max_m": None, "final_m": None, "final_signed_m": None, "raw_max_m": None}
    heading = math.atan2(command.vy_mps, command.vx_mps) if (command.vx_mps or command.vy_mps) else 0.0
    normal = np.array([-math.sin(heading), math.cos(heading)])
    lateral = (com - com[0]) @ normal
    dt = float(t[1] - t[0])
    touchdowns = np.asarray(trace.footstep_touchdown_s, dtype=float)
    periods = np.diff(touchdowns[2:])
    stride = 2.0 * float(np.median(periods)) if periods.size else 1.0
    n = max(1, int(round(stride / dt)))
    first = float(touchdowns[2]) if len(touchdowns) > 2 and np.isfinite(touchdowns[2]) else float(t[0])
    walking = lateral[t >= first - 1e-9]
    raw = round(float(np.max(np.abs(lateral))), 5)
    if len(walking) < n:
        return {"max_m": None, "final_m": None, "final_signed_m": None, "raw_max_m": raw}
    averaged = np.convolve(walking, np.ones(n) / n, mode="valid")
    return {
        "max_m": round(float(np.max(np.abs(averaged))), 5),
        "final_m": round(float(abs(averaged[-1])), 5),
        "final_signed_m": round(float(averaged[-1]), 5),
        "raw_max_m": raw,
    }


def _timing_after(trace, t_from: float | None, window_s: float = 0.5) -> dict:
    if t_from is None:
        return dict.fromkeys(("time_to_step_at_hit_s", "first_adaptation_s", "time_to_step_after_hit_s",
                              "min_time_to_step_after_hit_s", "adaptations_before_hit", "adaptations_after_hit"))
    t = trace["t_s"]
    tts = trace["time_to_step_s"]
    adapted_tts = trace["adapted_time_to_step_s"]  # to the touchdown each adaptation set
    adapted = np.nan_to_num(trace["timing_adapted"]) > 0
    mask = (t >= t_from - 1e-9) & (t <= t_from + window_s)
    first = np.flatnonzero(mask & adapted)
    planned = np.flatnonzero(mask)
    return {
        "time_to_step_at_hit_s": None if not planned.size else round(float(tts[planned[0]]), 4),
        "first_adaptation_s": None if not first.size else round(float(t[first[0]]), 4),
        "time_to_step_after_hit_s": None if not first.size else round(float(adapted_tts[first[0]]), 4),
        "min_time_to_step_after_hit_s": None if not first.size else round(float(np.nanmin(adapted_tts[first])), 4),
        "adaptations_before_hit": int(np.count_nonzero(adapted & (t < t_from - 1e-9))),
        "adaptations_after_hit": int(np.count_nonzero(adapted & (t >= t_from - 1e-9))),
    }


def disturbance_events(run: ScenarioRun) -> list[tuple[str, float]]:
    """The disturbances of a realised scenario as (label, start time [s]), for figures.

    The planned ball hit, then every force window in time order ("push" when it ends,
    "constant force" when it lasts to the end of the run), labelled with its magnitude in N.
    """
    events = []
    if "ball" in run.details:
        events.append(("ball hit (planned)", float(run.details["ball"]["hit_s"])))
    for force in sorted(run.nominal.forces, key=lambda f: f.t_start_s):
        kind = "push" if math.isfinite(force.t_end_s) else "constant force"
        events.append((f"{kind} {math.hypot(force.fx_n, force.fy_n):.0f} N", float(force.t_start_s)))
    return events


def push_start_s(forces) -> float | None:
    """Start of the first push among ``forces`` (ForceWindow: a window that ends) [s]; None without one."""
    pushes = [f for f in forces if math.isfinite(f.t_end_s)]
    return min(p.t_start_s for p in pushes) if pushes else None


def _mean(values: np.ndarray) -> list[float] | None:
    """Per-axis mean of ``values`` (n, 2) over its finite rows, rounded; None without one."""
    finite = values[np.all(np.isfinite(values), axis=1)] if values.size else values
    return [round(float(v), 5) for v in finite.mean(axis=0)] if len(finite) else None


def _last_finite(values: np.ndarray) -> list[float] | None:
    """The last finite row of ``values`` (n, 2), rounded; None without one."""
    finite = values[np.all(np.isfinite(values), axis=1)] if values.size else values
    return [round(float(v), 6) for v in finite[-1]] if len(finite) else None


def controller_comparison(result: RunResult, command: WalkCommand, event_s: float | None) -> dict:
    """One controller's entry of ``comparison.json``, the same keys for every comparison.

    Who fell (and when), path deviation (:func:`path_deviation` from ``command``), timing
    adaptations before and after the disturbance at ``event_s`` (the hit or the push; None
    entries without one), the disturbance the robust MPC planned with (w̃) and the one its
    observer measured (ŵ; None for nominal), each as the mean over the last half of the run and
    the final value, against the applied mean, and what the scene items did (``scene``, None without any).
    """
    s, trace = result.summary, result.trace
    t = trace["t_s"]
    half = t >= 0.5 * (t[-1] if len(t) else 0.0)
    w_planned = trace["disturbance_est_mps2"][half]
    w_measured = trace.channels.get("disturbance_measured_mps2", np.full((len(t), 2), np.nan))
    w_true = trace["disturbance_true_mps2"][half]
    entry = {
        "fell": s["fell"], "failure": s["failure"], "duration_s": s["duration_s"],
        "distance_m": s["distance_m"], "steps_taken": s["steps_taken"],
        "qp_infeasible_count": s["qp_infeasible_count"], "max_zmp_violation_m": s["max_zmp_violation_m"],
        "modules": s["modules"],
        "timing_adaptations": s["timing_adaptations"],
        "timing_returns": s["timing_returns"], "min_time_to_step_s": s["min_time_to_step_s"],
        "path_deviation": path_deviation(trace, command),
        "disturbance_planned_mean_mps2": _mean(w_planned),
        "disturbance_planned_final_mps2": s["disturbance_estimate_final"],
        "disturbance_measured_mean_mps2": _mean(w_measured[half]),
        "disturbance_measured_final_mps2": _last_finite(w_measured),
        "disturbance_applied_mean_mps2": _mean(w_true),
        "event_s": None if event_s is None else round(event_s, 4),
    }
    entry.update(_timing_after(trace, event_s))
    entry["scene"] = s.get("scene")
    return entry


def compare_results(results: dict[str, RunResult], command: WalkCommand, event_s: float | None) -> dict:
    """What every ``comparison.json`` says about its ``nominal`` and ``robust`` runs: an entry each
    (:func:`controller_comparison`), ``robust_survives_nominal_fails`` and ``robust_keeps_path``."""
    out: dict = {label: controller_comparison(result, command, event_s) for label, result in results.items()}
    out["robust_survives_nominal_fails"] = bool(not out["robust"]["fell"] and out["nominal"]["fell"])
    robust = out["robust"]
    out["robust_keeps_path"] = (not robust["fell"] and robust["path_deviation"]["max_m"] is not None
                                and _keeps_path(robust))
    return out


def comparison_metrics(run: ScenarioRun, results: dict[str, RunResult]) -> dict:
    """``comparison.json`` content for a realised scenario and its two results.

    The scenario, its seed and realised values, then :func:`compare_results` around the
    disturbance (the ball's hit, else the first push). ``expected_outcome`` applies the scenario's
    criterion (:func:`expected_outcome`).
    """
    scenario = run.scenario
    event_s = run.details["ball"]["hit_s"] if "ball" in run.details else push_start_s(run.nominal.forces)
    out: dict = {"scenario": scenario.name, "seed": run.seed, "paper": scenario.paper, "realised": run.details}
    out.update(compare_results(results, scenario.command, event_s))
    out["expected_outcome"] = expected_outcome(scenario, out)
    return out


def _keeps_path(run: dict) -> bool:
    """Whether a run's stride-averaged path deviation stays below :data:`DEVIATION_MIN_M`."""
    return (run["path_deviation"]["max_m"] or 0.0) < DEVIATION_MIN_M


def expected_outcome(scenario: Scenario, comparison: dict) -> bool:
    """Whether a comparison shows the paper's outcome.

    ``falls``: the robust run survives and the nominal one falls. ``deviates`` (the paper's
    Fig. 2: robust "accurately realizing the planned footsteps", nominal "a significant deviation
    from the planned path and almost leading to a fall"): the robust run survives and keeps the
    path (stride-averaged deviation below :data:`DEVIATION_MIN_M`), and the nominal one falls or
    deviates by at least :data:`DEVIATION_MIN_M` and :data:`DEVIATION_RATIO` times the robust one.
    """
    nominal, robust = comparison["nominal"], comparison["robust"]
    if robust["fell"]:
        return False
    if scenario.expect == "deviates" and not _keeps_path(robust):
        return False
    if nominal["fell"]:
        return True
    if scenario.expect == "falls":
        return False
    dn = nominal["path_deviation"]["max_m"] or 0.0
    return not _keeps_path(nominal) and dn >= DEVIATION_RATIO * (robust["path_deviation"]["max_m"] or 0.0)


@dataclass(frozen=True)
class ScenarioResult:
    """Both runs of a realised scenario and their comparison."""

    run: ScenarioRun
    results: dict
    comparison: dict


def run_scenario(
    scenario: Scenario | str,
    seed: int = 0,
    extra_forces: tuple[ForceWindow, ...] = (),
    duration_s: float | None = None,
    progress: Callable[[str], Callable[[float], None] | None] | None = None,
    video_dir=None,
    whole_body: str | None = None,
    sensing: str = "ideal",
    mismatch: ModelMismatch = NO_MISMATCH,
    load_factor: float = 1.0,
) -> ScenarioResult:
    """Run the nominal and the robust controller on one seed of ``scenario`` in MuJoCo.

    Parameters
    ----------
    scenario : Scenario or str
    seed : int
    extra_forces : tuple of ForceWindow
        Added to the scenario's forces.
    duration_s : float, optional
        Override the scenario's duration [s].
    progress : callable, optional
        ``progress(label)`` returns the per-run progress callback (or None).
    video_dir : path, optional
        Write ``video_dir/<label>/video.mp4`` for each run.
    whole_body : str or None
        ``servo`` or ``torque`` (:attr:`~robust_ismpc.runs.spec.RunSpec.whole_body`); None (default):
        the run specs' default.
    sensing : str
        What both controllers read (:attr:`~robust_ismpc.runs.spec.RunSpec.sensing`; ``ideal``
        by default).
    mismatch : ModelMismatch
        How the simulated robot differs from the controllers' model (none by default).
    load_factor : float
        The scenario's own disturbances times this (:func:`realise`; 1 by default).
    """
    from pathlib import Path

    from ...runs.mujoco import run_mujoco_spec

    if isinstance(scenario, str):
        scenario = get_scenario(scenario)
    if duration_s is not None:
        scenario = replace(scenario, duration_s=duration_s)
    realised = realise(scenario, seed, extra_forces, load_factor=load_factor)
    results = {}
    for label, spec in (("nominal", realised.nominal), ("robust", realised.robust)):
        spec = replace(spec, sensing=sensing, mismatch=mismatch)
        if whole_body is not None:
            spec = replace(spec, whole_body=whole_body)
        video = None
        if video_dir is not None:
            (Path(video_dir) / label).mkdir(parents=True, exist_ok=True)
            video = Path(video_dir) / label / "video.mp4"
        callback = progress(label) if progress is not None else None
        result = run_mujoco_spec(spec, progress=callback, video_path=video, scene_items=realised.scene_items)
        result.trace.meta["scenario"] = scenario.name
        result.summary["scenario"] = scenario.name
        results[label] = result
    comparison = comparison_metrics(realised, results)
    comparison["whole_body"] = results["nominal"].summary["whole_body"]
    for label, result in results.items():  # the figures' titles state it (plotting.run_outcome)
        result.trace.meta["path_deviation_m"] = comparison[label]["path_deviation"]["max_m"]
    return ScenarioResult(run=realised, results=results, comparison=comparison)
