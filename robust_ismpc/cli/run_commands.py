"""``ismpc run``, ``ismpc compare`` and ``ismpc scenarios``: single walks, nominal vs robust, and
the named scenarios."""

from __future__ import annotations

from dataclasses import replace

from ..exceptions import ParameterError
from .common import (
    _check_sim_flags,
    _end_progress,
    _forces,
    _interrupted,
    _one_line,
    _open_out,
    _progress,
    _require,
    _spec,
    _warn,
    _write_run,
)


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
    from ..experiments.scenarios.realise import check_load_factor
    from ..io import atomic_write_json
    from ..plotting import plot_comparison
    from ..robots.mismatch import parse_mismatch

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
    load_factor = 1.0 if args.load_factor is None else check_load_factor(args.load_factor)
    # the name the titles and the last line give the run: the scenario, scaled when it is
    name = scenario.name if load_factor == 1.0 else f"{scenario.name} x{load_factor:g}"
    out = _open_out(args)
    labels = {"nominal": "nominal", "robust": _robust_label(scenario.robust_modules)}
    result = run_scenario(scenario, seed=args.seed, extra_forces=tuple(w for _, _, w in forces),
                          progress=lambda label: _progress(args, labels.get(label, label)),
                          video_dir=out if args.video else None, whole_body=args.whole_body,
                          sensing=args.sensing, mismatch=parse_mismatch(args.mismatch), load_factor=load_factor)
    for label, run_result in result.results.items():
        (out / label).mkdir(exist_ok=True)
        _end_progress(args)
        _write_run(run_result, out / label, title=f"{name} seed {args.seed}: {labels[label]}")
        print(_one_line(run_result.summary, labels[label]))
    if args.interrupts.requested:
        return _interrupted(args, f"the runs' finished parts were written to {out}; no comparison")
    comparison = {**result.comparison, "warnings": []}
    atomic_write_json(out / "comparison.json", comparison)
    traces = [r.trace for r in result.results.values()]
    names = [f"{label} ({'+'.join(r.summary['modules']) or 'IS-MPC'})" for label, r in result.results.items()]
    held = "held" if comparison["expected_outcome"] else "not held"
    plot_comparison(traces, names, out / "comparison.png",
                    title=f"{name} on {scenario.robot}, seed {args.seed}: the paper's outcome {held}",
                    events=disturbance_events(result.run))
    dev = {k: comparison[k]["path_deviation"]["max_m"] for k in ("nominal", "robust")}
    print(f"{name} seed {args.seed}: nominal {'FELL' if comparison['nominal']['fell'] else 'walked'}, "
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
    from ..experiments.scenarios.compare import compare_results, push_start_s
    from ..io import atomic_write_json
    from ..plotting import plot_comparison
    from ..runs.run import run
    from .inputs import check_modules_flags

    if args.scenario is not None:
        _require(args)
        return _compare_scenario(args)
    if args.load_factor is not None:
        raise ParameterError("--load-factor scales a named scenario's disturbances; without a scenario give them "
                             "with --force/--push")
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
    # the schema of a named scenario's comparison.json (compare.comparison_metrics), without a scenario
    nominal, robust = results.values()
    spec = specs["nominal"]
    comparison = {"scenario": None, "seed": args.seed, "paper": None, "realised": None,
                  **compare_results({"nominal": nominal, "robust": robust}, spec.command, push_start_s(spec.forces)),
                  "expected_outcome": None, "whole_body": nominal.summary["whole_body"],
                  "warnings": list(args.warnings)}
    atomic_write_json(out / "comparison.json", comparison)
    plot_comparison([r.trace for r in results.values()], list(results), out / "comparison.png",
                    title=f"{args.robot} on {args.sim}: nominal vs robust")
    print(f"wrote {out / 'comparison.json'}, {out / 'comparison.png'}")
    return 0
