"""The constraint rows of the inverse-dynamics QP (:mod:`~robust_ismpc.sim.whole_body.inverse_dynamics`).

:func:`contact_cone` gives a sole's contact rows on its wrench; :class:`QpRows` holds the
constraint arrays of the QP for one pair of soles in contact, with the parts that do not change
from one solve to the next filled once, so that each solve writes only the blocks that depend on
the state.
"""

from __future__ import annotations

import numpy as np

NO_BOUND = 1e9  # DAQP's stand-in for an infinite row bound
#: DAQP's sense flag of an equality row.
EQUALITY = 5


def contact_cone(friction: float, half_width_m: float, half_length_m: float, torsion_m: float,
                 min_normal_force_n: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rows of a sole in contact on its wrench in the sole frame (f, m), and their bounds.

    The normal force is at least ``min_normal_force_n``; each of f_x, f_y, m_x, m_y, m_z lies
    within ± its limit times the normal force: the friction coefficient for the tangential forces,
    the half-width and the half-length of the (shrunk) sole [m] for the moments that move the
    centre of pressure, ``torsion_m`` for the moment about the normal.

    Returns
    -------
    rows : ndarray, shape (11, 6)
    lower, upper : ndarray, shape (11,)
    """
    limits = (friction, friction, half_width_m, half_length_m, torsion_m)
    rows = np.zeros((11, 6))
    rows[0, 2] = 1.0
    for k, (component, limit) in enumerate(zip((0, 1, 3, 4, 5), limits)):
        rows[1 + 2 * k, component] = 1.0
        rows[2 + 2 * k, component] = -1.0
        rows[1 + 2 * k:3 + 2 * k, 2] = -limit
    lower = np.concatenate([[min_normal_force_n], np.full(10, -NO_BOUND)])
    upper = np.concatenate([[NO_BOUND], np.zeros(10)])
    return rows, lower, upper


class QpRows:
    """The QP's constraint arrays for one pair of soles in contact, their constant parts filled.

    Rows: the floating base's dynamics (6), the acceleration of each sole in contact (6 each),
    then each sole's wrench (11 rows in contact, its cone, whose coefficients the caller writes at
    every solve; 6 in the air, where the wrench is zero), then one torque row per motor. The
    columns are ``(q̈, left wrench, right wrench)``.

    Parameters
    ----------
    in_contact : tuple of bool
        Whether the left and the right sole are in contact.
    nv, n_motors : int
        Degrees of freedom of the model and number of motors.
    contact_lower, contact_upper : ndarray, shape (11,)
        Bounds of the cone rows of a sole in contact (:func:`contact_cone`).

    Attributes
    ----------
    A : ndarray, shape (m, nv + 12)
        The rows; zero where no solve writes.
    upper, lower : ndarray, shape (m,)
        Their bounds, filled for the wrench rows.
    sense : ndarray of int32, shape (m,)
        DAQP's flags: the dynamics and the soles' accelerations are equalities.
    n_eq : int
        Number of equality rows (the first ones).
    wrench_row : list of int
        First wrench row of each sole.
    torque_row : int
        First torque row.
    """

    def __init__(self, in_contact: tuple[bool, bool], nv: int, n_motors: int, contact_lower: np.ndarray,
                 contact_upper: np.ndarray) -> None:
        self.n_eq = 6 + 6 * sum(in_contact)
        m_rows = self.n_eq + sum(11 if contact else 6 for contact in in_contact) + n_motors
        self.A = np.zeros((m_rows, nv + 12))
        self.upper = np.empty(m_rows)
        self.lower = np.empty(m_rows)
        self.sense = np.zeros(m_rows, dtype=np.int32)
        self.sense[:self.n_eq] = EQUALITY
        self.wrench_row: list[int] = []
        row = self.n_eq
        for i, contact in enumerate(in_contact):
            self.wrench_row.append(row)
            if contact:
                self.lower[row:row + 11] = contact_lower
                self.upper[row:row + 11] = contact_upper
                row += 11
            else:
                start = nv + 6 * i
                self.A[row:row + 6, start:start + 6] = np.eye(6)
                self.upper[row:row + 6] = self.lower[row:row + 6] = 0.0
                row += 6
        self.torque_row = row


__all__ = ["EQUALITY", "NO_BOUND", "QpRows", "contact_cone"]
