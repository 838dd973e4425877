r"""The robot's state as its controller knows it: the truth, or an estimate from its sensors.

The whole body and the measurement read the robot's configuration and velocity (``qpos``,
``qvel`` of the robot's own model) from one of two sources:

- :class:`TrueState`: the simulator's state (the ``ideal`` sensing, and tests);
- :class:`SensedState`: what a humanoid gets from its sensors. Every physics step
  :class:`RobotSensors` reads the encoders (positions rounded to their resolution, velocities with
  white noise) and a pelvis IMU (an orientation with a constant tilt error and noise, a gyroscope
  and an accelerometer with noise and constant biases), and
  :class:`~robust_ismpc.estimation.base_filter.BaseStateFilter` turns them, with the legs in contact,
  into the base position and velocity. The orientation and the angular velocity are the IMU's,
  the joints the encoders'. The kinematics of the robot's own MuJoCo model (its masses as
  built, not the simulated robot's) give the soles relative to the base for the filter, and the
  CoM, its velocity, the angular momentum and the soles for the measurement.

The estimate lives in a world of its own: its base position drifts at every touchdown (leg
odometry), and everything the controller reads is in that world, footsteps included. The foot
force-torque readings (the contacts) are placed in it by the estimated soles
(:meth:`SensedState.offset_m`).

MuJoCo (not Pinocchio) computes the kinematics: the robot is a MuJoCo model already, and one
library means one set of frames, masses and joint conventions for the simulation, the whole body
and the estimate.
"""

from __future__ import annotations

import copy
import math
from typing import Protocol

import mujoco
import numpy as np

from ..core.params import GRAVITY_MPS2
from ..estimation.base_filter import GRAVITY_VECTOR_MPS2, BaseFilterParams, BaseStateFilter
from ..exceptions import ModelError, ParameterError
from ..robots.sensing import SensingParams
from ..robots.spec import RobotSpec
from .model import compile_model
from .robot import SIDES, MujocoRobot

__all__ = ["RobotSensors", "RobotState", "SensedState", "TrueState", "state_index"]

#: A sole counts as fixed on the floor for the filter when it bears more than this share of the
#: robot's weight: a foot that only grazes the floor (at touchdown and lift-off) rolls and slides.
FIXED_SOLE_LOAD_FRACTION = 0.1


