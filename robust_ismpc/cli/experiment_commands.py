"""``ismpc soak``, ``ismpc calibrate``, ``ismpc bench`` and ``ismpc sweep``: long walks, the
swing-leg CoP fit, MPC timing and the push-recovery frontier."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from ..exceptions import ParameterError
from .common import (
    _check_sim_flags,
    _end_progress,
    _interrupted,
    _open_out,
    _progress,
    _require,
    _warn,
    _write_run,
)


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
                    modules=modules, whole_body=args.whole_body, sensing=args.sensing)
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
        from ..runs.spec import RunSpec

        RunSpec(robot=args.robot, sim="mujoco")  # --robot must have a MuJoCo model: fail before the long LIP rows
    from ..experiments.speed import check_repeats

    check_repeats(args.repeats)
    baseline = None
    if args.baseline is not None:
        baseline = _read_baseline(args.baseline)
    out = None
    if args.out is not None:
        out = _open_out(args, require_empty=False)
    from ..experiments.speed import commit, compare_speed, format_speed, measure_speed

    result = run_bench(args.robot, horizons, args.cycles, solvers)
    result["commit"] = commit()
    result["speed"] = measure_speed(args.repeats, mujoco=args.mujoco, progress=None if args.quiet else _say,
                                    robot=args.robot)
    if baseline is not None:
        result["comparison"] = compare_speed(result, baseline)
        result["baseline"] = {"path": str(Path(args.baseline).resolve()), "commit": baseline.get("commit"),
                              "date": baseline.get("date")}
    text = format_table(result) + "\n\n" + format_speed(result["speed"], result.get("comparison"))
    print(text)
    regressions = [c["row"] for c in result.get("comparison", []) if c["regression"]]
    if regressions:
        _warn(f"slower than the baseline by 10 % or more: {', '.join(regressions)}")
    if out is not None:
        paths = write_bench(result, out, text)
        print("wrote " + ", ".join(str(p) for p in paths))
    return 0


def _say(message: str) -> None:
    sys.stderr.write(f"bench: {message}\n")
    sys.stderr.flush()


def _read_baseline(path: str) -> dict:
    """The contents of a previous bench.json; ParameterError naming --baseline when unreadable."""
    try:
        data = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise ParameterError(f"--baseline {path!r}: no such file") from None
    except (OSError, ValueError) as exc:
        raise ParameterError(f"--baseline {path!r} is not a readable bench.json: {exc}") from None
    if not isinstance(data, dict) or "speed" not in data:
        raise ParameterError(f"--baseline {path!r} has no speed table (written by an older ismpc bench?)")
    return data


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
        seed=args.seed, whole_body=args.whole_body, sensing=args.sensing, repeats=args.repeats,
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
