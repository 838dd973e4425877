r"""Push-recovery sweep: the largest push each controller survives, per direction and gait phase.

For every controller (a set of robustness modules), push direction and gait phase, a bisection
finds the largest impulse [N s] the robot survives (a constant force over ``push_duration_s``
starting at that phase of the single support of one chosen step), and optionally the largest
constant force [N] switched on at the same instant and kept until the end. A trial fails when
the run fails (``summary["fell"]``: a fall, a diverged CoM or a persistent infeasible QP).

Organisation
------------
* A *task* is one bisection, keyed by (controller, direction, phase, kind). Its trial sequence
  is deterministic: trial 0 tries the maximum; if the robot survives the task is *saturated*,
  otherwise ``iterations`` bisection trials halve the bracket :math:`[lo, hi]`, starting from
  :math:`[0, max]`. The frontier is ``lo``, the largest survived magnitude (resolution
  :math:`max / 2^{iterations}`).
* Each finished trial is one row of ``runs.csv``, appended and flushed as it finishes. On a
  rerun with the same configuration (``sweep.json``), every task replays its finished trials from
  the CSV and only runs the missing ones, so an interrupted sweep resumes where it stopped.
* Trials of different tasks run in parallel on local processes
  (:class:`concurrent.futures.ProcessPoolExecutor`) or on Ray; a trial's seed is derived from the
  base seed and the trial key, so every run replays alone.

Bisection assumes that survival is monotonic in the magnitude; where it is not (a larger push may
trigger a step-timing adaptation that a smaller one does not), the frontier is the bisection's
answer, not the exact supremum: ``runs.csv`` keeps every trial for inspection.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import json
import logging
import math
import os
import platform
import signal
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, fields
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from ..control.modules import controller_modules, parse_controllers
from ..exceptions import ParameterError
from ..io import atomic_write_bytes, atomic_write_json
from ..runs.forces import ForceWindow
from ..runs.outputs import is_scratch, open_output_dir
from ..validation import check_positive

LOGGER = logging.getLogger("robust_ismpc")

SIMS = ("lip", "mujoco")
KINDS = ("impulse", "force")
UNITS = {"impulse": "N s", "force": "N"}
BACKENDS = ("local", "ray")
SWEEP_FORMAT = 1

RUNS_CSV = "runs.csv"
SWEEP_JSON = "sweep.json"
FRONTIER_JSON = "frontier.json"
REPORT_MD = "report.md"
#: Files a sweep writes into its output directory (``--overwrite`` removes exactly these).
OUTPUT_FILES = (
    RUNS_CSV, SWEEP_JSON, FRONTIER_JSON, REPORT_MD,
    "frontier_polar.png", "frontier_phase.png", "frontier_force_polar.png", "frontier_force_phase.png",
)

#: Columns of ``runs.csv``, one row per trial.
COLUMNS = (
    "controller", "modules", "direction_deg", "phase", "kind", "iteration", "magnitude", "unit",
    "fx_n", "fy_n", "t_push_s", "push_duration_s", "survived", "failure", "seed", "duration_s",
    "sim_time_s", "wall_time_s", "timing_adaptations",
)


# ---------------------------------------------------------------------------------------------
# Parsing of the user's lists
# ---------------------------------------------------------------------------------------------
def _range_spec(text: str, what: str) -> list[float]:
    parts = text.split(":")
    if len(parts) != 3:
        raise ParameterError(f"{what} {text!r}: expected START:STOP:STEPS or a comma-separated list of numbers")
    try:
        start, stop = float(parts[0]), float(parts[1])
    except ValueError:
        raise ParameterError(f"{what} {text!r}: START and STOP must be numbers") from None
    try:
        steps = int(parts[2])
    except ValueError:
        raise ParameterError(f"{what} {text!r}: STEPS must be an integer >= 1") from None
    if not (math.isfinite(start) and math.isfinite(stop)):
        raise ParameterError(f"{what} {text!r}: START and STOP must be finite")
    if steps < 1:
        raise ParameterError(f"{what} {text!r}: STEPS must be an integer >= 1")
    if stop <= start:
        raise ParameterError(f"{what} {text!r}: STOP must be greater than START")
    return [start + (stop - start) * k / steps for k in range(steps)]


def _number_list(text: str, what: str) -> list[float]:
    if not isinstance(text, str) or not text.strip():
        raise ParameterError(f"{what}: expected a comma-separated list of numbers or START:STOP:STEPS")
    text = text.strip()
    if ":" in text:
        return _range_spec(text, what)
    values = []
    for part in text.split(","):
        try:
            value = float(part)
        except ValueError:
            raise ParameterError(f"{what} {text!r}: {part.strip()!r} is not a number") from None
        if not math.isfinite(value):
            raise ParameterError(f"{what} {text!r}: values must be finite")
        values.append(value)
    return values


def parse_directions(text: str) -> tuple[float, ...]:
    """Push directions [deg]: ``0,45,90`` or ``START:STOP:STEPS`` (``0:360:8`` = every 45°).

    0 is forward (+x), 90 left (+y). Directions equal modulo 360° are refused.
    """
    values = _number_list(text, "directions")
    seen = set()
    for v in values:
        key = round(v % 360.0, 9) % 360.0
        if key in seen:
            raise ParameterError(f"directions {text!r}: {v:g}° repeats another direction (modulo 360°)")
        seen.add(key)
    return tuple(float(v) for v in values)


def parse_phases(text: str) -> tuple[float, ...]:
    """Gait phases in [0, 1): ``START:STOP:STEPS`` (STEPS evenly spaced in [START, STOP)) or a list.

    ``0:1:4`` gives 0, 0.25, 0.5, 0.75. A phase is the fraction of the pushed step's single
    support elapsed when the push starts.
    """
    values = _number_list(text, "phases")
    for v in values:
        if not 0.0 <= v < 1.0:
            raise ParameterError(f"phases {text!r}: every phase must be in [0, 1), got {v:g}")
    if len(set(values)) != len(values):
        raise ParameterError(f"phases {text!r}: phases must be distinct")
    return tuple(float(v) for v in values)


# ---------------------------------------------------------------------------------------------
# Configuration, tasks and trials
# ---------------------------------------------------------------------------------------------
#: Default time after the push [s] per simulator (``ismpc sweep --duration``). MuJoCo G1, 0.2 m/s,
#: 16 cells: the 3 s window reported a mean nominal frontier of 7.41 / 3.23 / 3.61 / 3.14 N s
#: (0°, 90°, 180°, 270°), the 6 s window 5.62 / 1.55 / 2.48 / 2.62 N s (docs/sweeps.md).
DEFAULT_POST_PUSH_S = {"lip": 3.0, "mujoco": 6.0}


@dataclass(frozen=True)
class SweepConfig:
    """What a sweep measures (everything that changes its results; not how it is executed).

    Attributes
    ----------
    robot : str
        Built-in robot name.
    sim : str
        ``lip`` or ``mujoco``.
    controllers : tuple of str
        Controller names (see :func:`controller_modules`).
    directions_deg : tuple of float
        Push directions in the horizontal plane [deg]; 0 = forward (+x), 90 = left (+y).
    phases : tuple of float
        Fractions in [0, 1) of the pushed step's single support at which the push starts.
    impulse_max_ns : float
        Upper end of the impulse bisection [N s].
    force_max_n : float or None
        Upper end of the constant-force bisection [N]; None: no force bisection.
    push_duration_s : float
        Duration of the impulsive push [s]; the force is ``impulse / push_duration_s``.
    vx_mps : float
        Forward walking command [m/s].
    post_push_s : float
        Simulated time after the push starts [s]: long enough to see a fall. On the LIP a push
        fails within a step (QP infeasible); the full G1 can fall 3-4.5 s after a small push
        (1.5 N s to the left at 0.2 m/s, nominal: fell at 8.72 s, 4.5 s after the push), which a
        3 s window counts as survived. ``ismpc sweep`` uses :data:`DEFAULT_POST_PUSH_S`.
    iterations : int
        Bisection trials after the first trial at the maximum (resolution ``max / 2**iterations``).
    pushed_step : int
        Which regular step is pushed (1 = the first step after the start-up double support).
    seed : int
        Base seed; every trial's seed derives from it and the trial key (:func:`trial_seed`).
    whole_body : str or None
        MuJoCo only: ``torque`` or ``servo`` (:attr:`~robust_ismpc.runs.spec.RunSpec.whole_body`);
        None is resolved to the default.
    """

    robot: str = "g1"
    sim: str = "lip"
    controllers: tuple[str, ...] = ("nominal", "robust")
    directions_deg: tuple[float, ...] = (0.0, 90.0, 180.0, 270.0)
    phases: tuple[float, ...] = (0.0,)
    impulse_max_ns: float = 20.0
    force_max_n: float | None = None
    push_duration_s: float = 0.1
    vx_mps: float = 0.2
    post_push_s: float = 3.0
    iterations: int = 8
    pushed_step: int = 4
    seed: int = 0
    whole_body: str | None = None

    def __post_init__(self) -> None:
        owner = "SweepConfig"
        from ..robots import robot_reference
        from ..runs.spec import gait_params

        if self.sim not in SIMS:
            raise ParameterError(f"unknown simulator {self.sim!r}; use one of: {', '.join(SIMS)}")
        object.__setattr__(self, "robot", robot_reference(self.robot))
        gait_params(self.robot, self.sim)  # validates the name or the file
        if not self.controllers:
            raise ParameterError(f"{owner}.controllers must name at least one controller")
        parse_controllers(",".join(self.controllers))
        if not self.directions_deg:
            raise ParameterError(f"{owner}.directions_deg must hold at least one direction")
        parse_directions(",".join(repr(float(d)) for d in self.directions_deg))
        if not self.phases:
            raise ParameterError(f"{owner}.phases must hold at least one phase")
        parse_phases(",".join(repr(float(p)) for p in self.phases))
        check_positive(owner, impulse_max_ns=self.impulse_max_ns)
        if self.force_max_n is not None:
            check_positive(owner, force_max_n=self.force_max_n)
        check_positive(owner, push_duration_s=self.push_duration_s, post_push_s=self.post_push_s)
        if isinstance(self.vx_mps, bool) or not isinstance(self.vx_mps, (int, float)) or not math.isfinite(self.vx_mps):
            raise ParameterError(f"{owner}.vx_mps must be a finite number, got {self.vx_mps!r}")
        if isinstance(self.iterations, bool) or not isinstance(self.iterations, int) or not 1 <= self.iterations <= 30:
            raise ParameterError(f"{owner}.iterations must be an integer in [1, 30], got {self.iterations!r}")
        if isinstance(self.pushed_step, bool) or not isinstance(self.pushed_step, int) or self.pushed_step < 1:
            raise ParameterError(f"{owner}.pushed_step must be an integer >= 1, got {self.pushed_step!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ParameterError(f"{owner}.seed must be an integer >= 0, got {self.seed!r}")
        from ..runs.spec import resolve_whole_body

        object.__setattr__(self, "whole_body", resolve_whole_body(owner, self.whole_body, self.sim))

    # -----------------------------------------------------------------------------------------
    @property
    def kinds(self) -> tuple[str, ...]:
        """``("impulse",)`` or ``("impulse", "force")``."""
        return KINDS if self.force_max_n is not None else KINDS[:1]

    def max_magnitude(self, kind: str) -> float:
        """Upper end of the bisection of ``kind`` [N s or N]."""
        if kind == "impulse":
            return float(self.impulse_max_ns)
        if kind == "force" and self.force_max_n is not None:
            return float(self.force_max_n)
        raise ParameterError(f"this sweep has no {kind!r} bisection; kinds: {', '.join(self.kinds)}")

    def resolution(self, kind: str) -> float:
        """Width of the final bisection bracket [N s or N]."""
        return self.max_magnitude(kind) / 2**self.iterations

    def tasks(self) -> list[TaskKey]:
        """Every bisection of the sweep, in a fixed order."""
        return [
            TaskKey(c, float(d), float(p), k)
            for k in self.kinds for c in self.controllers for d in self.directions_deg for p in self.phases
        ]

    @property
    def max_trials(self) -> int:
        """Upper bound on the number of trials (tasks that saturate need fewer)."""
        return len(self.tasks()) * (1 + self.iterations)

    def to_dict(self) -> dict:
        """JSON-ready dict (tuples as lists)."""
        return {f.name: (list(v) if isinstance(v := getattr(self, f.name), tuple) else v) for f in fields(self)}

    @classmethod
    def from_dict(cls, data: dict) -> SweepConfig:
        """Inverse of :meth:`to_dict` (validated)."""
        names = {f.name for f in fields(cls)}
        unknown = set(data) - names
        if unknown:
            raise ParameterError(f"sweep configuration has unknown fields: {', '.join(sorted(unknown))}")
        values = {k: (tuple(v) if isinstance(v, list) else v) for k, v in data.items()}
        return cls(**values)  # type: ignore[arg-type]

    # -----------------------------------------------------------------------------------------
    def gait_params(self):
        """Gait timing of the robot as the simulator uses it (:class:`~robust_ismpc.core.params.RobotParams`)."""
        from ..runs.spec import gait_params

        return gait_params(self.robot, self.sim)

    def pushed_step_window(self) -> tuple[float, float]:
        """Start and duration of the pushed step's single support [s].

        From the footstep plan that :func:`robust_ismpc.runs.spec.run` builds for the walk command:
        regular step k (1-based) is step index ``k + 1`` of the plan.
        """
        from ..control.walk import lip_start_soles
        from ..core.planner import WalkCommand, plan_footsteps

        robot = self.gait_params()
        j = self.pushed_step + 1
        horizon = (j + 4) * robot.T_step_s + 4.0 * robot.T_step_s
        plan = plan_footsteps(robot, WalkCommand(self.vx_mps, 0.0, 0.0), horizon, *lip_start_soles(robot))
        return float(plan.ss_start_s[j]), float(plan.T_ss_s[j])

    def push_start_s(self, phase: float) -> float:
        """Time at which a push at ``phase`` starts [s]."""
        start, T_ss = self.pushed_step_window()
        return start + phase * T_ss


@dataclass(frozen=True, order=True)
class TaskKey:
    """One bisection: controller, direction [deg], phase, kind (``impulse`` or ``force``)."""

    controller: str
    direction_deg: float
    phase: float
    kind: str


def trial_seed(base_seed: int, key: TaskKey, magnitude: float) -> int:
    """Seed of a trial, derived deterministically from the base seed and the trial key.

    The seed depends on the trial's (controller, direction, phase, kind, magnitude), not on when
    or where it ran, so a resumed or parallel sweep gives every trial the same seed.
    """
    text = f"{base_seed}|{key.controller}|{key.direction_deg!r}|{key.phase!r}|{key.kind}|{float(magnitude)!r}"
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
    from ..core.planner import WalkCommand
    from ..runs.run import run
    from ..runs.spec import RunSpec

    start = time.perf_counter()
    spec = RunSpec(
        robot=trial.robot, sim=trial.sim, modules=trial.modules, command=WalkCommand(trial.vx_mps, 0.0, 0.0),
        duration_s=trial.duration_s, forces=trial.forces(), seed=trial.seed, whole_body=trial.whole_body,
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


# ---------------------------------------------------------------------------------------------
# Bisection
# ---------------------------------------------------------------------------------------------
class Bisection:
    """Deterministic bisection of the largest survived magnitude in [0, max].

    Trial 0 tries ``max``; if it is survived the bisection is done (saturated). Otherwise each of
    the next ``iterations`` trials tries the midpoint of the bracket [lo, hi] (initially [0, max])
    and moves ``lo`` up on survival, ``hi`` down on failure. The sequence of magnitudes depends
    only on the outcomes so far, which is what lets a sweep replay it from ``runs.csv``.

    Parameters
    ----------
    max_magnitude : float
        Upper end, > 0.
    iterations : int
        Bisection trials after the first one, >= 1.
    """

    def __init__(self, max_magnitude: float, iterations: int):
        check_positive("Bisection", max_magnitude=max_magnitude)
        if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
            raise ParameterError(f"Bisection.iterations must be an integer >= 1, got {iterations!r}")
        self.max_magnitude = float(max_magnitude)
        self.iterations = iterations
        self.lo = 0.0
        self.hi = self.max_magnitude
        self.trials: list[tuple[float, bool]] = []

    def next_magnitude(self) -> float | None:
        """Magnitude of the next trial, or None when the bisection is done."""
        n = len(self.trials)
        if n == 0:
            return self.max_magnitude
        if self.trials[0][1] or n >= 1 + self.iterations:
            return None
        return 0.5 * (self.lo + self.hi)

    @property
    def done(self) -> bool:
        return self.next_magnitude() is None

    @property
    def remaining_max(self) -> int:
        """Most trials still to run."""
        if self.done:
            return 0
        return 1 + self.iterations - len(self.trials)

    def record(self, magnitude: float, survived: bool) -> None:
        """Record the outcome of the trial at ``next_magnitude()``.

        Raises
        ------
        ParameterError
            If ``magnitude`` is not the one the bisection asked for.
        """
        expected = self.next_magnitude()
        if expected is None or magnitude != expected:
            raise ParameterError(f"bisection expected a trial at {expected!r}, got {magnitude!r}")
        if self.trials:
            if survived:
                self.lo = magnitude
            else:
                self.hi = magnitude
        self.trials.append((float(magnitude), bool(survived)))

    @property
    def saturated(self) -> bool:
        """The maximum itself was survived."""
        return bool(self.trials) and self.trials[0][1]

    @property
    def frontier(self) -> float:
        """Largest survived magnitude found (0 if none; ``max`` when saturated)."""
        return self.max_magnitude if self.saturated else self.lo


def bisect(survives: Callable[[float], bool], max_magnitude: float, iterations: int) -> Bisection:
    """Run a whole bisection with ``survives(magnitude) -> bool`` (serially, in-process)."""
    b = Bisection(max_magnitude, iterations)
    while (m := b.next_magnitude()) is not None:
        b.record(m, bool(survives(m)))
    return b


# ---------------------------------------------------------------------------------------------
# runs.csv
# ---------------------------------------------------------------------------------------------
@contextlib.contextmanager
def _sigint_deferred():
    """Hold SIGINT (Ctrl-C) back while a row is written, so no half row reaches the file."""
    can_block = hasattr(signal, "pthread_sigmask") and threading.current_thread() is threading.main_thread()
    if not can_block:
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _csv_line(values: Sequence) -> str:
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\n").writerow(values)
    return buffer.getvalue()


def trial_row(trial: Trial, result: TrialResult) -> dict:
    """The ``runs.csv`` row of a finished trial (floats in ``repr`` form: they read back exactly)."""
    fx, fy = trial.force_components()
    return {
        "controller": trial.key.controller,
        "modules": "+".join(trial.modules) or "-",
        "direction_deg": repr(trial.key.direction_deg),
        "phase": repr(trial.key.phase),
        "kind": trial.key.kind,
        "iteration": str(trial.iteration),
        "magnitude": repr(float(trial.magnitude)),
        "unit": UNITS[trial.key.kind],
        "fx_n": f"{fx:.6g}",
        "fy_n": f"{fy:.6g}",
        "t_push_s": f"{trial.t_push_s:.6g}",
        "push_duration_s": f"{trial.push_duration_s:.6g}" if trial.key.kind == "impulse" else "inf",
        "survived": "1" if result.survived else "0",
        "failure": "" if result.failure is None else result.failure.replace("\n", " ")[:200],
        "seed": str(trial.seed),
        "duration_s": f"{trial.duration_s:.6g}",
        "sim_time_s": f"{result.sim_time_s:.6g}",
        "wall_time_s": f"{result.wall_time_s:.4f}",
        "timing_adaptations": str(result.timing_adaptations),
    }


def read_runs(path: Path) -> list[dict]:
    """Complete rows of ``runs.csv`` (as dicts of strings); repairs a torn last line.

    A last line without its newline (a process killed mid-write) is cut off and the file
    rewritten atomically; so are rows with the wrong number of fields.

    Raises
    ------
    ParameterError
        If the header is not :data:`COLUMNS` (not a sweep file of this version).
    """
    path = Path(path)
    if not path.exists():
        return []
    data = path.read_bytes()
    if not data:
        return []
    complete = data if data.endswith(b"\n") else data[: data.rfind(b"\n") + 1]
    try:
        lines = complete.decode().splitlines(keepends=True)
    except UnicodeDecodeError as exc:
        line = complete[: exc.start].count(b"\n") + 1
        raise ParameterError(f"{path} line {line} is not text (the file is corrupted); delete that line (its "
                             "trial runs again) or pass --overwrite to start the sweep again") from None
    if not lines:
        atomic_write_bytes(path, b"")
        return []
    header = next(csv.reader([lines[0]]))
    if tuple(header) != COLUMNS:
        raise ParameterError(f"{path} does not have the columns of a sweep's runs.csv; pass --overwrite to start again")
    rows, kept = [], [lines[0]]
    for number, line in enumerate(lines[1:], start=2):
        values = next(csv.reader([line]), [])
        if len(values) != len(COLUMNS):
            LOGGER.warning("dropping a malformed row of %s: %r", path, line[:80])
            continue
        rows.append(_check_row(path, number, dict(zip(COLUMNS, values))))
        kept.append(line)
    if len(kept) != len(lines) or complete != data:
        LOGGER.warning("repaired %s: kept %d complete rows", path, len(rows))
        atomic_write_bytes(path, "".join(kept).encode())
    return rows


def _check_row(path: Path, number: int, row: dict) -> dict:
    """``row`` (line ``number`` of ``path``) if the values a resume reads parse; else ParameterError."""
    checks = {"direction_deg": float, "phase": float, "magnitude": float, "iteration": int,
              "kind": KINDS.index, "survived": ("0", "1").index}
    for column, parse in checks.items():
        try:
            parse(row[column])
        except ValueError:
            raise ParameterError(
                f"{path} line {number}: {column} {row[column]!r} is not valid (the file is corrupted); delete that "
                "line (its trial runs again) or pass --overwrite to start the sweep again"
            ) from None
    return row


class _RunsWriter:
    """Appends rows to ``runs.csv``, one flushed line at a time."""

    def __init__(self, path: Path):
        new = not path.exists() or path.stat().st_size == 0
        self._handle = open(path, "a", newline="", encoding="utf-8")
        if new:
            self._write(_csv_line(COLUMNS))

    def _write(self, line: str) -> None:
        with _sigint_deferred():
            self._handle.write(line)
            self._handle.flush()

    def append(self, row: dict) -> None:
        self._write(_csv_line([row[c] for c in COLUMNS]))

    def close(self) -> None:
        self._handle.close()


def _row_key(row: dict) -> tuple[TaskKey, int]:
    key = TaskKey(row["controller"], float(row["direction_deg"]), float(row["phase"]), row["kind"])
    return key, int(row["iteration"])


# ---------------------------------------------------------------------------------------------
# Backends
# ---------------------------------------------------------------------------------------------
def _die_with_parent(parent_pid: int) -> None:
    """Ask Linux to SIGKILL this process when its parent dies (``prctl(PR_SET_PDEATHSIG)``), so a
    sweep killed by SIGKILL leaves no orphaned workers; exit now if the parent is already gone."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        pr_set_pdeathsig = 1
        libc.prctl(pr_set_pdeathsig, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):  # not Linux: the parent stops its workers on SIGINT/SIGTERM
        pass
    if os.getppid() != parent_pid:
        os._exit(1)


