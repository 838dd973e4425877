"""Feasibility governor of the mid-range disturbance: how much of a fresh estimate the MPC may use.

The mid-range disturbance w̃ enters the stability constraint through the shifted DCM
x̄_u = x_u + w̃/η² as if it lasted forever (spec §11.5). A fresh estimate cannot tell a persistent
force from a push: used at once it compensates a constant force early but over-compensates a
0.1 s push (the plan is committed to a disturbance that stops); used only once it has persisted
(:class:`~robust_ismpc.estimation.filters.PersistenceFilter`) it is safe against pushes but late for a
constant force.

The governor takes the persistent part ``w_p`` as a floor and lets the fresh estimate ``w_f`` in
only as far as the shifted DCM stays inside the exact feasibility region of the current step
timing (:func:`~robust_ismpc.core.feasibility.feasibility_bounds_at`). Since x̄_u is affine in w̃, the
admissible w̃ on each axis of the support frame is the interval

    [(l − d) η², (u − d) η²],  d = x_u in the support frame, (l, u) the feasibility bounds,

and the target is ``clip(w_f, interval)`` when ``w_p`` lies in it (a point between ``w_p`` and
``w_f``, the one closest to ``w_f``), else ``w_p``. So the transient part of the estimate never
moves the shifted DCM out of the region by itself: a push is left to the step timing adaptation,
while a persistent force gets its early compensation up to what the gait can absorb.
"""

from __future__ import annotations

import numpy as np

from ..exceptions import ParameterError
from ..validation import check_vector

__all__ = ["admissible_disturbance", "governed_disturbance", "interval_unchecked", "target_unchecked"]


def admissible_disturbance(
    dcm_local_m: np.ndarray, lower_m: np.ndarray, upper_m: np.ndarray, eta: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per-axis interval of w̃ that keeps the shifted DCM inside the feasibility bounds.

    Parameters
    ----------
    dcm_local_m : array_like, shape (2,)
        Unshifted DCM x_u in the support frame [m].
    lower_m, upper_m : array_like, shape (2,)
        Feasibility bounds of the shifted DCM in the same frame [m].
    eta : float
        LIP natural frequency [1/s].

    Returns
    -------
    low, high : ndarray, shape (2,)
        Admissible disturbance interval per axis [m/s²] (empty when low > high).
    """
    if not (np.isfinite(eta) and eta > 0):
        raise ParameterError(f"eta must be a finite number > 0, got {eta!r}")
    d = check_vector("", "dcm_local_m", dcm_local_m, 2)
    lower = check_vector("", "lower_m", lower_m, 2, allow_inf=True)
    upper = check_vector("", "upper_m", upper_m, 2, allow_inf=True)
    return interval_unchecked(d, lower, upper, eta * eta)


def governed_disturbance(
    persistent_mps2: np.ndarray, fresh_mps2: np.ndarray, low_mps2: np.ndarray, high_mps2: np.ndarray
) -> np.ndarray:
    """Target w̃ per axis: the fresh estimate clipped to the admissible interval, with the
    persistent part as a floor.

    On each axis: ``clip(fresh, low, high)`` when ``low <= persistent <= high`` (this point lies
    between ``persistent`` and ``fresh``), else ``persistent``.

    Parameters
    ----------
    persistent_mps2, fresh_mps2 : array_like, shape (2,)
        Persistent and fresh disturbance estimates, in the frame of the interval [m/s²].
    low_mps2, high_mps2 : array_like, shape (2,)
        Admissible interval (:func:`admissible_disturbance`) [m/s²].

    Returns
    -------
    ndarray, shape (2,)
    """
    persistent = check_vector("", "persistent_mps2", persistent_mps2, 2)
    fresh = check_vector("", "fresh_mps2", fresh_mps2, 2)
    low = check_vector("", "low_mps2", low_mps2, 2, allow_inf=True)
    high = check_vector("", "high_mps2", high_mps2, 2, allow_inf=True)
    return target_unchecked(persistent, fresh, low, high)


def interval_unchecked(dcm_local_m: np.ndarray, lower_m: np.ndarray, upper_m: np.ndarray, eta2: float):
    """:func:`admissible_disturbance` without input checks, for the controller's per-cycle use
    (its inputs are its own finite arrays of shape (2,)); ``eta2`` = η²."""
    return (lower_m - dcm_local_m) * eta2, (upper_m - dcm_local_m) * eta2


def target_unchecked(persistent: np.ndarray, fresh: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """:func:`governed_disturbance` without input checks (see :func:`interval_unchecked`)."""
    inside = (persistent >= low) & (persistent <= high)
    return np.where(inside, np.minimum(np.maximum(fresh, low), np.maximum(low, high)), persistent)
