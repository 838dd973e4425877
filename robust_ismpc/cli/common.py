"""Helpers shared by the ``ismpc`` commands: output folder, progress and warnings on stderr,
the RunSpec of the run flags, and a run's summary, trace and figure."""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path

from ..exceptions import ParameterError


def _warn(message: str) -> None:
    sys.stderr.write(f"ismpc: warning: {message}\n")


def _open_out(args, require_empty: bool = True) -> Path:
    """Check, create and lock ``--out`` (released when the command ends, in :func:`robust_ismpc.cli.main`)."""
    from ..runs.outputs import open_output_dir

    args.out_dir = open_output_dir(args.out, getattr(args, "overwrite", False), require_empty=require_empty)
    return args.out_dir.path


def _forces(args) -> list:
    """(flag, text, ForceWindow) of every ``--force`` and ``--push``."""
    from ..runs.forces import parse_force, parse_push

    return ([("--force", text, parse_force(text)) for text in args.force]
            + [("--push", text, parse_push(text)) for text in args.push])


def _progress(args, label: str):
    """Progress callback of a run: honours Ctrl-C at a tick boundary; prints on stderr (a line
    that rewrites itself on a terminal, about every 10 % of the run otherwise) unless --quiet."""
    interrupts = args.interrupts
    tty = sys.stderr.isatty()
    start = time.perf_counter()
    every = max(1.0, args.duration / 10)
    state = {"next": 0.0}

    def report(t_s: float) -> None:
        interrupts.check()
        if args.quiet:
            return
        text = f"{label}: t = {t_s:6.1f} / {args.duration:.1f} s  ({time.perf_counter() - start:5.1f} s wall)"
        if tty:
            sys.stderr.write("\r" + text)
        elif t_s + 1e-9 >= state["next"]:
            state["next"] += every
            sys.stderr.write(text + "\n")
        sys.stderr.flush()

    return report


def _end_progress(args) -> None:
    if not args.quiet and sys.stderr.isatty():
        sys.stderr.write("\n")


def _require(args, plot: bool = True) -> None:
    """Name the extra to install before anything runs."""
    from ..extras import require_extra

    command = f"ismpc {args.command}"
    if plot:
        require_extra("plot", f"{command} (its figures)")
    if getattr(args, "sim", None) == "mujoco" or getattr(args, "scenario", None):
        require_extra("sim", f"{command} --sim mujoco")
    if getattr(args, "video", False):
        require_extra("video", f"{command} --video")


def _check_sim_flags(args) -> None:
    from ..runs.spec import gait_params
    from .inputs import check_whole_body_flag

    check_whole_body_flag(args.whole_body, args.sim)
    if args.robot is not None:
        gait_params(args.robot, args.sim)  # an unknown name or a bad robot file: one line, before any output
    for flag in ("video", "viewer"):
        if getattr(args, flag, False) and args.sim != "mujoco":
            raise ParameterError(f"--{flag} needs --sim mujoco (the LIP has nothing to show)")
    if getattr(args, "viewer", False):
        from ..sim.video import check_viewer

        check_viewer()


def _spec(args, modules: tuple[str, ...]):
    """The RunSpec of ``args``, with the command clipped to the robot's steps, and the warnings."""
    from ..core.planner import WalkCommand
    from ..robots.mismatch import parse_mismatch
    from ..runs.spec import RunSpec, gait_params
    from .inputs import check_forces_in_run, limit_command

    forces = _forces(args)
    spec = RunSpec(
        robot=args.robot, sim=args.sim, modules=modules, duration_s=args.duration,
        forces=tuple(w for _, _, w in forces), seed=args.seed, delta_max_mps2=args.delta_max,
        whole_body=args.whole_body, sensing=args.sensing, mismatch=parse_mismatch(args.mismatch),
    )
    check_forces_in_run(forces, args.duration)
    requested = {"--vx": args.vx, "--vy": args.vy, "--omega": args.omega}
    applied, warnings = limit_command(args.robot, gait_params(args.robot, args.sim), requested)
    if spec.sim == "mujoco":
        from ..sim.loop import soft_servo_warning
        from ..sim.model import load_robot
        from ..sim.model_checks import physics_step_warning

        robot = load_robot(spec.robot)
        # servo playback: servos too soft to hold the robot; torque control: a coarse physics step
        warning = soft_servo_warning(robot) if spec.whole_body == "servo" else physics_step_warning(robot)
        warnings = warnings + ([warning] if warning else [])
    args.command_requested = {"vx_mps": args.vx, "vy_mps": args.vy, "omega_radps": args.omega}
    args.warnings = warnings
    return replace(spec, command=WalkCommand(applied["--vx"], applied["--vy"], applied["--omega"]))


def _write_run(result, out: Path, args=None, title: str | None = None) -> None:
    """summary.json (with the requested command and the warnings), trace.npz, gait.png; atomically."""
    from ..io import atomic_write_json
    from ..plotting import plot_run

    if args is not None and getattr(args, "command_requested", None) is not None:
        result.summary["command_requested"] = args.command_requested
        result.summary["warnings"] = list(args.warnings)
    atomic_write_json(out / "summary.json", result.summary)
    result.trace.save(out / "trace.npz")
    plot_run(result.trace, out / "gait.png", title=title)


def _one_line(summary: dict, label: str | None = None) -> str:
    failed = "SIMULATION FAILED" if str(summary["failure"]).startswith("simulator_unstable") else "FELL"
    state = f"{failed} ({summary['failure']})" if summary["fell"] else (
        "INTERRUPTED" if summary["failure"] == "interrupted" else "walked")
    return (
        f"{summary.get('robot_name') or summary['robot']}/{summary['sim']}/{label or summary['controller']}: {state}; "
        f"{summary['duration_s']:.2f} s, {summary['distance_m']:.2f} m, {summary['steps_taken']} steps, "
        f"{summary['qp_infeasible_count']} infeasible QPs, cycle median {summary['cycle_ms']['median']} ms"
    )


def _interrupted(args, what: str) -> int:
    sys.stderr.write(f"ismpc: interrupted; {what}\n")
    return 130