def _worker_init(log_level: int, parent_pid: int | None = None) -> None:
    """Local worker: leave Ctrl-C and SIGTERM to the parent (it stops the workers), die with the
    parent, and log like it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if parent_pid is not None:
        _die_with_parent(parent_pid)
    logging.getLogger("robust_ismpc").setLevel(log_level)


class _SerialBackend:
    """Runs trials in this process, one at a time (``workers=1``)."""

    name = "serial"

    def __init__(self) -> None:
        self._queue: list[tuple[object, Trial]] = []
        self._count = 0

    def submit(self, trial: Trial):
        self._count += 1
        handle = self._count
        self._queue.append((handle, trial))
        return handle

    def wait(self, handles) -> list[tuple[object, TrialResult]]:
        handle, trial = self._queue.pop(0)
        return [(handle, run_trial(trial))]

    def close(self, interrupted: bool = False) -> None:
        self._queue.clear()


class _LocalBackend:
    """A :class:`concurrent.futures.ProcessPoolExecutor` of ``workers`` processes."""

    name = "local"

    def __init__(self, workers: int):
        from concurrent.futures import ProcessPoolExecutor

        level = logging.getLogger("robust_ismpc").getEffectiveLevel()
        self._pool = ProcessPoolExecutor(max_workers=workers, initializer=_worker_init,
                                         initargs=(level, os.getpid()))

    def submit(self, trial: Trial):
        return self._pool.submit(run_trial, trial)

    def wait(self, handles) -> list[tuple[object, TrialResult]]:
        from concurrent.futures import FIRST_COMPLETED, wait

        done, _ = wait(handles, return_when=FIRST_COMPLETED)
        return [(f, f.result()) for f in done]

    def close(self, interrupted: bool = False) -> None:
        if interrupted:
            # The workers ignore SIGINT: stop them (trials under way are lost, not half-written);
            # the pool then sees its processes gone and its manager thread ends.
            processes = list((getattr(self._pool, "_processes", None) or {}).values())
            for process in processes:
                if process.is_alive():
                    process.terminate()
            for process in processes:
                process.join(timeout=5.0)
        self._pool.shutdown(wait=True, cancel_futures=True)


class _RayBackend:
    """The same trials as Ray tasks on a local Ray instance (``ray.init()``)."""

    name = "ray"

    def __init__(self, workers: int):
        import ray

        self._ray = ray
        self._started = False
        if not ray.is_initialized():
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False, logging_level=logging.ERROR)
            self._started = True
        self._remote = ray.remote(num_cpus=1)(run_trial)

    def submit(self, trial: Trial):
        return self._remote.remote(trial)

    def wait(self, handles) -> list[tuple[object, TrialResult]]:
        ready, _ = self._ray.wait(list(handles), num_returns=1)
        return [(ref, self._ray.get(ref)) for ref in ready]

    def close(self, interrupted: bool = False) -> None:
        if self._started:
            self._ray.shutdown()


def ray_available() -> bool:
    """True if ``import ray`` works."""
    try:
        import ray  # noqa: F401
    except Exception:
        return False
    return True


def make_backend(backend: str, workers: int):
    """The executor of trials: ``local`` (processes; in-process when ``workers == 1``) or ``ray``.

    Raises
    ------
    ParameterError
        Unknown backend, bad worker count, or Ray requested but not installed.
    """
    if backend not in BACKENDS:
        raise ParameterError(f"unknown backend {backend!r}; use one of: {', '.join(BACKENDS)}")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ParameterError(f"workers must be an integer >= 1, got {workers!r}")
    if backend == "ray":
        if not ray_available():
            raise ParameterError("--backend ray needs Ray, which is not installed: pip install ray")
        return _RayBackend(workers)
    if workers == 1:
        return _SerialBackend()
    return _LocalBackend(workers)


# ---------------------------------------------------------------------------------------------
# The sweep
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SweepProgress:
    """Progress of a sweep, passed to the ``progress`` callback after every finished trial.

    Attributes
    ----------
    done : int
        Trials finished, resumed ones included.
    total : int
        ``done`` plus the most trials still to run (it shrinks when bisections saturate).
    new : int
        Trials run by this invocation.
    elapsed_s : float
        Wall time of this invocation [s].
    """

    done: int
    total: int
    new: int
    elapsed_s: float


@dataclass(frozen=True)
class SweepResult:
    """What :func:`run_sweep` produced.

    Attributes
    ----------
    frontier : dict
        The ``frontier.json`` content.
    paths : tuple of Path
        Files written.
    trials_total, trials_new, trials_resumed : int
        Trials in ``runs.csv``; run now; replayed from an earlier invocation.
    wall_time_s : float
        Wall time of this invocation [s].
    """

    frontier: dict
    paths: tuple[Path, ...]
    trials_total: int
    trials_new: int
    trials_resumed: int
    wall_time_s: float

    @property
    def runs_per_s(self) -> float:
        """Trials run per second of wall time by this invocation."""
        return self.trials_new / self.wall_time_s if self.wall_time_s > 0 else math.nan


def _config_diff(old: dict, new: dict) -> list[str]:
    return sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k))


def code_digest() -> dict:
    """Package version and a digest of its Python sources: which code produced the trials."""
    from importlib import metadata

    root = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(str(path.relative_to(root)).encode())
        digest.update(path.read_bytes())
    try:
        version = metadata.version("robust-ismpc")
    except metadata.PackageNotFoundError:
        version = "unknown"
    return {"version": version, "sources_sha256": digest.hexdigest()[:16]}


def prepare_out(config: SweepConfig, out: Path, overwrite: bool) -> dict | None:
    """Check or create the output directory and its ``sweep.json``.

    An existing directory holding the same configuration (``sweep.json``) resumes; with
    ``overwrite`` the sweep's own files are removed first (other files are left alone).

    Returns
    -------
    dict or None
        When an earlier sweep is resumed, the code that started it (:func:`code_digest`);
        None for a new sweep.

    Raises
    ------
    ParameterError
        ``out`` is a file; or it is non-empty, and holds a different sweep or no sweep, and
        ``overwrite`` is false.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ParameterError(f"--out {str(out)!r} exists and is not a directory")
    wanted = json.loads(json.dumps(config.to_dict()))
    previous = None
    if out.exists() and any(not is_scratch(p.name) for p in out.iterdir()):
        if overwrite:
            for name in OUTPUT_FILES:
                (out / name).unlink(missing_ok=True)
        else:
            stored_path = out / SWEEP_JSON
            if not stored_path.exists():
                raise ParameterError(
                    f"--out {str(out)!r} is not empty and holds no sweep ({SWEEP_JSON}); "
                    "pass --overwrite to write into it or choose another directory"
                )
            try:
                stored_file: dict = json.loads(stored_path.read_text())
                stored = stored_file["config"]
            except (OSError, ValueError, KeyError, TypeError):
                stored_file, stored = {}, {}
            if stored != wanted:
                diff = _config_diff(stored, wanted) if isinstance(stored, dict) else ["all"]
                raise ParameterError(
                    f"--out {str(out)!r} holds a sweep with a different configuration (differs in: "
                    f"{', '.join(diff)}); pass --overwrite to replace it or choose another directory"
                )
            previous = stored_file.get("code") or {"version": "unknown", "sources_sha256": "unknown"}
    if previous is None:
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_json(out / SWEEP_JSON, {"format": SWEEP_FORMAT, "config": wanted, "code": code_digest()})
    return previous


