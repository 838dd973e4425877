"""Local worker processes for experiments: how they start, how they stop, and a task loop on them.

The sweep's local backend and the benchmarks' bisections run on the same kind of worker: it
leaves Ctrl-C and SIGTERM to its parent, dies with the parent (so a parent killed by SIGKILL
leaves no orphans), and logs at the parent's level. The parent stops its workers on Ctrl-C.
"""

from __future__ import annotations

import logging
import os
import signal
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from ..exceptions import ParameterError


def _die_with_parent(parent_pid: int) -> None:
    """Ask Linux to SIGKILL this process when its parent dies (``prctl(PR_SET_PDEATHSIG)``), so a
    parent killed by SIGKILL leaves no orphaned workers; exit now if the parent is already gone."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        pr_set_pdeathsig = 1
        libc.prctl(pr_set_pdeathsig, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):  # not Linux: the parent stops its workers on SIGINT/SIGTERM
        pass
    if os.getppid() != parent_pid:
        os._exit(1)


def worker_init(log_level: int, parent_pid: int | None = None) -> None:
    """Initializer of a local worker: leave Ctrl-C and SIGTERM to the parent (it stops the
    workers), die with the parent, and log like it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if parent_pid is not None:
        _die_with_parent(parent_pid)
    logging.getLogger("robust_ismpc").setLevel(log_level)


def check_workers(workers: object) -> int:
    """``workers`` as a process count, an integer >= 1.

    Raises
    ------
    ParameterError
        Otherwise.
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ParameterError(f"workers must be an integer >= 1, got {workers!r}")
    return workers


def process_pool(workers: int):
    """A :class:`concurrent.futures.ProcessPoolExecutor` of ``workers`` processes started with
    :func:`worker_init`."""
    from concurrent.futures import ProcessPoolExecutor

    level = logging.getLogger("robust_ismpc").getEffectiveLevel()
    return ProcessPoolExecutor(max_workers=workers, initializer=worker_init, initargs=(level, os.getpid()))


def stop_pool(pool, interrupted: bool) -> None:
    """Shut ``pool`` down; after an interruption, first terminate its workers (they ignore
    SIGINT; the tasks under way are lost, not half-written)."""
    if interrupted:
        processes = list((getattr(pool, "_processes", None) or {}).values())
        for process in processes:
            if process.is_alive():
                process.terminate()
        for process in processes:
            process.join(timeout=5.0)
    pool.shutdown(wait=True, cancel_futures=True)


def each_completed(function: Callable[..., Any], tasks: Sequence[tuple], workers: int,
                   ) -> Iterator[tuple[int, Any, BaseException | None]]:
    """``function(*task)`` for every task, on ``workers`` local processes, as each finishes.

    Yields ``(index into tasks, result, None)``, or ``(index, None, exception)`` for a task that
    raised: one failed task does not stop the others. With ``workers == 1`` the tasks run in
    this process, in order. Ctrl-C (or closing the generator) stops the workers.

    Parameters
    ----------
    function : callable
        Picklable (a module-level function) when ``workers > 1``.
    tasks : sequence of tuple
        The positional arguments of each call.
    workers : int
        Processes, >= 1.

    Raises
    ------
    ParameterError
        ``workers`` is not an integer >= 1.
    """
    if check_workers(workers) == 1:
        for i, task in enumerate(tasks):
            try:
                result = function(*task)
            except Exception as exc:  # noqa: BLE001  (reported to the caller with its task)
                yield i, None, exc
            else:
                yield i, result, None
        return
    from concurrent.futures import as_completed

    pool = process_pool(workers)
    finished = False
    try:
        futures = {pool.submit(function, *task): i for i, task in enumerate(tasks)}
        for future in as_completed(futures):
            exc = future.exception()
            yield futures[future], (None if exc is not None else future.result()), exc
        finished = True
    finally:
        stop_pool(pool, interrupted=not finished)
