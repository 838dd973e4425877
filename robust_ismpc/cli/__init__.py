"""``ismpc`` command line: the only module that parses arguments or prints.

Exit status: 0 success (also when the robot fell: the outcome is in ``summary.json``),
2 bad input (one line on stderr), 1 an unexpected internal error, 3 ``ismpc robot check`` ran
and the robot failed it, 130 interrupted.
"""

from __future__ import annotations

import logging
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

from ..exceptions import IsmpcError, ParameterError
from .args import build_parser, flag_names

__all__ = ["build_parser", "main"]



def _warn(message: str) -> None:
    sys.stderr.write(f"ismpc: warning: {message}\n")


def _open_out(args, require_empty: bool = True) -> Path:
    """Check, create and lock ``--out`` (released when the command ends, in :func:`main`)."""
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
    from ..runs.spec import RunSpec, gait_params
    from .inputs import check_forces_in_run, limit_command

    forces = _forces(args)
    spec = RunSpec(
        robot=args.robot, sim=args.sim, modules=modules, duration_s=args.duration,
        forces=tuple(w for _, _, w in forces), seed=args.seed, delta_max_mps2=args.delta_max,
        whole_body=args.whole_body,
    )
    check_forces_in_run(forces, args.duration)
    requested = {"--vx": args.vx, "--vy": args.vy, "--omega": args.omega}
    applied, warnings = limit_command(args.robot, gait_params(args.robot, args.sim), requested)
    if spec.sim == "mujoco" and spec.whole_body == "servo":
        from ..sim.loop import soft_servo_warning
        from ..sim.model import load_robot

        soft = soft_servo_warning(load_robot(spec.robot))
        warnings = warnings + ([soft] if soft else [])
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


def cmd_run(args) -> int:
    from ..control.modules import parse_modules
    from ..runs.run import run
    from .inputs import check_modules_flags

    modules = parse_modules(args.controller, args.modules)
    check_modules_flags(modules, args.modules, args.delta_max)
    _require(args)
    _check_sim_flags(args)
    spec = _spec(args, modules)
    out = _open_out(args)
    for line in args.warnings:
        _warn(line)
    video = out / "video.mp4" if args.video else None
    result = run(spec, progress=_progress(args, spec.controller_label), video_path=video, viewer=args.viewer)
    _end_progress(args)
    _write_run(result, out, args)
    print(_one_line(result.summary))
    print(f"wrote {out / 'summary.json'}, {out / 'gait.png'}, {out / 'trace.npz'}" + (f", {video}" if video else ""))
    if result.summary["failure"] == "interrupted" or args.interrupts.requested:
        return _interrupted(args, f"the part of the run that finished ({result.summary['duration_s']:.2f} s) "
                            f"was written to {out}")
    return 0


def _robust_label(modules) -> str:
    """"robust", or "robust (timing)" when the robust run has only some modules (paper-ball)."""
    from ..control.modules import MODULES

    return "robust" if set(modules) == set(MODULES) else f"robust ({'+'.join(modules)})"


