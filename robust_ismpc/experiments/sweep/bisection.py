"""Deterministic bisection of the largest survived push magnitude."""

from __future__ import annotations

import math
from collections.abc import Callable

from ...exceptions import ParameterError
from ...validation import check_positive


def check_repeats(owner: str, repeats: object) -> int:
    """``repeats`` as an odd integer >= 1 (a majority of an odd count is never a tie).

    Raises
    ------
    ParameterError
        Otherwise.
    """
    if isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1 or repeats % 2 == 0:
        raise ParameterError(f"{owner}.repeats must be an odd integer >= 1, got {repeats!r}")
    return repeats


def iterations_for_resolution(width: float, resolution: float) -> int:
    """Bisection magnitudes after the first that bring a bracket of ``width`` within ``resolution``.

    Each one halves the bracket, so this is ``ceil(log2(width / resolution))``, at least 1
    (:class:`Bisection` needs one).

    Raises
    ------
    ParameterError
        ``width`` or ``resolution`` not positive.
    """
    check_positive("iterations_for_resolution", width=width, resolution=resolution)
    return max(1, math.ceil(math.log2(width / resolution)))


class Bisection:
    """Deterministic bisection of the largest survived magnitude in [0, max].

    A magnitude is *held* when most of its trials survive: each magnitude gets up to ``repeats``
    trials (each with its own seed, so its own sensor noise), and no more once a majority is
    decided. The first magnitude is ``max``; if it is held the bisection is done (saturated).
    Otherwise each of the next ``iterations`` magnitudes is the midpoint of the bracket [lo, hi]
    (initially [0, max]), which moves ``lo`` up when it is held and ``hi`` down when not. The
    sequence of magnitudes depends only on the outcomes so far, which is what lets a sweep replay
    it from ``runs.csv``.

    Parameters
    ----------
    max_magnitude : float
        Upper end, > 0.
    iterations : int
        Bisection magnitudes after the first one, >= 1.
    repeats : int
        Most trials per magnitude, odd, >= 1 (1: the one trial decides, for deterministic runs).
    """

    def __init__(self, max_magnitude: float, iterations: int, repeats: int = 1):
        check_positive("Bisection", max_magnitude=max_magnitude)
        if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
            raise ParameterError(f"Bisection.iterations must be an integer >= 1, got {iterations!r}")
        self.repeats = check_repeats("Bisection", repeats)
        self.max_magnitude = float(max_magnitude)
        self.iterations = iterations
        self.lo = 0.0
        self.hi = self.max_magnitude
        #: Every trial, in order: (magnitude, survived).
        self.trials: list[tuple[float, bool]] = []
        #: Every decided magnitude, in order: (magnitude, held, trials survived, trials run).
        self.steps: list[tuple[float, bool, int, int]] = []
        self._pending: list[bool] = []  # outcomes at the magnitude being decided

    def next_magnitude(self) -> float | None:
        """Magnitude of the next trial, or None when the bisection is done."""
        if not self.steps:
            return self.max_magnitude
        if self.steps[0][1] or len(self.steps) >= 1 + self.iterations:
            return None
        return 0.5 * (self.lo + self.hi)

    @property
    def done(self) -> bool:
        return self.next_magnitude() is None

    @property
    def next_repeat(self) -> int:
        """Index of the next trial among those at its magnitude (0-based)."""
        return len(self._pending)

    @property
    def remaining_max(self) -> int:
        """Most trials still to run."""
        if self.done:
            return 0
        return (1 + self.iterations - len(self.steps)) * self.repeats - len(self._pending)

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
        self.trials.append((float(magnitude), bool(survived)))
        self._pending.append(bool(survived))
        majority = self.repeats // 2 + 1
        survivors = sum(self._pending)
        if survivors < majority and len(self._pending) - survivors < majority:
            return
        held = survivors >= majority
        if self.steps:
            if held:
                self.lo = float(magnitude)
            else:
                self.hi = float(magnitude)
        self.steps.append((float(magnitude), held, survivors, len(self._pending)))
        self._pending = []

    @property
    def saturated(self) -> bool:
        """The maximum itself was held."""
        return bool(self.steps) and self.steps[0][1]

    @property
    def frontier(self) -> float:
        """Largest held magnitude found (0 if none; ``max`` when saturated)."""
        return self.max_magnitude if self.saturated else self.lo


def bisect(survives: Callable[[float], bool], max_magnitude: float, iterations: int, repeats: int = 1) -> Bisection:
    """Run a whole bisection with ``survives(magnitude) -> bool`` (serially, in-process)."""
    b = Bisection(max_magnitude, iterations, repeats)
    while (m := b.next_magnitude()) is not None:
        b.record(m, bool(survives(m)))
    return b
