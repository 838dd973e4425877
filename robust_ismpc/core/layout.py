"""The one place that knows the order of the IS-MPC decision vector.

Per axis the decision vector is ``(Ẋ_z (C), X_f (F))``: the ZMP velocities over the control
horizon, then the free footstep coordinates. When the footstep orientations couple the axes
the two per-axis vectors are stacked, x first: ``(Ẋ_z, X_f, Ẏ_z, Y_f)`` (spec §7.1).
:mod:`robust_ismpc.core.mpc` assembles its matrices and reads its solutions only through
:class:`QpLayout`.
"""

from __future__ import annotations

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
