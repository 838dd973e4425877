"""What a sweep measures: parsing of the user's lists, :class:`SweepConfig`, file names and columns."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from ...control.modules import parse_controllers
from ...exceptions import ParameterError
from ...validation import check_positive
from .bisection import check_repeats
from .trials import TaskKey

SIMS = ("lip", "mujoco")
KINDS = ("impulse", "force")
UNITS = {"impulse": "N s", "force": "N"}
BACKENDS = ("local", "ray")
SWEEP_FORMAT = 2  # 2: repeats per magnitude; trial seeds shared by the controllers
#: Trials per magnitude under a noisy sensing preset (:attr:`SweepConfig.repeats`).
NOISY_REPEATS = 3

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
    sensing : str
        What the controllers read (:attr:`~robust_ismpc.runs.spec.RunSpec.sensing`; ``ideal`` by
        default); every trial draws its noise from its own seed.
    repeats : int or None
        Most trials per magnitude, odd; a magnitude is held when most of them survive
        (:class:`~robust_ismpc.experiments.sweep.bisection.Bisection`). None: 1 under ideal
        sensing, whose runs are deterministic, and :data:`NOISY_REPEATS` under a noisy preset,
        where one trial's outcome depends on its noise draw.
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
    sensing: str = "ideal"
    repeats: int | None = None

    def __post_init__(self) -> None:
        owner = "SweepConfig"
        from ...robots import robot_reference
        from ...runs.spec import gait_params

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
        from ...runs.spec import resolve_whole_body

        object.__setattr__(self, "whole_body", resolve_whole_body(owner, self.whole_body, self.sim))
        from ...robots.sensing import sensing_preset

        ideal = sensing_preset(self.sensing).is_ideal  # validates the name
        if self.repeats is None:
            object.__setattr__(self, "repeats", 1 if ideal else NOISY_REPEATS)
        repeats = check_repeats(owner, self.repeats)
        if ideal and repeats > 1:
            raise ParameterError(f"{owner}.repeats must be 1 under ideal sensing (its runs are deterministic: every "
                                 f"repeat would end as the first), got {repeats}")

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
        return len(self.tasks()) * (1 + self.iterations) * int(self.repeats or 1)

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
        from ...runs.spec import gait_params

        return gait_params(self.robot, self.sim)

    def pushed_step_window(self) -> tuple[float, float]:
        """Start and duration of the pushed step's single support [s].

        From the footstep plan that :func:`robust_ismpc.runs.run.run` builds for the walk command:
        regular step k (1-based) is step index ``k + 1`` of the plan.
        """
        from ...control.walk import lip_start_soles
        from ...core.planner import WalkCommand, plan_footsteps

        robot = self.gait_params()
        j = self.pushed_step + 1
        horizon = (j + 4) * robot.T_step_s + 4.0 * robot.T_step_s
        plan = plan_footsteps(robot, WalkCommand(self.vx_mps, 0.0, 0.0), horizon, *lip_start_soles(robot))
        return float(plan.ss_start_s[j]), float(plan.T_ss_s[j])

    def push_start_s(self, phase: float) -> float:
        """Time at which a push at ``phase`` starts [s]."""
        start, T_ss = self.pushed_step_window()
        return start + phase * T_ss
