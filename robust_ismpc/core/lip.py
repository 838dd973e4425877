r"""Linear inverted pendulum with dynamic extension (ZMP velocity as input).

Per horizontal axis the state is :math:`\xi = (x_c, \dot x_c, x_z)` and the input is
:math:`\dot x_z`:

.. math::
    \dot\xi = A\xi + B\dot x_z + E w,\quad
    A = \begin{bmatrix}0&1&0\\ \eta^2&0&-\eta^2\\ 0&0&0\end{bmatrix},\;
    B = (0, 0, 1)^T,\; E = (0, 1, 0)^T

with :math:`w` a disturbance acceleration on the CoM [m/s^2]. The discretisation is exact for a
zero-order hold on :math:`\dot x_z` and :math:`w` (spec §2.2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..exceptions import ParameterError


@dataclass(frozen=True)
class LipDiscretisation:
    """Exact ZOH discretisation of the extended LIP over ``period_s``.

    Attributes
    ----------
    A : ndarray, shape (3, 3)
        State transition.
    B : ndarray, shape (3,)
        Input column (ZMP velocity [m/s]).
    E : ndarray, shape (3,)
        Disturbance column (CoM acceleration [m/s^2]).
    """

    eta: float
    period_s: float
    A: np.ndarray
    B: np.ndarray
    E: np.ndarray


def continuous_matrices(eta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Continuous-time (A, B, E) of the extended LIP, shapes (3, 3), (3,), (3,)."""
    e2 = eta * eta
    A = np.array([[0.0, 1.0, 0.0], [e2, 0.0, -e2], [0.0, 0.0, 0.0]])
    return A, np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0])


def discretise(eta: float, period_s: float) -> LipDiscretisation:
    """Exact discretisation (spec §2.2) of the extended LIP.

    Parameters
    ----------
    eta : float
        LIP natural frequency sqrt(g/h) [1/s].
    period_s : float
        Hold period [s].
    """
    if not (math.isfinite(eta) and eta > 0):
        raise ParameterError(f"eta must be a finite number > 0, got {eta!r}")
    if not (math.isfinite(period_s) and period_s > 0):
        raise ParameterError(f"period_s must be a finite number > 0, got {period_s!r}")
    ch = math.cosh(eta * period_s)
    sh = math.sinh(eta * period_s)
    A = np.array(
        [[ch, sh / eta, 1.0 - ch], [eta * sh, ch, -eta * sh], [0.0, 0.0, 1.0]]
    )
    B = np.array([period_s - sh / eta, 1.0 - ch, period_s])
    E = np.array([(ch - 1.0) / eta**2, sh / eta, 0.0])
    return LipDiscretisation(eta=eta, period_s=period_s, A=A, B=B, E=E)


def dcm(com_pos_m: np.ndarray, com_vel_mps: np.ndarray, eta: float) -> np.ndarray:
    """Divergent component of motion x_u = x_c + ẋ_c / η [m], elementwise."""
    return np.asarray(com_pos_m) + np.asarray(com_vel_mps) / eta


def step_state(
    disc: LipDiscretisation,
    state: np.ndarray,
    zmp_vel_mps: np.ndarray | float,
    disturbance_mps2: np.ndarray | float = 0.0,
) -> np.ndarray:
    """Advance LIP states one period.

    Parameters
    ----------
    state : ndarray, shape (3,) or (3, n)
        (x_c, ẋ_c, x_z) per column (one column per axis).
    zmp_vel_mps : float or ndarray, shape (n,)
        Held ZMP velocity.
    disturbance_mps2 : float or ndarray, shape (n,)
        Held disturbance acceleration.

    Returns
    -------
    ndarray, same shape as ``state``.
    """
    state = np.asarray(state, dtype=float)
    u = np.asarray(zmp_vel_mps, dtype=float)
    w = np.asarray(disturbance_mps2, dtype=float)
    if state.ndim == 1:
        return disc.A @ state + disc.B * u + disc.E * w
    return disc.A @ state + np.outer(disc.B, u) + np.outer(disc.E, w)
