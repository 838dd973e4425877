"""Which step timings the robust controller tries when its QP is infeasible in double support.

The analytical feasibility bounds of the step timing adaptation hold in single support only
(:mod:`robust_ismpc.control.step_timing`). In double support the QP itself is the test: the
controller tries the timings listed here, in order, and keeps the first for which the QP is
feasible (:func:`first_feasible`, called by
:meth:`~robust_ismpc.control.robust.RobustIsmpcController._retime_next_step` and
:meth:`~robust_ismpc.control.robust.RobustIsmpcController._retime_start`).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from ..exceptions import InfeasibleMpc

__all__ = ["DS_RETIMING_FRACTIONS", "START_RETIMING_TRIES", "StartTiming", "first_feasible",
           "next_single_support_durations", "start_timings"]

Timing = TypeVar("Timing")
Plan = TypeVar("Plan")

#: Durations of the coming single support, as fractions of its nominal one, tried in double
#: support (within :meth:`~robust_ismpc.control.step_timing.StaParams.ss_limits`).
DS_RETIMING_FRACTIONS = (0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2, 1.3, 1.4, 1.5)

#: Largest number of earlier first touchdowns (and of later ones, while the robot still stands on
#: both feet) tried with the longest single support they allow.
START_RETIMING_TRIES = 8


def next_single_support_durations(nominal_s: float, current_s: float, limits_s: tuple[float, float],
                                  sampling_period_s: float) -> list[float]:
    """Durations [s] to try for the coming single support, nearest to ``current_s`` first.

    The :data:`DS_RETIMING_FRACTIONS` of ``nominal_s``, rounded to the sampling period, within
    ``limits_s`` (shortest, longest), the current one left out.
    """
    lo, hi = limits_s
    dt = sampling_period_s
    durations = {round(f * nominal_s / dt) * dt for f in DS_RETIMING_FRACTIONS}
    return sorted((d for d in durations if lo - 1e-9 <= d <= hi + 1e-9 and abs(d - current_s) > 1e-9),
                  key=lambda d: abs(d - current_s))


@dataclass(frozen=True)
class StartTiming:
    """One candidate timing of the first step: its single support from ``start_s`` to
    ``touchdown_s`` [s]."""

    start_s: float
    touchdown_s: float


def start_timings(t_s: float, start_s: float, touchdown_s: float, nominal_T_ss_s: float, T_ss_min_s: float,
                  T_ds_s: float, T_step_s: float, sampling_period_s: float, on_midpoint: bool,
                  latest_touchdown_s: float) -> list[StartTiming]:
    """First-step timings to try, in order, when the QP is infeasible in the initial stance.

    First, at most :data:`START_RETIMING_TRIES` earlier touchdowns between the current one and
    the earliest, each with the longest single support it allows (its double support
    compressed, never below ``T_ds_s``, before the single support is shortened to
    ``T_ss_min_s``), interleaved nearest first with as many later ones while the ZMP box is
    still on the feet's midpoint (``on_midpoint``; at the same spacing, not after
    ``latest_touchdown_s``, the single support keeping its length).

    Then, if none of those is feasible, the shortest single support after the longest double
    support: touchdowns one sampling period apart from the earliest one on, over one step
    (``T_step_s``), each with a single support of ``T_ss_min_s``. The longest single supports
    leave the least time to move the weight onto the support foot; a force the feet cannot
    hold (its DCM offset w/η² beyond the ZMP box) needs the weight moved first and the step
    made fast, and the earliest such step is the one the DCM has diverged least for.

    Parameters
    ----------
    t_s : float
        Now [s], in the initial stance.
    start_s, touchdown_s : float
        Current start of the first single support and its touchdown [s].
    nominal_T_ss_s, T_ss_min_s : float
        Nominal and shortest first single support [s].
    T_ds_s : float
        Shortest double support before the first single support [s].
    T_step_s : float
        Nominal step duration (single plus double support) [s].
    sampling_period_s : float
        MPC sampling period δ [s].
    on_midpoint : bool
        True while the ZMP box is still on the feet's midpoint (later touchdowns allowed).
    latest_touchdown_s : float
        Latest first touchdown allowed [s].

    Returns
    -------
    list of StartTiming
        Without the current timing.
    """
    dt = sampling_period_s
    T_ss_now = touchdown_s - start_s
    earliest_start = min(t_s + max(T_ds_s, dt), start_s)
    earliest = earliest_start + T_ss_min_s
    span = max(touchdown_s - earliest, T_step_s)
    spacing = max(dt, round(span / START_RETIMING_TRIES / dt) * dt)
    earlier = np.arange(touchdown_s - spacing, earliest - 1e-9, -spacing)
    if touchdown_s - earliest >= dt - 1e-9 and (len(earlier) == 0 or earlier[-1] > earliest + 1e-9):
        earlier = np.append(earlier, earliest)
    later = np.empty(0)
    if on_midpoint:
        later = touchdown_s + spacing * np.arange(1, START_RETIMING_TRIES + 1)
        later = later[later <= latest_touchdown_s + 1e-9]
    timings = []
    for td in (td for pair in itertools.zip_longest(earlier, later) for td in pair if td is not None):
        if td > touchdown_s:  # a longer stance on the midpoint
            start = td - T_ss_now
        else:
            start = max(earliest_start, min(start_s, td - min(nominal_T_ss_s, T_ss_now)))
        timings.append(StartTiming(float(start), float(td)))
    steps = int(np.floor(min(touchdown_s - earliest, T_step_s) / dt + 1e-9))
    for k in range(1, steps + 1):
        start = earliest_start + k * dt
        if start >= start_s - 1e-9:
            break
        timings.append(StartTiming(float(start), float(start + T_ss_min_s)))
    return timings


def first_feasible(timings: Iterable[Timing], apply: Callable[[Timing], object], solve: Callable[[], Plan],
                   undo: Callable[[], object]) -> tuple[Timing, Plan] | None:
    """The first of ``timings`` for which the QP is feasible, with its solution.

    Each timing is applied to the plan (``apply``) and the QP solved (``solve``); a timing whose
    QP raises :class:`~robust_ismpc.exceptions.InfeasibleMpc` is passed over. When none is
    feasible, ``undo`` puts the plan's timing back and None is returned; ``undo`` also runs
    before any other exception of ``solve`` propagates.
    """
    for timing in timings:
        apply(timing)
        try:
            result = solve()
        except InfeasibleMpc:
            continue
        except BaseException:
            undo()
            raise
        return timing, result
    undo()
    return None
