"""Argument parser of the ``ismpc`` command line (:mod:`robust_ismpc.cli` runs the commands).

Argument types check single values (a finite number, a bounded duration); checks across flags
are in :mod:`robust_ismpc.cli.inputs`.
"""

from __future__ import annotations

import argparse
import math
import re
import sys

from ..robots.sensing import SENSING_PRESETS
from .inputs import MAX_SIM_DURATION_S

EPILOG_FORCES = """force syntax:
  --force FX,FY            constant force [N] on the CoM (LIP) / torso (MuJoCo) for the whole run
  --force FX,FY@T0:T1      force active from T0 to T1 [s] (T1 empty = until the end)
  --push  FX,FY@T:DUR      push of FX,FY [N] starting at T lasting DUR [s]
  negative values as written: --force -45,0@3: --push -20,0@2:0.1
"""

#: A command-line word that is a value starting with a minus sign (``-45,0@3:``, ``-.5``,
#: ``-90,90``), not a flag.
_NEGATIVE_VALUE = re.compile(r"^-\.?\d")


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line and exit status 2, and whose flags that take one
    value accept a value that starts with a minus sign (``--force -45,0@3:``).

    argparse takes a word starting with ``-`` for a flag unless it is a plain negative number
    (``-0.1``), so ``--force -45,0@3:`` failed with "expected one argument" where
    ``--force=-45,0@3:`` worked. Before parsing, such a word that follows a flag taking one value
    is joined to it with ``=``.
    """

    def __init__(self, *args, **kwargs) -> None:
        self._value_flags: set[str] = set()  # before argparse adds its own flags
        super().__init__(*args, **kwargs)

    def add_argument(self, *args, **kwargs):
        action = super().add_argument(*args, **kwargs)
        if action.option_strings and action.nargs is None:  # a flag taking exactly one value
            self._value_flags.update(action.option_strings)
        return action

    def parse_known_args(self, args=None, namespace=None):  # type: ignore[override]
        words = list(sys.argv[1:] if args is None else args)
        joined: list[str] = []
        for word in words:
            if joined and joined[-1] in self._value_flags and _NEGATIVE_VALUE.match(word):
                joined[-1] = f"{joined[-1]}={word}"
            else:
                joined.append(word)
        return super().parse_known_args(joined, namespace)

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write(f"{self.prog}: error: {message} (see {self.prog} --help)\n")
        sys.exit(2)


def _positive_float(name: str, most: float | None = None, unit: str = "s"):
    """A finite number > 0, at most ``most`` (named in the message: the documented bound)."""

    def convert(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number, got {text!r}") from None
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"{name} must be a finite number > 0, got {text!r}")
        if most is not None and value > most:
            raise argparse.ArgumentTypeError(
                f"{name} must be at most {most:g} {unit} (one run keeps its trace in memory; split longer "
                f"walks into several runs), got {text!r}")
        return value

    return convert


def _duration():
    return _positive_float("duration", MAX_SIM_DURATION_S)


def _finite_float(name: str):
    def convert(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number, got {text!r}") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{name} must be finite, got {text!r}")
        return value

    return convert


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"seed must be an integer >= 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"seed must be an integer >= 0, got {text!r}")
    return value


def robot_help(mujoco_only: bool = False) -> str:
    """Help text of ``--robot``: the built-in robots and the robot-file alternative."""
    from ..core.params import ROBOT_DEFAULTS
    from ..robots import BUILTIN_ROBOTS

    files = "or the path of a robot file (.toml, docs/robots.md)"
    if mujoco_only:
        return f"built-in robot ({', '.join(BUILTIN_ROBOTS)}) {files}; default g1"
    lip = sorted(set(ROBOT_DEFAULTS) | set(BUILTIN_ROBOTS))
    return (f"built-in robot (lip: {', '.join(lip)}; mujoco: {', '.join(BUILTIN_ROBOTS)}) "
            f"{files}; default g1")


def _add_sensing_argument(p: argparse.ArgumentParser) -> None:
    """``--sensing``: the sensor model of the runs (:data:`~robust_ismpc.robots.sensing.SENSING_PRESETS`)."""
    p.add_argument("--sensing", default="ideal", choices=tuple(SENSING_PRESETS),
                   help="what the controller reads: ideal (the simulator's true state, the default) or realistic "
                        "(noise, bias and 10 ms latency; see docs/closed-loop.md)")


def _add_output_arguments(p: argparse.ArgumentParser, what: str = "output directory",
                          overwrite_help: str = "allow writing into an existing non-empty --out") -> None:
    """``--out`` (required; ``what`` is its help) and ``--overwrite``."""
    p.add_argument("--out", required=True, help=what)
    p.add_argument("--overwrite", action="store_true", help=overwrite_help)


def _add_run_arguments(p: argparse.ArgumentParser, with_controller: bool = True) -> None:
    p.add_argument("--sim", default="lip", help="simulator: lip (reduced model) or mujoco (full robot); default lip")
    p.add_argument("--robot", default="g1", help=robot_help())
    if with_controller:
        p.add_argument("--controller", default="nominal",
                       help="nominal (IS-MPC) or robust (observer + restriction + timing); default nominal")
        p.add_argument("--modules", default=None,
                       help="comma-separated subset of observer,restriction,timing (overrides --controller)")
    p.add_argument("--vx", type=_finite_float("vx"), default=0.2, help="forward velocity command [m/s] (0.2)")
    p.add_argument("--vy", type=_finite_float("vy"), default=0.0, help="lateral velocity command [m/s] (0)")
    p.add_argument("--omega", type=_finite_float("omega"), default=0.0, help="turning rate command [rad/s] (0)")
    p.add_argument("--duration", type=_duration(), default=10.0,
                   help=f"simulated time [s] (10; at most {MAX_SIM_DURATION_S:g})")
    p.add_argument("--force", action="append", default=[], metavar="FX,FY[@T0:T1]",
                   help="external force [N], repeatable (see below)")
    p.add_argument("--push", action="append", default=[], metavar="FX,FY@T:DUR",
                   help="impulsive push [N] for DUR seconds, repeatable")
    p.add_argument("--delta-max", type=_finite_float("delta-max"), default=None,
                   help="deviation bound Δmax for the ZMP restriction [m/s²] (default: module default)")
    p.add_argument("--seed", type=_seed, default=0, help="random seed (0; also of the sensor noise)")
    _add_sensing_argument(p)
    p.add_argument("--mismatch", action="append", default=[], metavar="KEY=VALUE",
                   help="mujoco only, repeatable: the simulated robot differs from the controller's model: "
                        "mass=FACTOR (every link), payload=KG[@X,Y,Z] (fixed to the torso, offset from its "
                        "origin [m]), motor=FACTOR (every motor's torque); see docs/closed-loop.md")
    _add_output_arguments(p, "output directory (summary.json, gait.png, trace.npz)")
    p.add_argument("--video", action="store_true",
                   help="mujoco only: also write an mp4 (offscreen rendering) with time, controller and push arrows")
    if with_controller:
        p.add_argument("--viewer", action="store_true",
                       help="mujoco only: watch the run in MuJoCo's interactive viewer (needs a display)")
    p.add_argument("--whole-body", default=None, choices=("servo", "torque"),
                   help="mujoco only: torque (an inverse-dynamics QP drives the joints; the default) or servo "
                        "(position servos play back the whole-body IK; see docs/robots.md)")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="ismpc",
        description="Robust IS-MPC gait generation: run humanoid walks on a LIP or in MuJoCo, compare "
        "nominal and robust controllers, benchmark the MPC.",
    )
    parser.add_argument("--verbose", action="store_true", help="log controller warnings")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser)

    p_run = sub.add_parser(
        "run", help="one closed-loop walk", epilog=EPILOG_FORCES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Run one closed-loop walk and write OUT/summary.json, OUT/gait.png and OUT/trace.npz.",
    )
    _add_run_arguments(p_run)

    p_cmp = sub.add_parser(
        "compare", help="nominal vs robust on the same disturbances", epilog=EPILOG_FORCES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Run the nominal and the robust controller on identical disturbances and write "
        "OUT/nominal/, OUT/robust/, OUT/comparison.json and OUT/comparison.png.",
    )
    p_cmp.add_argument("scenario", nargs="?", default=None,
                       help="optional named scenario: paper-bag, paper-ball, paper-push (see `ismpc scenarios`). "
                       "A scenario fixes robot, simulator (mujoco), command, duration and disturbances; --robot "
                       "moves it to another robot of a similar size (standing CoM within 2x; the disturbances scale "
                       "with the mass), --duration "
                       "overrides its duration, --force/--push ADD forces (unscaled, on the torso) to its own, "
                       "--seed varies its push time and magnitude (seed 0 = the paper's values)")
    _add_run_arguments(p_cmp, with_controller=False)
    p_cmp.add_argument("--robust-modules", default=None,
                       help="modules of the robust run (default: all three, or the scenario's)")
    p_cmp.add_argument("--load-factor", type=float, default=None,
                       help="with a scenario: its own disturbances (the bag's or the ball's mass, its forces) times "
                       "this, > 0 (default 1); benchmarks/scenario_frontier.py finds where each controller's limit is")
    # Defaults resolved in cmd_compare, so that a scenario can tell "not given" from a value.
    p_cmp.set_defaults(sim=None, robot=None, vx=None, vy=None, omega=None, duration=None)

    sub.add_parser("scenarios", help="list the named scenarios of `ismpc compare`",
                   description="List the named scenarios (the paper's experiments) with one line each.")

    p_soak = sub.add_parser("soak", help="long walk with random pushes inside the robust envelope",
                            description="Walk for a long time with the robust controller under random 0.1 s "
                            "pushes (seeded) and report falls, solver failures and memory (OUT/soak.json).")
    p_soak.add_argument("--sim", default="lip", help="lip or mujoco (default lip)")
    p_soak.add_argument("--robot", default="g1", help=robot_help())
    p_soak.add_argument("--minutes", type=_positive_float("minutes", MAX_SIM_DURATION_S / 60, "minutes"), default=10.0,
                        help=f"simulated minutes (10; at most {MAX_SIM_DURATION_S / 60:g})")
    p_soak.add_argument("--push-max", type=_finite_float("push-max"), default=None,
                        help="largest push [N] (default: the 0.1 s push that moves the DCM by half the sole width, docs/results.md)")
    p_soak.add_argument("--vx", type=_finite_float("vx"), default=None,
                        help="forward velocity command [m/s] (0.2 on the LIP, 0.1 in MuJoCo)")
    p_soak.add_argument("--seed", type=_seed, default=0, help="random seed (0)")
    p_soak.add_argument("--modules", default="observer,restriction,timing",
                        help="controller modules (default: all three, the robust controller)")
    p_soak.add_argument("--whole-body", default=None, choices=("servo", "torque"),
                        help="mujoco only: torque (inverse-dynamics QP, the default) or servo")
    _add_sensing_argument(p_soak)
    _add_output_arguments(p_soak)
    p_soak.add_argument("--quiet", action="store_true", help="no progress on stderr")

    p_cal = sub.add_parser(
        "calibrate", help="measure a robot's swing-leg CoP gain (the [gait] swing_cop_gain_s2)",
        description="Walk the robot's reference without physics (whole-body IK and the inverse dynamics of its "
        "motion) and fit κ, the forward shift of the centre of pressure per m/s² of forward swing-foot "
        "acceleration (docs/robots.md). Writes OUT/calibration.json and OUT/calibration.png.")
    p_cal.add_argument("--robot", default="g1", help=robot_help(mujoco_only=True))
    p_cal.add_argument("--vx", type=_finite_float("vx"), default=0.2, help="forward velocity command [m/s] (0.2)")
    p_cal.add_argument("--duration", type=_duration(), default=8.0, help="walk length [s] (8)")
    _add_output_arguments(p_cal)

    p_bench = sub.add_parser("bench", help="time the MPC cycle, the closed loop and start-up",
                             description="Measure the per-cycle time of the MPC (build and solve) at C = 50, 100, 200, "
                             "then the speed table: the LIP cycle, the robust cycle at C = 200, whole-process "
                             "start-up and, with --mujoco, the closed-loop tick in MuJoCo (medians of --repeats), all on --robot "
                             "(a robot file's own settings included, such as its inverse-dynamics rate).")
    p_bench.add_argument("--robot", default="g1", help=robot_help())
    p_bench.add_argument("--horizons", default="50,100,200", help="control-horizon samples, comma-separated")
    p_bench.add_argument("--cycles", type=int, default=1000, help="cycles per horizon (1000)")
    p_bench.add_argument("--solvers", default=None,
                         help="solvers to compare on the same QPs, comma-separated (default: those of daqp, osqp, "
                         "proxqp, quadprog that are installed)")
    p_bench.add_argument("--mujoco", action="store_true",
                         help="also measure the robot in MuJoCo: time per tick (torque and servo) and whole-process "
                         "start-up")
    p_bench.add_argument("--repeats", type=int, default=1, help="runs per speed-table row; the median is reported (1)")
    p_bench.add_argument("--baseline", default=None,
                         help="a previous bench.json: print each speed row's ratio to it and flag regressions (>= 1.1x)")
    p_bench.add_argument("--out", default=None, help="write bench.json (and bench.md) into this directory")
    p_bench.add_argument("--quiet", action="store_true", help="no progress on stderr")

    p_sweep = sub.add_parser(
        "sweep", help="push-recovery frontier: largest survived push per controller, direction and phase",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="For each controller, push direction and gait phase, find by bisection the largest impulse "
        "(and optionally constant force) the robot survives. Writes OUT/runs.csv (one row per trial, appended as "
        "trials finish), OUT/frontier.json, OUT/frontier_polar.png, OUT/frontier_phase.png and OUT/report.md. "
        "Rerunning the same command resumes an interrupted sweep.",
        epilog="examples:\n  ismpc sweep --controllers nominal,timing,robust --direction 0:360:8 --phase 0:1:4 "
        "--impulse-max 20 --out sweeps/g1\n  ismpc sweep --controllers robust --direction 90 --phase 0.5 "
        "--impulse-max 10 --force-max 100 --iterations 6 --out sweeps/g1-left",
    )
    p_sweep.add_argument("--sim", default="lip", help="simulator: lip or mujoco (default lip)")
    p_sweep.add_argument("--robot", default="g1", help=robot_help())
    p_sweep.add_argument("--controllers", default="nominal,robust",
                         help="comma-separated: nominal, robust, observer, restriction, timing, or modules joined "
                         "by '+' (default nominal,robust)")
    p_sweep.add_argument("--direction", default="0,90,180,270",
                         help="push directions [deg], 0 = forward, 90 = left: a list or START:STOP:STEPS "
                         "(default 0,90,180,270)")
    p_sweep.add_argument("--phase", default="0:1:4",
                         help="phases of the pushed step's single support in [0, 1): START:STOP:STEPS evenly "
                         "spaced in [START, STOP), or a list (default 0:1:4 = 0, 0.25, 0.5, 0.75)")
    p_sweep.add_argument("--impulse-max", type=_finite_float("impulse-max"), required=True,
                         help="upper end of the impulse bisection [N s]")
    p_sweep.add_argument("--force-max", type=_finite_float("force-max"), default=None,
                         help="also bisect a constant force in [0, FORCE_MAX] N, on from the push instant")
    p_sweep.add_argument("--push-duration", type=_finite_float("push-duration"), default=0.1,
                         help="duration of the impulsive push [s] (0.1)")
    p_sweep.add_argument("--vx", type=_finite_float("vx"), default=0.2, help="forward velocity command [m/s] (0.2)")
    p_sweep.add_argument("--duration", type=_duration(), default=None,
                         help="simulated time after the push starts [s] (3 on the LIP, 6 in MuJoCo, where the "
                         "full robot can fall seconds after a push)")
    p_sweep.add_argument("--iterations", type=int, default=8,
                         help="bisection steps after the trial at the maximum; resolution = max / 2^N (8)")
    p_sweep.add_argument("--repeats", type=int, default=None,
                         help="most trials per magnitude, each with its own seed, odd; a magnitude is held when "
                         "most survive (1 under ideal sensing, 3 under a noisy --sensing)")
    p_sweep.add_argument("--pushed-step", type=int, default=4,
                         help="which regular step is pushed, 1 = the first (4)")
    p_sweep.add_argument("--seed", type=_seed, default=0, help="base seed of the per-trial seeds (0)")
    p_sweep.add_argument("--whole-body", default=None, choices=("servo", "torque"),
                        help="mujoco only: torque (inverse-dynamics QP, the default) or servo")
    _add_sensing_argument(p_sweep)
    p_sweep.add_argument("--workers", type=int, default=None, help="parallel processes (default: CPU count)")
    p_sweep.add_argument("--backend", default="local", help="local (processes) or ray (needs `pip install ray`)")
    _add_output_arguments(p_sweep, overwrite_help="discard an earlier sweep in --out (without it, the same sweep "
                          "resumes and a different one is refused)")
    p_sweep.add_argument("--quiet", action="store_true", help="no progress on stderr")

    p_robot = sub.add_parser("robot", help="add a robot: draft its robot file from a model, check a robot file",
                             description="`ismpc robot init MODEL.xml --out robots/mybot.toml` drafts a robot file; "
                             "`ismpc robot check robots/mybot.toml --out DIR` stands and walks it in MuJoCo "
                             "(docs/robots.md).")
    robot_sub = p_robot.add_subparsers(dest="robot_command", parser_class=_Parser)
    p_init = robot_sub.add_parser(
        "init", help="draft a robot file from a URDF, an MJCF robot or an MJCF scene (robot and floor)",
        description="For a URDF or an MJCF robot without floor or floating base, first write a walking scene next "
        "to the robot file (free joint, floor, light, torque motors, physics step; docs/robots.md). Then find the "
        "floating base, the feet, the soles, the leg joints and a bent-knee standing posture (whole-body IK), "
        "measure the standing centre of pressure (a jittery one gets box soles in a scene written here, a warning "
        "otherwise) and the swing-leg CoP gain, and write a commented robot file.")
    p_init.add_argument("model", help="URDF, MJCF robot, or MJCF scene (the robot with a floor)")
    p_init.add_argument("--package-dir", action="append", default=[], metavar="DIR",
                        help="folder searched for a URDF's package:// paths (repeatable; the folders above the "
                        "URDF are searched too)")
    p_init.add_argument("--out", required=True, help="robot file to write (.toml)")
    p_init.add_argument("--name", default=None, help="robot name (default: the robot file's name for a URDF or an MJCF robot, the scene's folder name for a scene)")
    p_init.add_argument("--left-foot", default=None, help="left foot body (default: found)")
    p_init.add_argument("--right-foot", default=None, help="right foot body (default: found)")
    p_init.add_argument("--no-calibrate", action="store_true", help="skip the swing-leg CoP gain calibration")
    p_init.add_argument("--overwrite", action="store_true", help="replace an existing --out file")
    p_check = robot_sub.add_parser(
        "check", help="stand a robot 5 s and walk it 5 s in MuJoCo; report and picture",
        description="Hold the robot still in double support for 5 s (torque control), then walk it forward "
        "with the nominal controller for 5 s (--walk-duration). Writes OUT/check.json, OUT/gait.png and "
        "OUT/summary.json.")
    p_check.add_argument("file", help="robot file (.toml) or built-in robot name")
    p_check.add_argument("--vx", type=_finite_float("vx"), default=None,
                         help="walking speed [m/s] (default: half of what the robot's steps allow)")
    p_check.add_argument("--walk-duration", type=_positive_float("walk-duration", MAX_SIM_DURATION_S), default=5.0,
                         help="walking time after the first step [s] (default 5)")
    _add_output_arguments(p_check)
    return parser


#: Names of the library's parameters that a command-line flag sets, as they appear in the
#: messages of ParameterError, and the flag the CLI names instead.
FLAG_NAMES = {
    "SweepConfig.impulse_max_ns": "--impulse-max",
    "SweepConfig.force_max_n": "--force-max",
    "SweepConfig.push_duration_s": "--push-duration",
    "SweepConfig.iterations": "--iterations",
    "SweepConfig.repeats": "--repeats",
    "SweepConfig.pushed_step": "--pushed-step",
    "SweepConfig.post_push_s": "--duration",
    "SweepConfig.vx_mps": "--vx",
    "push_max_n": "--push-max",
    "workers must": "--workers must",
    "phases '": "--phase '",
    "directions '": "--direction '",
    "unknown backend": "--backend: unknown backend",
    "delta_max": "--delta-max",
}


def flag_names(message: str) -> str:
    """``message`` with the library's parameter names replaced by the flags that set them."""
    for name, flag in FLAG_NAMES.items():
        message = message.replace(name, flag)
    return message
