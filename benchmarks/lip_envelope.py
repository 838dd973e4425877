"""Largest constant force and impulse survived on the LIP by each module combination.

Usage: python benchmarks/lip_envelope.py [ROBOT] > envelope.md

For each module combination, bisection (8 steps) on the magnitude of
  * a constant force switched on at t = 3.0 s (walking at 0.2 m/s), sagittal (+x) and coronal (+y);
  * a 0.1 s push starting 0.05 s into the single support of step 5, in +x, -x, +y, -y.
A run survives if it walks to the end (12 s) without a persistent infeasible QP or divergence.
"""

from __future__ import annotations

import logging
import sys
import time

import numpy as np

from robust_ismpc.core.params import robot_params
from robust_ismpc.core.planner import WalkCommand, plan_footsteps
from robust_ismpc.runs.forces import ForceWindow
from robust_ismpc.runs.run import run
from robust_ismpc.runs.spec import RunSpec

COMBOS = [(), ("observer",), ("restriction",), ("timing",), ("observer", "timing"), ("observer", "restriction", "timing")]


def survives(robot: str, modules, forces, duration: float) -> bool:
    spec = RunSpec(robot=robot, modules=tuple(modules), command=WalkCommand(0.2), duration_s=duration, forces=tuple(forces))
    return not run(spec).summary["fell"]


def largest(robot, modules, make_forces, hi, duration, steps=8):
    lo = 0.0
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        if survives(robot, modules, make_forces(mid), duration):
            lo = mid
        else:
            hi = mid
    return lo


def main() -> None:
    logging.disable(logging.WARNING)
    robot = sys.argv[1] if len(sys.argv) > 1 else "g1"
    params = robot_params(robot)
    left = np.array([0.0, 0.5 * params.foot_spacing_m])
    plan = plan_footsteps(params, WalkCommand(0.2), 20.0, left, -left)
    t_push = float(plan.ss_start_s[5] + 0.05)
    scale = params.mass_kg / 33.3
    cases = {
        "const +x [N]": (lambda f: [ForceWindow(f, 0.0, 3.0)], 80 * scale),
        "const +y [N]": (lambda f: [ForceWindow(0.0, f, 3.0)], 40 * scale),
        "push +x [N]": (lambda f: [ForceWindow(f, 0.0, t_push, t_push + 0.1)], 300 * scale),
        "push -x [N]": (lambda f: [ForceWindow(-f, 0.0, t_push, t_push + 0.1)], 300 * scale),
        "push +y [N]": (lambda f: [ForceWindow(0.0, f, t_push, t_push + 0.1)], 200 * scale),
        "push -y [N]": (lambda f: [ForceWindow(0.0, -f, t_push, t_push + 0.1)], 200 * scale),
    }
    start = time.perf_counter()
    print(f"# LIP envelope, robot {robot} (mass {params.mass_kg} kg), push at t = {t_push:.2f} s, 0.1 s\n")
    print("| modules | " + " | ".join(cases) + " |")
    print("|---|" + "---|" * len(cases))
    for combo in COMBOS:
        values = [largest(robot, combo, make, hi, 12.0) for make, hi in cases.values()]
        print(f"| {'+'.join(combo) or 'nominal'} | " + " | ".join(f"{v:.1f}" for v in values) + " |", flush=True)
    print(f"\nwall time {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
