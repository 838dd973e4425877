"""How much of a paper scenario's disturbance each controller holds: a frontier per seed.

Usage:
    python benchmarks/scenario_frontier.py SCENARIO [--seeds 0-9] [--upper 4] [--resolution 0.05]
        [--sensing ideal|realistic] [--workers 2] [--json OUT.json] [--plot OUT.png]
    python benchmarks/scenario_frontier.py --replot A.json [B.json ...] --plot OUT.png

The scenario's own disturbances (the bag's or the ball's mass, the forces' magnitudes) are
multiplied by a load factor (:func:`~robust_ismpc.experiments.scenarios.realise`, ``load_factor``;
1 = the scenario as ``ismpc compare SCENARIO --seed N`` runs it), and a bisection on that factor
over ``(0, upper]`` (``upper`` > 1) finds, per seed and controller (nominal; robust with the scenario's modules):

* ``walks``: the largest factor at which the run reaches its end without a fall or a persistent
  infeasible QP (``summary["fell"]``);
* ``keeps path`` (scenarios whose paper outcome is a path kept, paper-bag): the largest factor at
  which it also keeps its stride-averaged path deviation below 3 cm (``DEVIATION_MIN_M``).

Each bisection probes the factor 1 first (the scenario's own outcome), then halves its bracket
to ``resolution``; it assumes one boundary (a run that fails at a factor between two that hold
reads as the lower boundary's neighbour). Prints one markdown row per seed and a summary row;
``--plot`` draws the frontiers per seed (one panel per criterion), and ``--replot`` draws them
from earlier ``--json`` files, side by side, without running anything.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

CRITERIA = ("walks", "keeps path")
CONTROLLERS = ("nominal", "robust")


def largest(survives: Callable[[float], bool], upper: float, resolution: float) -> tuple[float, dict]:
    """Bisection on the load factor: (largest factor found to hold, {factor: held}).

    Probes 1 first (the sweep's :func:`~robust_ismpc.experiments.sweep.bisection.bisect` on
    [0, 1]); if 1 holds, bisects (1, ``upper``] the same way, ``upper`` first. Returns ``upper``
    when it holds and 0 when no probe down to ``resolution`` does.
    """
    from robust_ismpc.experiments.sweep.bisection import bisect, iterations_for_resolution

    below = bisect(survives, 1.0, iterations_for_resolution(1.0, resolution))
    probes = {round(k, 6): held for k, held in below.trials}
    if not below.saturated:
        return below.frontier, probes
    if upper - 1.0 <= resolution:  # (1, upper] is within the resolution: upper alone decides
        probes[round(upper, 6)] = held = bool(survives(upper))
        return (upper if held else 1.0), probes
    above = bisect(lambda k: survives(1.0 + k), upper - 1.0, iterations_for_resolution(upper - 1.0, resolution))
    probes.update({round(1.0 + k, 6): held for k, held in above.trials})
    return 1.0 + above.frontier, probes


def frontier(scenario: str, seed: int, controller: str, criterion: str, upper: float, resolution: float,
             sensing: str) -> dict:
    """One cell of the table: the bisection of ``criterion`` for ``controller`` on ``seed``."""
    logging.disable(logging.WARNING)
    from robust_ismpc.experiments.scenarios import realise
    from robust_ismpc.experiments.scenarios.compare import DEVIATION_MIN_M, path_deviation
    from robust_ismpc.runs.mujoco import run_mujoco_spec

    def survives(k: float) -> bool:
        realised = realise(scenario, seed, load_factor=k)
        spec = replace(realised.robust if controller == "robust" else realised.nominal, sensing=sensing)
        result = run_mujoco_spec(spec, scene_items=realised.scene_items)
        if result.summary["fell"]:
            return False
        if criterion == "walks":
            return True
        deviation = path_deviation(result.trace, realised.scenario.command)["max_m"]
        return deviation is not None and deviation < DEVIATION_MIN_M

    value, probes = largest(survives, upper, resolution)
    return {"seed": seed, "controller": controller, "criterion": criterion, "factor": value, "probes": probes}


def plot_frontiers(results: list[dict], path: str) -> None:
    """Per seed, each controller's largest load factor, one panel per scenario and criterion.

    ``results``: ``--json`` contents (keys ``scenario``, ``sensing``, ``cells``).
    """
    from robust_ismpc.plotting.figure import finish_figure, pyplot

    panels = [(r, k) for r in results for k in CRITERIA if any(c["criterion"] == k for c in r["cells"])]
    plt = pyplot()
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.6), squeeze=False)
    for ax, (result, criterion) in zip(axes[0], panels):
        for controller, marker, colour in (("nominal", "o", "tab:gray"), ("robust", "s", "tab:blue")):
            cells = sorted((c for c in result["cells"] if c["criterion"] == criterion and c["controller"] == controller),
                           key=lambda c: c["seed"])
            label = controller if controller == "nominal" else "robust (the scenario's modules)"
            ax.plot([c["seed"] for c in cells], [c["factor"] for c in cells], marker, color=colour, label=label,
                    linestyle="none")
        ax.axhline(1.0, color="k", linewidth=0.8, linestyle=":", label="the scenario (K = 1)")
        sensing = "" if result.get("sensing", "ideal") == "ideal" else f", {result['sensing']} sensing"
        ax.set_title(f"{result['scenario']}: {criterion}{sensing}", fontsize=10)
        ax.set_xlabel("seed")
        ax.set_ylabel("largest load factor K held")
        top = max((c["factor"] for c in result["cells"] if c["criterion"] == criterion and math.isfinite(c["factor"])),
                  default=1.0)  # a cell that failed has no factor
        ax.set_ylim(0.0, 1.1 * max(top, 1.0))
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=8, loc="lower left")
    finish_figure(plt, fig, path)


def _seeds(text: str) -> list[int]:
    if "-" in text:
        first, last = (int(v) for v in text.split("-", 1))
        return list(range(first, last + 1))
    return [int(v) for v in text.split(",") if v]


def main() -> None:
    from robust_ismpc.experiments.scenarios import SCENARIOS
    from robust_ismpc.robots.sensing import SENSING_PRESETS

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenario", nargs="?", choices=sorted(SCENARIOS))
    parser.add_argument("--seeds", default="0-9", help="seeds, as 0-9 or 0,3,5 (default 0-9)")
    parser.add_argument("--upper", type=float, default=4.0, help="largest load factor tried (4)")
    parser.add_argument("--resolution", type=float, default=0.05, help="bisection resolution (0.05)")
    parser.add_argument("--sensing", default="ideal", choices=sorted(SENSING_PRESETS))
    parser.add_argument("--workers", type=int, default=2, help="processes (2)")
    parser.add_argument("--json", default=None, help="also write every probe here")
    parser.add_argument("--plot", default=None, help="also draw the frontiers per seed here (PNG)")
    parser.add_argument("--replot", nargs="+", default=None, metavar="JSON",
                        help="draw --plot from these earlier --json files instead of running")
    args = parser.parse_args()
    if args.replot is not None:
        if args.plot is None or args.scenario is not None:
            parser.error("--replot draws earlier results: give --plot and no scenario")
        from robust_ismpc.exceptions import ParameterError
        from robust_ismpc.io import read_json

        try:
            results = [read_json(Path(name), "cells") for name in args.replot]
        except ParameterError as exc:
            parser.error(str(exc))
        plot_frontiers(results, args.plot)
        print(f"wrote {args.plot}")
        return
    if args.scenario is None:
        parser.error("give a scenario (or --replot JSON... --plot PNG)")
    if not (args.upper > 1 and 0 < args.resolution < 1 and args.workers >= 1):
        parser.error("need --upper > 1, 0 < --resolution < 1 and --workers >= 1")
    try:
        seeds = _seeds(args.seeds)
    except ValueError:
        parser.error(f"--seeds must read like 0-9 or 0,3,5, got {args.seeds!r}")
    criteria = CRITERIA if SCENARIOS[args.scenario].expect == "deviates" else CRITERIA[:1]
    try:
        results = _run(args, seeds, criteria)
    except KeyboardInterrupt:
        kept = f"; {args.json} keeps the finished cells" if args.json else ""
        print(f"interrupted{kept}", file=sys.stderr)
        raise SystemExit(130) from None
    _print_table(results, seeds, criteria)
    if args.plot:
        plot_frontiers([_saved(args, results)], args.plot)


def _saved(args, results: dict) -> dict:
    """The ``--json`` content: the settings and every finished cell with its probes."""
    return {"scenario": args.scenario, "sensing": args.sensing, "upper": args.upper, "resolution": args.resolution,
            "cells": [{**cell, "probes": {str(k): v for k, v in cell["probes"].items()}} for cell in results.values()]}


def _run(args, seeds: list[int], criteria) -> dict[tuple, dict]:
    """Every cell's bisection on ``args.workers`` processes; ``--json`` is rewritten after each
    finished cell, so that a run stopped or failed halfway keeps what it measured. A cell whose
    runs raise is reported and recorded with its error (factor NaN)."""
    from robust_ismpc.experiments.workers import each_completed
    from robust_ismpc.io import atomic_write_json

    cells = [(s, c, k) for s in seeds for c in CONTROLLERS for k in criteria]
    tasks = [(args.scenario, s, c, k, args.upper, args.resolution, args.sensing) for s, c, k in cells]
    results: dict[tuple, dict] = {}
    for done, (i, cell, exc) in enumerate(each_completed(frontier, tasks, args.workers), 1):
        seed, controller, criterion = cells[i]
        if exc is not None:  # one failed cell must not lose the others
            cell = {"seed": seed, "controller": controller, "criterion": criterion, "factor": math.nan,
                    "probes": {}, "error": f"{type(exc).__name__}: {exc}"}
        results[cells[i]] = cell
        outcome = cell.get("error") or f"{cell['factor']:.3f}"
        print(f"[{done}/{len(cells)}] seed {seed} {controller} {criterion}: {outcome}", file=sys.stderr, flush=True)
        if args.json:
            atomic_write_json(Path(args.json), _saved(args, results))
    return results


def _print_table(results: dict, seeds: list[int], criteria) -> None:
    """One markdown row per seed, a min / median / max row, and the seeds robust is above and
    below nominal on (cells that failed read "error" and are left out)."""
    columns = [(c, k) for k in criteria for c in CONTROLLERS]
    print("| seed | " + " | ".join(f"{c} {k}" for c, k in columns) + " |")
    print("|---|" + "---|" * len(columns))
    for s in seeds:
        factors = (results[(s, c, k)]["factor"] for c, k in columns)
        print(f"| {s} | " + " | ".join("error" if math.isnan(v) else f"{v:.2f}" for v in factors) + " |")
    summary = []
    for c, k in columns:
        values = np.array([results[(s, c, k)]["factor"] for s in seeds])
        values = values[np.isfinite(values)]
        summary.append(f"{values.min():.2f} / {np.median(values):.2f} / {values.max():.2f}" if values.size else "-")
    print("| min / median / max | " + " | ".join(summary) + " |")
    for k in criteria:
        pairs = [(results[(s, "robust", k)]["factor"], results[(s, "nominal", k)]["factor"]) for s in seeds]
        above = sum(r > n for r, n in pairs)
        below = sum(r < n for r, n in pairs)
        print(f"\n{k}: robust above nominal on {above} of {len(seeds)} seeds, below on {below}")

if __name__ == "__main__":
    main()