def _replay(config: SweepConfig, rows: list[dict]) -> tuple[dict[TaskKey, Bisection], int]:
    """Bisections of every task with their finished trials replayed from ``rows``."""
    finished: dict[tuple[TaskKey, int], dict] = {}
    for row in rows:
        try:
            rk = _row_key(row)
        except (ValueError, KeyError):
            LOGGER.warning("ignoring an unreadable row of %s", RUNS_CSV)
            continue
        finished.setdefault(rk, row)
    bisections: dict[TaskKey, Bisection] = {}
    replayed = 0
    for key in config.tasks():
        b = Bisection(config.max_magnitude(key.kind), config.iterations)
        while (m := b.next_magnitude()) is not None:
            done_row = finished.get((key, len(b.trials)))
            if done_row is None:
                break
            row = done_row
            if float(row["magnitude"]) != m:
                raise ParameterError(
                    f"{RUNS_CSV} does not follow this sweep's bisection ({key.controller}, {key.direction_deg:g}°, "
                    f"phase {key.phase:g}, {key.kind}, trial {len(b.trials)}: {row['magnitude']} instead of {m!r}); "
                    "pass --overwrite to start again"
                )
            b.record(m, row["survived"] == "1")
            replayed += 1
        bisections[key] = b
    return bisections, replayed


