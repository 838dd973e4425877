"""Tests of the whole-body IK (robust_ismpc.sim.whole_body.ik)."""
# ruff: noqa: F811  (pytest fixtures imported from mujoco_fixtures are redefined as arguments)

from __future__ import annotations

import numpy as np
import pytest
from mujoco_fixtures import double_support_reference, g1_spec, robot_spec  # noqa: F401  (fixtures)

from robust_ismpc.exceptions import ParameterError
from robust_ismpc.robots import RobotSpec
from robust_ismpc.sim.loop import initial_state
from robust_ismpc.sim.whole_body.actuators import ActuatorMap
from robust_ismpc.sim.whole_body.ik import IkSettings, WholeBodyIk


def _com_errors(spec: RobotSpec, settings: IkSettings, n_steps: int) -> tuple[list[float], WholeBodyIk]:
    ik = WholeBodyIk(spec, settings)
    com, left, right = initial_state(spec)
    target = com + np.array([0.02, 0.015, -0.02]) * spec.com_height_m / 0.6
    reference = double_support_reference(0.0, target, left, right)
    errors = []
    for _ in range(n_steps):
        ik.step(reference, 0.01)
        errors.append(float(np.linalg.norm(ik.com_m() - target)))
    return errors, ik


def test_ik_converges_with_decreasing_error(robot_spec: RobotSpec) -> None:
    """Without posture task, IK on a moved CoM target converges with a strictly decreasing error."""
    errors, ik = _com_errors(robot_spec, IkSettings(posture_cost=0.0, upper_body_posture_cost=0.0), 20)
    assert errors[-1] < 1e-6
    significant = [e for e in errors if e > 1e-9]
    assert all(b < a for a, b in zip(significant, significant[1:]))
    err = ik.errors()
    assert err.max_position_m < 1e-5 and err.torso_rad < 1e-4


def test_ik_with_posture_task_reaches_target_closely(robot_spec: RobotSpec) -> None:
    """With the default (low) posture weight the CoM settles within 0.5 mm of its target."""
    errors, ik = _com_errors(robot_spec, IkSettings(), 10)
    assert errors[-1] < 5e-4
    assert ik.errors().max_position_m < 1e-3


def test_ik_step_time(g1_spec: RobotSpec) -> None:
    """One G1 IK step takes less than 5 ms (a 100 Hz loop must run faster than real time)."""
    ik = WholeBodyIk(g1_spec)
    com, left, right = initial_state(g1_spec)
    times = []
    for k in range(30):
        ik.step(double_support_reference(0.0, com + [0.0, 0.001 * k, 0.0], left, right), 0.01)
        times.append(ik.last_solve_time_s)
    assert np.median(times) < 5e-3


def test_static_torques_balance_floating_base(g1_spec: RobotSpec) -> None:
    """Static torques leave no force on the floating base and are symmetric for an even load."""
    ik = WholeBodyIk(g1_spec)
    torque = ik.static_torques(0.5)
    assert np.all(torque[:6] == 0.0)
    model = ik.model
    knees = [model.joint(f"{s}_knee_joint").dofadr[0] for s in ("left", "right")]
    assert torque[knees[0]] == pytest.approx(torque[knees[1]], rel=0.05)
    assert abs(torque[knees[0]]) > 5.0  # the knees carry the bent-knee weight


@pytest.mark.parametrize("feet", [(True, True), (True, False)], ids=["double", "left-single"])
def test_force_on_com_moves_the_contact_cop_by_its_moment(g1_spec: RobotSpec, feet) -> None:
    """With a force F on the CoM the feet carry the rest: their CoP moves by F z_c / (m g).

    A horizontal force at the CoM height z_c tips the robot about the floor with the moment
    F z_c; the soles balance it only if their centre of pressure moves along F by
    F z_c / (m g). A wrong sign of the generalised force would move it the other way.
    """
    ik = WholeBodyIk(g1_spec)
    mass = float(ik.model.body_subtreemass[1])
    com_height = float(ik.com_m()[2])
    ik.static_torques(0.5, *feet)
    cop_free = ik.last_contact_cop_m.copy()
    force = np.array([20.0, -8.0, 0.0])
    torque = ik.static_torques(0.5, *feet, com_force_n=force)
    cop_pushed = ik.last_contact_cop_m
    np.testing.assert_allclose(cop_pushed - cop_free, force[:2] * com_height / (mass * 9.81), atol=1e-6)
    assert np.all(torque[:6] == 0.0)


def test_actuator_map_covers_all_actuators(robot_spec: RobotSpec) -> None:
    """Every actuator maps to its joint in the IK model; the built-ins use position servos."""
    ik = WholeBodyIk(robot_spec)
    amap = ActuatorMap(ik.model, ik.model)
    assert amap.is_position.all()
    targets = amap.targets(ik.qpos)
    assert targets.shape == (ik.model.nu,)
    np.testing.assert_array_equal(amap.ik_qpos_index, amap.sim_qpos_index)


def test_ik_settings_validated() -> None:
    """Negative weights and zero iterations raise ParameterError."""
    with pytest.raises(ParameterError):
        IkSettings(com_cost=-1.0)
    with pytest.raises(ParameterError):
        IkSettings(iterations=0)
