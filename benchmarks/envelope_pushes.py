"""Pushes on a full robot with and without the DCM error envelope, nominal and timing adaptation.

Usage: python benchmarks/envelope_pushes.py [--robot g1] [--whole-body torque] [--direction 90]
                                            [--phases 0.25,0.5] [--impulses 6,8,10]

The envelope is measured on an undisturbed run of the same walk (0.2 m/s forward, 12 s,
:func:`robust_ismpc.scenarios.measure_dcm_error_envelope`), as paper-ball does. Each push lasts
0.1 s and starts at ``phase`` of the single support of regular step 4 (where ``ismpc sweep``
puts it); a run lasts until 6 s after the push. Prints one markdown row per push: for nominal,
nominal + envelope, timing, timing + envelope, "walks" or the fall time, and the number of
timing adaptations. docs/scenarios.md ("The DCM error envelope") has the G1 table.
"""

from __future__ import annotations

import argparse
import logging
import math
from dataclasses import replace

import numpy as np

from robust_ismpc.forces import ForceWindow
from robust_ismpc.planner import WalkCommand
from robust_ismpc.runner import RunSpec
from robust_ismpc.scenarios import measure_dcm_error_envelope
from robust_ismpc.sim.run import run_mujoco_spec, walk_settings
from robust_ismpc.sweep import SweepConfig

PUSH_S = 0.1
AFTER_PUSH_S = 6.0


def _floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",")]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="g1")
    parser.add_argument("--whole-body", default="torque", choices=("servo", "torque"))
    parser.add_argument("--direction", type=float, default=90.0, help="push direction [deg], 0 = forward")
    parser.add_argument("--phases", type=_floats, default=[0.25, 0.5])
    parser.add_argument("--impulses", type=_floats, default=[6.0, 8.0, 10.0], help="[N s]")
    args = parser.parse_args()
    logging.disable(logging.WARNING)

    walk = RunSpec(robot=args.robot, sim="mujoco", command=WalkCommand(0.2), duration_s=12.0, whole_body=args.whole_body)
    envelope = measure_dcm_error_envelope(walk)
    print(f"envelope [mm]: {np.round(1e3 * np.asarray(envelope), 1).tolist()}\n")
    config = SweepConfig(robot=args.robot, sim="mujoco", controllers=("nominal",), directions_deg=(args.direction,),
                         phases=tuple(args.phases), impulse_max_ns=max(args.impulses), whole_body=args.whole_body)
    settings = walk_settings(args.robot)
    print("| phase | impulse [N s] | nominal | nominal + envelope | timing | timing + envelope |")
    print("|---|---|---|---|---|---|")
    for phase in args.phases:
        start = config.push_start_s(phase)
        for impulse in args.impulses:
            force = impulse / PUSH_S
            push = ForceWindow(force * math.cos(math.radians(args.direction)),
                               force * math.sin(math.radians(args.direction)), start, start + PUSH_S)
            cells = []
            for modules in ((), ("timing",)):
                for env in (None, envelope):
                    spec = replace(walk, modules=modules, forces=(push,), duration_s=start + AFTER_PUSH_S)
                    summary = run_mujoco_spec(spec, settings=replace(settings, dcm_error_envelope_m=env)).summary
                    outcome = f"falls {summary['duration_s']:.1f} s" if summary["fell"] else "walks"
                    cells.append(f"{outcome} ({summary['timing_adaptations']})" if modules else outcome)
            print(f"| {phase} | {impulse} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
