"""The state a robot estimates from its encoders, IMU and foot contacts (sim/state_estimation.py)."""
# ruff: noqa: F811  (pytest fixtures imported from mujoco_fixtures are redefined as arguments)

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("mink")

from mujoco_fixtures import g1_spec  # noqa: F401  (fixture)

from robust_ismpc.exceptions import ParameterError
from robust_ismpc.robots.sensing import SENSING_PRESETS, SensingParams
from robust_ismpc.sim.loop import LoopSettings, MujocoSimulation
from robust_ismpc.sim.model import compile_model
from robust_ismpc.sim.state_estimation import RobotSensors, SensedState, TrueState, state_index
from robust_ismpc.sim.whole_body.inverse_dynamics import TorqueControlSettings

REALISTIC = SENSING_PRESETS["realistic"]


def test_ideal_sensing_reads_the_simulator_and_realistic_sensing_estimates(g1_spec):
    ideal = MujocoSimulation(g1_spec, sensing=SENSING_PRESETS["ideal"])
    assert ideal.estimator is None and ideal.sensed_robot is ideal.robot
    sensed = MujocoSimulation(g1_spec, sensing=REALISTIC)
    assert isinstance(sensed.estimator, SensedState) and sensed.sensed_robot is not sensed.robot


def test_the_estimate_starts_at_the_robot_s_placed_state(g1_spec):
    """The robot knows where it is placed and that it stands still: before any step, the estimate
    is the simulator's configuration (to the encoders' resolution and the IMU's tilt error)."""
    sim = MujocoSimulation(g1_spec, sensing=REALISTIC)
    truth = TrueState(sim.estimator.model, sim.model, sim.data)
    np.testing.assert_allclose(sim.estimator.qpos, truth.qpos, atol=1e-12)
    np.testing.assert_allclose(sim.estimator.qvel, 0.0)


def test_the_sensors_quantise_the_encoders_and_tilt_the_imu_by_the_preset_s_error(g1_spec):
    model = compile_model(g1_spec)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0) if model.nkey else mujoco.mj_resetData(model, data)
    data.qpos[7:] += 0.01 * np.arange(model.nq - 7) / (model.nq - 7)
    sensors = RobotSensors(REALISTIC, TrueState(model, model, data), 0.002, np.random.default_rng(3))
    joints, _, rotation, _, specific_force = sensors.read()
    steps = joints / REALISTIC.joint_pos_resolution_rad
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-6)
    assert np.max(np.abs(joints - data.qpos[7:])) <= 0.5 * REALISTIC.joint_pos_resolution_rad + 1e-12
    np.testing.assert_allclose(np.linalg.norm(sensors.tilt_error_rad), REALISTIC.imu_tilt_error_rad)
    true_rotation = np.empty(9)
    mujoco.mju_quat2Mat(true_rotation, data.qpos[3:7])
    error = rotation @ true_rotation.reshape(3, 3).T  # the reported orientation's error rotation
    angle = np.arccos(np.clip((np.trace(error) - 1.0) / 2.0, -1.0, 1.0))
    assert abs(angle - REALISTIC.imu_tilt_error_rad) < 5 * REALISTIC.imu_orientation_noise_rad
    # at rest the accelerometer reads gravity's reaction, 9.81 m/s² up, within its bias and noise
    assert abs(np.linalg.norm(specific_force) - 9.81) < REALISTIC.accel_bias_mps2 + 5 * REALISTIC.accel_noise_mps2


def test_a_robot_joint_missing_from_the_scene_is_refused(g1_spec):
    model = compile_model(g1_spec)
    other = mujoco.MjModel.from_xml_string("<mujoco><worldbody><body name='b'><freejoint/>"
                                           "<geom size='0.1'/></body></worldbody></mujoco>")
    with pytest.raises(ParameterError, match="not in the simulated scene"):
        state_index(model, other)


def test_the_estimate_follows_a_torque_controlled_walk(g1_spec):
    """G1 walks 4 s at 0.2 m/s, its whole body fed by the estimate of the realistic sensors. The
    estimated CoM velocity errs by less than 1 cm/s (σ per axis), the CoM relative to the soles
    by less than 5 mm (the IMU's 0.3° tilt error on a 0.7 m lever is 3.5 mm), and the base drifts
    less than 1 cm. The truth is read from the simulator only to check."""
    from robust_ismpc.control.modules import controller_modules
    from robust_ismpc.core.planner import WalkCommand
    from robust_ismpc.runs.run import run
    from robust_ismpc.runs.spec import RunSpec

    errors: list[np.ndarray] = []
    original = MujocoSimulation.measure

    def measure(self):
        measurement, contacts = original(self)
        com, vel = self.robot.com()
        sole_error = self.estimator.offset_m("left", self.robot)
        base_error = self.sensed_robot.base_qpos()[:3] - self.robot.base_qpos()[:3]
        errors.append(np.concatenate([measurement.com_vel_mps - vel, measurement.com_pos_m - com - sole_error,
                                      base_error]))
        return measurement, contacts

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(MujocoSimulation, "measure", measure)
        result = run(RunSpec(robot="g1", sim="mujoco", modules=controller_modules("robust"),
                             command=WalkCommand(0.2), duration_s=4.0, sensing="realistic", seed=4))
    assert not result.summary["fell"], result.summary["failure"]
    e = np.array(errors)[50:]
    assert np.all(e[:, :2].std(axis=0) < 0.01), e[:, :2].std(axis=0)
    assert np.all(np.abs(e[:, 3:5]) < 0.005), np.abs(e[:, 3:5]).max(axis=0)
    assert np.all(np.abs(e[:, 6:9]) < 0.01), np.abs(e[:, 6:9]).max(axis=0)
    assert result.summary["distance_m"] > 0.2


def test_the_inverse_dynamics_reads_the_estimate(g1_spec):
    """Under torque control with modelled sensors the QP copies the estimated state, not the
    simulator's, and the motor drivers read the encoders' rounded joint positions."""
    sim = MujocoSimulation(g1_spec, settings=LoopSettings(torque_control=TorqueControlSettings()),
                           sensing=REALISTIC)
    assert sim.inverse_dynamics.state is sim.estimator
    sim.estimator.update((200.0, 200.0))
    q, _ = sim.inverse_dynamics.joint_state()  # what the motor drivers read: the encoders
    steps = q / REALISTIC.joint_pos_resolution_rad
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-6)


def test_sensing_params_tell_a_sensor_model_from_a_signal_model():
    assert REALISTIC.models_sensors and not SENSING_PRESETS["ideal"].models_sensors
    signals = REALISTIC.for_estimated_state()
    assert signals.com_pos_noise_m == 0 and signals.position_noise_m == 0
    assert signals.com_vel_noise_mps == REALISTIC.com_vel_noise_mps and signals.com_pos_bias_m == REALISTIC.com_pos_bias_m
    with pytest.raises(ParameterError):
        dataclasses.replace(REALISTIC, gyro_bias_radps=-1.0)
    assert not SensingParams(name="flat").models_sensors
