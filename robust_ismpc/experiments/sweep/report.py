"""Results of a sweep: :class:`SweepResult`, the frontier summary (``frontier.json``), its tables,
plots and ``report.md``."""

from __future__ import annotations

import io
import json
import math
import os
import platform
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

from .bisection import Bisection
from .config import UNITS, SweepConfig
from .trials import TaskKey


@dataclass(frozen=True)
class SweepResult:
    """What :func:`run_sweep` produced.

    Attributes
    ----------
    frontier : dict
        The ``frontier.json`` content.
    paths : tuple of Path
        Files written.
    trials_total, trials_new, trials_resumed : int
        Trials in ``runs.csv``; run now; replayed from an earlier invocation.
    wall_time_s : float
        Wall time of this invocation [s].
    """

    frontier: dict
    paths: tuple[Path, ...]
    trials_total: int
    trials_new: int
    trials_resumed: int
    wall_time_s: float

    @property
    def runs_per_s(self) -> float:
        """Trials run per second of wall time by this invocation."""
        return self.trials_new / self.wall_time_s if self.wall_time_s > 0 else math.nan


def _dir_label(direction_deg: float) -> str:
    return f"{direction_deg:g}"


def _ratio(a: float, b: float) -> float | None:
    """a / b, None when b is 0 (the nominal frontier is below the resolution)."""
    return round(a / b, 4) if b > 0 else None


def frontier_summary(config: SweepConfig, bisections: dict[TaskKey, Bisection]) -> dict:
    """The ``frontier.json`` content.

    ``entries`` lists every bisection. For each kind, ``frontier[kind][controller][direction]``
    holds the per-phase frontier and its ``min`` and ``mean`` over phases. If ``nominal`` is one
    of the controllers, ``ratios[kind]["<controller>/nominal"][direction]`` holds the ratio of
    the min-over-phases frontiers, of the mean-over-phases frontiers, and per phase (None where
    the nominal frontier is 0), and ``ratio_summary`` the smallest per-phase ratio over all
    directions and whether it is >= 2.
    """
    entries = []
    per: dict[str, dict[str, dict[str, dict]]] = {}
    for key in config.tasks():
        b = bisections[key]
        entries.append({
            "controller": key.controller, "direction_deg": key.direction_deg, "phase": key.phase,
            "kind": key.kind, "max_survived": b.frontier, "first_failed": None if b.saturated else b.hi,
            "saturated": b.saturated, "complete": b.done, "trials": len(b.trials),
            "magnitudes": [[m, held, survived, run] for m, held, survived, run in b.steps],
        })
        cell = per.setdefault(key.kind, {}).setdefault(key.controller, {}).setdefault(
            _dir_label(key.direction_deg), {"phases": [], "per_phase": []}
        )
        cell["phases"].append(key.phase)
        cell["per_phase"].append(b.frontier)
    for kind_table in per.values():
        for ctrl_table in kind_table.values():
            for cell in ctrl_table.values():
                values = np.array(cell["per_phase"])
                cell["min"] = float(values.min())
                cell["mean"] = round(float(values.mean()), 6)
    ratios: dict[str, dict] = {}
    ratio_summary: dict[str, dict] = {}
    if "nominal" in config.controllers:
        for kind, kind_table in per.items():
            nominal = kind_table["nominal"]
            for controller, ctrl_table in kind_table.items():
                if controller == "nominal":
                    continue
                name = f"{controller}/nominal"
                table: dict[str, dict[str, Any]] = {}
                for d, cell in ctrl_table.items():
                    base = nominal[d]
                    per_phase = [_ratio(a, b) for a, b in zip(cell["per_phase"], base["per_phase"])]
                    table[d] = {"min": _ratio(cell["min"], base["min"]), "mean": _ratio(cell["mean"], base["mean"]),
                                "per_phase": per_phase}
                ratios.setdefault(kind, {})[name] = table
                all_ratios = [r for cell in table.values() for r in cell["per_phase"] if r is not None]
                ratio_summary.setdefault(kind, {})[name] = {
                    "min_per_phase_ratio": min(all_ratios) if all_ratios else None,
                    "mean_of_mean_ratios": round(float(np.mean([c["mean"] for c in table.values() if c["mean"] is not None])), 4)
                    if any(c["mean"] is not None for c in table.values()) else None,
                    "at_least_2x_everywhere": bool(all_ratios) and min(all_ratios) >= 2.0
                    and len(all_ratios) == sum(len(c["per_phase"]) for c in table.values()),
                }
    return {
        "robot": config.robot,
        "sim": config.sim,
        "config": config.to_dict(),
        "pushed_step_window_s": list(config.pushed_step_window()),
        "resolution": {kind: config.resolution(kind) for kind in config.kinds},
        "units": {kind: UNITS[kind] for kind in config.kinds},
        "aggregate_over_phases": "min (the frontier at every phase) and mean",
        "complete": all(b.done for b in bisections.values()),
        "frontier": per,
        "ratios": ratios,
        "ratio_summary": ratio_summary,
        "entries": entries,
    }


