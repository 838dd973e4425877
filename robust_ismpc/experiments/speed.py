"""The speed table of ``ismpc bench``: MPC cycle, closed-loop tick, whole-process start-up.

Each row is measured ``repeats`` times and reported as the median over the repeats, with the
machine, the package versions and the commit, so that two ``bench.json`` files can be compared
(:func:`compare_speed`).
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from ..core.planner import WalkCommand
from ..exceptions import ParameterError

#: A row is flagged as a regression when it is this many times its baseline value or more
#: (times: larger is slower).
REGRESSION_RATIO = 1.10

#: (row name, what it measures, unit).
ROWS = (
    ("lip_cycle_nominal_median_ms", "MPC cycle, C = 100, LIP 20 s walk, nominal, median", "ms"),
    ("lip_cycle_robust_median_ms", "same, robust, median", "ms"),
    ("lip_cycle_robust_p99_ms", "same, robust, p99", "ms"),
    ("bench_robust_c200_median_ms", "robust cycle at C = 200 (LIP, 1000 cycles with pushes), median", "ms"),
    ("mujoco_torque_tick_ms", "{robot} in MuJoCo, torque control: wall time per 10 ms tick", "ms"),
    ("mujoco_servo_tick_ms", "{robot} in MuJoCo, servo playback: wall time per 10 ms tick", "ms"),
    ("process_lip_s", "`ismpc run --sim lip --robot {robot} --duration 10`, whole process", "s"),
    ("process_mujoco_servo_s", "`ismpc run --sim mujoco --robot {robot} --duration 10 --whole-body servo`, whole process",
     "s"),
    ("process_mujoco_torque_s", "`ismpc run --sim mujoco --robot {robot} --duration 10`, whole process", "s"),
)
ROW_NAMES = tuple(name for name, _, _ in ROWS)


#: Largest number of runs per row.
MAX_REPEATS = 50


def check_repeats(repeats: int) -> None:
    """Raise ParameterError (naming ``--repeats``) unless 1 <= ``repeats`` <= :data:`MAX_REPEATS`."""
    if isinstance(repeats, bool) or not isinstance(repeats, int) or not 1 <= repeats <= MAX_REPEATS:
        raise ParameterError(f"--repeats must be from 1 to {MAX_REPEATS}, got {repeats!r}")


def commit() -> str | None:
    """The git commit of the package's checkout (with ``-dirty`` for local changes), or None
    when the package is not in a git checkout."""
    root = Path(__file__).resolve().parents[2]
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=10, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return f"{head}-dirty" if dirty else head


def _lip_cycle(robot: str, modules: tuple[str, ...]) -> dict:
    from ..runs.run import run
    from ..runs.spec import RunSpec

    summary = run(RunSpec(robot=robot, sim="lip", modules=modules, command=WalkCommand(0.2), duration_s=20.0)).summary
    return summary["cycle_ms"]


def _mujoco_tick(robot: str, whole_body: str) -> dict:
    from ..runs.run import run
    from ..runs.spec import RunSpec

    summary = run(RunSpec(robot=robot, sim="mujoco", command=WalkCommand(0.2), duration_s=5.0,
                          whole_body=whole_body)).summary
    phases = summary["time_per_tick_ms"]
    return {"tick_ms": round(sum(phases.values()), 4), "phases_ms": phases,
            "realtime_factor": summary["realtime_factor"], "fell": summary["fell"]}


def _process_wall(robot: str, extra: list[str]) -> float:
    with tempfile.TemporaryDirectory() as out:
        command = [sys.executable, "-m", "robust_ismpc.cli", "run", "--robot", robot, "--duration", "10",
                   "--out", str(Path(out) / "run"), *extra]
        start = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True)
        wall = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed: {done.stderr.strip()[-500:]}")
    return wall


def measure_speed(repeats: int = 1, mujoco: bool = False, progress: Callable[[str], None] | None = None,
                  robot: str = "g1") -> dict:
    """Measure every row of :data:`ROWS` ``repeats`` times (the MuJoCo rows only with ``mujoco``)
    on ``robot`` (a built-in robot's name or a robot file's path; its MuJoCo rows run the
    robot file's own settings, such as its inverse-dynamics rate).

    Returns
    -------
    dict
        ``robot``; ``rows``: row name -> median over the repeats; ``samples``: row name -> every
        measurement; ``mujoco_phases_ms``: the torque loop's time per tick by phase (median run);
        ``repeats``.
    """
    from ..core.params import MpcParams
    from .bench import bench_robust

    check_repeats(repeats)
    samples: dict[str, list[float]] = {name: [] for name in ROW_NAMES}
    phases = []
    say = progress or (lambda _: None)
    for k in range(repeats):
        say(f"speed table: repeat {k + 1}/{repeats}")
        nominal = _lip_cycle(robot, ())
        robust = _lip_cycle(robot, ("observer", "restriction", "timing"))
        samples["lip_cycle_nominal_median_ms"].append(nominal["median"])
        samples["lip_cycle_robust_median_ms"].append(robust["median"])
        samples["lip_cycle_robust_p99_ms"].append(robust["p99"])
        mpc = MpcParams(control_horizon_s=2.0, preview_horizon_s=3.5)
        samples["bench_robust_c200_median_ms"].append(bench_robust(robot, mpc, 1000)["cycle_ms"]["median"])
        samples["process_lip_s"].append(_process_wall(robot, ["--sim", "lip"]))
        if mujoco:
            torque = _mujoco_tick(robot, "torque")
            phases.append(torque)
            samples["mujoco_torque_tick_ms"].append(torque["tick_ms"])
            samples["mujoco_servo_tick_ms"].append(_mujoco_tick(robot, "servo")["tick_ms"])
            samples["process_mujoco_servo_s"].append(_process_wall(robot, ["--sim", "mujoco", "--whole-body", "servo"]))
            samples["process_mujoco_torque_s"].append(_process_wall(robot, ["--sim", "mujoco"]))
    rows = {name: round(statistics.median(values), 4) for name, values in samples.items() if values}
    result: dict = {"robot": robot, "repeats": repeats, "rows": rows,
                    "samples": {name: [round(v, 4) for v in values] for name, values in samples.items() if values}}
    if phases:
        middle = sorted(phases, key=lambda p: p["tick_ms"])[len(phases) // 2]
        result["mujoco_phases_ms"] = middle["phases_ms"]
        result["mujoco_realtime_factor"] = middle["realtime_factor"]
    return result


def compare_speed(current: dict, baseline: dict) -> list[dict]:
    """Rows of two speed tables side by side.

    Parameters
    ----------
    current, baseline : dict
        ``bench.json`` contents (their ``speed`` entries are compared).

    Returns
    -------
    list of dict
        Per row present in both: ``row``, ``baseline``, ``now``, ``ratio`` (now / baseline) and
        ``regression`` (ratio >= :data:`REGRESSION_RATIO`).

    Raises
    ------
    ParameterError
        The baseline has no speed table, or measured another robot.
    """
    try:
        before = baseline["speed"]["rows"]
    except (KeyError, TypeError):
        raise ParameterError("--baseline: that bench.json has no speed table (written by an older ismpc bench?)") from None
    robots = (baseline["speed"].get("robot", "g1"), current["speed"].get("robot", "g1"))
    if robots[0] != robots[1]:
        raise ParameterError(f"--baseline measured robot {robots[0]!r}, this bench {robots[1]!r}: compare the same robot")
    now = current["speed"]["rows"]
    out = []
    for name in ROW_NAMES:
        if name in now and name in before and before[name] > 0:
            ratio = now[name] / before[name]
            out.append({"row": name, "baseline": before[name], "now": now[name], "ratio": round(ratio, 3),
                        "regression": ratio >= REGRESSION_RATIO})
    return out


def format_speed(speed: dict, comparison: list[dict] | None = None) -> str:
    """Markdown table of a speed table, with the baseline columns when compared."""
    robot = str(speed.get("robot", "g1"))
    labels = {name: (what.replace("{robot}", robot), unit) for name, what, unit in ROWS}
    lines = [f"Speed (median of {speed['repeats']} run{'s' if speed['repeats'] > 1 else ''}):", ""]
    by_row = {c["row"]: c for c in comparison or []}
    if comparison is not None:
        lines += ["| what | baseline | now | now / baseline |", "|---|---|---|---|"]
    else:
        lines += ["| what | now |", "|---|---|"]
    for name in ROW_NAMES:
        if name not in speed["rows"]:
            continue
        what, unit = labels[name]
        now = f"{speed['rows'][name]:g} {unit}"
        if comparison is None:
            lines.append(f"| {what} | {now} |")
            continue
        c = by_row.get(name)
        if c is None:
            lines.append(f"| {what} | - | {now} | - |")
        else:
            flag = " **regression**" if c["regression"] else ""
            lines.append(f"| {what} | {c['baseline']:g} {unit} | {now} | {c['ratio']:g}{flag} |")
    if "mujoco_phases_ms" in speed:
        phases = ", ".join(f"{k} {v:g}" for k, v in speed["mujoco_phases_ms"].items())
        lines += ["", f"Torque-loop tick by phase [ms]: {phases} (real-time factor {speed['mujoco_realtime_factor']}x)"]
    return "\n".join(lines)