def _make_trial(config: SweepConfig, key: TaskKey, b: Bisection, push_window: tuple[float, float]) -> Trial:
    magnitude = b.next_magnitude()
    if magnitude is None:
        raise ParameterError(f"bisection {key} is already complete")
    start, T_ss = push_window
    t_push = start + key.phase * T_ss
    return Trial(
        key=key, iteration=len(b.trials), magnitude=float(magnitude), robot=config.robot, sim=config.sim,
        modules=controller_modules(key.controller), vx_mps=float(config.vx_mps), t_push_s=t_push,
        push_duration_s=float(config.push_duration_s), duration_s=t_push + config.post_push_s,
        seed=trial_seed(config.seed, key, magnitude), whole_body=config.whole_body,
    )


def run_sweep(
    config: SweepConfig,
    out: str | Path,
    workers: int | None = None,
    backend: str = "local",
    overwrite: bool = False,
    progress: Callable[[SweepProgress], None] | None = None,
    command_line: str | None = None,
) -> SweepResult:
    """Run (or resume) a push-recovery sweep and write its outputs into ``out``.

    Parameters
    ----------
    config : SweepConfig
    out : path
        Output directory: ``sweep.json``, ``runs.csv``, ``frontier.json``, ``report.md`` and the
        frontier plots.
    workers : int, optional
        Parallel workers (default ``os.cpu_count()``); 1 runs the trials in this process.
    backend : str
        ``local`` (processes) or ``ray``.
    overwrite : bool
        Discard an earlier sweep in ``out`` instead of resuming it / refusing a different one.
    progress : callable, optional
        Called with a :class:`SweepProgress` after every finished trial.
    command_line : str, optional
        Recorded in ``report.md``.

    Returns
    -------
    SweepResult

    Raises
    ------
    ParameterError
        Bad backend or worker count, or an ``out`` that cannot be used (see :func:`prepare_out`).
    KeyboardInterrupt
        Ctrl-C: the finished trials are in ``runs.csv`` (complete rows only); rerun to resume.

    Notes
    -----
    ``out`` is locked while the sweep runs (:func:`robust_ismpc.runs.outputs.open_output_dir`): a
    second sweep into the same folder is refused instead of duplicating rows.
    """
    workers = (os.cpu_count() or 1) if workers is None else workers
    out = Path(out)
    start = time.perf_counter()
    started_at = datetime.now(timezone.utc)
    if backend not in BACKENDS:
        raise ParameterError(f"unknown backend {backend!r}; use one of: {', '.join(BACKENDS)}")
    if backend == "ray" and not ray_available():
        raise ParameterError("--backend ray needs Ray, which is not installed: pip install ray")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ParameterError(f"workers must be an integer >= 1, got {workers!r}")
    # One sweep per folder at a time (a second one would append the same trials to runs.csv).
    with open_output_dir(str(out), overwrite=True, require_empty=False):
        push_window = config.pushed_step_window()
        code = code_digest()
        previous_code = prepare_out(config, out, overwrite)
        if previous_code is not None and previous_code != code:
            LOGGER.warning("resuming a sweep started with other code (%s); runs.csv will mix trials of both",
                           previous_code.get("sources_sha256"))
        runs_path = out / RUNS_CSV
        bisections, replayed = _replay(config, read_runs(runs_path))
        pending_tasks = [k for k, b in bisections.items() if not b.done]
        done = replayed
        new = 0

        def total() -> int:
            return done + sum(b.remaining_max for b in bisections.values())

        writer = _RunsWriter(runs_path)
        executor = None
        interrupted = False
        try:
            if pending_tasks:
                executor = make_backend(backend, min(workers, len(pending_tasks)) if backend == "local" else workers)
                in_flight: dict[object, Trial] = {}
                for key in pending_tasks:
                    trial = _make_trial(config, key, bisections[key], push_window)
                    in_flight[executor.submit(trial)] = trial
                while in_flight:
                    for handle, result in executor.wait(list(in_flight)):
                        trial = in_flight.pop(handle)
                        writer.append(trial_row(trial, result))
                        b = bisections[trial.key]
                        b.record(trial.magnitude, result.survived)
                        done += 1
                        new += 1
                        if not b.done:
                            nxt = _make_trial(config, trial.key, b, push_window)
                            in_flight[executor.submit(nxt)] = nxt
                        if progress is not None:
                            progress(SweepProgress(done, total(), new, time.perf_counter() - start))
        except BaseException:
            interrupted = True
            raise
        finally:
            writer.close()
            if executor is not None:
                executor.close(interrupted=interrupted)
        wall = time.perf_counter() - start
        frontier = frontier_summary(config, bisections)
        rows = read_runs(runs_path)
        paths = [out / SWEEP_JSON, runs_path]
        atomic_write_json(out / FRONTIER_JSON, frontier)
        paths.append(out / FRONTIER_JSON)
        paths.extend(plot_frontiers(frontier, out))
        result = SweepResult(frontier=frontier, paths=(), trials_total=len(rows), trials_new=new,
                             trials_resumed=replayed, wall_time_s=wall)
        report = format_report(config, frontier, result, rows, command_line=command_line, backend=backend,
                               workers=workers, started_at=started_at, code=code, previous_code=previous_code)
        atomic_write_bytes(out / REPORT_MD, report.encode())
        paths.append(out / REPORT_MD)
        return SweepResult(frontier=frontier, paths=tuple(paths), trials_total=len(rows), trials_new=new,
                           trials_resumed=replayed, wall_time_s=wall)


