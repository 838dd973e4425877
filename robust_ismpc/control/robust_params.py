"""Settings of the robust controller's modules (:class:`RobustParams`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..exceptions import ParameterError
from ..validation import check_nonnegative
from .step_timing import StaParams

__all__ = ["RobustParams"]


@dataclass(frozen=True)
class RobustParams:
    """Settings of the robustness modules.

    Attributes
    ----------
    delta_max_mps2 : float or None
        Δmax, the deviation of the disturbance from its mid-range that the ZMP restriction
        guarantees [m/s²]. None: ``delta_max_fraction`` of the largest value the foot and horizon
        can guarantee.
    delta_max_fraction : float
        Used when ``delta_max_mps2`` is None, in (0, 1).
    disturbance_time_constant_s : float
        Time constant of the low-pass filter on the measured disturbance [s]
        (:class:`~robust_ismpc.estimation.estimator.DisturbanceEstimator`).
    persistence_s : float
        The part of the estimate that persisted this long with one sign is its persistent part
        (see :class:`~robust_ismpc.estimation.filters.PersistenceFilter`) [s], the floor of the mid-range
        target: impulsive pushes are left to the step timing adaptation instead of being
        compensated as if they lasted forever.
    transient_time_constant_s : float
        T, how long a fresh disturbance (the part of ŵ that has not yet persisted for
        ``persistence_s``) is expected to last [s]. The modified stability constraint treats
        w̃ as constant forever; a disturbance decaying as ``e^{-t/T}`` shifts the DCM by only
        ``ηT / (1 + ηT)`` of that (docs/derivations.md), so the fresh part enters the target
        scaled by this factor. Default 0.1 s, the length of a push (the choice is measured in
        docs/robust.md). ``math.inf``: the fresh part counts in full.
    governor : bool
        True (default): the fresh estimate (without the persistence window) enters the mid-range
        target as far as the shifted DCM stays inside the exact feasibility region of the current
        step timing, on each axis of the support frame, in single support
        (:mod:`robust_ismpc.estimation.governor`), and as far as the QP stays feasible in double
        support; a persistent force is then compensated without waiting for the persistence
        window, while a push cannot move the shifted DCM out of the region.
        False: the persistent part only (what the governor adds: docs/robust.md).
    midrange_rate_mps3 : float
        Largest rate of change of the mid-range disturbance w̃ used by the MPC [m/s³]. The
        restriction's guarantee holds while w̃ is steady.
    sta : StaParams or None
        Step timing adaptation settings; None: defaults with the safety margin (and trigger
        distance) set to 1/16 of the smaller ZMP box side, the largest fraction at which no
        undisturbed gait adapts (docs/robust.md).
    """

    delta_max_mps2: float | None = None
    delta_max_fraction: float = 0.5
    disturbance_time_constant_s: float = 0.03
    persistence_s: float = 0.12
    transient_time_constant_s: float = 0.1
    governor: bool = True
    midrange_rate_mps3: float = 10.0
    sta: StaParams | None = None

    def __post_init__(self) -> None:
        if self.delta_max_mps2 is not None and not (
            isinstance(self.delta_max_mps2, (int, float)) and math.isfinite(self.delta_max_mps2) and self.delta_max_mps2 >= 0
        ):
            raise ParameterError(f"RobustParams.delta_max_mps2 must be a finite number >= 0, got {self.delta_max_mps2!r}")
        if not (isinstance(self.delta_max_fraction, (int, float)) and 0 < self.delta_max_fraction < 1):
            raise ParameterError(f"RobustParams.delta_max_fraction must be in (0, 1), got {self.delta_max_fraction!r}")
        if not (isinstance(self.persistence_s, (int, float)) and math.isfinite(self.persistence_s)
                and self.persistence_s >= 0):
            raise ParameterError(f"RobustParams.persistence_s must be a finite number >= 0, got {self.persistence_s!r}")
        if not (isinstance(self.transient_time_constant_s, (int, float)) and self.transient_time_constant_s > 0
                and not math.isnan(self.transient_time_constant_s)):
            raise ParameterError("RobustParams.transient_time_constant_s must be a number > 0 (inf allowed), "
                                 f"got {self.transient_time_constant_s!r}")
        if not isinstance(self.governor, bool):
            raise ParameterError(f"RobustParams.governor must be a bool, got {self.governor!r}")
        check_nonnegative("RobustParams", disturbance_time_constant_s=self.disturbance_time_constant_s)
        if not (isinstance(self.midrange_rate_mps3, (int, float)) and math.isfinite(self.midrange_rate_mps3)
                and self.midrange_rate_mps3 > 0):
            raise ParameterError(f"RobustParams.midrange_rate_mps3 must be a finite number > 0, got {self.midrange_rate_mps3!r}")
