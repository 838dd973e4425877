"""The LIP cycle time of several checkouts of this repository, measured run by run in alternation.

Usage: python benchmarks/compare_checkouts.py CHECKOUT [CHECKOUT ...] [--rounds 8] [--instructions]
       > compare.md

A shared or virtual machine drifts by tens of percent within minutes, so two codes measured one
after the other can differ by more than the change between them. Here every round runs a 20 s
G1 walk on the reduced model (nominal, then robust) on each checkout in turn, in a fresh process
with that checkout first on ``PYTHONPATH``, and the table gives the medians over the rounds and
the median of the per-round ratios to the first checkout, with their range.

``--instructions`` also counts the instructions of one cycle (valgrind's callgrind, which must
be installed): the difference between a 6 s and a 2 s walk, over the 400 cycles between them.
The count is the same on every run, so it resolves changes that wall time cannot; it weighs a
cache miss like any other instruction.

Checkouts from before the package was split into layers (``robust_ismpc.runner``) work too.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

WALK = """
import sys
try:
    from robust_ismpc.runs.run import run
    from robust_ismpc.runs.spec import RunSpec
    from robust_ismpc.core.planner import WalkCommand
except ImportError:  # checkouts before the layered package
    from robust_ismpc.runner import RunSpec, run
    from robust_ismpc.planner import WalkCommand
modules = () if sys.argv[1] == "nominal" else ("observer", "restriction", "timing")
summary = run(RunSpec(robot="g1", sim="lip", modules=modules, command=WalkCommand(0.2),
                      duration_s=float(sys.argv[2]))).summary
print(summary["cycle_ms"]["median"], summary["cycle_ms"]["p99"])
"""
CONTROLLERS = ("nominal", "robust")


def _environment(checkout: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(checkout))
    env.setdefault("MUJOCO_GL", "egl")
    return env


def cycle_ms(checkout: Path, controller: str) -> tuple[float, float]:
    """Median and p99 of the cycle time of one 20 s walk [ms]."""
    done = subprocess.run([sys.executable, "-c", WALK, controller, "20"], cwd=checkout, env=_environment(checkout),
                          capture_output=True, text=True, check=True)
    median, p99 = done.stdout.split()[-2:]
    return float(median), float(p99)


def instructions_per_cycle(checkout: Path, controller: str) -> float:
    """Instructions of one cycle (controller, plant and trace), from two walks under callgrind."""
    counts = []
    for seconds in ("2", "6"):
        done = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null", sys.executable, "-c",
                               WALK, controller, seconds], cwd=checkout, env=_environment(checkout),
                              capture_output=True, text=True, check=True)
        line = next(line for line in done.stderr.splitlines() if "Collected" in line)
        counts.append(int(line.split()[-1]))
    return (counts[1] - counts[0]) / 400


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checkouts", nargs="+", type=Path)
    parser.add_argument("--rounds", type=int, default=8)
    parser.add_argument("--instructions", action="store_true")
    args = parser.parse_args()
    checkouts = [path.resolve() for path in args.checkouts]
    for path in checkouts:
        if not (path / "robust_ismpc").is_dir():
            parser.error(f"{path} is not a checkout of this repository (no robust_ismpc/ in it)")
    samples: dict = {(path, c): [] for path in checkouts for c in CONTROLLERS}
    for k in range(args.rounds):
        for path in checkouts:
            for controller in CONTROLLERS:
                samples[path, controller].append(cycle_ms(path, controller))
        print(f"round {k + 1}/{args.rounds} done", file=sys.stderr)
    print("| checkout | controller | cycle median [ms] | p99 [ms] | median / first's (range) |"
          + (" instructions per cycle |" if args.instructions else ""))
    print("|---|---|---|---|---|" + ("---|" if args.instructions else ""))
    for controller in CONTROLLERS:
        first = samples[checkouts[0], controller]
        for path in checkouts:
            runs = samples[path, controller]
            ratios = sorted(b[0] / a[0] for a, b in zip(first, runs))
            row = (f"| {path.name} | {controller} | {statistics.median(r[0] for r in runs):.3f} "
                   f"| {statistics.median(r[1] for r in runs):.3f} "
                   f"| {statistics.median(ratios):.2f} ({ratios[0]:.2f}-{ratios[-1]:.2f}) |")
            if args.instructions:
                row += f" {instructions_per_cycle(path, controller) / 1e6:.2f} M |"
            print(row)


if __name__ == "__main__":
    main()