# ---------------------------------------------------------------------------------------------
# Frontier
# ---------------------------------------------------------------------------------------------
def _dir_label(direction_deg: float) -> str:
    return f"{direction_deg:g}"


def _ratio(a: float, b: float) -> float | None:
    """a / b, None when b is 0 (the nominal frontier is below the resolution)."""
    return round(a / b, 4) if b > 0 else None


def frontier_summary(config: SweepConfig, bisections: dict[TaskKey, Bisection]) -> dict:
    """The ``frontier.json`` content.

    ``entries`` lists every bisection. For each kind, ``frontier[kind][controller][direction]``
    holds the per-phase frontier and its ``min`` and ``mean`` over phases. If ``nominal`` is one
    of the controllers, ``ratios[kind]["<controller>/nominal"][direction]`` holds the ratio of
    the min-over-phases frontiers, of the mean-over-phases frontiers, and per phase (None where
    the nominal frontier is 0), and ``ratio_summary`` the smallest per-phase ratio over all
    directions and whether it is >= 2.
    """
    entries = []
    per: dict[str, dict[str, dict[str, dict]]] = {}
    for key in config.tasks():
        b = bisections[key]
        entries.append({
            "controller": key.controller, "direction_deg": key.direction_deg, "phase": key.phase,
            "kind": key.kind, "max_survived": b.frontier, "first_failed": None if b.saturated else b.hi,
            "saturated": b.saturated, "complete": b.done, "trials": len(b.trials),
        })
        cell = per.setdefault(key.kind, {}).setdefault(key.controller, {}).setdefault(
            _dir_label(key.direction_deg), {"phases": [], "per_phase": []}
        )
        cell["phases"].append(key.phase)
        cell["per_phase"].append(b.frontier)
    for kind_table in per.values():
        for ctrl_table in kind_table.values():
            for cell in ctrl_table.values():
                values = np.array(cell["per_phase"])
                cell["min"] = float(values.min())
                cell["mean"] = round(float(values.mean()), 6)
    ratios: dict[str, dict] = {}
    ratio_summary: dict[str, dict] = {}
    if "nominal" in config.controllers:
        for kind, kind_table in per.items():
            nominal = kind_table["nominal"]
            for controller, ctrl_table in kind_table.items():
                if controller == "nominal":
                    continue
                name = f"{controller}/nominal"
                table: dict[str, dict[str, Any]] = {}
                for d, cell in ctrl_table.items():
                    base = nominal[d]
                    per_phase = [_ratio(a, b) for a, b in zip(cell["per_phase"], base["per_phase"])]
                    table[d] = {"min": _ratio(cell["min"], base["min"]), "mean": _ratio(cell["mean"], base["mean"]),
                                "per_phase": per_phase}
                ratios.setdefault(kind, {})[name] = table
                all_ratios = [r for cell in table.values() for r in cell["per_phase"] if r is not None]
                ratio_summary.setdefault(kind, {})[name] = {
                    "min_per_phase_ratio": min(all_ratios) if all_ratios else None,
                    "mean_of_mean_ratios": round(float(np.mean([c["mean"] for c in table.values() if c["mean"] is not None])), 4)
                    if any(c["mean"] is not None for c in table.values()) else None,
                    "at_least_2x_everywhere": bool(all_ratios) and min(all_ratios) >= 2.0
                    and len(all_ratios) == sum(len(c["per_phase"]) for c in table.values()),
                }
    return {
        "robot": config.robot,
        "sim": config.sim,
        "config": config.to_dict(),
        "pushed_step_window_s": list(config.pushed_step_window()),
        "resolution": {kind: config.resolution(kind) for kind in config.kinds},
        "units": {kind: UNITS[kind] for kind in config.kinds},
        "aggregate_over_phases": "min (the frontier at every phase) and mean",
        "complete": all(b.done for b in bisections.values()),
        "frontier": per,
        "ratios": ratios,
        "ratio_summary": ratio_summary,
        "entries": entries,
    }


