"""Executors of trials: in-process, a local process pool, or Ray."""

from __future__ import annotations

import logging

from ...exceptions import ParameterError
from ..workers import check_workers, process_pool, stop_pool
from .config import BACKENDS
from .trials import Trial, TrialResult, run_trial


class _SerialBackend:
    """Runs trials in this process, one at a time (``workers=1``)."""

    name = "serial"

    def __init__(self) -> None:
        self._queue: list[tuple[object, Trial]] = []
        self._count = 0

    def submit(self, trial: Trial):
        self._count += 1
        handle = self._count
        self._queue.append((handle, trial))
        return handle

    def wait(self, handles) -> list[tuple[object, TrialResult]]:
        handle, trial = self._queue.pop(0)
        return [(handle, run_trial(trial))]

    def close(self, interrupted: bool = False) -> None:
        self._queue.clear()


class _LocalBackend:
    """A :class:`concurrent.futures.ProcessPoolExecutor` of ``workers`` processes."""

    name = "local"

    def __init__(self, workers: int):
        self._pool = process_pool(workers)

    def submit(self, trial: Trial):
        return self._pool.submit(run_trial, trial)

    def wait(self, handles) -> list[tuple[object, TrialResult]]:
        from concurrent.futures import FIRST_COMPLETED, wait

        done, _ = wait(handles, return_when=FIRST_COMPLETED)
        return [(f, f.result()) for f in done]

    def close(self, interrupted: bool = False) -> None:
        stop_pool(self._pool, interrupted)


class _RayBackend:
    """The same trials as Ray tasks on a local Ray instance (``ray.init()``)."""

    name = "ray"

    def __init__(self, workers: int):
        import ray

        self._ray = ray
        self._started = False
        if not ray.is_initialized():
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False, logging_level=logging.ERROR)
            self._started = True
        self._remote = ray.remote(num_cpus=1)(run_trial)

    def submit(self, trial: Trial):
        return self._remote.remote(trial)

    def wait(self, handles) -> list[tuple[object, TrialResult]]:
        ready, _ = self._ray.wait(list(handles), num_returns=1)
        return [(ref, self._ray.get(ref)) for ref in ready]

    def close(self, interrupted: bool = False) -> None:
        if self._started:
            self._ray.shutdown()


def ray_available() -> bool:
    """True if ``import ray`` works."""
    try:
        import ray  # noqa: F401
    except Exception:
        return False
    return True


def make_backend(backend: str, workers: int):
    """The executor of trials: ``local`` (processes; in-process when ``workers == 1``) or ``ray``.

    Raises
    ------
    ParameterError
        Unknown backend, bad worker count, or Ray requested but not installed.
    """
    if backend not in BACKENDS:
        raise ParameterError(f"unknown backend {backend!r}; use one of: {', '.join(BACKENDS)}")
    check_workers(workers)
    if backend == "ray":
        if not ray_available():
            raise ParameterError("--backend ray needs Ray, which is not installed: pip install ray")
        return _RayBackend(workers)
    if workers == 1:
        return _SerialBackend()
    return _LocalBackend(workers)
