"""Long-run soak: a continuous walk with random pushes inside the robust envelope.

The pushes are drawn from an explicit ``np.random.Generator`` seeded by the caller, so a soak
replays exactly. Resident memory is sampled during the run to show that it does not grow beyond
the recorded trace.
"""

from __future__ import annotations

import math
import resource
import time
from dataclasses import dataclass

import numpy as np

from ..control.modules import MODULES
from ..core.params import RobotParams
from ..core.planner import WalkCommand
from ..exceptions import ParameterError
from ..runs.forces import ForceWindow
from ..runs.run import run
from ..runs.spec import RunSpec, gait_params

#: Default forward speed of a soak per simulator [m/s].
DEFAULT_VX_MPS = {"lip": 0.2, "mujoco": 0.1}
#: Duration of a soak push [s].
PUSH_DURATION_S = 0.1


@dataclass(frozen=True)
class SoakSpec:
    """A soak run.

    Attributes
    ----------
    robot, sim : str
        Robot and simulator.
    duration_s : float
        Simulated time [s].
    push_max_n : float or None
        Largest push force [N] (pushes of :data:`PUSH_DURATION_S`); None:
        :func:`default_push_max_n` of the robot.
    push_interval_s : tuple of float
        Range of the time between pushes [s].
    vx_mps : float or None
        Forward speed command [m/s]; None: :data:`DEFAULT_VX_MPS` of the simulator.
    seed : int
    modules : tuple of str
        Controller modules (default: all three, the robust controller).
    whole_body : str
        MuJoCo only: ``torque`` or ``servo`` (:attr:`~robust_ismpc.runs.spec.RunSpec.whole_body`);
        None is resolved to the default.
    sensing : str
        What the controller reads (:attr:`~robust_ismpc.runs.spec.RunSpec.sensing`; ``ideal`` by
        default).
    """

    robot: str = "g1"
    sim: str = "lip"
    duration_s: float = 600.0
    push_max_n: float | None = None
    push_interval_s: tuple[float, float] = (2.0, 4.0)
    vx_mps: float | None = None
    seed: int = 0
    modules: tuple[str, ...] = MODULES
    whole_body: str | None = None
    sensing: str = "ideal"

    def __post_init__(self) -> None:
        run = RunSpec(robot=self.robot, sim=self.sim, whole_body=self.whole_body, sensing=self.sensing)  # validates
        object.__setattr__(self, "robot", run.robot)
        object.__setattr__(self, "whole_body", run.whole_body)
        if not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise ParameterError(f"soak duration must be > 0 s, got {self.duration_s!r}")
        lo, hi = self.push_interval_s
        if not (0 < lo <= hi):
            raise ParameterError(f"push interval must satisfy 0 < min <= max, got {self.push_interval_s!r}")
        if self.vx_mps is None:
            object.__setattr__(self, "vx_mps", DEFAULT_VX_MPS.get(self.sim, 0.2))
        if not (isinstance(self.vx_mps, (int, float)) and math.isfinite(self.vx_mps)):
            raise ParameterError(f"soak forward speed must be a finite number of m/s, got {self.vx_mps!r}")
        if self.push_max_n is not None and not (math.isfinite(self.push_max_n) and self.push_max_n >= 0):
            raise ParameterError(f"push_max_n must be a finite number >= 0, got {self.push_max_n!r}")


def default_push_max_n(params: RobotParams) -> float:
    """The largest push of a soak when none is given [N]: the push of :data:`PUSH_DURATION_S`
    whose impulse J moves the DCM by half the sole's width, J/(m η) = w/2. Such a push leaves a
    standing robot's capture point on its sole, where its ankles alone can hold it; walking, the
    controller must hold it at any phase and in any direction. 33 N on the G1 (3.3 N s), 0.44 of
    its smallest push frontier in MuJoCo and 0.82 of its smallest on the reduced model
    (docs/sweeps.md); 6.9 N on the OP3."""
    return params.mass_kg * params.eta * 0.5 * params.sole_width_m / PUSH_DURATION_S


def random_pushes(spec: SoakSpec, rng: np.random.Generator) -> tuple[ForceWindow, ...]:
    """Pushes of :data:`PUSH_DURATION_S`, of random direction and magnitude, at random
    intervals, after 5 s of walking."""
    params = gait_params(spec.robot, "lip")
    push_max = spec.push_max_n if spec.push_max_n is not None else default_push_max_n(params)
    pushes = []
    t = 5.0 + rng.uniform(*spec.push_interval_s)
    while t < spec.duration_s - 3.0:
        angle = rng.uniform(0.0, 2 * math.pi)
        magnitude = rng.uniform(0.0, push_max)
        pushes.append(ForceWindow(magnitude * math.cos(angle), magnitude * math.sin(angle), t, t + PUSH_DURATION_S))
        t += rng.uniform(*spec.push_interval_s)
    return tuple(pushes)


def _rss_mb() -> float:
    try:
        with open("/proc/self/statm") as handle:
            pages = int(handle.read().split()[1])
        return pages * resource.getpagesize() / 2**20
    except OSError:  # not Linux: peak RSS
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def run_soak(spec: SoakSpec, progress=None) -> tuple[dict, object]:
    """Run the soak; returns (report dict, RunResult)."""
    rng = np.random.default_rng(spec.seed)
    pushes = random_pushes(spec, rng)
    samples = [(0.0, _rss_mb())]

    def on_progress(t_s: float) -> None:
        if int(t_s) % 60 == 0:
            samples.append((t_s, _rss_mb()))
        if progress is not None:
            progress(t_s)

    run_spec = RunSpec(robot=spec.robot, sim=spec.sim, modules=tuple(spec.modules), command=WalkCommand(spec.vx_mps),
                       duration_s=spec.duration_s, forces=pushes, seed=spec.seed, whole_body=spec.whole_body,
                       sensing=spec.sensing)
    start = time.perf_counter()
    result = run(run_spec, progress=on_progress)
    wall = time.perf_counter() - start
    samples.append((result.summary["duration_s"], _rss_mb()))
    summary = result.summary
    report = {
        "robot": spec.robot,
        "sim": spec.sim,
        "whole_body": spec.whole_body,
        "sensing": spec.sensing,
        "seed": spec.seed,
        "vx_mps": spec.vx_mps,
        "modules": list(spec.modules),
        "simulated_s": summary["duration_s"],
        "wall_s": round(wall, 1),
        "pushes": len(pushes),
        "push_max_n": max((math.hypot(p.fx_n, p.fy_n) for p in pushes), default=0.0),
        "fell": summary["fell"],
        "failure": summary["failure"],
        "qp_infeasible_count": summary["qp_infeasible_count"],
        "timing_adaptations": summary["timing_adaptations"],
        "rss_mb": [{"t_s": round(t, 1), "rss_mb": round(m, 1)} for t, m in samples],
        "trace_mb": round(sum(v.nbytes for v in result.trace.channels.values()) / 2**20, 1),
        "cycle_ms": summary["cycle_ms"],
    }
    return report, result