def _compare_scenario(args) -> int:
    """``ismpc compare NAME``: both controllers on one seed of a named scenario."""
    from ..control.modules import parse_modules
    from ..experiments.scenarios import disturbance_events, get_scenario, on_robot, run_scenario
    from ..io import atomic_write_json
    from ..plotting import plot_comparison

    scenario = get_scenario(args.scenario)
    if args.sim is not None and args.sim != "mujoco":
        raise ParameterError(f"scenario {scenario.name} runs --sim mujoco; drop --sim {args.sim}")
    if args.robot is not None:
        from ..robots import robot_reference

        scenario = on_robot(scenario, robot_reference(args.robot))
    for flag, given in (("--vx", args.vx), ("--vy", args.vy), ("--omega", args.omega), ("--delta-max", args.delta_max)):
        if given is not None:
            raise ParameterError(f"scenario {scenario.name} fixes its command and modules; {flag} is not allowed with it")
    if args.robust_modules is not None:
        modules = parse_modules("robust", args.robust_modules)
        from .inputs import check_modules_flags

        check_modules_flags(modules, args.robust_modules, None, "--robust-modules")
        scenario = replace(scenario, robust_modules=modules)
    if args.duration is not None:
        scenario = replace(scenario, duration_s=args.duration)
    args.duration = scenario.duration_s
    forces = _forces(args)
    from .inputs import check_forces_in_run

    check_forces_in_run(forces, scenario.duration_s)
    out = _open_out(args)
    labels = {"nominal": "nominal", "robust": _robust_label(scenario.robust_modules)}
    result = run_scenario(scenario, seed=args.seed, extra_forces=tuple(w for _, _, w in forces),
                          progress=lambda label: _progress(args, labels.get(label, label)),
                          video_dir=out if args.video else None, whole_body=args.whole_body)
    for label, run_result in result.results.items():
        (out / label).mkdir(exist_ok=True)
        _end_progress(args)
        _write_run(run_result, out / label, title=f"{scenario.name} seed {args.seed}: {labels[label]}")
        print(_one_line(run_result.summary, labels[label]))
    if args.interrupts.requested:
        return _interrupted(args, f"the runs' finished parts were written to {out}; no comparison")
    comparison = result.comparison
    atomic_write_json(out / "comparison.json", comparison)
    traces = [r.trace for r in result.results.values()]
    names = [f"{label} ({'+'.join(r.summary['modules']) or 'IS-MPC'})" for label, r in result.results.items()]
    plot_comparison(traces, names, out / "comparison.png", title=f"{scenario.name}, seed {args.seed}: {scenario.paper}",
                    events=disturbance_events(result.run))
    dev = {k: comparison[k]["path_deviation"]["max_m"] for k in ("nominal", "robust")}
    print(f"{scenario.name} seed {args.seed}: nominal {'FELL' if comparison['nominal']['fell'] else 'walked'}, "
          f"{labels['robust']} {'FELL' if comparison['robust']['fell'] else 'walked'}; path deviation (stride-averaged "
          f"max) nominal {dev['nominal']} m, {labels['robust']} {dev['robust']} m; expected outcome: "
          f"{'yes' if comparison['expected_outcome'] else 'NO'}")
    print(f"wrote {out / 'comparison.json'}, {out / 'comparison.png'}, {out / 'nominal'}, {out / 'robust'}")
    return 0


def cmd_scenarios(args) -> int:
    from ..experiments.scenarios import SCENARIOS

    width = max(len(n) for n in SCENARIOS)
    for name, scenario in SCENARIOS.items():
        print(f"{name:<{width}}  {scenario.summary}")
    return 0


