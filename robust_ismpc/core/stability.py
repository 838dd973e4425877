r"""Stability constraint coefficients and tails (spec §6).

For a piecewise-linear ZMP with velocities :math:`\dot x_z^{k+i}` over the control horizon and a
conjectured tail, the stability condition :math:`\bar x_u^k=\eta\int_{t_k}^\infty
e^{-\eta(\tau-t_k)}x_z(\tau)d\tau` becomes one linear equality per axis

.. math::
    a_u^T \dot X_z + \tau^T \tilde X = \bar x_u^k - c_z x_z^k

where :math:`\tilde X=(\tilde x^C,\dots,\tilde x^P)` are tail ZMP samples (anticipative tail only).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import ParameterError


@dataclass(frozen=True)
class StabilityCoefficients:
    """Coefficients of the stability equality for one tail type.

    Attributes
    ----------
    zmp_vel : ndarray, shape (C,)
        a_u, multiplying the ZMP velocities [s].
    zmp_now : float
        c_z, multiplying the current ZMP x_z^k on the right-hand side.
    tail : ndarray, shape (P - C + 1,)
        τ, multiplying the tail samples x̃^C..x̃^P (zeros unless anticipative).
    """

    zmp_vel: np.ndarray
    zmp_now: float
    tail: np.ndarray


def stability_coefficients(eta: float, sampling_period_s: float, C: int, P: int, tail: str) -> StabilityCoefficients:
    """Coefficients of the stability constraint (spec §6.2-§6.3).

    Parameters
    ----------
    eta : float
        LIP natural frequency [1/s].
    sampling_period_s : float
        δ [s].
    C, P : int
        Control and preview horizon samples (P >= C).
    tail : str
        ``anticipative`` (position form of §6.3 with a linearly interpolated tail held after
        T_p), ``periodic`` or ``truncated``.
    """
    if P < C:
        raise ParameterError(f"preview samples P={P} must be >= control samples C={C}")
    lam = np.exp(-eta * sampling_period_s)
    powers = lam ** np.arange(C)
    tail_coef = np.zeros(P - C + 1)
    if tail == "truncated":
        a_u = (1.0 - lam) * powers / eta
        c_z = 1.0
    elif tail == "periodic":
        a_u = (1.0 - lam) * powers / (eta * (1.0 - lam**C))
        c_z = 1.0
    elif tail == "anticipative":
        a_u = (1.0 - lam) * powers / eta - sampling_period_s * lam**C
        c_z = 1.0 - lam**C
        kappa = (1.0 - lam) / (eta * sampling_period_s) - lam
        seg = lam ** np.arange(C, P)  # segment i = C..P-1 weight λ^i
        tail_coef[:-1] += seg * (1.0 - lam - kappa)  # x̃^i coefficient from its own segment
        tail_coef[1:] += seg * kappa  # x̃^{i+1} coefficient from segment i
        tail_coef[-1] += lam**P  # held after T_p
    else:
        raise ParameterError(f"unknown tail {tail!r}; use anticipative, periodic or truncated")
    return StabilityCoefficients(zmp_vel=a_u, zmp_now=float(c_z), tail=tail_coef)
