"""Largest persistent force held while standing, starting and walking, per direction.

Usage:
    python benchmarks/persistent_force.py ROBOT [--sim lip|mujoco] [--controllers nominal,robust]
        [--directions 0,45,...] [--cases stand_t0,...] [--sensing ideal|realistic] [--seed N]
        [--workers 2] [--json OUT.json] [--plot OUT.png]
    python benchmarks/persistent_force.py --replot A.json [B.json ...] --plot OUT.png

For each controller and direction (0 = forward, 90 = left), bisection on the force magnitude
[N] to a resolution of 0.25 % of the robot's weight, for these cases:

* ``stand_t0``: ``--vx 0``, the force switched on at t = 0, 10 s;
* ``stand_ramp_t0``: ``--vx 0``, ramped in over 1 s from t = 0, 10 s;
* ``walk_t0``: walking at the robot's usual speed, switched on at t = 0, 20 s;
* ``walk_ramp_t0``: walking, ramped in over 1 s from t = 0, 20 s;
* ``walk_on``: walking, switched on at 3 s + k/4 of a stride (k = 0..3, four phases), 9 s;
* ``walk_ramp3``: walking, ramped in over 1 s from 3 s, 9 s.

A run holds the force if it reaches its end without a fall, a persistent infeasible QP or a
diverged CoM (``summary["fell"]``). Each bisection (one case, one onset of ``walk_on``) runs on
one of ``--workers`` processes; progress goes to stderr, ``--json`` is rewritten after each
finished bisection (a stopped run keeps what it measured; a bisection whose runs raise is
recorded with its error), and one markdown row per controller and direction is printed at the
end. ``--plot`` draws the frontiers on polar axes, one panel per controller and one line per
case (``walk_on``: its weakest onset), and ``--replot`` draws them from earlier ``--json``
files without running anything (files of one robot, simulator and sensing are merged, so runs
split by direction or case draw together; one row of panels per robot). Under ``--sensing
realistic`` every run draws its sensors' noise and bias from ``--seed``: one trial per
magnitude, so the frontier is that seed's.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
from pathlib import Path

from robust_ismpc.control.modules import MODULES
from robust_ismpc.core.planner import WalkCommand
from robust_ismpc.exceptions import ParameterError
from robust_ismpc.experiments.sweep.bisection import bisect, iterations_for_resolution
from robust_ismpc.experiments.workers import each_completed
from robust_ismpc.io import atomic_write_json, read_json
from robust_ismpc.robots.sensing import SENSING_PRESETS
from robust_ismpc.runs.forces import ramped_force
from robust_ismpc.runs.run import run
from robust_ismpc.runs.spec import RunSpec, gait_params

WALK_SPEED_MPS = {"g1": 0.2, "op3": 0.1, "t1": 0.2, "apollo": 0.2}
CASES = ("stand_t0", "stand_ramp_t0", "walk_t0", "walk_ramp_t0", "walk_on", "walk_ramp3")


def holds(robot: str, sim: str, modules, vx: float, force_n: float, direction_deg: float, start_s: float,
          ramp_s: float, duration_s: float, sensing: str = "ideal", seed: int = 0) -> bool:
    c, s = math.cos(math.radians(direction_deg)), math.sin(math.radians(direction_deg))
    forces = ramped_force(force_n * c, force_n * s, start_s, ramp_s) if force_n > 0 else ()
    spec = RunSpec(robot=robot, sim=sim, modules=tuple(modules), command=WalkCommand(vx), duration_s=duration_s,
                   forces=forces, sensing=sensing, seed=seed)
    return not run(spec).summary["fell"]


def largest(resolution_n: float, upper_n: float, survives) -> float:
    """The sweep's bisection (:func:`~robust_ismpc.experiments.sweep.bisection.bisect`) on [0,
    ``upper_n``], ``upper_n`` first, until the bracket is within ``resolution_n``: the largest
    force found to hold (``upper_n`` itself if it holds, 0 if no probe does)."""
    return bisect(survives, upper_n, iterations_for_resolution(upper_n, resolution_n)).frontier


def bisection(robot: str, sim: str, controller: str, direction_deg: float, case: str, onset: int | None,
              sensing: str = "ideal", seed: int = 0) -> float:
    """The largest force [N] one case holds (``onset``: k of ``walk_on``, else None)."""
    logging.disable(logging.WARNING)
    modules = MODULES if controller == "robust" else ()
    params = gait_params(robot, sim)
    weight_n = params.mass_kg * 9.81
    vx = WALK_SPEED_MPS.get(robot, 0.2)
    speed, start, ramp, duration = {
        "stand_t0": (0.0, 0.0, 0.0, 10.0),
        "stand_ramp_t0": (0.0, 0.0, 1.0, 10.0),
        "walk_t0": (vx, 0.0, 0.0, 20.0),
        "walk_ramp_t0": (vx, 0.0, 1.0, 20.0),
        "walk_on": (vx, 3.0 + (onset or 0) * 2 * params.T_step_s / 4, 0.0, 9.0),
        "walk_ramp3": (vx, 3.0, 1.0, 9.0),
    }[case]
    return largest(0.0025 * weight_n, 0.25 * weight_n,
                   lambda f: holds(robot, sim, modules, speed, f, direction_deg, start, ramp, duration, sensing, seed))


def _cells(controllers: list[str], directions: list[float], cases: list[str]) -> list[tuple]:
    """Every bisection: (controller, direction, case, onset), the four onsets of ``walk_on`` apart."""
    return [(c, d, case, k) for c in controllers for d in directions for case in cases
            for k in ((0, 1, 2, 3) if case == "walk_on" else (None,))]


def _frontiers(results: dict, controllers, directions, cases) -> dict:
    """``{controller: {direction: {case: N, "walk_on": [N x 4]}}}`` of the finished bisections
    (NaN where one raised, None where one has not finished)."""
    out: dict = {}
    for c in controllers:
        for d in directions:
            row = out.setdefault(c, {}).setdefault(f"{d:g}", {})
            for case in cases:
                if case == "walk_on":
                    row[case] = [results.get((c, d, case, k)) for k in range(4)]
                else:
                    row[case] = results.get((c, d, case, None))
    return out


CASE_LABELS = {
    "stand_t0": "stand, on from t = 0",
    "stand_ramp_t0": "stand, ramped in from t = 0",
    "walk_t0": "walk, on from t = 0",
    "walk_ramp_t0": "walk, ramped in from t = 0",
    "walk_on": "walk, switched on at 3 s (weakest of 4 onsets)",
    "walk_ramp3": "walk, ramped in from 3 s",
}


def _case_value(value) -> float:
    """A case's frontier [N] as a float: ``walk_on``'s weakest onset; NaN if none finished."""
    if isinstance(value, list):
        finished = [v for v in value if v is not None and math.isfinite(v)]
        return min(finished) if len(finished) == len(value) else math.nan
    return math.nan if value is None else float(value)


def merged(results: list[dict]) -> list[dict]:
    """``--json`` contents of the same robot, simulator and sensing merged into one (a later file's
    finished cells replace an earlier one's), so runs split by direction or case draw together."""
    out: dict[tuple, dict] = {}
    for result in results:
        key = (result["robot"], result["sim"], result.get("sensing", "ideal"))
        into = out.setdefault(key, {"robot": key[0], "sim": key[1], "sensing": key[2], "frontiers_n": {}})
        for controller, table in result["frontiers_n"].items():
            for direction, row in table.items():
                cells = into["frontiers_n"].setdefault(controller, {}).setdefault(direction, {})
                cells.update({case: v for case, v in row.items() if not _unfinished(v)})
    return list(out.values())


def _unfinished(value) -> bool:
    return value is None or (isinstance(value, list) and all(v is None for v in value))


def plot_frontiers(results: list[dict], path: str) -> None:
    """Polar frontiers, one row per robot (:func:`merged` contents) and one panel per controller:
    radius the largest force held [N], angle its direction (0 = forward, 90 = left), one line per
    case."""
    import numpy as np

    from robust_ismpc.plotting.figure import pyplot, save_figure

    panels = [(r, c) for r in results for c in r["frontiers_n"]]
    rows = len(results)
    cols = max(len(r["frontiers_n"]) for r in results)
    colours = dict(zip(CASES, ("tab:blue", "tab:cyan", "tab:orange", "tab:olive", "tab:green", "tab:red")))
    plt = pyplot()
    fig = plt.figure(figsize=(4.6 * cols, 4.4 * rows + 0.9))
    drawn: dict[str, object] = {}
    for result, controller in panels:
        row = results.index(result)
        col = list(result["frontiers_n"]).index(controller)
        ax = fig.add_subplot(rows, cols, row * cols + col + 1, projection="polar")
        table = result["frontiers_n"][controller]
        directions = sorted(table, key=float)
        closed = directions + directions[:1] if len(directions) >= 3 else directions
        theta = np.radians([float(d) for d in closed])
        for case in CASES:
            if any(case in table[d] for d in directions):
                radius = np.array([_case_value(table[d].get(case)) for d in closed])
                (drawn[case],) = ax.plot(theta, radius, "o-", ms=3, lw=1.3, color=colours[case])
        ax.set_theta_zero_location("E")
        ax.set_ylim(bottom=0.0)
        sensing = "" if result.get("sensing", "ideal") == "ideal" else f", {result['sensing']} sensing"
        ax.set_title(f"{result['robot']} / {result['sim']}, {controller}{sensing}", fontsize=10)
    cases = [c for c in CASES if c in drawn]
    fig.legend([drawn[c] for c in cases], [CASE_LABELS[c] for c in cases], loc="lower center",
               ncol=min(3, len(cases)), fontsize=8, frameon=False)
    fig.suptitle("Largest persistent force held [N] by direction (0° forward, 90° left)", fontsize=11)
    fig.tight_layout(rect=(0.0, 0.9 / (4.4 * rows + 0.9), 1.0, 0.97))
    save_figure(fig, path, crop=False)
    plt.close(fig)


def _measure(args, cells: list[tuple], controllers, directions, cases) -> dict[tuple, float]:
    """Every bisection of ``cells`` on ``args.workers`` processes: progress on stderr, ``--json``
    rewritten after each; a bisection that raises is recorded with its error (NaN)."""
    results: dict[tuple, float] = {}
    errors: dict[str, str] = {}
    tasks = [(args.robot, args.sim, c, d, case, k, args.sensing, args.seed) for c, d, case, k in cells]
    for done, (i, value, exc) in enumerate(each_completed(bisection, tasks, args.workers), 1):
        c, d, case, k = cell = cells[i]
        name = f"{c} {d:g} {case}" + ("" if k is None else f" onset {k}")
        if exc is None:
            results[cell] = value
            outcome = f"{value:.1f} N"
        else:  # one failed bisection must not lose the others
            results[cell] = math.nan
            errors[name] = outcome = f"{type(exc).__name__}: {exc}"
        print(f"[{done}/{len(cells)}] {name}: {outcome}", file=sys.stderr, flush=True)
        if args.json:
            atomic_write_json(Path(args.json), {
                "robot": args.robot, "sim": args.sim, "sensing": args.sensing, "seed": args.seed,
                "frontiers_n": _frontiers(results, controllers, directions, cases), "errors": errors})
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("robot", nargs="?")
    parser.add_argument("--sim", default="lip")
    parser.add_argument("--controllers", default="nominal,robust")
    parser.add_argument("--directions", default="0,45,90,135,180,225,270,315")
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--sensing", default="ideal", choices=sorted(SENSING_PRESETS),
                        help="what the controller reads (default ideal)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the sensors' noise and bias (0)")
    parser.add_argument("--workers", type=int, default=2, help="processes (2)")
    parser.add_argument("--json", default=None, help="also write the frontiers here, after each bisection")
    parser.add_argument("--plot", default=None, help="also draw the frontiers here (PNG)")
    parser.add_argument("--replot", nargs="+", default=None, metavar="JSON",
                        help="draw --plot from these earlier --json files instead of running")
    args = parser.parse_args()
    if args.replot is not None:
        if args.plot is None or args.robot is not None:
            parser.error("--replot draws earlier results: give --plot and no robot")
        try:
            saved = [read_json(Path(name), "frontiers_n") for name in args.replot]
        except ParameterError as exc:
            parser.error(str(exc))
        plot_frontiers(merged(saved), args.plot)
        print(f"wrote {args.plot}")
        return
    if args.robot is None:
        parser.error("give a robot (or --replot JSON... --plot PNG)")
    cases = [c for c in args.cases.split(",") if c]
    unknown = set(cases) - set(CASES)
    if unknown:
        parser.error(f"unknown cases {sorted(unknown)}; choose from {', '.join(CASES)}")
    controllers = [c for c in args.controllers.split(",") if c]
    if set(controllers) - {"nominal", "robust"}:
        parser.error(f"--controllers takes nominal and robust, got {args.controllers!r}")
    try:
        directions = [float(d) for d in args.directions.split(",") if d]
    except ValueError:
        parser.error(f"--directions must be numbers [deg] separated by commas, got {args.directions!r}")
    if args.workers < 1:
        parser.error("--workers must be >= 1")
    cells = _cells(controllers, directions, cases)
    try:
        results = _measure(args, cells, controllers, directions, cases)
    except KeyboardInterrupt:
        kept = f"; {args.json} keeps the finished bisections" if args.json else ""
        print(f"interrupted{kept}", file=sys.stderr)
        raise SystemExit(130) from None
    frontiers = _frontiers(results, controllers, directions, cases)
    print("| controller | direction | " + " | ".join(cases) + " |")
    print("|---|---|" + "---|" * len(cases))
    for c in controllers:
        for d in directions:
            row = frontiers[c][f"{d:g}"]
            cells_md = [" / ".join(f"{v:.1f}" for v in row[case]) if case == "walk_on" else f"{row[case]:.1f}"
                        for case in cases]
            print(f"| {c} | {d:g} | " + " | ".join(cells_md) + " |")
    if args.plot:
        plot_frontiers([{"robot": args.robot, "sim": args.sim, "sensing": args.sensing, "frontiers_n": frontiers}],
                       args.plot)
        print(f"wrote {args.plot}", file=sys.stderr)


if __name__ == "__main__":
    main()