def cmd_compare(args) -> int:
    from ..control.modules import parse_modules
    from ..io import atomic_write_json
    from ..plotting import plot_comparison
    from ..runs.run import run
    from .inputs import check_modules_flags

    if args.scenario is not None:
        _require(args)
        return _compare_scenario(args)
    for name, default in (("sim", "lip"), ("robot", "g1"), ("vx", 0.2), ("vy", 0.0), ("omega", 0.0), ("duration", 10.0)):
        if getattr(args, name) is None:
            setattr(args, name, default)
    _require(args)
    robust_modules = parse_modules("robust", "observer,restriction,timing" if args.robust_modules is None
                                   else args.robust_modules)
    check_modules_flags(robust_modules, args.robust_modules, args.delta_max, "--robust-modules")
    _check_sim_flags(args)
    specs = {"nominal": replace(_spec(args, robust_modules), modules=(), delta_max_mps2=None),
             _robust_label(robust_modules): _spec(args, robust_modules)}
    out = _open_out(args)
    for line in args.warnings:
        _warn(line)
    results = {}
    for label, spec in specs.items():
        if args.interrupts.requested:
            break
        folder = "nominal" if label == "nominal" else "robust"
        (out / folder).mkdir(exist_ok=True)
        video = out / folder / "video.mp4" if args.video else None
        results[label] = run(spec, progress=_progress(args, label), video_path=video)
        _end_progress(args)
        _write_run(results[label], out / folder, args, title=None)
        print(_one_line(results[label].summary, label))
    if args.interrupts.requested:
        return _interrupted(args, f"{', '.join(results)} written to {out} (the last one as far as it ran); "
                            "no comparison")
    nominal, robust = results.values()
    comparison = {
        key: {k: r.summary[k] for k in ("fell", "failure", "distance_m", "steps_taken", "qp_infeasible_count",
                                        "max_zmp_violation_m", "timing_adaptations", "min_time_to_step_s",
                                        "disturbance_estimate_final", "modules")}
        for key, r in (("nominal", nominal), ("robust", robust))
    }
    comparison["robust_survives_nominal_fails"] = (not robust.summary["fell"]) and nominal.summary["fell"]
    comparison["warnings"] = list(args.warnings)
    atomic_write_json(out / "comparison.json", comparison)
    plot_comparison([r.trace for r in results.values()], list(results), out / "comparison.png",
                    title=f"{args.robot} on {args.sim}: nominal vs robust")
    print(f"wrote {out / 'comparison.json'}, {out / 'comparison.png'}")
    return 0


def cmd_soak(args) -> int:
    from ..control.modules import parse_modules
    from ..experiments.soak import DEFAULT_VX_MPS, SoakSpec, run_soak
    from ..io import atomic_write_json
    from ..runs.spec import gait_params
    from .inputs import limit_command

    _require(args)
    modules = parse_modules("robust", args.modules)
    from .inputs import check_modules_flags

    check_modules_flags(modules, args.modules, None)
    _check_sim_flags(args)
    warnings = []
    if args.vx is not None:
        applied, warnings = limit_command(args.robot, gait_params(args.robot, args.sim), {"--vx": args.vx})
        args.vx = applied["--vx"]
    spec = SoakSpec(robot=args.robot, sim=args.sim, duration_s=60.0 * args.minutes, push_max_n=args.push_max,
                    vx_mps=args.vx if args.vx is not None else DEFAULT_VX_MPS.get(args.sim), seed=args.seed,
                    modules=modules, whole_body=args.whole_body)
    out = _open_out(args)
    for line in warnings:
        _warn(line)
    args.duration = spec.duration_s
    report, result = run_soak(spec, progress=_progress(args, "soak"))
    report["warnings"] = warnings
    _end_progress(args)
    atomic_write_json(out / "soak.json", report)
    _write_run(result, out)
    state = "FELL" if report["fell"] else ("INTERRUPTED" if report["failure"] == "interrupted" else "no fall")
    print(f"soak {spec.robot}/{spec.sim}: {report['simulated_s']:.0f} s simulated in {report['wall_s']:.0f} s, "
          f"{report['pushes']} pushes (max {report['push_max_n']:.1f} N), {state}, "
          f"{report['qp_infeasible_count']} infeasible QPs, RSS {report['rss_mb'][0]['rss_mb']} -> "
          f"{report['rss_mb'][-1]['rss_mb']} MB (trace {report['trace_mb']} MB)")
    print(f"wrote {out / 'soak.json'}")
    if report["failure"] == "interrupted" or args.interrupts.requested:
        return _interrupted(args, f"the part of the soak that finished ({report['simulated_s']:.0f} s) was written "
                            f"to {out}")
    return 0  # a fall is an outcome (soak.json), not an error