def plot_frontiers(frontier: dict, out: Path) -> list[Path]:
    """Polar and per-phase frontier figures for every kind; returns the files written."""
    from ...plotting import plot_frontier_phase, plot_frontier_polar

    paths = []
    for kind in frontier["frontier"]:
        prefix = "frontier" if kind == "impulse" else "frontier_force"
        paths.append(plot_frontier_polar(frontier, kind, out / f"{prefix}_polar.png"))
        paths.append(plot_frontier_phase(frontier, kind, out / f"{prefix}_phase.png"))
    return paths


def _fmt(value: float | None, digits: int = 3) -> str:
    return "-" if value is None else f"{value:.{digits}g}"


def frontier_table(frontier: dict, kind: str = "impulse") -> str:
    """Markdown table: per direction, each controller's min/mean over phases and ratios to nominal."""
    table = frontier["frontier"].get(kind)
    if not table:
        return ""
    controllers = list(table)
    dirs = sorted(next(iter(table.values())), key=float)
    ratio_names = list(frontier["ratios"].get(kind, {}))
    head = ["direction [deg]"] + [f"{c} min / mean" for c in controllers] + [f"{r} (min / mean)" for r in ratio_names]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for d in dirs:
        cells = [d] + [f"{_fmt(table[c][d]['min'])} / {_fmt(table[c][d]['mean'])}" for c in controllers]
        for r in ratio_names:
            cell = frontier["ratios"][kind][r][d]
            cells.append(f"{_fmt(cell['min'])} / {_fmt(cell['mean'])}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _versions() -> dict:
    from importlib import metadata

    from ..bench import versions

    out = versions()
    for pkg in ("matplotlib", "ray"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            pass
    return out


def format_report(
    config: SweepConfig,
    frontier: dict,
    result: SweepResult,
    rows: Iterable[dict],
    command_line: str | None = None,
    backend: str = "local",
    workers: int = 1,
    started_at: datetime | None = None,
    code: dict | None = None,
    previous_code: dict | None = None,
) -> str:
    """``report.md``: command line, machine, versions, code, seeds, timing, frontier tables."""
    from ..bench import machine

    rows = list(rows)
    trial_wall = sum(float(r["wall_time_s"]) for r in rows if r.get("wall_time_s"))
    survived = sum(r["survived"] == "1" for r in rows)
    errors = sum(r["failure"].startswith("error:") for r in rows)
    start, T_ss = frontier["pushed_step_window_s"]
    md = io.StringIO()
    md.write(f"# Push-recovery sweep: {config.robot} on {config.sim}"
             + (f" ({config.whole_body} whole-body control)" if config.sim == "mujoco" else "")
             + (f", {config.sensing} sensing" if config.sensing != "ideal" else "") + "\n\n")
    md.write(f"Command: `{command_line or '(Python API)'}`\n\n")
    if started_at is not None:
        md.write(f"Started: {started_at.isoformat(timespec='seconds')}\n\n")
    md.write("## Setup\n\n")
    md.write(f"- controllers: {', '.join(config.controllers)}\n")
    md.write(f"- directions [deg] (0 = forward +x, 90 = left +y): {', '.join(f'{d:g}' for d in config.directions_deg)}\n")
    md.write(f"- phases (fraction of the single support of regular step {config.pushed_step}, which runs from "
             f"{start:.3g} s for {T_ss:.3g} s): {', '.join(f'{p:g}' for p in config.phases)}\n")
    md.write(f"- impulse: bisection in [0, {config.impulse_max_ns:g}] N s, applied as a constant force over "
             f"{config.push_duration_s:g} s; resolution {config.resolution('impulse'):.4g} N s "
             f"(the maximum + {config.iterations} bisection magnitudes)\n")
    if config.force_max_n is not None:
        md.write(f"- constant force: bisection in [0, {config.force_max_n:g}] N from the push instant to the end; "
                 f"resolution {config.resolution('force'):.4g} N\n")
    md.write(f"- walk: vx = {config.vx_mps:g} m/s; each trial runs until {config.post_push_s:g} s after the push starts\n")
    md.write("- failure: a fall, diverged CoM or persistent infeasible QP (`summary[\"fell\"]`)\n")
    md.write(f"- trials per magnitude: up to {config.repeats}, each with its own seed; a magnitude is held when "
             f"most of its trials survive (`magnitudes` in frontier.json: magnitude, held, survived, run)\n")
    md.write(f"- seeds: base seed {config.seed}; trial seed = first 31 bits of sha256(\"seed|direction|phase|kind|"
             f"magnitude|repeat\") (column `seed` of runs.csv): the controllers meet the same noise at the same "
             f"push\n\n")
    md.write("## Execution\n\n")
    md.write(f"- backend: {backend}, {workers} worker(s)\n")
    md.write(f"- trials in runs.csv: {result.trials_total} ({survived} survived, {errors} errors); "
             f"run by this invocation: {result.trials_new}; resumed from an earlier one: {result.trials_resumed}\n")
    md.write(f"- wall time of this invocation: {result.wall_time_s:.1f} s "
             f"({result.runs_per_s:.2f} runs/s); sum of trial wall times: {trial_wall:.1f} s\n")
    if hasattr(os, "getloadavg"):
        md.write(f"- load average at the end (1, 5, 15 min; other processes slow the trials down): "
                 f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}\n")
    md.write(f"- complete: {'yes' if frontier['complete'] else 'no (interrupted; rerun the command to resume)'}\n\n")
    md.write("Machine: " + json.dumps(machine()) + "\n\n")
    md.write("Versions: " + json.dumps(_versions()) + "\n\n")
    if code is not None:
        md.write(f"Code: robust-ismpc {code['version']}, sources sha256 {code['sources_sha256']}")
        if previous_code is not None and previous_code != code:
            md.write(f" (the sweep was started with sources {previous_code.get('sources_sha256')}: "
                     "runs.csv mixes trials of both)")
        md.write("\n\n")
    for kind in frontier["frontier"]:
        md.write(f"## Largest survived {kind} [{UNITS[kind]}]\n\n")
        md.write("Per direction, the frontier's minimum and mean over phases; ratios to nominal of those "
                 "(`-`: the nominal frontier is below the resolution).\n\n")
        md.write(frontier_table(frontier, kind) + "\n\n")
        for name, s in frontier["ratio_summary"].get(kind, {}).items():
            md.write(f"- {name}: smallest per-phase ratio {_fmt(s['min_per_phase_ratio'])}, mean of the per-direction "
                     f"mean ratios {_fmt(s['mean_of_mean_ratios'])}; >= 2x at every direction and phase: "
                     f"{'yes' if s['at_least_2x_everywhere'] else 'no'}\n")
        prefix = "frontier" if kind == "impulse" else "frontier_force"
        md.write(f"\n![polar]({prefix}_polar.png)\n\n![per phase]({prefix}_phase.png)\n\n")
    md.write(f"Python {platform.python_version()}; files: sweep.json, runs.csv, frontier.json, report.md, plots.\n")
    return md.getvalue()