def state_index(model: mujoco.MjModel, scene: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    """Indices into the scene's ``qpos`` and ``qvel`` of every coordinate of ``model``, whose
    joints the scene has under the same names (its free joint: the one of the same body).

    Raises
    ------
    ParameterError
        A joint of ``model`` is not in the scene.
    """
    qpos, qvel = [], []
    for j in range(model.njnt):
        name = model.joint(j).name
        if name:
            k = mujoco.mj_name2id(scene, mujoco.mjtObj.mjOBJ_JOINT, name)
        else:
            body = mujoco.mj_name2id(scene, mujoco.mjtObj.mjOBJ_BODY, model.body(model.jnt_bodyid[j]).name)
            k = int(scene.body_jntadr[body]) if body >= 0 else -1
        if k < 0 or scene.jnt_type[k] != model.jnt_type[j]:
            raise ParameterError(f"joint {name or j!r} of the robot is not in the simulated scene")
        n_q = {0: 7, 1: 4}.get(int(model.jnt_type[j]), 1)
        n_v = {0: 6, 1: 3}.get(int(model.jnt_type[j]), 1)
        qpos += range(int(scene.jnt_qposadr[k]), int(scene.jnt_qposadr[k]) + n_q)
        qvel += range(int(scene.jnt_dofadr[k]), int(scene.jnt_dofadr[k]) + n_v)
    return np.array(qpos, dtype=int), np.array(qvel, dtype=int)


class RobotState(Protocol):
    """A source of the robot's configuration and velocity in its own model's coordinates."""

    @property
    def qpos(self) -> np.ndarray: ...

    @property
    def qvel(self) -> np.ndarray: ...


class TrueState:
    """The simulator's state of the robot, in the robot model's coordinates.

    Parameters
    ----------
    model : mujoco.MjModel
        The robot's own model (:func:`~robust_ismpc.sim.model.compile_model`).
    scene_model : mujoco.MjModel
    scene_data : mujoco.MjData
        The simulated scene that contains the robot.
    """

    def __init__(self, model: mujoco.MjModel, scene_model: mujoco.MjModel, scene_data: mujoco.MjData) -> None:
        self._data = scene_data
        self._qpos_index, self._qvel_index = state_index(model, scene_model)

    @property
    def qpos(self) -> np.ndarray:
        """Configuration (nq,) of the robot's model."""
        return self._data.qpos[self._qpos_index]

    @property
    def qvel(self) -> np.ndarray:
        """Velocity (nv,) of the robot's model (free joint: world linear, body angular)."""
        return self._data.qvel[self._qvel_index]


def _quat_of_rotation_vector(v: np.ndarray) -> np.ndarray:
    quat = np.empty(4)
    angle = float(np.linalg.norm(v))
    if angle < 1e-12:
        return np.array([1.0, 0.0, 0.0, 0.0])
    mujoco.mju_axisAngle2Quat(quat, v / angle, angle)
    return quat


class RobotSensors:
    """The encoders and the pelvis IMU of a simulated robot, read every physics step.

    The IMU sits at the root body's origin. Its specific force is the root's acceleration over the
    last physics step (from the change of its velocity) minus gravity, in the root frame.

    Parameters
    ----------
    params : SensingParams
    truth : TrueState
        The simulator's state of the robot, in its own model's coordinates (those of the readings).
    timestep_s : float
        The physics step [s].
    rng : numpy.random.Generator
        Source of the noise and of the biases' directions.
    """

    def __init__(self, params: SensingParams, truth: TrueState, timestep_s: float, rng: np.random.Generator) -> None:
        self.params = params
        self._truth = truth
        self._timestep_s = float(timestep_s)
        self._rng = rng

        def direction(planar: bool = False) -> np.ndarray:
            v = rng.standard_normal(3)
            if planar:
                v[2] = 0.0
            return v / max(float(np.linalg.norm(v)), 1e-12)

        self.gyro_bias_radps = params.gyro_bias_radps * direction()
        self.accel_bias_mps2 = params.accel_bias_mps2 * direction()
        #: The constant roll/pitch error of the IMU's orientation, a rotation vector in the world [rad].
        self.tilt_error_rad = params.imu_tilt_error_rad * direction(planar=True)
        self._previous_velocity: np.ndarray | None = None

    def _noise(self, sigma: float, size: int) -> np.ndarray:
        return sigma * self._rng.standard_normal(size) if sigma > 0 else np.zeros(size)

    def read(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The readings of this physics step.

        Returns
        -------
        joint_pos_rad, joint_vel_radps : ndarray, shape (nq - 7,), (nv - 6,)
            Encoders, in the robot model's joint order.
        rotation : ndarray, shape (3, 3)
            The IMU's orientation of the root (root to world).
        gyro_radps : ndarray, shape (3,)
            Angular velocity in the root frame [rad/s].
        specific_force_mps2 : ndarray, shape (3,)
            Acceleration minus gravity in the root frame [m/s²].
        """
        p = self.params
        qpos, qvel = self._truth.qpos, self._truth.qvel
        joints = qpos[7:]
        if p.joint_pos_resolution_rad > 0:
            joints = np.round(joints / p.joint_pos_resolution_rad) * p.joint_pos_resolution_rad
        joint_vel = qvel[6:] + self._noise(p.joint_vel_noise_radps, len(qvel) - 6)
        error = self.tilt_error_rad + self._noise(p.imu_orientation_noise_rad, 3)
        quat = np.empty(4)
        mujoco.mju_mulQuat(quat, _quat_of_rotation_vector(error), qpos[3:7])
        rotation = np.empty(9)
        mujoco.mju_quat2Mat(rotation, quat)
        rotation = rotation.reshape(3, 3)
        gyro = qvel[3:6] + self.gyro_bias_radps + self._noise(p.gyro_noise_radps, 3)
        true_rotation = np.empty(9)
        mujoco.mju_quat2Mat(true_rotation, qpos[3:7])
        velocity = qvel[:3].copy()
        acc = np.zeros(3) if self._previous_velocity is None else (velocity - self._previous_velocity) / self._timestep_s
        self._previous_velocity = velocity
        specific_force = (true_rotation.reshape(3, 3).T @ (acc - GRAVITY_VECTOR_MPS2)
                          + self.accel_bias_mps2 + self._noise(p.accel_noise_mps2, 3))
        return joints.copy(), joint_vel, rotation, gyro, specific_force


def filter_params(params: SensingParams, leg_length_m: float) -> BaseFilterParams:
    """The base filter's noise model for these sensors on legs of about ``leg_length_m`` [m].

    The accelerometer's world acceleration errs by its noise, its bias and the gravity its tilt
    error leaks, plus the root's own vibration the filter does not model (0.5 m/s²). A sole in
    contact gives the base velocity to the joint velocity noise through about three joints on the
    leg's length, plus 2 cm/s of rolling and slipping, and its position to the encoders'
    resolution through six joints on that length, plus 2 mm.
    """
    acc = math.hypot(params.accel_noise_mps2, params.accel_bias_mps2, GRAVITY_MPS2 * params.imu_tilt_error_rad, 0.5)
    vel = math.hypot(math.sqrt(3.0) * params.joint_vel_noise_radps * leg_length_m, 0.02)
    pos = math.hypot(math.sqrt(6.0) * params.joint_pos_resolution_rad * leg_length_m, 0.002)
    return BaseFilterParams(acc_noise_mps2=acc, leg_vel_noise_mps=vel, leg_pos_noise_m=pos)


class SensedState:
    """The robot's state estimated from its encoders, IMU and foot contacts (module docstring).

    Parameters
    ----------
    spec : RobotSpec
    params : SensingParams
        The sensors (:attr:`SensingParams.models_sensors` should be true).
    scene_model, scene_data : mujoco.MjModel, mujoco.MjData
        The simulated scene; the estimate starts at its current state (the robot knows where it
        is placed and that it stands still).
    seed : int
        Seed of the sensors' noise and biases.

    Raises
    ------
    ModelError
        The robot's model does not start with the root's free joint, or has ball joints.
    """

    def __init__(self, spec: RobotSpec, params: SensingParams, scene_model: mujoco.MjModel,
                 scene_data: mujoco.MjData, seed: int = 0) -> None:
        if not isinstance(params, SensingParams):
            raise ParameterError(f"params must be SensingParams, got {type(params).__name__}")
        self.model = _own_model(spec)
        m = self.model
        if m.njnt == 0 or m.jnt_type[0] != mujoco.mjtJoint.mjJNT_FREE or m.nq - 7 != m.nv - 6:
            raise ModelError(f"robot {spec.name!r}: estimating its state needs a free joint at the root first and "
                             "hinge or slide joints after it")
        self.data = mujoco.MjData(self.model)
        #: The robot as its controller computes it: CoM, momentum and soles of the estimate.
        self.robot = MujocoRobot(spec, self.model, self.data)
        self._params, self._seed = params, seed
        self._timestep_s = float(scene_model.opt.timestep)
        self._truth = TrueState(self.model, scene_model, scene_data)
        self._fixed_load_n = FIXED_SOLE_LOAD_FRACTION * self.robot.mass_kg * GRAVITY_MPS2
        self._sole_body = {side: self.robot.foot_body_id(side) for side in SIDES}
        self._jac = np.zeros((3, self.model.nv))
        self._filter_params = filter_params(params, spec.com_height_m)
        self.reset()

    def reset(self) -> None:
        """Start again from the scene's current state, at rest, with the sensors' noise and biases
        drawn anew from the seed."""
        timestep = self._timestep_s
        self.sensors = RobotSensors(self._params, self._truth, timestep, np.random.default_rng([self._seed, 0x5E45]))
        self._qpos = self._truth.qpos.copy()
        self._qvel = np.zeros(self.model.nv)
        self._set_data()
        mujoco.mj_forward(self.model, self.data)
        floor = float(np.mean([self.robot.sole_frame(side)[0][2] for side in SIDES]))  # flat: where it stands
        self.filter = BaseStateFilter(self._filter_params, timestep, self._truth.qpos[:3].copy(),
                                      floor_height_m=floor)

    @property
    def qpos(self) -> np.ndarray:
        """Estimated configuration (nq,) of the robot's model."""
        return self._qpos

    @property
    def qvel(self) -> np.ndarray:
        """Estimated velocity (nv,) of the robot's model (free joint: world linear, body angular)."""
        return self._qvel

    def _set_data(self) -> None:
        self.data.qpos[:] = self._qpos
        self.data.qvel[:] = self._qvel

    def update(self, normal_force_n: tuple[float, float]) -> None:
        """One physics step: read the sensors and update the estimate.

        Parameters
        ----------
        normal_force_n : tuple of float
            Normal force on the (left, right) sole [N] from the foot force-torque sensors; a sole
            bearing more than :data:`FIXED_SOLE_LOAD_FRACTION` of the weight corrects the filter.
        """
        joints, joint_vel, rotation, gyro, specific_force = self.sensors.read()
        m, d = self.model, self.data
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, rotation.ravel())
        d.qpos[:3] = self.filter.position_m
        d.qpos[3:7] = quat
        d.qpos[7:] = joints
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        base = d.qpos[:3].copy()
        soles: dict[str, np.ndarray] = {}
        velocities: dict[str, np.ndarray] = {}
        for side, force in zip(SIDES, normal_force_n):
            if force <= self._fixed_load_n:
                continue
            point, _ = self.robot.sole_frame(side)
            mujoco.mj_jac(m, d, self._jac, None, point, self._sole_body[side])
            # the sole's velocity relative to the base, from the joints alone (base at rest)
            soles[side] = rotation.T @ (point - base)
            velocities[side] = rotation.T @ (self._jac[:, 6:] @ joint_vel)
        self.filter.predict(rotation, specific_force)
        self.filter.correct(rotation, gyro, soles, velocities)
        self._qpos = np.concatenate([self.filter.position_m, quat, joints])
        self._qvel = np.concatenate([self.filter.velocity_mps, gyro, joint_vel])
        self._set_data()

    def refresh(self) -> None:
        """Compute the estimate's kinematics and velocities (CoM, momentum, soles) for reading."""
        self._set_data()
        mujoco.mj_forward(self.model, self.data)

    def offset_m(self, side: str, true_robot: MujocoRobot) -> np.ndarray:
        """Where the estimate puts ``side``'s sole minus where it is [m], shape (3,): what places a
        force-torque reading (true contact points) in the estimate's world. Call after
        :meth:`refresh` or :meth:`update`."""
        return self.robot.sole_frame(side)[0] - true_robot.sole_frame(side)[0]


def _own_model(spec: RobotSpec) -> mujoco.MjModel:
    """A copy of the robot's own model for kinematics only (no collisions, no constraints)."""
    model = copy.deepcopy(compile_model(spec))
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    return model