def cmd_calibrate(args) -> int:
    from ..core.planner import WalkCommand
    from ..extras import require_extra
    from ..io import atomic_write_json
    from ..plotting import plot_swing_cop_fit
    from ..runs.spec import gait_params
    from .inputs import limit_command

    require_extra("plot", "ismpc calibrate (its figure)")
    require_extra("sim", "ismpc calibrate")
    from ..sim.calibrate import fit_swing_cop_gain

    applied, warnings = limit_command(args.robot, gait_params(args.robot, "mujoco"), {"--vx": args.vx})
    out = _open_out(args)
    for line in warnings:
        _warn(line)
    fit = fit_swing_cop_gain(args.robot, WalkCommand(applied["--vx"]), duration_s=args.duration)
    report = {"robot": args.robot, "vx_mps": applied["--vx"], "duration_s": args.duration, **fit.summary(),
              "warnings": warnings}
    atomic_write_json(out / "calibration.json", report)
    plot_swing_cop_fit(fit.swing_acceleration_mps2, fit.cop_deviation_m, fit.gain_s2, fit.offset_m,
                       out / "calibration.png", title=f"{args.robot}: swing-leg CoP gain at {applied['--vx']} m/s")
    print(f"{args.robot}: κ = {fit.gain_s2:.4f} s² (forward CoP deviation {100 * fit.rms_before_m:.2f} cm rms, "
          f"{100 * fit.rms_after_m:.2f} cm with κ a removed, {fit.samples} ticks); "
          f"in the robot's [gait]: swing_cop_gain_s2 = {fit.gain_s2:.4f}")
    print(f"wrote {out / 'calibration.json'}, {out / 'calibration.png'}")
    return 0


def cmd_bench(args) -> int:
    from ..experiments.bench import check_bench_args, format_table, run_bench, write_bench

    horizons, solvers = check_bench_args(args.horizons, args.cycles, args.solvers)
    if args.mujoco:
        from ..extras import require_extra

        require_extra("sim", "ismpc bench --mujoco")
    out = None
    if args.out is not None:
        out = _open_out(args, require_empty=False)
    result = run_bench(args.robot, horizons, args.cycles, solvers, mujoco=args.mujoco)
    print(format_table(result))
    if out is not None:
        paths = write_bench(result, out)
        print("wrote " + ", ".join(str(p) for p in paths))
    return 0


def _sweep_progress(args):
    """Progress bar with ETA on a TTY, else a line about every 10 %; None with --quiet."""
    if args.quiet:
        return None
    tty = sys.stderr.isatty()
    state = {"decile": -1}

    def report(p) -> None:
        rate = p.new / p.elapsed_s if p.elapsed_s > 0 else 0.0
        eta = (p.total - p.done) / rate if rate > 0 else float("nan")
        eta_s = "--:--" if not math.isfinite(eta) else f"{int(eta // 60)}:{int(eta % 60):02d}"
        fraction = p.done / p.total if p.total else 1.0
        if tty:
            bar = "#" * int(30 * fraction)
            sys.stderr.write(f"\r[{bar:<30}] {p.done}/{p.total} trials  {rate:5.1f} runs/s  ETA {eta_s} ")
            sys.stderr.flush()
        elif int(10 * fraction) > state["decile"]:
            state["decile"] = int(10 * fraction)
            sys.stderr.write(f"sweep: {p.done}/{p.total} trials ({100 * fraction:.0f} %), {rate:.1f} runs/s, ETA {eta_s}\n")
            sys.stderr.flush()

    return report


