"""One closed-loop run described as data: build the plan and controller, simulate, summarise.

This is the Python API behind ``ismpc run``; it returns results and writes nothing.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from .controller import IsmpcController
from .exceptions import ParameterError
from .forces import ForceWindow
from .inputs import gait_params, robot_reference
from .lip_sim import INTERRUPTED, RunOutcome, run_lip
from .params import MpcParams, RobotParams, mpc_params_for
from .planner import WalkCommand, plan_footsteps
from .report import summarize
from .trace import Trace, TraceRecorder

MODULES = ("observer", "restriction", "timing")
SIMS = ("lip", "mujoco")
#: Whole-body control on MuJoCo: position servos playing back the IK, or inverse-dynamics torques.
WHOLE_BODY_CONTROLS = ("servo", "torque")


def resolve_whole_body(owner: str, whole_body, sim: str = "mujoco") -> str:
    """The whole-body control of a run: ``whole_body`` checked, or for None the default,
    ``torque`` on MuJoCo (``servo`` on the LIP, which has no joints).

    Raises
    ------
    ParameterError
        ``whole_body`` is not None or one of :data:`WHOLE_BODY_CONTROLS`, or it is ``torque``
        on the LIP.
    """
    if whole_body is None:
        return "torque" if sim == "mujoco" else "servo"
    if whole_body not in WHOLE_BODY_CONTROLS:
        raise ParameterError(
            f"{owner}.whole_body must be one of {', '.join(WHOLE_BODY_CONTROLS)} (whole-body control), "
            f"got {whole_body!r}"
        )
    if whole_body != "servo" and sim != "mujoco":
        raise ParameterError(
            f"{owner}: whole-body control {whole_body!r} needs the mujoco simulator (the LIP has no joints)"
        )
    return whole_body


def parse_modules(controller: str, modules: str | None = None) -> tuple[str, ...]:
    """Module list from ``--controller nominal|robust`` and an optional ``--modules a,b``."""
    if modules is not None:
        names = tuple(m.strip() for m in modules.split(",") if m.strip())
        unknown = [m for m in names if m not in MODULES]
        if unknown:
            raise ParameterError(
                f"unknown module {unknown[0]!r}; modules are: {', '.join(MODULES)}"
            )
        return tuple(m for m in MODULES if m in names)
    if controller == "nominal":
        return ()
    if controller == "robust":
        return MODULES
    raise ParameterError(f"unknown controller {controller!r}; use nominal or robust (or --modules)")


@dataclass(frozen=True)
class RunSpec:
    """A closed-loop run.

    Attributes
    ----------
    robot : str
        Built-in robot name, or the path of a robot file (``.toml``, docs/robots.md; kept as an
        absolute path). On the LIP a file's reduced model is measured from its MuJoCo model.
    sim : str
        ``lip`` or ``mujoco``.
    modules : tuple of str
        Robustness modules switched on (subset of observer, restriction, timing).
    command : WalkCommand
        Velocity command.
    duration_s : float
        Simulated time [s].
    forces : tuple of ForceWindow
        External forces [N] (constant, windowed and pushes alike).
    seed : int
        Seed of every random choice in the run.
    delta_max_mps2 : float or None
        Deviation bound Δmax for the restriction [m/s²] (None: module default).
    mpc : MpcParams or None
        MPC settings; None: :func:`~robust_ismpc.params.mpc_params_for` the robot (the defaults,
        with a control horizon of at least one step).
    whole_body : str or None
        MuJoCo only: ``torque`` (an inverse-dynamics QP drives torque motors,
        :mod:`robust_ismpc.sim.inverse_dynamics`; the default) or ``servo`` (the model's
        position servos play back the whole-body IK). None is resolved to the default.
    """

    robot: str = "g1"
    sim: str = "lip"
    modules: tuple[str, ...] = ()
    command: WalkCommand = field(default_factory=lambda: WalkCommand(0.2, 0.0, 0.0))
    duration_s: float = 10.0
    forces: tuple[ForceWindow, ...] = ()
    seed: int = 0
    delta_max_mps2: float | None = None
    mpc: MpcParams | None = None
    whole_body: str | None = None

    def __post_init__(self) -> None:
        if self.sim not in SIMS:
            raise ParameterError(f"unknown simulator {self.sim!r}; use one of: {', '.join(SIMS)}")
        object.__setattr__(self, "whole_body", resolve_whole_body("RunSpec", self.whole_body, self.sim))
        if not isinstance(self.robot, str) or not self.robot:
            raise ParameterError(f"robot must be a built-in robot name or a robot file path, got {self.robot!r}")
        object.__setattr__(self, "robot", robot_reference(self.robot))
        params = gait_params(self.robot, self.sim)  # validates the name or the file
        if self.mpc is None:
            object.__setattr__(self, "mpc", mpc_params_for(params))
        if not (isinstance(self.duration_s, (int, float)) and math.isfinite(self.duration_s) and self.duration_s > 0):
            raise ParameterError(f"duration must be a finite number of seconds > 0, got {self.duration_s!r}")
        for m in self.modules:
            if m not in MODULES:
                raise ParameterError(f"unknown module {m!r}; modules are: {', '.join(MODULES)}")
        if not isinstance(self.seed, int) or self.seed < 0:
            raise ParameterError(f"seed must be an integer >= 0, got {self.seed!r}")
        if self.delta_max_mps2 is not None and not (
            math.isfinite(self.delta_max_mps2) and self.delta_max_mps2 >= 0
        ):
            raise ParameterError(f"delta max must be a finite number >= 0 m/s², got {self.delta_max_mps2!r}")

    @property
    def controller_label(self) -> str:
        if not self.modules:
            return "nominal"
        if set(self.modules) == set(MODULES):
            return "robust"
        return "+".join(self.modules)


@dataclass(frozen=True)
class RunResult:
    """Summary (the ``summary.json`` content) and trace of a run."""

    summary: dict
    trace: Trace


def make_controller(robot: RobotParams, spec: RunSpec, **controller_options) -> IsmpcController:
    """The controller for ``spec``: nominal IS-MPC plus the requested modules.

    ``controller_options`` go to the controller (``estimator``, and for the robust one
    ``params``).
    """
    if not spec.modules:
        return IsmpcController(robot, spec.mpc, **controller_options)
    from .robust import RobustIsmpcController

    return RobustIsmpcController(
        robot, spec.mpc, modules=spec.modules, delta_max_mps2=spec.delta_max_mps2,
        **controller_options,
    )


def run_meta(spec: RunSpec, robot: RobotParams) -> dict:
    """Metadata stored with a trace."""
    return {
        "robot": spec.robot,
        "robot_name": robot.name,
        "sim": spec.sim,
        "controller": spec.controller_label,
        "modules": list(spec.modules),
        "seed": spec.seed,
        "command": {"vx_mps": spec.command.vx_mps, "vy_mps": spec.command.vy_mps,
                    "omega_radps": spec.command.omega_radps},
        "forces": [
            {"fx_n": f.fx_n, "fy_n": f.fy_n, "t_start_s": f.t_start_s,
             "t_end_s": None if math.isinf(f.t_end_s) else f.t_end_s}
            for f in spec.forces
        ],
        "delta_max_mps2": spec.delta_max_mps2,
        "whole_body": spec.whole_body,
        "zmp_box_x_m": robot.zmp_box_x_m,
        "zmp_box_y_m": robot.zmp_box_y_m,
        "sole_length_m": robot.sole_length_m,
        "sole_width_m": robot.sole_width_m,
        "mass_kg": robot.mass_kg,
        "com_height_m": robot.com_height_m,
    }


def run(spec: RunSpec, progress=None, video_path=None, viewer: bool = False) -> RunResult:
    """Run ``spec`` and return its summary and trace.

    Parameters
    ----------
    spec : RunSpec
    progress : callable, optional
        ``progress(t_s)`` called about once per simulated second. If it raises
        ``KeyboardInterrupt`` (as on Ctrl-C), the run stops there and returns what ran, with
        failure ``"interrupted"``.
    video_path : path, optional
        MuJoCo only: write an mp4 of the run there.
    viewer : bool
        MuJoCo only: show the run in MuJoCo's interactive viewer (needs a display).
    """
    if spec.sim == "mujoco":
        from .sim.run import run_mujoco_spec

        return run_mujoco_spec(spec, progress=progress, video_path=video_path, viewer=viewer)
    if video_path is not None or viewer:
        raise ParameterError("--video and --viewer need --sim mujoco (the LIP has nothing to show)")
    robot = gait_params(spec.robot, "lip")
    controller = make_controller(robot, spec)
    left = np.array([0.0, 0.5 * robot.foot_spacing_m])
    plan = plan_footsteps(robot, spec.command, controller.plan_duration_s(spec.duration_s), left, -left)
    controller.reset(plan, np.zeros(2))
    start = time.perf_counter()
    recorder = TraceRecorder(int(spec.duration_s / controller.dt) + 2)
    try:
        outcome, recorder = run_lip(controller, spec.duration_s, spec.forces, recorder=recorder, progress=progress)
    except KeyboardInterrupt:  # from progress, between ticks: keep the ticks recorded so far
        t = recorder.last_time_s()
        outcome = RunOutcome(fell=False, failure=INTERRUPTED, duration_s=0.0 if t is None else t + controller.dt)
    wall = time.perf_counter() - start
    meta = run_meta(spec, robot)
    meta["fell"] = outcome.fell
    meta["timing_adaptations"] = getattr(controller, "timing_adaptations", 0)
    trace = recorder.finish(controller.plan, meta)
    summary = summarize(trace, outcome.fell, outcome.failure, outcome.duration_s, wall)
    return RunResult(summary=summary, trace=trace)
