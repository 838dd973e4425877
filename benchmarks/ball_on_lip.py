"""paper-ball's hit replayed on the reduced model (LIP), where the MPC sees the hit.

Usage: python benchmarks/ball_on_lip.py [--runs PATTERN] [SEED ...] > ball_on_lip.md

For each seed (default 0-5) the scenario is realised as ``ismpc compare paper-ball --seed N``
realises it (hit time, ball momentum). The hit is replayed on OP3's LIP as a 10 ms forward push
of the same size at the same instant, for nominal IS-MPC and for the scenario's robust modules
(timing adaptation only). With ``--runs PATTERN`` (a path containing ``{seed}``, e.g.
``runs/paper-ball-{seed}``, the ``--out`` of earlier ``ismpc compare`` runs) the replay uses the
impulse and contact time measured in MuJoCo instead of the ball's momentum and the planned hit,
and the table also shows the MuJoCo outcome.

On the robots the MPC runs on its internal model, so the MuJoCo robot's MPC never sees the hit;
this replay shows what the same hit does to the controllers when it does (docs/scenarios.md).
"""

from __future__ import annotations

import argparse
import json
import logging
from dataclasses import replace
from pathlib import Path

from robust_ismpc.experiments.scenarios import realise
from robust_ismpc.runs.forces import ForceWindow
from robust_ismpc.runs.run import run

HIT_DURATION_S = 0.01


def _measured(pattern: str | None, seed: int) -> dict | None:
    """MuJoCo comparison of ``seed`` (comparison.json), or None."""
    if pattern is None:
        return None
    path = Path(pattern.format(seed=seed)) / "comparison.json"
    if not path.is_file():
        return None
    return json.loads(path.read_text())


def _lip_outcome(spec, hit_s: float, touchdown_s: float) -> str:
    """LIP outcome, with the shortest time to step chosen between the hit and the planned touchdown."""
    result = run(spec)
    summary, trace = result.summary, result.trace
    if summary["fell"]:
        kind = "infeasible" if "infeasible" in (summary["failure"] or "") else "falls"
        return f"{kind} at {summary['duration_s']:.2f} s"
    t = trace["t_s"]
    in_step = (t >= hit_s - 1e-9) & (t < touchdown_s) & (trace["timing_adapted"] > 0)
    chosen = trace["time_to_step_s"][in_step]
    after = f", time to step -> {chosen.min():.2f} s" if chosen.size else ""
    return f"walks{after}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("seeds", nargs="*", type=int, default=list(range(6)))
    parser.add_argument("--runs", help="path pattern of earlier `ismpc compare paper-ball` outputs, with {seed}")
    args = parser.parse_args()
    logging.disable(logging.WARNING)

    print("| seed | hit [s] | time to step at hit [s] | impulse [N s] | LIP nominal | LIP timing | MuJoCo nominal / robust |")
    print("|---|---|---|---|---|---|---|")
    for seed in args.seeds:
        scenario_run = realise("paper-ball", seed)
        ball = scenario_run.details["ball"]
        hit_s, impulse_ns, source = ball["hit_s"], ball["ball_momentum_ns"], "ball momentum"
        touchdown_s = ball["planned_touchdown_s"]
        comparison = _measured(args.runs, seed)
        mujoco = "-"
        if comparison is not None:
            hits = [b for b in comparison["robust"]["scene"]["balls"] if b["hit"]]
            if hits:
                hit_s, impulse_ns, source = hits[0]["first_contact_s"], hits[0]["impulse_ns"][0], "measured"
            mujoco = " / ".join("falls" if comparison[c]["fell"] else "walks" for c in ("nominal", "robust"))
        hit = ForceWindow(impulse_ns / HIT_DURATION_S, 0.0, hit_s, hit_s + HIT_DURATION_S)
        outcomes = [
            _lip_outcome(replace(spec, sim="lip", forces=spec.forces + (hit,)), hit_s, touchdown_s)
            for spec in (scenario_run.nominal, scenario_run.robust)
        ]
        print(f"| {seed} | {hit_s:.3f} | {touchdown_s - hit_s:.2f} | {impulse_ns:.3f} ({source}) | "
              f"{outcomes[0]} | {outcomes[1]} | {mujoco} |", flush=True)


if __name__ == "__main__":
    main()