def cmd_sweep(args) -> int:
    import shlex

    from ..experiments.sweep import (
        DEFAULT_POST_PUSH_S,
        SweepConfig,
        frontier_table,
        parse_controllers,
        parse_directions,
        parse_phases,
        run_sweep,
    )
    from ..runs.spec import gait_params
    from .inputs import limit_command

    _require(args)
    _check_sim_flags(args)
    controllers = parse_controllers(args.controllers)
    applied, warnings = limit_command(args.robot, gait_params(args.robot, args.sim), {"--vx": args.vx})
    config = SweepConfig(
        robot=args.robot, sim=args.sim, controllers=controllers,
        directions_deg=parse_directions(args.direction), phases=parse_phases(args.phase),
        impulse_max_ns=args.impulse_max, force_max_n=args.force_max, push_duration_s=args.push_duration,
        vx_mps=applied["--vx"],
        post_push_s=args.duration if args.duration is not None else DEFAULT_POST_PUSH_S.get(args.sim, 3.0),
        iterations=args.iterations, pushed_step=args.pushed_step,
        seed=args.seed, whole_body=args.whole_body,
    )
    for line in warnings:
        _warn(line)
    progress = _sweep_progress(args)
    out = Path(args.out)
    try:
        result = run_sweep(config, out, workers=args.workers, backend=args.backend, overwrite=args.overwrite,
                           progress=progress, command_line=shlex.join(["ismpc", *sys.argv[1:]]))
    except KeyboardInterrupt:
        sys.stderr.write(f"\nismpc: sweep interrupted; finished trials are in {out / 'runs.csv'}; "
                         "rerun the same command to resume\n")
        return 130
    if progress is not None and sys.stderr.isatty():
        sys.stderr.write("\n")
    print(f"sweep {config.robot}/{config.sim}: {result.trials_total} trials ({result.trials_new} run now, "
          f"{result.trials_resumed} resumed) in {result.wall_time_s:.1f} s ({result.runs_per_s:.2f} runs/s)")
    for kind in result.frontier["frontier"]:
        print(f"\nlargest survived {kind} ({'N s' if kind == 'impulse' else 'N'}), min / mean over phases:")
        print(frontier_table(result.frontier, kind))
    print("wrote " + ", ".join(str(p) for p in result.paths))
    return 0


#: Commands whose Ctrl-C (and SIGTERM) ends the simulation at a tick boundary and writes what
#: ran; the others stop at once (a sweep keeps its finished trials in runs.csv).
DEFERRED_INTERRUPT_COMMANDS = ("run", "compare", "soak")


def cmd_robot(args) -> int:
    """``ismpc robot init|check``."""
    from ..extras import require_extra

    if args.robot_command is None:
        raise ParameterError("ismpc robot needs a subcommand: init MODEL.xml --out FILE, or check FILE --out DIR")
    require_extra("sim", f"ismpc robot {args.robot_command}")
    if args.robot_command == "init":
        return _robot_init(args)
    require_extra("plot", "ismpc robot check (its gait.png)")
    return _robot_check(args)


def _robot_init(args) -> int:
    from ..io import atomic_write_bytes
    from ..sim.wizard import draft_robot, robot_file_text

    out = Path(args.out).expanduser()
    if out.suffix != ".toml":
        raise ParameterError(f"--out {args.out!r}: a robot file ends in .toml")
    if out.exists() and not args.overwrite:
        raise ParameterError(f"--out {args.out!r} exists; use --overwrite to replace it")
    out.parent.mkdir(parents=True, exist_ok=True)
    draft = draft_robot(args.model, args.left_foot, args.right_foot, args.name)
    atomic_write_bytes(out, robot_file_text(draft, out).encode())
    print(f"{draft.name}: feet {draft.left_foot} / {draft.right_foot}, sole {100 * draft.sole_length_m:.1f} x "
          f"{100 * draft.sole_width_m:.1f} cm, {len(draft.leg_joints)} leg joints, standing CoM "
          f"{draft.com_height_m:.3f} m, feet {draft.foot_spacing_m:.3f} m apart")
    for note in draft.notes:
        _warn(note)
    if not args.no_calibrate:
        gain = _calibrate_draft(out)
        if gain is not None:
            atomic_write_bytes(out, robot_file_text(draft, out, swing_cop_gain_s2=gain).encode())
    print(f"wrote {out}; check it with: ismpc robot check {out} --out DIR")
    return 0


