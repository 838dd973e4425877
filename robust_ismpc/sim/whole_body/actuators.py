"""A simulation model's actuators: which joint coordinate each drives, and the torques it can apply."""

from __future__ import annotations

import mujoco
import numpy as np

from ...exceptions import ModelError


def as_slice(index: np.ndarray) -> slice | np.ndarray:
    """``index`` as a slice when it is a run of consecutive increasing integers (indexing with it
    then gives a view of the same elements instead of a copy), else ``index`` itself."""
    index = np.asarray(index)
    if index.size and np.array_equal(index, np.arange(index[0], index[0] + index.size)):
        return slice(int(index[0]), int(index[0]) + index.size)
    return index


class ActuatorMap:
    """Which IK coordinate each actuator of a simulation model drives.

    Parameters
    ----------
    sim_model : mujoco.MjModel
        Simulation model (may contain extra bodies, e.g. disturbances).
    ik_model : mujoco.MjModel
        Model of the IK configuration.

    Attributes
    ----------
    ik_qpos_index, ik_dof_index : ndarray of int, shape (nu,)
        For actuator ``a``, the index in the IK ``qpos`` / ``qvel`` of its joint.
    kp : ndarray, shape (nu,)
        Position gains of the servos [N m/rad] (meaningless for motors).
    kd : ndarray, shape (nu,)
        Velocity gains of the servos [N m s/rad] (``-biasprm[2]``; 0 for motors).
    sim_qpos_index, sim_dof_index : ndarray of int, shape (nu,)
        Index of the actuated joint in the simulation ``qpos`` / ``qvel``.
    is_position : ndarray of bool, shape (nu,)
        True for position servos (``ctrl`` is the joint angle target); False for motors
        (``ctrl`` is a torque, computed by a PD law in the loop).

    Raises
    ------
    ModelError
        An actuator does not drive a hinge or slide joint present in the IK model.
    """

    def __init__(self, sim_model: mujoco.MjModel, ik_model: mujoco.MjModel) -> None:
        ik_q, ik_v, sim_q, sim_v, is_pos = [], [], [], [], []
        for a in range(sim_model.nu):
            if sim_model.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT:
                raise ModelError(f"actuator {sim_model.actuator(a).name!r} does not drive a joint")
            jid = int(sim_model.actuator_trnid[a, 0])
            jname = sim_model.joint(jid).name
            ik_jid = mujoco.mj_name2id(ik_model, mujoco.mjtObj.mjOBJ_JOINT, jname)
            if ik_jid < 0:
                raise ModelError(f"actuated joint {jname!r} is not in the IK model")
            hinge_or_slide = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
            if int(sim_model.jnt_type[jid]) not in hinge_or_slide:
                raise ModelError(f"actuated joint {jname!r} is not a hinge or slide joint")
            ik_q.append(int(ik_model.jnt_qposadr[ik_jid]))
            ik_v.append(int(ik_model.jnt_dofadr[ik_jid]))
            sim_q.append(int(sim_model.jnt_qposadr[jid]))
            sim_v.append(int(sim_model.jnt_dofadr[jid]))
            kp = sim_model.actuator_gainprm[a, 0]
            is_pos.append(bool(kp > 0 and abs(sim_model.actuator_biasprm[a, 1] + kp) < 1e-9 * max(1.0, kp)))
        self.ik_qpos_index = np.array(ik_q, dtype=int)
        self.ik_dof_index = np.array(ik_v, dtype=int)
        self.kp = sim_model.actuator_gainprm[:, 0].copy()
        self.kd = np.where(is_pos, -sim_model.actuator_biasprm[:, 2], 0.0)
        self.sim_qpos_index = np.array(sim_q, dtype=int)
        self.sim_dof_index = np.array(sim_v, dtype=int)
        self.is_position = np.array(is_pos, dtype=bool)

    def targets(self, ik_qpos: np.ndarray) -> np.ndarray:
        """Joint angle targets of all actuators, shape (nu,) [rad or m]."""
        return ik_qpos[self.ik_qpos_index]


def actuator_torque_limits_nm(model: mujoco.MjModel) -> np.ndarray:
    """The joint torque interval each actuator of ``model`` can apply, shape (nu, 2) [N m].

    The intersection, through the actuator's gear, of its force range (if force-limited), a
    motor's control range times its gain (if control-limited; a position servo's control range is
    an angle, not a torque) and its joint's actuator force range (if limited); ±inf where nothing
    limits it.
    """
    limits = np.tile([-np.inf, np.inf], (model.nu, 1))
    for a in range(model.nu):
        gear = float(model.actuator_gear[a, 0])
        gain = float(model.actuator_gainprm[a, 0])
        motor = (int(model.actuator_biastype[a]) == int(mujoco.mjtBias.mjBIAS_NONE)
                 or not np.any(model.actuator_biasprm[a, :3]))
        ranges = []
        if model.actuator_forcelimited[a]:
            ranges.append(model.actuator_forcerange[a] * gear)
        if motor and model.actuator_ctrllimited[a]:
            ranges.append(model.actuator_ctrlrange[a] * gain * gear)
        joint = int(model.actuator_trnid[a, 0])
        if model.jnt_actfrclimited[joint]:
            ranges.append(model.jnt_actfrcrange[joint])
        for bound in ranges:
            low, high = float(min(bound)), float(max(bound))
            limits[a] = max(limits[a, 0], low), min(limits[a, 1], high)
    return limits
