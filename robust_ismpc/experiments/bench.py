"""Timing benchmarks of the MPC cycle.

For each control horizon C the controller walks on the LIP (closed loop, 0.2 m/s) and every
cycle's QP build, solve and whole-step times are recorded, for the nominal controller and for
the robust one (observer + restriction + timing adaptation, with a few pushes so that the
adaptation runs), split by component. A sample of the QPs solved in the nominal run is then
solved again by each requested solver (DAQP directly, cold start, and qpsolvers backends) to
compare solvers on identical problems. The speed table (:mod:`robust_ismpc.experiments.speed`)
follows.
"""

from __future__ import annotations

import io
import json
import platform
import time
from importlib import metadata
from pathlib import Path

import numpy as np

from ..control.controller import IsmpcController
from ..control.robust import RobustIsmpcController
from ..control.walk import start_walk
from ..core.params import MpcParams
from ..core.planner import WalkCommand
from ..core.qp import DaqpSolver, QpsolversSolver
from ..exceptions import ParameterError
from ..io import atomic_write_bytes, atomic_write_json
from ..runs.forces import ForceWindow
from ..runs.lip import run_lip
from ..runs.report import timing_stats
from ..runs.spec import gait_params


class _RecordingSolver(DaqpSolver):
    """DAQP solver that keeps every ``keep_every``-th problem for re-solving by other solvers."""

    def __init__(self, keep_every: int = 10):
        super().__init__()
        self.keep_every = keep_every
        self.kept: list = []
        self._count = 0

    def solve(self, problem):
        self._count += 1
        if self._count % self.keep_every == 0:
            self.kept.append(problem.copy())
        return super().solve(problem)


def versions() -> dict:
    """Versions of Python and the packages that matter for timing."""
    out = {"python": platform.python_version()}
    for pkg in ("numpy", "scipy", "daqp", "qpsolvers", "osqp", "proxsuite", "quadprog", "mujoco", "mink"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            pass
    return out


def machine() -> dict:
    import os

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as handle:
            for line in handle:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "platform": platform.platform()}


def gait_for_horizon(robot_name: str, control_horizon_s: float):
    """The robot's parameters, with the step shortened (T_ss and T_ds scaled alike) when the
    control horizon is shorter than one step (the controller refuses such a horizon)."""
    robot = gait_params(robot_name, "lip")
    if control_horizon_s < robot.T_step_s:
        scale = control_horizon_s / robot.T_step_s
        robot = robot.with_values(T_ss_s=round(robot.T_ss_s * scale, 2), T_ds_s=round(robot.T_ds_s * scale, 2))
    return robot