def _calibrate_draft(path: Path) -> float | None:
    """The swing-leg CoP gain of a drafted robot file, or None (with a warning) when the fit
    explains less than a third of the CoP deviation or fails."""
    from ..core.planner import WalkCommand, command_limits
    from ..exceptions import IsmpcError
    from ..sim.calibrate import fit_swing_cop_gain
    from ..sim.model import load_robot

    try:
        spec = load_robot(str(path))
        vx = 0.5 * command_limits(spec.params())["vx_mps"][0]
        fit = fit_swing_cop_gain(spec, WalkCommand(vx))
    except IsmpcError as exc:
        _warn(f"swing-leg CoP gain not calibrated: {exc}")
        return None
    explained = 1.0 - fit.rms_after_m / fit.rms_before_m if fit.rms_before_m > 0 else 0.0
    if explained < 1.0 / 3.0:
        _warn(f"swing-leg CoP gain not written: κ = {fit.gain_s2:.4f} s² explains only {explained:.0%} of the "
              f"forward CoP deviation ({100 * fit.rms_before_m:.2f} cm rms)")
        return None
    print(f"swing-leg CoP gain κ = {fit.gain_s2:.4f} s² (explains {explained:.0%} of the forward CoP deviation)")
    return fit.gain_s2


def _robot_check(args) -> int:
    from ..experiments.robot_check import check_robot
    from ..io import atomic_write_json
    from ..robots import robot_reference

    robot = robot_reference(args.file)
    out = _open_out(args)
    report, result = check_robot(robot, walk_s=args.walk_duration, vx_mps=args.vx)
    atomic_write_json(out / "check.json", report)
    _write_run(result, out, title=f"{report['robot_name']}: walk of `ismpc robot check`")
    stand, walk = report["stand"], report["walk"]
    held = "held" if stand["stood"] else f"FELL at {stand['fell_at_s']:.2f} s"
    print(f"{report['robot_name']}: stand {held} "
          f"(CoM drift {100 * stand['com_drift_m']:.1f} cm); walk at {walk['vx_mps']} m/s "
          f"{'FELL: ' + str(walk['failure']) if walk['fell'] else 'walked'} ({walk['distance_m']:.2f} m, "
          f"{walk['steps_taken']} steps, {walk['qp_infeasible_count']} infeasible QPs)")
    print(f"{'passed' if report['passed'] else 'FAILED'}; wrote {out / 'check.json'}, {out / 'gait.png'}")
    return 0 if report["passed"] else 3


def main(argv: list[str] | None = None) -> int:
    from ..runs.outputs import Interrupts

    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING if args.verbose else logging.ERROR, format="%(levelname)s %(message)s")
    if args.command is None:
        parser.print_help()
        return 2
    handlers = {"run": cmd_run, "compare": cmd_compare, "bench": cmd_bench, "sweep": cmd_sweep, "soak": cmd_soak,
                "scenarios": cmd_scenarios, "calibrate": cmd_calibrate, "robot": cmd_robot}
    args.out_dir = None
    if getattr(args, "robot", None) is not None:
        from ..robots import robot_reference

        args.robot = robot_reference(args.robot)
    args.interrupts = Interrupts(deferred=args.command in DEFERRED_INTERRUPT_COMMANDS).install()
    logging.captureWarnings(True)  # numerical warnings go to the log (shown with --verbose), not stderr
    try:
        return handlers[args.command](args)
    except IsmpcError as exc:
        if args.interrupts.requested:
            return _interrupted(args, "stopped before a run finished; nothing more was written")
        sys.stderr.write(f"ismpc: error: {flag_names(str(exc))}\n")
        return 2
    except KeyboardInterrupt:
        if args.interrupts.deferred:
            return _interrupted(args, "stopped at once (second signal); files already written were kept")
        return _interrupted(args, "files already written were kept")
    except Exception as exc:  # an internal error: one line, details only with --verbose
        logging.getLogger("robust_ismpc").debug("internal error", exc_info=True)
        sys.stderr.write(f"ismpc: internal error: {type(exc).__name__}: {exc} (rerun with --verbose for details)\n")
        if args.verbose:
            raise
        return 1
    finally:
        logging.captureWarnings(False)
        args.interrupts.restore()
        if args.out_dir is not None:
            args.out_dir.release()

