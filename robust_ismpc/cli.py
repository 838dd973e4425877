"""``ismpc`` command line: the only module that parses arguments or prints.

Exit status: 0 success (also when the robot fell: the outcome is in ``summary.json``),
2 bad input (one line on stderr), 1 an unexpected internal error, 130 interrupted.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import time
from pathlib import Path

from .exceptions import IsmpcError, ParameterError

EPILOG_FORCES = """force syntax:
  --force FX,FY            constant force [N] on the CoM (LIP) / torso (MuJoCo) for the whole run
  --force FX,FY@T0:T1      force active from T0 to T1 [s] (T1 empty = until the end)
  --push  FX,FY@T:DUR      push of FX,FY [N] starting at T lasting DUR [s]
"""


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line and exit status 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write(f"{self.prog}: error: {message} (see {self.prog} --help)\n")
        sys.exit(2)


def _positive_float(name: str):
    def convert(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number, got {text!r}") from None
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"{name} must be a finite number > 0, got {text!r}")
        return value

    return convert


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


def _add_run_arguments(p: argparse.ArgumentParser, with_controller: bool = True) -> None:
    from .params import ROBOT_DEFAULTS

    p.add_argument("--sim", default="lip", help="simulator: lip (reduced model) or mujoco (full robot); default lip")
    p.add_argument("--robot", default="g1",
                   help=f"robot: {', '.join(sorted(ROBOT_DEFAULTS))} (mujoco: g1, op3); default g1")
    if with_controller:
        p.add_argument("--controller", default="nominal",
                       help="nominal (IS-MPC) or robust (observer + restriction + timing); default nominal")
        p.add_argument("--modules", default=None,
                       help="comma-separated subset of observer,restriction,timing (overrides --controller)")
    p.add_argument("--vx", type=_finite_float("vx"), default=0.2, help="forward velocity command [m/s] (0.2)")
    p.add_argument("--vy", type=_finite_float("vy"), default=0.0, help="lateral velocity command [m/s] (0)")
    p.add_argument("--omega", type=_finite_float("omega"), default=0.0, help="turning rate command [rad/s] (0)")
    p.add_argument("--duration", type=_positive_float("duration"), default=10.0, help="simulated time [s] (10)")
    p.add_argument("--force", action="append", default=[], metavar="FX,FY[@T0:T1]",
                   help="external force [N], repeatable (see below)")
    p.add_argument("--push", action="append", default=[], metavar="FX,FY@T:DUR",
                   help="impulsive push [N] for DUR seconds, repeatable")
    p.add_argument("--delta-max", type=_finite_float("delta-max"), default=None,
                   help="deviation bound Δmax for the ZMP restriction [m/s²] (default: module default)")
    p.add_argument("--seed", type=_seed, default=0, help="random seed (0)")
    p.add_argument("--out", required=True, help="output directory (summary.json, gait.png, trace.npz)")
    p.add_argument("--overwrite", action="store_true", help="allow writing into an existing non-empty --out")
    p.add_argument("--video", action="store_true", help="mujoco only: also write an mp4 (offscreen rendering)")
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
                       "A scenario fixes robot, simulator (mujoco), command, duration and disturbances; --duration "
                       "overrides its duration, --force/--push ADD forces (unscaled, on the torso) to its own, "
                       "--seed varies its push time and magnitude (seed 0 = the paper's values)")
    _add_run_arguments(p_cmp, with_controller=False)
    p_cmp.add_argument("--robust-modules", default=None,
                       help="modules of the robust run (default: all three, or the scenario's)")
    # Defaults resolved in cmd_compare, so that a scenario can tell "not given" from a value.
    p_cmp.set_defaults(sim=None, robot=None, vx=None, vy=None, omega=None, duration=None)

    sub.add_parser("scenarios", help="list the named scenarios of `ismpc compare`",
                   description="List the named scenarios (the paper's experiments) with one line each.")

    p_soak = sub.add_parser("soak", help="long walk with random pushes inside the robust envelope",
                            description="Walk for a long time with the robust controller under random 0.1 s "
                            "pushes (seeded) and report falls, solver failures and memory (OUT/soak.json).")
    p_soak.add_argument("--sim", default="lip", help="lip or mujoco (default lip)")
    p_soak.add_argument("--robot", default="g1", help="robot (g1)")
    p_soak.add_argument("--minutes", type=_positive_float("minutes"), default=10.0, help="simulated minutes (10)")
    p_soak.add_argument("--push-max", type=_finite_float("push-max"), default=None,
                        help="largest push [N] (default 8 N scaled by robot mass)")
    p_soak.add_argument("--vx", type=_finite_float("vx"), default=None,
                        help="forward velocity command [m/s] (0.2 on the LIP, 0.1 in MuJoCo)")
    p_soak.add_argument("--seed", type=_seed, default=0, help="random seed (0)")
    p_soak.add_argument("--modules", default="observer,restriction,timing",
                        help="controller modules (default: all three, the robust controller)")
    p_soak.add_argument("--whole-body", default=None, choices=("servo", "torque"),
                        help="mujoco only: torque (inverse-dynamics QP, the default) or servo")
    p_soak.add_argument("--out", required=True, help="output directory")
    p_soak.add_argument("--overwrite", action="store_true", help="allow writing into an existing non-empty --out")

    p_cal = sub.add_parser(
        "calibrate", help="measure a robot's swing-leg CoP gain (the [gait] swing_cop_gain_s2)",
        description="Walk the robot's reference without physics (whole-body IK and the inverse dynamics of its "
        "motion) and fit κ, the forward shift of the centre of pressure per m/s² of forward swing-foot "
        "acceleration (docs/robots.md). Writes OUT/calibration.json and OUT/calibration.png.")
    p_cal.add_argument("--robot", default="g1", help="built-in robot (g1, op3) or a robot TOML file (g1)")
    p_cal.add_argument("--vx", type=_finite_float("vx"), default=0.2, help="forward velocity command [m/s] (0.2)")
    p_cal.add_argument("--duration", type=_positive_float("duration"), default=8.0, help="walk length [s] (8)")
    p_cal.add_argument("--out", required=True, help="output directory")
    p_cal.add_argument("--overwrite", action="store_true", help="allow writing into an existing non-empty --out")

    p_bench = sub.add_parser("bench", help="time the MPC cycle at several horizons",
                             description="Measure the per-cycle time of the MPC (build and solve) at C = 50, 100, 200.")
    p_bench.add_argument("--robot", default="g1", help="robot parameters (g1)")
    p_bench.add_argument("--horizons", default="50,100,200", help="control-horizon samples, comma-separated")
    p_bench.add_argument("--cycles", type=int, default=1000, help="cycles per horizon (1000)")
    p_bench.add_argument("--solvers", default="daqp,osqp,proxqp,quadprog",
                         help="solvers to compare on the same QPs (those installed)")
    p_bench.add_argument("--mujoco", action="store_true", help="also measure the MuJoCo G1 closed loop's real-time factor")
    p_bench.add_argument("--out", default=None, help="write bench.json (and bench.md) into this directory")

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
    p_sweep.add_argument("--robot", default="g1", help="robot (g1)")
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
    p_sweep.add_argument("--duration", type=_finite_float("duration"), default=None,
                         help="simulated time after the push starts [s] (3 on the LIP, 6 in MuJoCo, where the "
                         "full robot can fall seconds after a push)")
    p_sweep.add_argument("--iterations", type=int, default=8,
                         help="bisection steps after the trial at the maximum; resolution = max / 2^N (8)")
    p_sweep.add_argument("--pushed-step", type=int, default=4,
                         help="which regular step is pushed, 1 = the first (4)")
    p_sweep.add_argument("--seed", type=_seed, default=0, help="base seed of the per-trial seeds (0)")
    p_sweep.add_argument("--whole-body", default=None, choices=("servo", "torque"),
                         help="mujoco only: torque (inverse-dynamics QP, the default) or servo")
    p_sweep.add_argument("--workers", type=int, default=None, help="parallel processes (default: CPU count)")
    p_sweep.add_argument("--backend", default="local", help="local (processes) or ray (needs `pip install ray`)")
    p_sweep.add_argument("--out", required=True, help="output directory")
    p_sweep.add_argument("--overwrite", action="store_true",
                         help="discard an earlier sweep in --out (without it, the same sweep resumes and a "
                         "different one is refused)")
    p_sweep.add_argument("--quiet", action="store_true", help="no progress on stderr")
    return parser


def _prepare_out(path: str, overwrite: bool) -> Path:
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise ParameterError(f"--out {path!r} exists and is not a directory")
    if out.exists() and any(out.iterdir()) and not overwrite:
        raise ParameterError(f"--out {path!r} exists and is not empty; pass --overwrite to write into it")
    out.mkdir(parents=True, exist_ok=True)
    return out


def _forces(args) -> tuple:
    from .forces import parse_force, parse_push

    return tuple(parse_force(s) for s in args.force) + tuple(parse_push(s) for s in args.push)


def _progress(args, label: str):
    if args.quiet or not sys.stderr.isatty():
        return None
    start = time.perf_counter()

    def report(t_s: float) -> None:
        sys.stderr.write(f"\r{label}: t = {t_s:6.1f} / {args.duration:.1f} s  ({time.perf_counter() - start:5.1f} s wall)")
        sys.stderr.flush()

    return report


def _end_progress(args) -> None:
    if not args.quiet:
        sys.stderr.write("\n")


def _spec(args, modules: tuple[str, ...]):
    from .planner import WalkCommand
    from .runner import RunSpec

    return RunSpec(
        robot=args.robot, sim=args.sim, modules=modules,
        command=WalkCommand(args.vx, args.vy, args.omega), duration_s=args.duration,
        forces=_forces(args), seed=args.seed, delta_max_mps2=args.delta_max, whole_body=args.whole_body,
    )


def _write_run(result, out: Path, title: str | None = None) -> None:
    from .io import atomic_write_json
    from .plotting import plot_run

    atomic_write_json(out / "summary.json", result.summary)
    result.trace.save(out / "trace.npz")
    plot_run(result.trace, out / "gait.png", title=title)


def _one_line(summary: dict) -> str:
    state = f"FELL ({summary['failure']})" if summary["fell"] else (
        "INTERRUPTED" if summary["failure"] == "interrupted" else "walked")
    return (
        f"{summary['robot']}/{summary['sim']}/{summary['controller']}: {state}; "
        f"{summary['duration_s']:.2f} s, {summary['distance_m']:.2f} m, {summary['steps_taken']} steps, "
        f"{summary['qp_infeasible_count']} infeasible QPs, cycle median {summary['cycle_ms']['median']} ms"
    )


def cmd_run(args) -> int:
    from .runner import parse_modules, run

    modules = parse_modules(args.controller, args.modules)
    spec = _spec(args, modules)
    out = _prepare_out(args.out, args.overwrite)
    video = out / "video.mp4" if args.video else None
    result = run(spec, progress=_progress(args, spec.controller_label), video_path=video)
    _end_progress(args)
    _write_run(result, out)
    print(_one_line(result.summary))
    print(f"wrote {out / 'summary.json'}, {out / 'gait.png'}, {out / 'trace.npz'}" + (f", {video}" if video else ""))
    if result.summary["failure"] == "interrupted":
        sys.stderr.write("ismpc: interrupted; the part of the run that finished was written\n")
        return 130
    return 0


def _compare_scenario(args) -> int:
    """``ismpc compare NAME``: both controllers on one seed of a named scenario."""
    from dataclasses import replace

    from .io import atomic_write_json
    from .plotting import plot_comparison
    from .runner import parse_modules
    from .scenarios import disturbance_events, get_scenario, run_scenario

    scenario = get_scenario(args.scenario)
    fixed = {"--robot": (args.robot, scenario.robot), "--sim": (args.sim, "mujoco")}
    for flag, (given, value) in fixed.items():
        if given is not None and given != value:
            raise ParameterError(f"scenario {scenario.name} runs {flag} {value}; drop {flag} {given}")
    for flag, given in (("--vx", args.vx), ("--vy", args.vy), ("--omega", args.omega), ("--delta-max", args.delta_max)):
        if given is not None:
            raise ParameterError(f"scenario {scenario.name} fixes its command and modules; {flag} is not allowed with it")
    if args.robust_modules is not None:
        scenario = replace(scenario, robust_modules=parse_modules("robust", args.robust_modules))
    if args.duration is not None:
        scenario = replace(scenario, duration_s=args.duration)
    args.duration = scenario.duration_s
    out = _prepare_out(args.out, args.overwrite)
    result = run_scenario(scenario, seed=args.seed, extra_forces=_forces(args),
                          progress=lambda label: _progress(args, label), video_dir=out if args.video else None,
                          whole_body=args.whole_body)
    for label, run_result in result.results.items():
        (out / label).mkdir(exist_ok=True)
        _end_progress(args)
        _write_run(run_result, out / label, title=f"{scenario.name} seed {args.seed}: {label}")
        print(_one_line(run_result.summary))
    comparison = result.comparison
    atomic_write_json(out / "comparison.json", comparison)
    traces = [r.trace for r in result.results.values()]
    labels = [f"{label} ({'+'.join(r.summary['modules']) or 'IS-MPC'})" for label, r in result.results.items()]
    plot_comparison(traces, labels, out / "comparison.png", title=f"{scenario.name}, seed {args.seed}: {scenario.paper}",
                    events=disturbance_events(result.run))
    dev = {k: comparison[k]["path_deviation"]["max_m"] for k in ("nominal", "robust")}
    print(f"{scenario.name} seed {args.seed}: nominal {'FELL' if comparison['nominal']['fell'] else 'walked'}, "
          f"robust {'FELL' if comparison['robust']['fell'] else 'walked'}; path deviation (stride-averaged max) "
          f"nominal {dev['nominal']} m, robust {dev['robust']} m; expected outcome: "
          f"{'yes' if comparison['expected_outcome'] else 'NO'}")
    print(f"wrote {out / 'comparison.json'}, {out / 'comparison.png'}, {out / 'nominal'}, {out / 'robust'}")
    return 0


def cmd_scenarios(args) -> int:
    from .scenarios import SCENARIOS

    width = max(len(n) for n in SCENARIOS)
    for name, scenario in SCENARIOS.items():
        print(f"{name:<{width}}  {scenario.summary}")
    return 0


def cmd_compare(args) -> int:
    from .io import atomic_write_json
    from .plotting import plot_comparison
    from .runner import parse_modules, run

    if args.scenario is not None:
        return _compare_scenario(args)
    for name, default in (("sim", "lip"), ("robot", "g1"), ("vx", 0.2), ("vy", 0.0), ("omega", 0.0), ("duration", 10.0)):
        if getattr(args, name) is None:
            setattr(args, name, default)
    robust_modules = parse_modules("robust", args.robust_modules or "observer,restriction,timing")
    out = _prepare_out(args.out, args.overwrite)
    results = {}
    for label, modules in (("nominal", ()), ("robust", robust_modules)):
        spec = _spec(args, modules)
        (out / label).mkdir(exist_ok=True)
        video = out / label / "video.mp4" if args.video else None
        results[label] = run(spec, progress=_progress(args, label), video_path=video)
        _end_progress(args)
        _write_run(results[label], out / label)
        print(_one_line(results[label].summary))
    comparison = {
        label: {k: r.summary[k] for k in ("fell", "failure", "distance_m", "steps_taken", "qp_infeasible_count",
                                          "max_zmp_violation_m", "timing_adaptations", "min_time_to_step_s",
                                          "disturbance_estimate_final", "modules")}
        for label, r in results.items()
    }
    comparison["robust_survives_nominal_fails"] = (not results["robust"].summary["fell"]) and results["nominal"].summary["fell"]
    atomic_write_json(out / "comparison.json", comparison)
    plot_comparison([r.trace for r in results.values()], list(results), out / "comparison.png",
                    title=f"{args.robot} on {args.sim}: nominal vs robust")
    print(f"wrote {out / 'comparison.json'}, {out / 'comparison.png'}")
    return 0


def cmd_soak(args) -> int:
    from .io import atomic_write_json
    from .runner import parse_modules
    from .soak import SoakSpec, run_soak

    spec = SoakSpec(robot=args.robot, sim=args.sim, duration_s=60.0 * args.minutes, push_max_n=args.push_max,
                    vx_mps=args.vx, seed=args.seed, modules=parse_modules("robust", args.modules),
                    whole_body=args.whole_body)
    out = _prepare_out(args.out, args.overwrite)
    args.duration = spec.duration_s
    args.quiet = False
    report, result = run_soak(spec, progress=_progress(args, "soak"))
    _end_progress(args)
    atomic_write_json(out / "soak.json", report)
    _write_run(result, out)
    state = "FELL" if report["fell"] else "no fall"
    print(f"soak {spec.robot}/{spec.sim}: {report['simulated_s']:.0f} s simulated in {report['wall_s']:.0f} s, "
          f"{report['pushes']} pushes (max {report['push_max_n']:.1f} N), {state}, "
          f"{report['qp_infeasible_count']} infeasible QPs, RSS {report['rss_mb'][0]['rss_mb']} -> "
          f"{report['rss_mb'][-1]['rss_mb']} MB (trace {report['trace_mb']} MB)")
    print(f"wrote {out / 'soak.json'}")
    return 0 if not report["fell"] else 1


def cmd_calibrate(args) -> int:
    from .io import atomic_write_json
    from .planner import WalkCommand
    from .plotting import plot_swing_cop_fit
    from .sim.calibrate import fit_swing_cop_gain

    out = _prepare_out(args.out, args.overwrite)
    fit = fit_swing_cop_gain(args.robot, WalkCommand(args.vx), duration_s=args.duration)
    report = {"robot": args.robot, "vx_mps": args.vx, "duration_s": args.duration, **fit.summary()}
    atomic_write_json(out / "calibration.json", report)
    plot_swing_cop_fit(fit.swing_acceleration_mps2, fit.cop_deviation_m, fit.gain_s2, fit.offset_m,
                       out / "calibration.png", title=f"{args.robot}: swing-leg CoP gain at {args.vx} m/s")
    print(f"{args.robot}: κ = {fit.gain_s2:.4f} s² (forward CoP deviation {100 * fit.rms_before_m:.2f} cm rms, "
          f"{100 * fit.rms_after_m:.2f} cm with κ a removed, {fit.samples} ticks); "
          f"in the robot's [gait]: swing_cop_gain_s2 = {fit.gain_s2:.4f}")
    print(f"wrote {out / 'calibration.json'}, {out / 'calibration.png'}")
    return 0


def cmd_bench(args) -> int:
    from .bench import format_table, run_bench, write_bench

    try:
        horizons = [int(h) for h in args.horizons.split(",")]
    except ValueError:
        raise ParameterError(f"--horizons must be comma-separated integers, got {args.horizons!r}") from None
    if any(h < 2 for h in horizons):
        raise ParameterError(f"--horizons must be >= 2 samples, got {args.horizons!r}")
    if args.cycles < 10:
        raise ParameterError(f"--cycles must be >= 10, got {args.cycles}")
    solvers = [s.strip() for s in args.solvers.split(",") if s.strip()]
    result = run_bench(args.robot, horizons, args.cycles, solvers, mujoco=args.mujoco)
    print(format_table(result))
    if args.out:
        paths = write_bench(result, Path(args.out))
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

    from .sweep import (
        DEFAULT_POST_PUSH_S,
        SweepConfig,
        frontier_table,
        parse_controllers,
        parse_directions,
        parse_phases,
        run_sweep,
    )

    config = SweepConfig(
        robot=args.robot, sim=args.sim, controllers=parse_controllers(args.controllers),
        directions_deg=parse_directions(args.direction), phases=parse_phases(args.phase),
        impulse_max_ns=args.impulse_max, force_max_n=args.force_max, push_duration_s=args.push_duration,
        vx_mps=args.vx, post_push_s=args.duration if args.duration is not None else DEFAULT_POST_PUSH_S.get(args.sim, 3.0),
        iterations=args.iterations, pushed_step=args.pushed_step,
        seed=args.seed, whole_body=args.whole_body,
    )
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


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING if args.verbose else logging.ERROR, format="%(levelname)s %(message)s")
    if args.command is None:
        parser.print_help()
        return 2
    handlers = {"run": cmd_run, "compare": cmd_compare, "bench": cmd_bench, "sweep": cmd_sweep, "soak": cmd_soak,
                "scenarios": cmd_scenarios, "calibrate": cmd_calibrate}
    try:
        return handlers[args.command](args)
    except IsmpcError as exc:
        sys.stderr.write(f"ismpc: error: {exc}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("\nismpc: interrupted; finished outputs were kept\n")
        return 130
    except Exception as exc:  # an internal error: one line, details only with --verbose
        logging.getLogger("robust_ismpc").debug("internal error", exc_info=True)
        sys.stderr.write(f"ismpc: internal error: {type(exc).__name__}: {exc} (rerun with --verbose for details)\n")
        if args.verbose:
            raise
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
