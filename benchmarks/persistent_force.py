"""Largest persistent force held while standing, starting and walking, per direction.

Usage:
    python benchmarks/persistent_force.py ROBOT [--sim lip|mujoco] [--controllers nominal,robust]
        [--directions 0,45,...] [--cases stand_t0,...] [--sensing ideal|realistic] [--seed N]
        [--json OUT.json]

For each controller and direction (0 = forward, 90 = left), bisection on the force magnitude
[N] to a resolution of 0.25 % of the robot's weight, for these cases:

* ``stand_t0``: ``--vx 0``, the force switched on at t = 0, 10 s;
* ``stand_ramp_t0``: ``--vx 0``, ramped in over 1 s from t = 0, 10 s;
* ``walk_t0``: walking at the robot's usual speed, switched on at t = 0, 20 s;
* ``walk_ramp_t0``: walking, ramped in over 1 s from t = 0, 20 s;
* ``walk_on``: walking, switched on at 3 s + k/4 of a stride (k = 0..3, four phases), 9 s;
* ``walk_ramp3``: walking, ramped in over 1 s from 3 s, 9 s.

A run holds the force if it reaches its end without a fall, a persistent infeasible QP or a
diverged CoM (``summary["fell"]``). Prints one markdown row per controller and direction.
Under ``--sensing realistic`` every run draws its sensors' noise and bias from ``--seed``: one
trial per magnitude, so the frontier is that seed's.
"""

from __future__ import annotations

import argparse
import json
import logging
import math

from robust_ismpc.control.modules import MODULES
from robust_ismpc.core.planner import WalkCommand
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
    """Bisection on [0, upper_n] to ``resolution_n``; ``upper_n`` itself if it holds."""
    if survives(upper_n):
        return upper_n
    lo, hi = 0.0, upper_n
    while hi - lo > resolution_n:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if survives(mid) else (lo, mid)
    return lo


def frontier(robot: str, sim: str, modules, direction_deg: float, cases, sensing: str = "ideal",
             seed: int = 0) -> dict:
    params = gait_params(robot, sim)
    weight_n = params.mass_kg * 9.81
    resolution, upper = 0.0025 * weight_n, 0.25 * weight_n
    vx = WALK_SPEED_MPS.get(robot, 0.2)
    stride_s = 2 * params.T_step_s

    def case(speed, start, ramp, duration):
        return largest(resolution, upper, lambda f: holds(robot, sim, modules, speed, f, direction_deg, start,
                                                           ramp, duration, sensing, seed))

    row: dict = {}
    if "stand_t0" in cases:
        row["stand_t0"] = case(0.0, 0.0, 0.0, 10.0)
    if "stand_ramp_t0" in cases:
        row["stand_ramp_t0"] = case(0.0, 0.0, 1.0, 10.0)
    if "walk_t0" in cases:
        row["walk_t0"] = case(vx, 0.0, 0.0, 20.0)
    if "walk_ramp_t0" in cases:
        row["walk_ramp_t0"] = case(vx, 0.0, 1.0, 20.0)
    if "walk_on" in cases:
        row["walk_on"] = [case(vx, 3.0 + k * stride_s / 4, 0.0, 9.0) for k in range(4)]
    if "walk_ramp3" in cases:
        row["walk_ramp3"] = case(vx, 3.0, 1.0, 9.0)
    return row


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
    parser.add_argument("--json", default=None, help="also write the frontiers here")
    args = parser.parse_args()
    logging.disable(logging.WARNING)
    cases = [c for c in args.cases.split(",") if c]
    unknown = set(cases) - set(CASES)
    if unknown:
        parser.error(f"unknown cases {sorted(unknown)}; choose from {', '.join(CASES)}")
    results: dict = {}
    print("| controller | direction | " + " | ".join(cases) + " |")
    print("|---|---|" + "---|" * len(cases))
    for controller in args.controllers.split(","):
        modules = MODULES if controller == "robust" else ()
        for direction in (float(d) for d in args.directions.split(",")):
            row = frontier(args.robot, args.sim, modules, direction, cases, args.sensing, args.seed)
            results.setdefault(controller, {})[f"{direction:g}"] = row
            cells = [" / ".join(f"{v:.1f}" for v in row[c]) if isinstance(row[c], list) else f"{row[c]:.1f}"
                     for c in cases]
            print(f"| {controller} | {direction:g} | " + " | ".join(cells) + " |", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"robot": args.robot, "sim": args.sim, "sensing": args.sensing, "seed": args.seed,
                       "frontiers_n": results}, f, indent=1)


if __name__ == "__main__":
    main()
