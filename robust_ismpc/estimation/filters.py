r"""Filters between the disturbance estimate ŵ and the mid-range w̃ the MPC uses (spec §11.5).

:class:`PersistenceFilter` keeps the part of ŵ that lasted (a push is left to the step timing);
:class:`MidrangeFilter` saturates and rate-limits the target into w̃, which the modified stability
constraint and the reference integration use. The estimate itself comes from
:class:`~robust_ismpc.estimation.estimator.DisturbanceEstimator`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..exceptions import ParameterError
from ..validation import check_vector

__all__ = ["MidrangeFilter", "MidrangeParams", "PersistenceFilter"]


@dataclass(frozen=True)
class MidrangeParams:
    r"""Saturation and rate limit that turn the observer estimate ŵ into the mid-range w̃ (§11.5).

    Attributes
    ----------
    max_change_mps2 : float
        Largest change of w̃ between two consecutive samples [m/s² per sample], > 0. The same
        number must be passed as ``max_midrange_change_mps2`` to
        :func:`robust_ismpc.core.restriction.restriction_rate`: a mid-range change of Δw̃ per sample
        moves the shifted DCM by Δw̃/η², which the restriction must absorb. Default 0.002 m/s²
        per sample (0.2 m/s³ at δ = 0.01 s): at h = 0.71 m, T_c = 1 s it costs
        r ≈ 0.015 m/s, about 38 % of the largest restriction of a 0.08 m ZMP box, and it tracks a
        change of 1 m/s² (40 N on 40 kg) in 5 s. Faster changes (pushes) are STA's job.
        See ``docs/derivations.md`` §2.4.
    band_centre_mps2 : tuple of float or None
        Mid-range centre (w_m,x, w_m,y) of the admissible band [m/s²]; None: no band.
    band_half_width_mps2 : float or None
        Half width Δ of the band [m/s²]: w̃ is saturated to [w_m − Δ, w_m + Δ]. None: no band.
    """

    max_change_mps2: float = 0.002
    band_centre_mps2: tuple[float, float] | None = None
    band_half_width_mps2: float | None = None

    def __post_init__(self) -> None:
        v = self.max_change_mps2
        if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
            raise ParameterError(f"MidrangeParams.max_change_mps2 must be a finite number > 0, got {v!r}")
        if (self.band_centre_mps2 is None) != (self.band_half_width_mps2 is None):
            raise ParameterError(
                "MidrangeParams: give both band_centre_mps2 and band_half_width_mps2, or neither"
            )
        if self.band_half_width_mps2 is not None:
            hw = self.band_half_width_mps2
            if not isinstance(hw, (int, float)) or not math.isfinite(hw) or hw < 0:
                raise ParameterError(f"MidrangeParams.band_half_width_mps2 must be a finite number >= 0, got {hw!r}")
            centre = tuple(float(c) for c in np.broadcast_to(np.asarray(self.band_centre_mps2, dtype=float), (2,)))
            if not all(math.isfinite(c) for c in centre):
                raise ParameterError(f"MidrangeParams.band_centre_mps2 must be finite, got {self.band_centre_mps2!r}")
            object.__setattr__(self, "band_centre_mps2", centre)


class MidrangeFilter:
    r"""Saturate and rate-limit the disturbance estimate: ŵ → w̃ (spec §11.5).

    Per axis, :math:`\tilde w_k = \mathrm{clip}(\mathrm{clip}(\hat w_k, w_m - Δ, w_m + Δ),
    \tilde w_{k-1} - ρ, \tilde w_{k-1} + ρ)`: the closed form of the reference code's 1-D
    saturation QP, with the rate limit ρ expressed in m/s² per sample (the reference's limit mixes
    units). The rate limit is applied last so that |w̃_k − w̃_{k−1}| ≤ ρ always holds, which is
    what the restriction guarantee needs; the band is therefore reached at most ρ per sample.

    Parameters
    ----------
    params : MidrangeParams
    """

    def __init__(self, params: MidrangeParams | None = None):
        self.params = params if params is not None else MidrangeParams()
        self._value = np.zeros(2)

    @property
    def value(self) -> np.ndarray:
        """Current mid-range w̃ (x, y) [m/s²], shape (2,)."""
        return self._value.copy()

    def reset(self, w_xy: np.ndarray | float = 0.0) -> None:
        """Set w̃ (x, y) [m/s²] without rate limit."""
        self._value = check_vector("", "w_xy", np.broadcast_to(np.asarray(w_xy, dtype=float), (2,)), 2)

    def update(self, w_hat_xy: np.ndarray) -> np.ndarray:
        """Return the new mid-range w̃ (x, y) [m/s²], shape (2,), from the estimate ŵ (x, y)."""
        target = check_vector("", "w_hat_xy", w_hat_xy, 2)
        p = self.params
        if p.band_half_width_mps2 is not None:
            centre = np.asarray(p.band_centre_mps2)
            target = np.clip(target, centre - p.band_half_width_mps2, centre + p.band_half_width_mps2)
        rho = p.max_change_mps2
        self._value = np.clip(target, self._value - rho, self._value + rho)
        return self._value.copy()


class PersistenceFilter:
    r"""Keep only the persistent part of the disturbance estimate (a sliding-window erosion).

    Per axis, the output is the estimate of smallest magnitude over the last ``window``
    samples when they all have the same sign, and 0 otherwise. A disturbance shorter than the
    window (an impulsive push) therefore never reaches the mid-range w̃, where the modified
    stability constraint would treat it as lasting forever, while a persistent force passes
    after one window. Pushes are the job of the step timing adaptation (spec §13).

    Parameters
    ----------
    window : int
        Number of samples (>= 1; 1 passes the estimate through unchanged).
    """

    def __init__(self, window: int):
        if not isinstance(window, (int, np.integer)) or window < 1:
            raise ParameterError(f"PersistenceFilter window must be an integer >= 1, got {window!r}")
        self.window = int(window)
        self._buffer = np.zeros((self.window, 2))
        self._count = 0

    def reset(self) -> None:
        self._buffer[:] = 0.0
        self._count = 0

    def update(self, w_hat_xy: np.ndarray) -> np.ndarray:
        """Push ŵ (x, y) [m/s²] and return its persistent part, shape (2,)."""
        self._buffer[self._count % self.window] = check_vector("", "w_hat_xy", w_hat_xy, 2)
        self._count += 1
        buf = self._buffer
        same_sign = np.all(buf > 0, axis=0) | np.all(buf < 0, axis=0)
        smallest = buf[np.argmin(np.abs(buf), axis=0), [0, 1]]
        return np.where(same_sign, smallest, 0.0)
