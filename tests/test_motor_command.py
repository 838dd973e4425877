"""The robot's own command interface: per-motor (q, q̇, kp, kd, τ_ff), held between inverse-dynamics
solves (robust_ismpc.sim.whole_body.motor_command) and the inverse-dynamics rate of a robot file."""
# ruff: noqa: F811  (pytest fixtures imported from mujoco_fixtures are redefined as arguments)

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from robust_ismpc.exceptions import ParameterError
from robust_ismpc.sim.whole_body.motor_command import MotorCommand, held_command

LIMITS = np.array([[-5.0, 5.0], [-5.0, 5.0]])


def test_the_drivers_apply_feedforward_plus_pd_within_the_limits():
    command = MotorCommand(q_rad=np.array([0.1, 0.0]), dq_radps=np.array([0.0, 1.0]),
                           kp_nm_per_rad=np.array([10.0, 0.0]), kd_nms_per_rad=np.array([0.0, 2.0]),
                           tau_ff_nm=np.array([1.0, -1.0]))
    np.testing.assert_allclose(command.torques(np.zeros(2), np.zeros(2), LIMITS), [1.0 + 1.0, -1.0 + 2.0])
    # far from the target the torque saturates at the limit
    np.testing.assert_allclose(command.torques(np.array([-10.0, 0.0]), np.zeros(2), LIMITS)[0], 5.0)


def test_the_held_targets_are_where_the_accelerations_lead_and_the_gains_critically_damp():
    """Over the hold Δ the targets are q + q̇Δ + q̈Δ²/2 and q̇ + q̈Δ; kp = I ω², kd = 2 I ω, so that
    a joint of inertia I alone has the double pole -ω."""
    q, dq, qdd, inertia = np.array([0.2, -0.1]), np.array([1.0, 0.5]), np.array([10.0, -4.0]), np.array([0.5, 2.0])
    command = held_command(np.array([3.0, 4.0]), q, dq, qdd, inertia, hold_s=0.01, bandwidth_radps=20.0)
    np.testing.assert_allclose(command.q_rad, q + 0.01 * dq + 0.5 * 1e-4 * qdd)
    np.testing.assert_allclose(command.dq_radps, dq + 0.01 * qdd)
    for k in range(2):
        # characteristic polynomial I s² + kd s + kp = I (s + ω)²
        roots = np.roots([inertia[k], command.kd_nms_per_rad[k], command.kp_nm_per_rad[k]])
        np.testing.assert_allclose(roots, [-20.0, -20.0], atol=1e-5)
    torques_only = held_command(np.array([3.0, 4.0]), q, dq, qdd, inertia, hold_s=0.01, bandwidth_radps=0.0)
    np.testing.assert_allclose(torques_only.torques(q + 1.0, dq - 1.0, np.full((2, 2), [-np.inf, np.inf])), [3.0, 4.0])


@pytest.mark.parametrize("kwargs", [dict(hold_s=0.0, bandwidth_radps=1.0), dict(hold_s=0.01, bandwidth_radps=-1.0)])
def test_bad_holds_and_gains_raise(kwargs):
    with pytest.raises(ParameterError):
        held_command(np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2), np.ones(2), **kwargs)
    with pytest.raises(ParameterError, match="same length"):
        MotorCommand(np.zeros(2), np.zeros(3), np.zeros(2), np.zeros(2), np.zeros(2))


mujoco = pytest.importorskip("mujoco")

from mujoco_fixtures import ComShiftController, g1_spec, step_simulation  # noqa: E402, F401  (fixtures)

from robust_ismpc.sim.loop import LoopSettings, MujocoSimulation  # noqa: E402
from robust_ismpc.sim.whole_body.inverse_dynamics import TorqueControlSettings  # noqa: E402


@pytest.mark.parametrize("rate_hz, per_tick", [(None, 5), (100.0, 1), (500.0, 5)])
def test_the_inverse_dynamics_runs_at_the_robot_files_rate(g1_spec, rate_hz, per_tick):
    """G1 (2 ms physics, 10 ms ticks): one QP per physics step by default, one per tick at 100 Hz;
    the motors get a torque at every physics step either way."""
    spec = dataclasses.replace(g1_spec, inverse_dynamics_rate_hz=rate_hz)
    sim = MujocoSimulation(spec, settings=LoopSettings(torque_control=TorqueControlSettings()))
    controller = ComShiftController(g1_spec, (0.0, 0.01))
    ticks = 20
    for _ in range(ticks):
        step_simulation(sim, controller, 0.01)
    assert sim.inverse_dynamics.solve_count == ticks * per_tick
    assert np.any(sim.data.ctrl != 0.0)


def test_a_rate_the_physics_step_does_not_divide_is_refused(g1_spec):
    with pytest.raises(ParameterError, match="whole multiple of the physics step"):
        MujocoSimulation(dataclasses.replace(g1_spec, inverse_dynamics_rate_hz=300.0),
                         settings=LoopSettings(torque_control=TorqueControlSettings()))
    with pytest.raises(ParameterError, match="inverse_dynamics_rate_hz"):
        dataclasses.replace(g1_spec, inverse_dynamics_rate_hz=0.0)


def test_g1_walks_with_the_inverse_dynamics_at_100_hz(tmp_path):
    """A robot file asking for 100 Hz (one solve per 10 ms tick, the command held over five
    physics steps): robust G1 walks 8 s at the commanded speed."""
    from robust_ismpc.control.modules import controller_modules
    from robust_ismpc.core.planner import WalkCommand
    from robust_ismpc.robots.robot_file import robot_file_path
    from robust_ismpc.runs.run import run
    from robust_ismpc.runs.spec import RunSpec

    text = robot_file_path("g1").read_text().replace("[simulation]\n", "[simulation]\ninverse_dynamics_rate_hz = 100\n")
    path = tmp_path / "g1_100hz.toml"
    path.write_text(text)
    result = run(RunSpec(robot=str(path), sim="mujoco", modules=controller_modules("robust"), command=WalkCommand(0.2),
                         duration_s=8.0))
    assert not result.summary["fell"], result.summary["failure"]
    assert result.summary["inverse_dynamics_rate_hz"] == 100.0
    assert result.summary["distance_m"] > 0.8 * 0.2 * (8.0 - 2.6)
