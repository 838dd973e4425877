"""A closed-loop run described as data (:class:`RunSpec`), its result, and the gait it uses.

:func:`robust_ismpc.runs.run.run` executes a spec.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..control.modules import check_modules, controller_label
from ..core.params import MpcParams, RobotParams, mpc_params_for
from ..core.planner import WalkCommand
from ..exceptions import ParameterError
from ..extras import require_extra
from ..robots import BUILTIN_ROBOTS, is_robot_file, robot_reference
from ..robots.mismatch import NO_MISMATCH, ModelMismatch
from ..robots.sensing import sensing_preset
from .forces import ForceWindow
from .trace import Trace

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
        MPC settings; None: :func:`~robust_ismpc.core.params.mpc_params_for` the robot (the defaults,
        with a control horizon of at least one step).
    sensing : str
        Sensor model between the simulator's true state and the controller
        (:data:`~robust_ismpc.robots.sensing.SENSING_PRESETS`: ``ideal``, the default, or
        ``realistic``); its noise is drawn from ``seed``.
    mismatch : ModelMismatch
        MuJoCo only: how the simulated robot differs from the controller's model (masses, a
        payload, motors; :mod:`robust_ismpc.robots.mismatch`). None by default.
    whole_body : str or None
        MuJoCo only: ``torque`` (an inverse-dynamics QP drives torque motors,
        :mod:`robust_ismpc.sim.whole_body.inverse_dynamics`; the default) or ``servo`` (the model's
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
    sensing: str = "ideal"
    mismatch: ModelMismatch = NO_MISMATCH

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
        object.__setattr__(self, "modules", check_modules(self.modules))
        sensing_preset(self.sensing)  # validates the name
        if not isinstance(self.mismatch, ModelMismatch):
            raise ParameterError(f"mismatch must be a ModelMismatch, got {type(self.mismatch).__name__}")
        if self.sim != "mujoco" and not self.mismatch.is_none:
            raise ParameterError("a model mismatch (--mismatch) needs --sim mujoco: the reduced model has no "
                                 "masses or motors to change")
        if not isinstance(self.seed, int) or self.seed < 0:
            raise ParameterError(f"seed must be an integer >= 0, got {self.seed!r}")
        if self.delta_max_mps2 is not None and not (
            math.isfinite(self.delta_max_mps2) and self.delta_max_mps2 >= 0
        ):
            raise ParameterError(f"delta max must be a finite number >= 0 m/s², got {self.delta_max_mps2!r}")

    @property
    def controller_label(self) -> str:
        """``nominal``, ``robust`` or the modules joined by ``+``."""
        return controller_label(self.modules)


@dataclass(frozen=True)
class RunResult:
    """Summary (the ``summary.json`` content) and trace of a run."""

    summary: dict
    trace: Trace


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
        "sensing": sensing_preset(spec.sensing).as_dict(),
        "mismatch": spec.mismatch.as_dict(),
        "zmp_box_x_m": robot.zmp_box_x_m,
        "zmp_box_y_m": robot.zmp_box_y_m,
        "sole_length_m": robot.sole_length_m,
        "sole_width_m": robot.sole_width_m,
        "mass_kg": robot.mass_kg,
        "com_height_m": robot.com_height_m,
    }


def gait_params(robot: str, sim: str):
    """The gait parameters (:class:`~robust_ismpc.core.params.RobotParams`) that a run of ``robot`` on
    ``sim`` uses: a robot file's (measured from its model, on either simulator), a built-in
    robot's file on MuJoCo, on the LIP its reduced model if it has one (hrp4, nao, g1, op3),
    else its file's.

    Raises
    ------
    ParameterError
        Unknown name (the message lists the robots), an invalid robot file, or a file without
        the ``sim`` extra (mujoco measures its model).
    ModelError
        The file's model is missing or does not match the file.
    """
    from ..core.params import ROBOT_DEFAULTS, robot_params

    if sim == "mujoco" or is_robot_file(robot) or (robot in BUILTIN_ROBOTS and robot not in ROBOT_DEFAULTS):
        require_extra("sim", f"robot {robot}" if is_robot_file(robot) else "--sim mujoco")
        from ..sim.model import load_robot

        return load_robot(robot).params()
    if robot not in ROBOT_DEFAULTS:
        raise ParameterError(f"unknown robot {robot!r}; built-in robots are: "
                             f"{', '.join(sorted(set(ROBOT_DEFAULTS) | set(BUILTIN_ROBOTS)))} "
                             "(or the path of a robot file, .toml)")
    return robot_params(robot)
