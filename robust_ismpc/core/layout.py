"""The one place that knows the order of the IS-MPC decision vector and constraint rows.

Per axis the decision vector is ``(Ẋ_z (C), X_f (F))``: the ZMP velocities over the control
horizon (in the coordinates y = U Ẋ_z that make their cost the identity,
:attr:`robust_ismpc.core.mpc.IsmpcQp.zmp_vel_basis`), then the free footstep coordinates. When the footstep orientations couple the axes
the two per-axis vectors are stacked, x first: ``(Ẋ_z, X_f, Ẏ_z, Y_f)`` (spec §7.1).
:mod:`robust_ismpc.core.mpc` assembles its matrices and reads its solutions only through
:class:`QpLayout`.

Per axis the rows are the C ZMP rows (at t_{k+1} .. t_{k+C}), the F kinematic rows and the
stability row; a coupled QP groups them by kind: ZMP (a, b), kinematic (a, b), stability (a, b),
where a and b are the axes of each row's frame.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from .planner import rotation


@dataclass(frozen=True)
class QpLayout:
    """Index ranges of the decision vector.

    Attributes
    ----------
    C : int
        Control-horizon samples (ZMP velocity variables per axis).
    F : int
        Free footsteps in the control horizon (footstep variables per axis).
    coupled : bool
        True if both axes share one QP.
    frame_yaw_rad : float
        Per-axis QPs only: their axes are those of the frame rotated by this yaw, the one yaw of
        every ZMP box and kinematic box in the horizon [rad] (0 for world axes).
    """

    C: int
    F: int
    coupled: bool
    frame_yaw_rad: float = 0.0

    @property
    def n_axis(self) -> int:
        """Variables of one axis."""
        return self.C + self.F

    @property
    def n(self) -> int:
        """Variables of the QP."""
        return 2 * self.n_axis if self.coupled else self.n_axis

    def zmp_vel(self, axis: int = 0) -> slice:
        """Slice of the ZMP velocities of ``axis`` (0 = x, 1 = y) in this QP's vector."""
        base = axis * self.n_axis if self.coupled else 0
        return slice(base, base + self.C)

    def footsteps(self, axis: int = 0) -> slice:
        """Slice of the free footstep coordinates of ``axis`` in this QP's vector."""
        base = axis * self.n_axis if self.coupled else 0
        return slice(base + self.C, base + self.C + self.F)

    @property
    def m(self) -> int:
        """Rows of the QP."""
        per_axis = self.C + self.F + 1
        return 2 * per_axis if self.coupled else per_axis

    def zmp_rows(self, axis: int = 0) -> slice:
        """Rows of the ZMP constraints of ``axis`` (0 = a, 1 = b; per-axis QPs have one)."""
        return slice(axis * self.C, (axis + 1) * self.C)

    def kinematic_rows(self, axis: int = 0) -> slice:
        """Rows of the kinematic constraints of ``axis``."""
        base = (2 if self.coupled else 1) * self.C + axis * self.F
        return slice(base, base + self.F)

    def stability_rows(self) -> slice:
        """The stability equality row(s): one per axis."""
        return slice(self.m - (2 if self.coupled else 1), self.m)

    def rows_from(self, previous: QpLayout, samples: int, footsteps: int) -> np.ndarray | None:
        """Which row of the previous cycle's QP each row of this one continues (-1: none).

        Parameters
        ----------
        previous : QpLayout
            Layout of the previous cycle.
        samples : int
            Samples the horizon advanced since then (>= 0): ZMP row i continues row i + samples.
        footsteps : int
            How far the first free footstep moved along the plan: kinematic row j continues row
            j + footsteps.

        Returns
        -------
        ndarray of int, shape (m,), or None
            None when the two QPs are not of the same kind (per-axis against coupled).
        """
        if previous.coupled != self.coupled or previous.C != self.C or samples < 0:
            return None
        return _row_map(self.C, self.F, previous.F, self.coupled, samples, footsteps)

    def axis_columns(self, zmp_vel: np.ndarray, footsteps: np.ndarray) -> np.ndarray:
        """One axis's columns joined in order: ``zmp_vel`` (..., C) then ``footsteps`` (..., F)."""
        return np.concatenate([zmp_vel, footsteps], axis=-1)

    def both_axes(self, x_part: np.ndarray, y_part: np.ndarray) -> np.ndarray:
        """A coupled QP's columns: the x axis's (..., C+F) then the y axis's (..., C+F)."""
        return np.concatenate([x_part, y_part], axis=-1)

    def to_frame(self, xy_world: np.ndarray) -> np.ndarray:
        """World (x, y) vectors, shape (..., 2), in the per-axis QPs' frame."""
        return np.asarray(xy_world) @ rotation(self.frame_yaw_rad)

    def to_world(self, xy_frame: np.ndarray) -> np.ndarray:
        """The inverse of :meth:`to_frame`."""
        return np.asarray(xy_frame) @ rotation(self.frame_yaw_rad).T


@functools.lru_cache(maxsize=256)
def _row_map(C: int, F: int, previous_F: int, coupled: bool, samples: int, footsteps: int) -> np.ndarray:
    """:meth:`QpLayout.rows_from`, once per combination (read-only: the MPC asks every cycle)."""
    layout = QpLayout(C=C, F=F, coupled=coupled)
    previous = QpLayout(C=C, F=previous_F, coupled=coupled)
    rows = np.full(layout.m, -1, dtype=np.intp)
    for axis in range(2 if coupled else 1):
        zmp = np.arange(samples, samples + C)
        kept = zmp < C
        rows[layout.zmp_rows(axis)][kept] = previous.zmp_rows(axis).start + zmp[kept]
        kin = np.arange(footsteps, footsteps + F)
        kept = (kin >= 0) & (kin < previous_F)
        rows[layout.kinematic_rows(axis)][kept] = previous.kinematic_rows(axis).start + kin[kept]
    stability = previous.stability_rows()
    rows[layout.stability_rows()] = np.arange(stability.start, stability.stop)
    rows.flags.writeable = False
    return rows
