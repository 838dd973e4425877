"""Running (or resuming) a sweep: :func:`run_sweep` and its progress reports."""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from ...control.modules import controller_modules
from ...exceptions import ParameterError
from ...io import atomic_write_bytes, atomic_write_json
from ...runs.outputs import open_output_dir
from ..workers import check_workers
from .backends import make_backend, ray_available
from .bisection import Bisection
from .config import BACKENDS, FRONTIER_JSON, REPORT_MD, RUNS_CSV, SWEEP_JSON, SweepConfig
from .report import SweepResult, format_report, frontier_summary, plot_frontiers
from .storage import _replay, _RunsWriter, code_digest, prepare_out, read_runs, trial_row
from .trials import TaskKey, Trial, trial_seed

LOGGER = logging.getLogger("robust_ismpc")


@dataclass(frozen=True)
class SweepProgress:
    """Progress of a sweep, passed to the ``progress`` callback after every finished trial.

    Attributes
    ----------
    done : int
        Trials finished, resumed ones included.
    total : int
        ``done`` plus the most trials still to run (it shrinks when bisections saturate).
    new : int
        Trials run by this invocation.
    elapsed_s : float
        Wall time of this invocation [s].
    """

    done: int
    total: int
    new: int
    elapsed_s: float


def _make_trial(config: SweepConfig, key: TaskKey, b: Bisection, push_window: tuple[float, float]) -> Trial:
    magnitude = b.next_magnitude()
    if magnitude is None:
        raise ParameterError(f"bisection {key} is already complete")
    start, T_ss = push_window
    t_push = start + key.phase * T_ss
    return Trial(
        key=key, iteration=len(b.trials), magnitude=float(magnitude), robot=config.robot, sim=config.sim,
        modules=controller_modules(key.controller), vx_mps=float(config.vx_mps), t_push_s=t_push,
        push_duration_s=float(config.push_duration_s), duration_s=t_push + config.post_push_s,
        seed=trial_seed(config.seed, key, magnitude, b.next_repeat), whole_body=config.whole_body, sensing=config.sensing,
    )


def run_sweep(
    config: SweepConfig,
    out: str | Path,
    workers: int | None = None,
    backend: str = "local",
    overwrite: bool = False,
    progress: Callable[[SweepProgress], None] | None = None,
    command_line: str | None = None,
) -> SweepResult:
    """Run (or resume) a push-recovery sweep and write its outputs into ``out``.

    Parameters
    ----------
    config : SweepConfig
    out : path
        Output directory: ``sweep.json``, ``runs.csv``, ``frontier.json``, ``report.md`` and the
        frontier plots.
    workers : int, optional
        Parallel workers (default ``os.cpu_count()``); 1 runs the trials in this process.
    backend : str
        ``local`` (processes) or ``ray``.
    overwrite : bool
        Discard an earlier sweep in ``out`` instead of resuming it / refusing a different one.
    progress : callable, optional
        Called with a :class:`SweepProgress` after every finished trial.
    command_line : str, optional
        Recorded in ``report.md``.

    Returns
    -------
    SweepResult

    Raises
    ------
    ParameterError
        Bad backend or worker count, or an ``out`` that cannot be used (see :func:`prepare_out`).
    KeyboardInterrupt
        Ctrl-C: the finished trials are in ``runs.csv`` (complete rows only); rerun to resume.

    Notes
    -----
    ``out`` is locked while the sweep runs (:func:`robust_ismpc.runs.outputs.open_output_dir`): a
    second sweep into the same folder is refused instead of duplicating rows.
    """
    workers = (os.cpu_count() or 1) if workers is None else workers
    out = Path(out)
    start = time.perf_counter()
    started_at = datetime.now(UTC)
    if backend not in BACKENDS:
        raise ParameterError(f"unknown backend {backend!r}; use one of: {', '.join(BACKENDS)}")
    if backend == "ray" and not ray_available():
        raise ParameterError("--backend ray needs Ray, which is not installed: pip install ray")
    check_workers(workers)
    # One sweep per folder at a time (a second one would append the same trials to runs.csv).
    with open_output_dir(str(out), overwrite=True, require_empty=False):
        push_window = config.pushed_step_window()
        code = code_digest()
        previous_code = prepare_out(config, out, overwrite)
        if previous_code is not None and previous_code != code:
            LOGGER.warning("resuming a sweep started with other code (%s); runs.csv will mix trials of both",
                           previous_code.get("sources_sha256"))
        runs_path = out / RUNS_CSV
        bisections, replayed = _replay(config, read_runs(runs_path))
        pending_tasks = [k for k, b in bisections.items() if not b.done]
        done = replayed
        new = 0

        def total() -> int:
            return done + sum(b.remaining_max for b in bisections.values())

        writer = _RunsWriter(runs_path)
        executor = None
        interrupted = False
        try:
            if pending_tasks:
                executor = make_backend(backend, min(workers, len(pending_tasks)) if backend == "local" else workers)
                in_flight: dict[object, Trial] = {}
                for key in pending_tasks:
                    trial = _make_trial(config, key, bisections[key], push_window)
                    in_flight[executor.submit(trial)] = trial
                while in_flight:
                    for handle, result in executor.wait(list(in_flight)):
                        trial = in_flight.pop(handle)
                        writer.append(trial_row(trial, result))
                        b = bisections[trial.key]
                        b.record(trial.magnitude, result.survived)
                        done += 1
                        new += 1
                        if not b.done:
                            nxt = _make_trial(config, trial.key, b, push_window)
                            in_flight[executor.submit(nxt)] = nxt
                        if progress is not None:
                            progress(SweepProgress(done, total(), new, time.perf_counter() - start))
        except BaseException:
            interrupted = True
            raise
        finally:
            writer.close()
            if executor is not None:
                executor.close(interrupted=interrupted)
        wall = time.perf_counter() - start
        frontier = frontier_summary(config, bisections)
        rows = read_runs(runs_path)
        paths = [out / SWEEP_JSON, runs_path]
        atomic_write_json(out / FRONTIER_JSON, frontier)
        paths.append(out / FRONTIER_JSON)
        paths.extend(plot_frontiers(frontier, out))
        result = SweepResult(frontier=frontier, paths=(), trials_total=len(rows), trials_new=new,
                             trials_resumed=replayed, wall_time_s=wall)
        report = format_report(config, frontier, result, rows, command_line=command_line, backend=backend,
                               workers=workers, started_at=started_at, code=code, previous_code=previous_code)
        atomic_write_bytes(out / REPORT_MD, report.encode())
        paths.append(out / REPORT_MD)
        return SweepResult(frontier=frontier, paths=tuple(paths), trials_total=len(rows), trials_new=new,
                           trials_resumed=replayed, wall_time_s=wall)
