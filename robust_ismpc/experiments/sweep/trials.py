"""Trials of a sweep: task keys, trial seeds, one trial and its outcome, and running it."""

from __future__ import annotations

import hashlib
import logging
import math
import time
from dataclasses import dataclass

from ...runs.forces import ForceWindow

LOGGER = logging.getLogger("robust_ismpc")


@dataclass(frozen=True, order=True)
class TaskKey:
    """One bisection: controller, direction [deg], phase, kind (``impulse`` or ``force``)."""

    controller: str
    direction_deg: float
    phase: float
    kind: str


def trial_seed(base_seed: int, key: TaskKey, magnitude: float, repeat: int = 0) -> int:
    """Seed of a trial, derived deterministically from the base seed and the trial's cell.

    The seed depends on the trial's (direction, phase, kind, magnitude) and its index ``repeat``
    among the trials at that magnitude, not on when or where it ran, so a resumed or parallel
    sweep gives every trial the same seed. It does not depend on the controller: every controller
    meets the same sensor noise at the same push, so their frontiers differ by the controller
    alone (common random numbers).
    """
    text = f"{base_seed}|{key.direction_deg!r}|{key.phase!r}|{key.kind}|{float(magnitude)!r}|{int(repeat)}"
    digest = hashlib.sha256(text.encode()).digest()
    return int.from_bytes(digest[:4], "big") & 0x7FFFFFFF


@dataclass(frozen=True)
class Trial:
    """One closed-loop run of the sweep, self-contained (picklable, sent to workers).

    Attributes
    ----------
    key : TaskKey
    iteration : int
        Index of the trial in its bisection (0 = the maximum).
    magnitude : float
        Impulse [N s] or force [N].
    robot, sim : str
    modules : tuple of str
    vx_mps : float
    t_push_s : float
        Push start [s].
    push_duration_s : float
        Impulse duration [s] (the constant force lasts until the end of the run).
    duration_s : float
        Simulated time of the run [s].
    seed : int
    """

    key: TaskKey
    iteration: int
    magnitude: float
    robot: str
    sim: str
    modules: tuple[str, ...]
    vx_mps: float
    t_push_s: float
    push_duration_s: float
    duration_s: float
    seed: int
    whole_body: str | None = None
    sensing: str = "ideal"

    def force_components(self) -> tuple[float, float]:
        """World-frame force (fx, fy) [N] of the push."""
        value = self.magnitude / self.push_duration_s if self.key.kind == "impulse" else self.magnitude
        angle = math.radians(self.key.direction_deg)
        fx, fy = value * math.cos(angle), value * math.sin(angle)
        # cos(90°) is 6e-17, not 0: drop such rounding residues
        return (0.0 if abs(fx) < 1e-12 * max(value, 1.0) else fx, 0.0 if abs(fy) < 1e-12 * max(value, 1.0) else fy)

    def forces(self) -> tuple[ForceWindow, ...]:
        fx, fy = self.force_components()
        end = self.t_push_s + self.push_duration_s if self.key.kind == "impulse" else math.inf
        return (ForceWindow(fx, fy, self.t_push_s, end),)


@dataclass(frozen=True)
class TrialResult:
    """Outcome of a trial (what ``runs.csv`` records besides the trial itself)."""

    survived: bool
    failure: str | None
    sim_time_s: float
    wall_time_s: float
    timing_adaptations: int


def run_trial(trial: Trial) -> TrialResult:
    """Run one trial (in a worker process, on Ray, or in-process).

    An exception other than a fall is recorded as a failure ``error: ...`` (and logged): one bad
    run does not stop a sweep of a thousand.
    """
    from ...core.planner import WalkCommand
    from ...runs.run import run
    from ...runs.spec import RunSpec

    start = time.perf_counter()
    spec = RunSpec(
        robot=trial.robot, sim=trial.sim, modules=trial.modules, command=WalkCommand(trial.vx_mps, 0.0, 0.0),
        duration_s=trial.duration_s, forces=trial.forces(), seed=trial.seed, whole_body=trial.whole_body,
        sensing=trial.sensing,
    )
    try:
        summary = run(spec).summary
    except Exception as exc:  # recorded, not raised: see the docstring
        LOGGER.warning("sweep trial %s #%d failed with an error: %s", trial.key, trial.iteration, exc)
        return TrialResult(False, f"error: {type(exc).__name__}: {exc}", math.nan, time.perf_counter() - start, 0)
    return TrialResult(
        survived=not summary["fell"], failure=summary["failure"], sim_time_s=float(summary["duration_s"]),
        wall_time_s=time.perf_counter() - start, timing_adaptations=int(summary.get("timing_adaptations", 0)),
    )

