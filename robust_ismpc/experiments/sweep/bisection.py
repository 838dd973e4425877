"""Deterministic bisection of the largest survived push magnitude."""

from __future__ import annotations

from collections.abc import Callable

from ...exceptions import ParameterError
from ...validation import check_positive


class Bisection:
    """Deterministic bisection of the largest survived magnitude in [0, max].

    Trial 0 tries ``max``; if it is survived the bisection is done (saturated). Otherwise each of
    the next ``iterations`` trials tries the midpoint of the bracket [lo, hi] (initially [0, max])
    and moves ``lo`` up on survival, ``hi`` down on failure. The sequence of magnitudes depends
    only on the outcomes so far, which is what lets a sweep replay it from ``runs.csv``.

    Parameters
    ----------
    max_magnitude : float
        Upper end, > 0.
    iterations : int
        Bisection trials after the first one, >= 1.
    """

    def __init__(self, max_magnitude: float, iterations: int):
        check_positive("Bisection", max_magnitude=max_magnitude)
        if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
            raise ParameterError(f"Bisection.iterations must be an integer >= 1, got {iterations!r}")
        self.max_magnitude = float(max_magnitude)
        self.iterations = iterations
        self.lo = 0.0
        self.hi = self.max_magnitude
        self.trials: list[tuple[float, bool]] = []

    def next_magnitude(self) -> float | None:
        """Magnitude of the next trial, or None when the bisection is done."""
        n = len(self.trials)
        if n == 0:
            return self.max_magnitude
        if self.trials[0][1] or n >= 1 + self.iterations:
            return None
        return 0.5 * (self.lo + self.hi)

    @property
    def done(self) -> bool:
        return self.next_magnitude() is None

    @property
    def remaining_max(self) -> int:
        """Most trials still to run."""
        if self.done:
            return 0
        return 1 + self.iterations - len(self.trials)

    def record(self, magnitude: float, survived: bool) -> None:
        """Record the outcome of the trial at ``next_magnitude()``.

        Raises
        ------
        ParameterError
            If ``magnitude`` is not the one the bisection asked for.
        """
        expected = self.next_magnitude()
        if expected is None or magnitude != expected:
            raise ParameterError(f"bisection expected a trial at {expected!r}, got {magnitude!r}")
        if self.trials:
            if survived:
                self.lo = magnitude
            else:
                self.hi = magnitude
        self.trials.append((float(magnitude), bool(survived)))

    @property
    def saturated(self) -> bool:
        """The maximum itself was survived."""
        return bool(self.trials) and self.trials[0][1]

    @property
    def frontier(self) -> float:
        """Largest survived magnitude found (0 if none; ``max`` when saturated)."""
        return self.max_magnitude if self.saturated else self.lo


def bisect(survives: Callable[[float], bool], max_magnitude: float, iterations: int) -> Bisection:
    """Run a whole bisection with ``survives(magnitude) -> bool`` (serially, in-process)."""
    b = Bisection(max_magnitude, iterations)
    while (m := b.next_magnitude()) is not None:
        b.record(m, bool(survives(m)))
    return b