def bench_horizon(robot_name: str, C: int, cycles: int, solvers: list[str]) -> dict:
    """Time ``cycles`` closed-loop cycles at horizon ``C`` and compare solvers."""
    dt = 0.01
    robot = gait_for_horizon(robot_name, C * dt)
    mpc = MpcParams(sampling_period_s=dt, control_horizon_s=C * dt, preview_horizon_s=C * dt + 1.5)
    recorder_solver = _RecordingSolver(keep_every=max(1, cycles // 100))
    controller = IsmpcController(robot, mpc, solver=recorder_solver)
    duration = (cycles + 100) * dt
    start_walk(controller, WalkCommand(0.2, 0.0, 0.0), duration)
    start = time.perf_counter()
    outcome, rec = run_lip(controller, duration)
    lip_rtf = duration / (time.perf_counter() - start)
    trace = rec.finish(controller.plan, {})
    skip = 100  # warm-up cycles
    result = {
        "C": C,
        "cycles": len(trace) - skip,
        "fell": outcome.fell,
        "build_ms": timing_stats(trace["build_ms"][skip:]),
        "solve_ms": timing_stats(trace["solve_ms"][skip:]),
        "cycle_ms": timing_stats(trace["cycle_ms"][skip:]),
        "lip_realtime_factor": round(lip_rtf, 1),
        "robust": bench_robust(robot_name, mpc, cycles),
        "qp_size": None,
        "solvers": {},
    }
    problems = recorder_solver.kept
    if problems:
        p0 = problems[0]
        result["qp_size"] = {"variables": int(p0.n), "rows": int(p0.A.shape[0])}
    for name in solvers:
        try:
            solver = DaqpSolver() if name == "daqp" else QpsolversSolver(backend=name)
        except Exception as exc:  # not installed
            result["solvers"][name] = {"error": str(exc)}
            continue
        times = []
        errors = []
        for problem in problems:
            if name == "daqp":
                solver.reset()  # cold start, like the other solvers
            start = time.perf_counter()
            try:
                sol = solver.solve(problem)
            except Exception as exc:
                errors.append(str(exc))
                continue
            times.append(1e3 * (time.perf_counter() - start))
            if sol.x is None:
                errors.append("no solution")
        result["solvers"][name] = {"solve_ms": timing_stats(np.array(times)), "failures": len(errors),
                                   "problems": len(problems)}
    base = result["solvers"].get("daqp", {}).get("solve_ms", {}).get("median")
    for entry in result["solvers"].values():
        med = entry.get("solve_ms", {}).get("median") if isinstance(entry, dict) else None
        if base and med:
            entry["ratio_to_daqp"] = round(med / base, 2)
    return result


def bench_robust(robot_name: str, mpc: MpcParams, cycles: int) -> dict:
    """Per-component cycle times of the robust controller on the LIP (all three modules).

    Small pushes every 2 s (30 N, 0.1 s, alternating directions) keep the timing adaptation busy.
    """
    robot = gait_for_horizon(robot_name, mpc.control_horizon_s)
    controller = RobustIsmpcController(robot, mpc)
    dt = mpc.sampling_period_s
    duration = (cycles + 100) * dt
    start_walk(controller, WalkCommand(0.2, 0.0, 0.0), duration)
    scale = robot.mass_kg / 33.3
    pushes = [ForceWindow(30.0 * scale * (-1) ** i, 0.0, 3.0 + 2.0 * i, 3.1 + 2.0 * i)
              for i in range(int(duration // 2))]
    start = time.perf_counter()
    outcome, rec = run_lip(controller, duration, pushes)
    rtf = duration / (time.perf_counter() - start)
    trace = rec.finish(controller.plan, {})
    skip = 100
    parts = {name: timing_stats(trace[f"{name}_ms"][skip:]) for name in ("observer", "timing", "build", "solve", "cycle")}
    other = trace["cycle_ms"] - trace["observer_ms"] - trace["timing_ms"] - trace["build_ms"] - trace["solve_ms"]
    parts["other"] = timing_stats(other[skip:])
    return {"fell": outcome.fell, "timing_adaptations": controller.timing_adaptations,
            "lip_realtime_factor": round(rtf, 1), **{f"{k}_ms": v for k, v in parts.items()}}


#: Solvers compared by default (those of them that are installed).
DEFAULT_SOLVERS = ("daqp", "osqp", "proxqp", "quadprog")
#: Largest --cycles and --horizons accepted (a horizon of C samples builds a QP of about 2 C variables).
MAX_CYCLES = 100_000
MAX_HORIZON = 1000


def installed_solvers() -> list[str]:
    """``daqp`` and the qpsolvers backends installed (``robust-ismpc[solvers]``)."""
    try:
        import qpsolvers
    except ImportError:
        return ["daqp"]
    return ["daqp", *sorted(s for s in qpsolvers.available_solvers if s != "daqp")]


def check_bench_args(horizons_text: str, cycles: int, solvers_text: str | None) -> tuple[list[int], list[str]]:
    """Horizons and solvers of ``ismpc bench`` from its flags; ParameterError naming the flag.

    ``solvers_text`` None means those of :data:`DEFAULT_SOLVERS` that are installed.
    """
    try:
        horizons = [int(h) for h in horizons_text.split(",")]
    except ValueError:
        raise ParameterError(f"--horizons must be comma-separated integers, got {horizons_text!r}") from None
    if any(h < 2 or h > MAX_HORIZON for h in horizons):
        raise ParameterError(f"--horizons must be between 2 and {MAX_HORIZON} samples, got {horizons_text!r}")
    if not 10 <= cycles <= MAX_CYCLES:
        raise ParameterError(f"--cycles must be between 10 and {MAX_CYCLES}, got {cycles}")
    installed = installed_solvers()
    if solvers_text is None:
        return horizons, [s for s in DEFAULT_SOLVERS if s in installed]
    solvers = [s.strip() for s in solvers_text.split(",") if s.strip()]
    unknown = [s for s in solvers if s not in installed]
    if not solvers or unknown:
        raise ParameterError(
            f"--solvers {solvers_text!r}: {'no solver named' if not solvers else f'{unknown[0]!r} is not an installed solver'}"
            f"; installed: {', '.join(installed)} (more with pip install 'robust-ismpc[solvers]')"
        )
    return horizons, solvers


def run_bench(robot_name: str, horizons: list[int], cycles: int, solvers: list[str]) -> dict:
    """Benchmark every horizon; returns a JSON-serialisable dict with the machine and versions
    (``ismpc bench`` adds the speed table of :mod:`robust_ismpc.experiments.speed`)."""
    return {
        "robot": robot_name,
        "date": time.strftime("%Y-%m-%d %H:%M:%S"),
        "machine": machine(),
        "versions": versions(),
        "horizons": [bench_horizon(robot_name, C, cycles, solvers) for C in horizons],
    }


def format_table(result: dict) -> str:
    """Terminal/Markdown table of a benchmark result."""
    lines = [
        f"MPC cycle times, robot {result['robot']}, {result['machine']['cpu']} ({result['machine']['cores']} cores)",
        "",
        "| C | QP (vars x rows) | build median/p99 ms | solve median/p99 ms | cycle median/p99 ms | solvers (cold, median ms; ratio to DAQP) |",
        "|---|---|---|---|---|---|",
    ]
    for h in result["horizons"]:
        size = h["qp_size"]
        size_s = f"{size['variables']} x {size['rows']}" if size else "-"
        solv = []
        for name, entry in h["solvers"].items():
            if "error" in entry:
                solv.append(f"{name}: n/a")
            else:
                solv.append(f"{name}: {entry['solve_ms']['median']} ({entry.get('ratio_to_daqp', '-')}x)")
        lines.append(
            f"| {h['C']} | {size_s} | {h['build_ms']['median']}/{h['build_ms']['p99']} | "
            f"{h['solve_ms']['median']}/{h['solve_ms']['p99']} | {h['cycle_ms']['median']}/{h['cycle_ms']['p99']} | "
            + "; ".join(solv) + " |"
        )
    lines.append("")
    lines.append("Solve times per axis QP pair (x and y solved separately when the footsteps are not rotated);")
    lines.append("solver columns: the same QPs (one axis) solved cold by each solver. Where C δ is shorter than")
    lines.append("the robot's step (C = 50 on g1), the step is shortened to C δ (T_ss and T_ds scaled alike).")
    lines += [
        "",
        "Robust controller (observer + restriction + timing adaptation), per component, median/p99 ms:",
        "",
        "| C | observer | timing adaptation | QP build | QP solve | other | whole cycle | LIP real-time factor |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for h in result["horizons"]:
        r = h["robust"]
        cells = [f"{r[k]['median']}/{r[k]['p99']}" for k in ("observer_ms", "timing_ms", "build_ms", "solve_ms", "other_ms", "cycle_ms")]
        lines.append(f"| {h['C']} | " + " | ".join(cells) + f" | {r['lip_realtime_factor']}x |")
    return "\n".join(lines)


def write_bench(result: dict, out: Path, text: str) -> list[Path]:
    """Write ``bench.json`` and ``bench.md`` (``text``, the tables as printed, with the commit,
    machine and versions) into ``out``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_json(out / "bench.json", result)
    md = io.StringIO()
    md.write("# robust-ismpc benchmark\n\n")
    md.write(text + "\n\n")
    md.write(f"Commit: {result.get('commit')}, {result.get('date')}\n\n")
    md.write("Machine: " + json.dumps(result["machine"]) + "\n\n")
    md.write("Versions: " + json.dumps(result["versions"]) + "\n")
    atomic_write_bytes(out / "bench.md", md.getvalue().encode())
    return [out / "bench.json", out / "bench.md"]
