"""Largest persistent force held while standing, starting and walking, per direction.

Usage:
    python benchmarks/persistent_force.py ROBOT [--sim lip|mujoco] [--controllers nominal,robust]
        [--directions 0,45,...] [--cases stand_t0,...] [--sensing ideal|realistic] [--seed N]
        [--workers 2] [--json OUT.json]

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
end. Under ``--sensing realistic`` every run draws its sensors' noise and bias from ``--seed``:
one trial per magnitude, so the frontier is that seed's.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from robust_ismpc.control.modules import MODULES
from robust_ismpc.core.planner import WalkCommand
from robust_ismpc.experiments.sweep.bisection import bisect
from robust_ismpc.io import atomic_write_json
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
    iterations = max(1, math.ceil(math.log2(upper_n / resolution_n)))
    return bisect(survives, upper_n, iterations).frontier


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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("robot")
    parser.add_argument("--sim", default="lip")
    parser.add_argument("--controllers", default="nominal,robust")
    parser.add_argument("--directions", default="0,45,90,135,180,225,270,315")
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--sensing", default="ideal", choices=sorted(SENSING_PRESETS),
                        help="what the controller reads (default ideal)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the sensors' noise and bias (0)")
    parser.add_argument("--workers", type=int, default=2, help="processes (2)")
    parser.add_argument("--json", default=None, help="also write the frontiers here, after each bisection")
    args = parser.parse_args()
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
    results: dict[tuple, float] = {}
    errors: dict[str, str] = {}
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        futures = {pool.submit(bisection, args.robot, args.sim, c, d, case, k, args.sensing, args.seed): (c, d, case, k)
                   for c, d, case, k in cells}
        for done, future in enumerate(as_completed(futures), 1):
            c, d, case, k = cell = futures[future]
            name = f"{c} {d:g} {case}" + ("" if k is None else f" onset {k}")
            try:
                results[cell] = future.result()
                outcome = f"{results[cell]:.1f} N"
            except Exception as exc:  # noqa: BLE001  (one failed bisection must not lose the others)
                results[cell] = math.nan
                errors[name] = outcome = f"{type(exc).__name__}: {exc}"
            print(f"[{done}/{len(cells)}] {name}: {outcome}", file=sys.stderr, flush=True)
            if args.json:
                atomic_write_json(Path(args.json), {
                    "robot": args.robot, "sim": args.sim, "sensing": args.sensing, "seed": args.seed,
                    "frontiers_n": _frontiers(results, controllers, directions, cases), "errors": errors})
    frontiers = _frontiers(results, controllers, directions, cases)
    print("| controller | direction | " + " | ".join(cases) + " |")
    print("|---|---|" + "---|" * len(cases))
    for c in controllers:
        for d in directions:
            row = frontiers[c][f"{d:g}"]
            cells_md = [" / ".join(f"{v:.1f}" for v in row[case]) if case == "walk_on" else f"{row[case]:.1f}"
                        for case in cases]
            print(f"| {c} | {d:g} | " + " | ".join(cells_md) + " |")


if __name__ == "__main__":
    main()