# ---------------------------------------------------------------------------------------------
# Plots (matplotlib through robust_ismpc.plotting, the one module that imports it)
# ---------------------------------------------------------------------------------------------
def plot_frontiers(frontier: dict, out: Path) -> list[Path]:
    """Polar and per-phase frontier figures for every kind; returns the files written."""
    paths = []
    for kind in frontier["frontier"]:
        prefix = "frontier" if kind == "impulse" else "frontier_force"
        paths.append(plot_polar(frontier, kind, out / f"{prefix}_polar.png"))
        paths.append(plot_phase(frontier, kind, out / f"{prefix}_phase.png"))
    return paths


def _label(kind: str) -> str:
    return f"largest survived {kind} [{UNITS[kind]}]"


def plot_polar(frontier: dict, kind: str, path: Path) -> Path:
    """Polar frontier: per controller, radius = min over phases (solid) and mean over phases (dashed)."""
    from ..plotting import pyplot, save_figure

    plt = pyplot()
    table = frontier["frontier"][kind]
    fig = plt.figure(figsize=(6, 6))
    ax = fig.add_subplot(projection="polar")
    for controller, ctrl_table in table.items():
        dirs = sorted(ctrl_table, key=float)
        theta = np.radians([float(d) for d in dirs])
        low = np.array([ctrl_table[d]["min"] for d in dirs])
        mean = np.array([ctrl_table[d]["mean"] for d in dirs])
        if len(dirs) >= 3:
            theta, low, mean = (np.append(a, a[0]) for a in (theta, low, mean))
        (line,) = ax.plot(theta, low, "o-", lw=1.5, ms=4, label=controller)
        if len(table[controller][dirs[0]]["per_phase"]) > 1:
            ax.plot(theta, mean, "--", lw=0.9, color=line.get_color(), alpha=0.7)
    ax.set_theta_zero_location("E")
    ax.set_theta_direction(1)
    ax.set_title(f"{frontier['robot']} / {frontier['sim']}: {_label(kind)}\n(solid: min over phases, dashed: mean; "
                 "0° = forward, 90° = left)", fontsize=9)
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8)
    save_figure(fig, path)
    plt.close(fig)
    return Path(path)


