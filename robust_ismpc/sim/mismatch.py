"""A model mismatch realised on the simulated robot (:class:`~robust_ismpc.robots.mismatch.ModelMismatch`).

The payload is a body of the scene (:func:`~robust_ismpc.sim.scene.build_scene`); this module
scales the simulated robot's masses, inertias and motors. The controller's side keeps the model:
:class:`~robust_ismpc.sim.robot.MujocoRobot` copies the masses and inertias it measures with when
it is built, before :func:`apply_mismatch`, and the whole-body layer compiles its own model.
"""

from __future__ import annotations

import mujoco
import numpy as np

from ..robots.mismatch import ModelMismatch


def apply_mismatch(model: mujoco.MjModel, robot_body_ids: np.ndarray, mismatch: ModelMismatch) -> None:
    """Scale, in place, the masses and inertias of ``robot_body_ids`` by ``mismatch.mass_scale``
    and every actuator's force (gain, bias and force range) by ``mismatch.motor_strength``.

    Parameters
    ----------
    model : mujoco.MjModel
        The simulated scene (a copy of its own, not the cached robot model).
    robot_body_ids : ndarray of int
        The robot's bodies (the scene's disturbance bodies are not scaled).
    mismatch : ModelMismatch
    """
    ids = np.asarray(robot_body_ids, dtype=int)
    if mismatch.mass_scale != 1.0:
        model.body_mass[ids] *= mismatch.mass_scale
        model.body_inertia[ids] *= mismatch.mass_scale
    if mismatch.motor_strength != 1.0:
        model.actuator_gainprm[:] *= mismatch.motor_strength
        model.actuator_biasprm[:] *= mismatch.motor_strength
        model.actuator_forcerange[:] *= mismatch.motor_strength


__all__ = ["apply_mismatch"]
