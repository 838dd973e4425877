"""External forces on the robot, as the user states them.

A :class:`ForceWindow` is a horizontal force [N] applied at the CoM (LIP) or the torso (full
robot) over a time window; a constant force is a window over the whole run and an impulse is a
short window. The CLI syntax is ``FX,FY@T0:T1`` for a window (``FX,FY`` alone for the whole
run) and ``FX,FY@T:DUR`` for a push starting at T lasting DUR seconds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..exceptions import ParameterError


@dataclass(frozen=True)
class ForceWindow:
    """Horizontal force [N] active for ``t_start_s <= t < t_end_s``.

    Attributes
    ----------
    fx_n, fy_n : float
        Force components in the world frame [N].
    t_start_s, t_end_s : float
        Window [s]; ``t_end_s`` may be ``inf``.
    """

    fx_n: float
    fy_n: float
    t_start_s: float = 0.0
    t_end_s: float = math.inf

    def __post_init__(self) -> None:
        for name in ("fx_n", "fy_n", "t_start_s"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ParameterError(f"ForceWindow.{name} must be a finite number, got {value!r}")
        if not isinstance(self.t_end_s, (int, float)) or math.isnan(self.t_end_s):
            raise ParameterError(f"ForceWindow.t_end_s must be a number, got {self.t_end_s!r}")
        if self.t_start_s < 0:
            raise ParameterError(f"ForceWindow.t_start_s must be >= 0, got {self.t_start_s}")
        if self.t_end_s <= self.t_start_s:
            raise ParameterError(
                f"ForceWindow end {self.t_end_s} s must be after its start {self.t_start_s} s"
            )

    @property
    def impulse_ns(self) -> float:
        """Magnitude of the impulse [N s] (inf for an unbounded window)."""
        return math.hypot(self.fx_n, self.fy_n) * (self.t_end_s - self.t_start_s)

    def active(self, t_s: float) -> bool:
        return self.t_start_s <= t_s < self.t_end_s


def total_force(windows: Sequence[ForceWindow], t_s: float) -> np.ndarray:
    """Sum of the forces active at ``t_s`` [N], shape (2,)."""
    f = np.zeros(2)
    for w in windows:
        if w.active(t_s):
            f[0] += w.fx_n
            f[1] += w.fy_n
    return f


def ramped_force(fx_n: float, fy_n: float, start_s: float, ramp_s: float,
                 step_s: float = 0.01) -> tuple[ForceWindow, ...]:
    """A constant force (fx, fy) [N] reached linearly over ``ramp_s`` [s] from ``start_s`` [s], as
    stairs of ``step_s`` (one control period by default: each period sees one value, as a force
    sampled by the controller would): windows of (fx, fy)/n from ``start_s + i ramp_s/n`` on,
    n = ramp_s/step_s. ``ramp_s`` 0 gives the force switched on at ``start_s``.
    """
    for name, value in (("ramp_s", ramp_s), ("step_s", step_s)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
            raise ParameterError(f"ramped_force: {name} must be a finite number >= 0, got {value!r}")
    if step_s == 0:
        raise ParameterError("ramped_force: step_s must be > 0")
    n = max(1, int(round(ramp_s / step_s)))
    return tuple(ForceWindow(fx_n / n, fy_n / n, start_s + i * ramp_s / n) for i in range(n))


def _numbers(text: str, count: int, what: str, spec: str) -> list[float]:
    parts = text.split(",")
    if len(parts) != count:
        raise ParameterError(f"{what} {spec!r}: expected {count} comma-separated numbers before '@'")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ParameterError(f"{what} {spec!r}: {text!r} is not a list of numbers") from None
    if not all(math.isfinite(v) for v in values):
        raise ParameterError(f"{what} {spec!r}: values must be finite")
    return values


def _window(flag: str, spec: str, fx: float, fy: float, t0: float, t1: float) -> ForceWindow:
    """The ForceWindow of a command-line value, with errors that name the flag, not the class."""
    if not math.isfinite(t0) or math.isnan(t1):
        raise ParameterError(f"{flag} {spec!r}: times must be finite numbers of seconds")
    if t0 < 0:
        raise ParameterError(f"{flag} {spec!r}: the start time must be >= 0 s, got {t0:g}")
    if t1 <= t0:
        raise ParameterError(f"{flag} {spec!r}: the end {t1:g} s must be after its start {t0:g} s")
    return ForceWindow(fx, fy, t0, t1)


def parse_force(spec: str) -> ForceWindow:
    """Parse ``FX,FY`` or ``FX,FY@T0:T1`` (newtons, seconds; ``T1`` may be empty = until the end)."""
    if not isinstance(spec, str) or not spec.strip():
        raise ParameterError("--force: expected FX,FY[@T0:T1], got an empty string")
    head, _, window = spec.strip().partition("@")
    fx, fy = _numbers(head, 2, "--force", spec)
    if not window:
        return ForceWindow(fx, fy)
    t0_text, sep, t1_text = window.partition(":")
    if not sep:
        raise ParameterError(f"--force {spec!r}: the window must be T0:T1 (seconds), e.g. 10,0@1.0:3.0")
    try:
        t0 = float(t0_text)
        t1 = float(t1_text) if t1_text.strip() else math.inf
    except ValueError:
        raise ParameterError(f"--force {spec!r}: window {window!r} is not T0:T1 in seconds") from None
    return _window("--force", spec, fx, fy, t0, t1)


def parse_push(spec: str) -> ForceWindow:
    """Parse ``FX,FY@T:DUR``: a push of force (FX, FY) [N] from T lasting DUR [s]."""
    if not isinstance(spec, str) or "@" not in spec:
        raise ParameterError(f"--push {spec!r}: expected FX,FY@T:DUR, e.g. 0,80@2.3:0.1")
    head, _, window = spec.strip().partition("@")
    fx, fy = _numbers(head, 2, "--push", spec)
    t_text, sep, dur_text = window.partition(":")
    if not sep:
        raise ParameterError(f"--push {spec!r}: expected FX,FY@T:DUR, e.g. 0,80@2.3:0.1")
    try:
        t0, dur = float(t_text), float(dur_text)
    except ValueError:
        raise ParameterError(f"--push {spec!r}: {window!r} is not T:DUR in seconds") from None
    if not (math.isfinite(dur) and dur > 0):
        raise ParameterError(f"--push {spec!r}: duration must be > 0 s, got {dur_text!r}")
    return _window("--push", spec, fx, fy, t0, t0 + dur)