def plot_phase(frontier: dict, kind: str, path: Path) -> Path:
    """Per-phase frontier: one panel per direction, one line per controller."""
    from ..plotting import pyplot, save_figure

    plt = pyplot()
    table = frontier["frontier"][kind]
    dirs = sorted(next(iter(table.values())), key=float)
    cols = min(4, len(dirs))
    rows = int(math.ceil(len(dirs) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.6 * rows), squeeze=False, sharey=True)
    for ax, d in zip(axes.flat, dirs):
        for controller, ctrl_table in table.items():
            cell = ctrl_table[d]
            ax.plot(cell["phases"], cell["per_phase"], "o-", ms=3, lw=1.2, label=controller)
        ax.set_title(f"direction {d}°", fontsize=9)
        ax.set_xlabel("phase of single support", fontsize=8)
        ax.set_xlim(-0.05, 1.0)
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(dirs):]:
        ax.set_visible(False)
    for ax in axes[:, 0]:
        ax.set_ylabel(f"{kind} [{UNITS[kind]}]", fontsize=8)
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(f"{frontier['robot']} / {frontier['sim']}: {_label(kind)} per gait phase", fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
    return Path(path)


# ---------------------------------------------------------------------------------------------
# Report
# ---------------------------------------------------------------------------------------------
def _fmt(value: float | None, digits: int = 3) -> str:
    return "-" if value is None else f"{value:.{digits}g}"


def frontier_table(frontier: dict, kind: str = "impulse") -> str:
    """Markdown table: per direction, each controller's min/mean over phases and ratios to nominal."""
    table = frontier["frontier"].get(kind)
    if not table:
        return ""
    controllers = list(table)
    dirs = sorted(next(iter(table.values())), key=float)
    ratio_names = list(frontier["ratios"].get(kind, {}))
    head = ["direction [deg]"] + [f"{c} min / mean" for c in controllers] + [f"{r} (min / mean)" for r in ratio_names]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for d in dirs:
        cells = [d] + [f"{_fmt(table[c][d]['min'])} / {_fmt(table[c][d]['mean'])}" for c in controllers]
        for r in ratio_names:
            cell = frontier["ratios"][kind][r][d]
            cells.append(f"{_fmt(cell['min'])} / {_fmt(cell['mean'])}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _versions() -> dict:
    from importlib import metadata

    from .bench import versions

    out = versions()
    for pkg in ("matplotlib", "ray"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            pass
    return out


def format_report(
    config: SweepConfig,
    frontier: dict,
    result: SweepResult,
    rows: Iterable[dict],
    command_line: str | None = None,
    backend: str = "local",
    workers: int = 1,
    started_at: datetime | None = None,
    code: dict | None = None,
    previous_code: dict | None = None,
) -> str:
    """``report.md``: command line, machine, versions, code, seeds, timing, frontier tables."""
    from .bench import machine

    rows = list(rows)
    trial_wall = sum(float(r["wall_time_s"]) for r in rows if r.get("wall_time_s"))
    survived = sum(r["survived"] == "1" for r in rows)
    errors = sum(r["failure"].startswith("error:") for r in rows)
    start, T_ss = frontier["pushed_step_window_s"]
    md = io.StringIO()
    md.write(f"# Push-recovery sweep: {config.robot} on {config.sim}"
             + (f" ({config.whole_body} whole-body control)" if config.sim == "mujoco" else "") + "\n\n")
    md.write(f"Command: `{command_line or '(Python API)'}`\n\n")
    if started_at is not None:
        md.write(f"Started: {started_at.isoformat(timespec='seconds')}\n\n")
    md.write("## Setup\n\n")
    md.write(f"- controllers: {', '.join(config.controllers)}\n")
    md.write(f"- directions [deg] (0 = forward +x, 90 = left +y): {', '.join(f'{d:g}' for d in config.directions_deg)}\n")
    md.write(f"- phases (fraction of the single support of regular step {config.pushed_step}, which runs from "
             f"{start:.3g} s for {T_ss:.3g} s): {', '.join(f'{p:g}' for p in config.phases)}\n")
    md.write(f"- impulse: bisection in [0, {config.impulse_max_ns:g}] N s, applied as a constant force over "
             f"{config.push_duration_s:g} s; resolution {config.resolution('impulse'):.4g} N s "
             f"(1 trial at the maximum + {config.iterations} bisection trials)\n")
    if config.force_max_n is not None:
        md.write(f"- constant force: bisection in [0, {config.force_max_n:g}] N from the push instant to the end; "
                 f"resolution {config.resolution('force'):.4g} N\n")
    md.write(f"- walk: vx = {config.vx_mps:g} m/s; each trial runs until {config.post_push_s:g} s after the push starts\n")
    md.write("- failure: a fall, diverged CoM or persistent infeasible QP (`summary[\"fell\"]`)\n")
    md.write(f"- seeds: base seed {config.seed}; trial seed = first 31 bits of sha256(\"seed|controller|direction|"
             f"phase|kind|magnitude\") (column `seed` of runs.csv)\n\n")
    md.write("## Execution\n\n")
    md.write(f"- backend: {backend}, {workers} worker(s)\n")
    md.write(f"- trials in runs.csv: {result.trials_total} ({survived} survived, {errors} errors); "
             f"run by this invocation: {result.trials_new}; resumed from an earlier one: {result.trials_resumed}\n")
    md.write(f"- wall time of this invocation: {result.wall_time_s:.1f} s "
             f"({result.runs_per_s:.2f} runs/s); sum of trial wall times: {trial_wall:.1f} s\n")
    if hasattr(os, "getloadavg"):
        md.write(f"- load average at the end (1, 5, 15 min; other processes slow the trials down): "
                 f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}\n")
    md.write(f"- complete: {'yes' if frontier['complete'] else 'no (interrupted; rerun the command to resume)'}\n\n")
    md.write("Machine: " + json.dumps(machine()) + "\n\n")
    md.write("Versions: " + json.dumps(_versions()) + "\n\n")
    if code is not None:
        md.write(f"Code: robust-ismpc {code['version']}, sources sha256 {code['sources_sha256']}")
        if previous_code is not None and previous_code != code:
            md.write(f" (the sweep was started with sources {previous_code.get('sources_sha256')}: "
                     "runs.csv mixes trials of both)")
        md.write("\n\n")
    for kind in frontier["frontier"]:
        md.write(f"## Largest survived {kind} [{UNITS[kind]}]\n\n")
        md.write("Per direction, the frontier's minimum and mean over phases; ratios to nominal of those "
                 "(`-`: the nominal frontier is below the resolution).\n\n")
        md.write(frontier_table(frontier, kind) + "\n\n")
        for name, s in frontier["ratio_summary"].get(kind, {}).items():
            md.write(f"- {name}: smallest per-phase ratio {_fmt(s['min_per_phase_ratio'])}, mean of the per-direction "
                     f"mean ratios {_fmt(s['mean_of_mean_ratios'])}; >= 2x at every direction and phase: "
                     f"{'yes' if s['at_least_2x_everywhere'] else 'no'}\n")
        prefix = "frontier" if kind == "impulse" else "frontier_force"
        md.write(f"\n![polar]({prefix}_polar.png)\n\n![per phase]({prefix}_phase.png)\n\n")
    md.write(f"Python {platform.python_version()}; files: sweep.json, runs.csv, frontier.json, report.md, plots.\n")
    return md.getvalue()


__all__ = [
    "Bisection", "COLUMNS", "DEFAULT_POST_PUSH_S", "SweepConfig", "SweepProgress", "SweepResult", "TaskKey", "Trial", "TrialResult",
    "bisect", "format_report", "frontier_summary", "frontier_table", "make_backend",
    "parse_directions", "parse_phases", "plot_frontiers", "read_runs", "run_sweep",
    "run_trial", "trial_seed",
]
