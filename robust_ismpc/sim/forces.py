"""External forces on robot bodies: constant windows and impulses, applied at every physics step.

A :class:`Force` or :class:`Impulse` is written into ``data.xfrc_applied`` of a robot body (the
torso by default) by a :class:`ForceSchedule`; it acts at the body's centre of mass.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from ..exceptions import ModelError, ParameterError
from ..validation import check_number, check_positive
from .robot import DISTURBANCE_PREFIX


@dataclass(frozen=True)
class Force:
    """A constant force on a body during [t_start_s, t_end_s).

    Attributes
    ----------
    fx_n, fy_n : float
        Horizontal force components, world frame [N].
    t_start_s : float
        Start time [s].
    t_end_s : float
        End time [s] (``math.inf`` for a force that never stops).
    fz_n : float
        Vertical component [N].
    body : str or None
        Body the force acts on (at its CoM); None means the robot's torso body.
    """

    fx_n: float
    fy_n: float
    t_start_s: float = 0.0
    t_end_s: float = math.inf
    fz_n: float = 0.0
    body: str | None = None

    def __post_init__(self) -> None:
        check_number("Force", allow_inf=True, fx_n=self.fx_n, fy_n=self.fy_n, fz_n=self.fz_n, t_start_s=self.t_start_s,
                t_end_s=self.t_end_s)
        if not all(math.isfinite(v) for v in (self.fx_n, self.fy_n, self.fz_n, self.t_start_s)):
            raise ParameterError(f"Force components and t_start_s must be finite, got {self}")
        if not self.t_end_s > self.t_start_s:
            raise ParameterError(f"Force.t_end_s ({self.t_end_s}) must be > t_start_s ({self.t_start_s})")

    def vector_n(self) -> np.ndarray:
        """Force vector, shape (3,) [N]."""
        return np.array([self.fx_n, self.fy_n, self.fz_n])

    def is_active(self, t_s: float) -> bool:
        """True while t_start_s <= t_s < t_end_s."""
        return self.t_start_s <= t_s < self.t_end_s

    def as_force(self) -> Force:
        """This force (for uniform handling with :class:`Impulse`)."""
        return self


@dataclass(frozen=True)
class Impulse:
    """A push: momentum delivered by a constant force over a short duration.

    Attributes
    ----------
    px_ns, py_ns : float
        Horizontal impulse components [N s].
    t_s : float
        Start of the push [s].
    duration_s : float
        Duration over which the force ``p / duration_s`` acts [s].
    body : str or None
        Body pushed (at its CoM); None means the robot's torso body.
    """

    px_ns: float
    py_ns: float
    t_s: float
    duration_s: float = 0.1
    body: str | None = None

    def __post_init__(self) -> None:
        check_number("Impulse", allow_inf=True, px_ns=self.px_ns, py_ns=self.py_ns, t_s=self.t_s)
        if not all(math.isfinite(v) for v in (self.px_ns, self.py_ns, self.t_s)):
            raise ParameterError(f"Impulse components and t_s must be finite, got {self}")
        check_positive("Impulse", duration_s=self.duration_s)

    def as_force(self) -> Force:
        """The equivalent windowed :class:`Force`."""
        return Force(
            fx_n=self.px_ns / self.duration_s,
            fy_n=self.py_ns / self.duration_s,
            t_start_s=self.t_s,
            t_end_s=self.t_s + self.duration_s,
            body=self.body,
        )


Disturbance = Force | Impulse


class ForceSchedule:
    """Forces to write into ``data.xfrc_applied`` as time goes.

    Parameters
    ----------
    model : mujoco.MjModel
        Scene model.
    disturbances : sequence of Force or Impulse
    default_body : str
        Body for disturbances whose ``body`` is None (the robot's torso).

    Raises
    ------
    ModelError
        A named body is absent from the model.
    """

    def __init__(self, model: mujoco.MjModel, disturbances: Sequence[Disturbance], default_body: str) -> None:
        self._forces: list[tuple[Force, int]] = []
        for dist in disturbances:
            if not isinstance(dist, (Force, Impulse)):
                raise ParameterError(f"expected Force or Impulse, got {dist!r}")
            force = dist.as_force()
            name = force.body or default_body
            body_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
            if body_id < 0:
                raise ModelError(f"disturbance body {name!r} not found in the model")
            self._forces.append((force, body_id))
        self._bodies = sorted({b for _, b in self._forces})
        self._on_robot = {b for _, b in self._forces if not model.body(b).name.startswith(DISTURBANCE_PREFIX)}

    def apply(self, data: mujoco.MjData, t_s: float) -> np.ndarray:
        """Write the forces active at ``t_s`` (and zero the others).

        Returns the total force on robot bodies (3,) [N]; forces on added scene bodies (the
        holding force of a :class:`SwingingBall`) are applied but not counted.
        """
        total = np.zeros(3)
        for b in self._bodies:
            data.xfrc_applied[b, :] = 0.0
        for force, b in self._forces:
            if force.is_active(t_s):
                vec = force.vector_n()
                data.xfrc_applied[b, :3] += vec
                if b in self._on_robot:
                    total += vec
        return total

    def __len__(self) -> int:
        return len(self._forces)
