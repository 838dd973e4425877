"""Tests of the MuJoCo layer (robust_ismpc.sim): measurements, disturbances, loop, video."""
# ruff: noqa: F811  (pytest fixtures imported from mujoco_fixtures are redefined as arguments)

from __future__ import annotations

import copy
import math
import os

import numpy as np
import pytest
from mujoco_fixtures import (  # noqa: F401  (fixtures)
    ComShiftController,
    StandingController,
    g1_spec,
    op3_spec,
    robot_spec,
    step_simulation,
)

from robust_ismpc.exceptions import ModelError, ParameterError
from robust_ismpc.robots import RobotSpec
from robust_ismpc.sim.forces import Force, ForceSchedule, Impulse
from robust_ismpc.sim.loop import LoopSettings, MujocoSimulation
from robust_ismpc.sim.model import compile_model
from robust_ismpc.sim.polygon import SolePose, convex_hull, distance_outside, sole_corners
from robust_ismpc.sim.robot import FallCriteria, MujocoRobot, standing_state
from robust_ismpc.sim.scene import Payload, SwingingBall, build_scene
from robust_ismpc.sim.video import VideoRecorder, VideoSettings

mujoco = pytest.importorskip("mujoco")


# ------------------------------------------------------------------ geometry
def test_convex_hull_of_two_soles() -> None:
    """The hull of two side-by-side rectangles is their bounding rectangle (4 vertices)."""
    left = sole_corners(SolePose(np.array([0.0, 0.1, 0.0]), 0.0), 0.2, 0.1)
    right = sole_corners(SolePose(np.array([0.0, -0.1, 0.0]), 0.0), 0.2, 0.1)
    hull = convex_hull(np.vstack([left, right]))
    assert len(hull) == 4
    assert hull[:, 0].min() == pytest.approx(-0.1) and hull[:, 1].max() == pytest.approx(0.15)


def test_distance_outside_polygon() -> None:
    """Distance is 0 inside the polygon and the Euclidean distance to the nearest edge outside."""
    square = convex_hull(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float))
    assert distance_outside(np.array([0.5, 0.5]), square) == 0.0
    assert distance_outside(np.array([1.5, 0.5]), square) == pytest.approx(0.5)
    assert distance_outside(np.array([2.0, 2.0]), square) == pytest.approx(math.sqrt(2))
    assert distance_outside(np.array([0.0, 0.0]), np.zeros((0, 2))) == math.inf


# ------------------------------------------------------------------ measurements
def test_cop_equals_com_projection_when_still(robot_spec: RobotSpec) -> None:
    """After settling, the CoP from the contact forces equals the CoM ground projection (< 3 mm)."""
    sim = MujocoSimulation(robot_spec)
    controller = StandingController(robot_spec)
    trace = step_simulation(sim, controller, 1.5)
    measurement, contacts = sim.robot.measure()
    assert contacts.left_in_contact and contacts.right_in_contact
    assert np.linalg.norm(measurement.com_vel_mps) < 5e-3
    np.testing.assert_allclose(measurement.zmp_m, measurement.com_pos_m[:2], atol=3e-3)
    weight = robot_spec.mass_kg * 9.81
    assert contacts.left_force_n + contacts.right_force_n == pytest.approx(weight, rel=0.02)
    assert trace.max_zmp_outside_m == 0.0


def test_com_velocity_and_angular_momentum_match_mujoco(g1_spec: RobotSpec) -> None:
    """At a random velocity, the CoM (also alone, ``com_position``), its velocity (from body
    velocities) and the robot's angular momentum about its CoM equal MuJoCo's subtree CoM, linear
    momentum / mass and angular momentum."""
    model = compile_model(g1_spec)
    data = mujoco.MjData(model)
    standing_state(g1_spec, model, data)
    data.qvel[:] = np.random.default_rng(0).normal(scale=0.3, size=model.nv)
    mujoco.mj_forward(model, data)
    mujoco.mj_subtreeVel(model, data)
    robot = MujocoRobot(g1_spec, model, data)
    com, vel = robot.com()
    np.testing.assert_allclose(com, data.subtree_com[robot.root_id], atol=1e-12)
    np.testing.assert_allclose(robot.com_position(), data.subtree_com[robot.root_id], atol=1e-12)
    np.testing.assert_allclose(vel, data.subtree_linvel[robot.root_id], atol=1e-10)
    np.testing.assert_allclose(robot.angular_momentum(), data.subtree_angmom[robot.root_id], atol=1e-10)


def _measured_disturbance(spec: RobotSpec, controller, seconds: float, force_n: float = 0.0):
    """The robot in :class:`MujocoSimulation` (servos) following ``controller``; per 10 ms tick
    after 0.5 s, the x disturbance an LIP reads from the raw CoP, ẍ - η² (x_c - x_z), and the
    one measured from the period-mean contact force and external moment
    (:class:`DisturbanceEstimator`, unfiltered) [m/s²]. ``force_n`` pushes the torso body along x."""
    from robust_ismpc.estimation.estimator import DisturbanceEstimator

    forces = [Force(force_n, 0.0, 0.0, math.inf)] if force_n else []
    sim = MujocoSimulation(spec, forces)
    estimator = DisturbanceEstimator(0.0)
    eta2 = 9.81 / spec.com_height_m
    rows = []
    for k in range(int(seconds / 0.01)):
        t = k * 0.01
        measurement, _ = sim.measure()
        w = estimator.update(t, measurement.com_vel_mps, measurement.contact_acc_mps2,
                             measurement.external_moment_acc_mps2)
        rows.append([measurement.com_pos_m[0], measurement.com_vel_mps[0], measurement.zmp_m[0], w[0]])
        sim.command(controller.step(t, measurement))
        sim.advance()
    rows = np.array(rows)
    w_cop = np.gradient(rows[:, 1], 0.01) - eta2 * (rows[:, 0] - rows[:, 2])
    return w_cop[50:], rows[50:, 3], sim


def test_the_measured_disturbance_ignores_the_robots_own_motion(g1_spec: RobotSpec) -> None:
    """The robot shifts its CoM by 3 cm and back: its CoP swings, but no external force acts:
    the measured disturbance stays near zero while the raw CoP reads a large one."""
    w_cop, w_measured, _ = _measured_disturbance(g1_spec, ComShiftController(g1_spec, (0.03, 0.0), 0.6, 0.4), 1.5)
    assert np.max(np.abs(w_cop)) > 0.1  # what the CoP shows [m/s²] (measured 0.19)
    assert np.max(np.abs(w_measured)) < 1e-3  # (measured 4e-5)


def test_the_measured_disturbance_is_the_push_mapped_onto_the_lip(g1_spec: RobotSpec) -> None:
    """Standing under a constant push F on the torso body, the measured disturbance is
    F / m (1 + Δz / h): the force, plus its moment about the CoM (Δz the height of the push above
    the CoM, h the LIP height) as an acceleration."""
    force = 15.0
    _, w_measured, sim = _measured_disturbance(g1_spec, StandingController(g1_spec), 1.5, force_n=force)
    robot = sim.robot
    lever = sim.data.xipos[sim.model.body(g1_spec.torso_body).id][2] - robot.com()[0][2]
    expected = force / robot.mass_kg * (1 + lever / g1_spec.com_height_m)
    np.testing.assert_allclose(w_measured[-50:], expected, rtol=0.03)


def test_no_contact_gives_no_zmp(op3_spec: RobotSpec) -> None:
    """A robot lifted off the floor measures no ZMP and no foot in contact."""
    model = compile_model(op3_spec)
    data = mujoco.MjData(model)
    standing_state(op3_spec, model, data)
    data.qpos[2] += 0.1
    measurement, contacts = MujocoRobot(op3_spec, model, data).measure()
    assert measurement.zmp_m is None
    assert not contacts.left_in_contact and not contacts.right_in_contact


# ------------------------------------------------------------------ disturbances
def test_force_accelerates_com_by_f_over_m(g1_spec: RobotSpec) -> None:
    """Without gravity, a force on the pelvis changes the CoM velocity by F t / m."""
    model = copy.deepcopy(compile_model(g1_spec))
    model.opt.gravity[:] = 0.0
    data = mujoco.MjData(model)
    standing_state(g1_spec, model, data)
    data.qpos[2] += 0.5  # in the air
    mujoco.mj_forward(model, data)
    robot = MujocoRobot(g1_spec, model, data)
    schedule = ForceSchedule(model, [Force(fx_n=40.0, fy_n=-20.0, t_start_s=0.0, t_end_s=0.2)], "pelvis")
    n_steps = int(round(0.2 / model.opt.timestep))
    for _ in range(n_steps):
        schedule.apply(data, data.time)
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    _, vel = robot.com()
    expected = np.array([40.0, -20.0]) * n_steps * model.opt.timestep / robot.mass_kg
    np.testing.assert_allclose(vel[:2], expected, rtol=1e-3)


def test_impulse_is_windowed_force() -> None:
    """An impulse is a force p / duration during [t, t + duration)."""
    force = Impulse(px_ns=10.0, py_ns=0.0, t_s=1.0, duration_s=0.1).as_force()
    assert force.fx_n == pytest.approx(100.0)
    assert force.is_active(1.05) and not force.is_active(1.1) and not force.is_active(0.99)
    with pytest.raises(ParameterError):
        Force(1.0, 0.0, t_start_s=1.0, t_end_s=0.5)


def test_unknown_force_body_raises(op3_spec: RobotSpec) -> None:
    """A force on a body absent from the model raises ModelError naming it."""
    with pytest.raises(ModelError, match="wing"):
        ForceSchedule(compile_model(op3_spec), [Force(1.0, 0.0, body="wing")], "body_link")


def test_payload_exists_swings_and_is_not_robot_mass(g1_spec: RobotSpec) -> None:
    """A payload released at an angle swings, and the robot's measured mass excludes it."""
    items = [Payload(mass_kg=2.0, rope_length_m=0.3, initial_angle_rad=0.4, attach_offset_m=(0.0, 0.0, -0.1))]
    sim = MujocoSimulation(g1_spec, scene_items=items)
    body = sim.model.body("disturbance_payload_0").id
    assert sim.model.body_mass[body] == pytest.approx(2.0)
    assert sim.robot.mass_kg == pytest.approx(g1_spec.mass_kg)
    x0 = sim.data.xipos[body][0] - sim.data.xpos[sim.robot.root_id][0]
    trace = step_simulation(sim, StandingController(g1_spec), 0.3)
    x1 = sim.data.xipos[body][0] - sim.data.xpos[sim.robot.root_id][0]
    assert x0 < -0.1 and x1 > x0 + 0.1  # swung through
    assert not trace.fallen


@pytest.mark.parametrize("angle_rad", [0.0, 0.4])
def test_a_payload_starts_at_its_world_angle_from_a_turned_link(op3_spec: RobotSpec, angle_rad: float) -> None:
    """OP3's elbow link is turned by the arms-down posture; the bag still starts at its angle from
    the world's vertical (0: hanging straight down), on the -x side, and a hanging one stays."""
    from robust_ismpc.sim.scene import set_scene_initial_state

    items = [Payload(mass_kg=0.4, rope_length_m=0.1, link="r_el_link", initial_angle_rad=angle_rad)]
    model = build_scene(op3_spec, items)
    data = mujoco.MjData(model)
    standing_state(op3_spec, model, data)
    elbow_z = data.xmat[model.body("r_el_link").id].reshape(3, 3)[:, 2]
    assert abs(elbow_z[2]) < 0.9  # the link's z axis is not the world's: the case under test
    set_scene_initial_state(model, data, items)
    body = model.body("disturbance_payload_0").id
    rope = data.xipos[body] - data.xpos[body]  # pivot to bag
    np.testing.assert_allclose(rope, [-0.1 * math.sin(angle_rad), 0.0, -0.1 * math.cos(angle_rad)], atol=1e-9)


def test_swinging_ball_swings_from_release_angle(op3_spec: RobotSpec) -> None:
    """A ball released at an angle starts on the -x side at the right height and swings to +x."""
    ball = SwingingBall(pivot_m=(0.0, 0.5, 1.0), rope_length_m=0.5, mass_kg=0.5, radius_m=0.05,
                        release_angle_rad=0.6)
    model = build_scene(op3_spec, [ball])
    data = mujoco.MjData(model)
    from robust_ismpc.sim.scene import set_scene_initial_state

    standing_state(op3_spec, model, data)
    set_scene_initial_state(model, data, [ball])
    body = model.body("disturbance_ball").id
    np.testing.assert_allclose(data.xipos[body], [-0.5 * math.sin(0.6), 0.5, 1.0 - 0.5 * math.cos(0.6)], atol=1e-9)
    for _ in range(int(0.8 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    assert data.xipos[body][0] > 0.05


# ------------------------------------------------------------------ falls and the loop
def test_fall_criteria() -> None:
    """Low root or large tilt counts as a fall; upright at nominal height does not."""
    crit = FallCriteria(min_height_fraction=0.6, max_tilt_rad=0.8)
    assert not crit.has_fallen(0.7, 0.7, 0.1)
    assert crit.has_fallen(0.3, 0.7, 0.1)
    assert crit.has_fallen(0.7, 0.7, 1.0)
    with pytest.raises(ParameterError):
        FallCriteria(min_height_fraction=1.5)


def test_strong_push_makes_robot_fall(op3_spec: RobotSpec) -> None:
    """A push far beyond what standing can absorb is detected as a fall."""
    push = Force(fx_n=25.0, fy_n=0.0, t_start_s=0.2, t_end_s=0.6)
    trace = step_simulation(MujocoSimulation(op3_spec, [push]), StandingController(op3_spec), 2.0)
    assert trace.fallen and trace.fall_time_s is not None and trace.fall_time_s < 2.0
    assert trace.applied_force_n[30, 0] == pytest.approx(25.0)


def test_standing_loop_does_not_fall(robot_spec: RobotSpec) -> None:
    """Standing in closed loop for 3 s keeps the robot up with the CoM on its reference."""
    controller = StandingController(robot_spec)
    trace = step_simulation(MujocoSimulation(robot_spec), controller, 3.0)
    assert not trace.fallen
    assert len(trace.com_pos_m) == 300 and controller.calls == 300
    assert np.all(trace.left_contact[5:]) and np.all(trace.right_contact[5:])  # after touchdown
    assert np.abs(trace.com_pos_m[-50:, :2] - trace.ref_com_pos_m[-50:, :2]).max() < 3e-3
    assert trace.max_zmp_outside_m == 0.0


def test_com_shift_is_tracked(robot_spec: RobotSpec) -> None:
    """A CoM reference shifted by a few cm is reached within 5 mm after 1 s."""
    shift = np.array([0.02, 0.03]) * robot_spec.com_height_m / 0.6
    controller = ComShiftController(robot_spec, (shift[0], shift[1]), t_start_s=0.2, ramp_s=0.6)
    trace = step_simulation(MujocoSimulation(robot_spec), controller, 1.8)
    assert not trace.fallen
    final = trace.com_pos_m[-20:, :2].mean(axis=0)
    np.testing.assert_allclose(final, controller.target(10.0)[:2], atol=5e-3)


def test_control_period_must_match_timestep(op3_spec: RobotSpec) -> None:
    """A control period that is not a multiple of the physics timestep is rejected."""
    with pytest.raises(ParameterError):
        MujocoSimulation(op3_spec, settings=LoopSettings(control_period_s=0.0105))


def test_foot_friction_setting(g1_spec: RobotSpec) -> None:
    """LoopSettings.foot_friction sets the sliding friction of exactly the foot contact geoms, on a copy of the model."""
    cached = compile_model(g1_spec)
    before = cached.geom_friction.copy()
    sim = MujocoSimulation(g1_spec, settings=LoopSettings(foot_friction=1.3))
    feet = sim.robot.foot_geom_ids()
    assert len(feet) == 8  # four contact spheres per foot
    np.testing.assert_allclose(sim.model.geom_friction[feet, 0], 1.3)
    others = np.setdiff1d(np.arange(sim.model.ngeom), feet)
    np.testing.assert_array_equal(sim.model.geom_friction[others], before[others])
    np.testing.assert_array_equal(cached.geom_friction, before)  # the cached model is untouched
    with pytest.raises(ParameterError):
        LoopSettings(foot_friction=0.0)


# ------------------------------------------------------------------ video
def _offscreen_gl_works() -> bool:
    from robust_ismpc.sim.video import configure_offscreen_gl

    configure_offscreen_gl()
    try:
        model = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
        renderer = mujoco.Renderer(model, 32, 32)
        renderer.close()
        return True
    except Exception:  # noqa: BLE001  (any GL failure means: skip)
        return False


def test_video_is_written(op3_spec: RobotSpec, tmp_path) -> None:
    """A short run with video writes an mp4 with the expected number of frames."""
    if not _offscreen_gl_works():
        pytest.skip(f"no offscreen OpenGL (MUJOCO_GL={os.environ.get('MUJOCO_GL')})")
    path = tmp_path / "stand.mp4"
    sim = MujocoSimulation(op3_spec)
    recorder = VideoRecorder(sim.model, VideoSettings(path=path, fps=30, width=320, height=240, distance_m=1.0),
                             op3_spec.root_body)
    trace = step_simulation(sim, StandingController(op3_spec), 0.5, recorder)
    assert path.stat().st_size > 1000
    import imageio.v2 as imageio

    reader = imageio.get_reader(str(path))
    frames = sum(1 for _ in reader)
    assert 14 <= frames <= 16
    assert trace.render_s > 0


@pytest.mark.parametrize("kwargs,message", [
    ({"estimator": "exact"}, "estimator"),
    ({"estimator": None}, "estimator"),
])
def test_bad_walk_settings_raise_parameter_error(kwargs, message):
    from robust_ismpc.exceptions import ParameterError
    from robust_ismpc.runs.mujoco import WalkSettings

    with pytest.raises(ParameterError, match=message):
        WalkSettings(**kwargs)


def test_compiled_models_are_kept_on_disk_between_processes(tmp_path, monkeypatch):
    """The second compilation of a scene reads the binary model that the first one wrote, and
    gets the same model; an empty ROBUST_ISMPC_CACHE turns the disk cache off."""
    from robust_ismpc.sim import model as model_module
    from robust_ismpc.sim.model import CACHE_ENV, _compile_model, load_robot

    spec = load_robot("op3")
    path, mtime = str(spec.model_path), spec.model_path.stat().st_mtime
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "cache"))
    _compile_model.cache_clear()
    fresh = _compile_model(path, mtime, spec.sole_sites)
    files = list((tmp_path / "cache").glob("*.mjb"))
    assert len(files) == 1
    _compile_model.cache_clear()
    read = []
    monkeypatch.setattr(model_module.mujoco.MjModel, "from_xml_path",
                        lambda *a: read.append(a) or pytest.fail("compiled again instead of reading the cache"))
    cached = _compile_model(path, mtime, spec.sole_sites)
    assert (cached.nq, cached.nv, cached.nbody, cached.ngeom) == (fresh.nq, fresh.nv, fresh.nbody, fresh.ngeom)
    assert [cached.body(i).name for i in range(cached.nbody)] == [fresh.body(i).name for i in range(fresh.nbody)]
    np.testing.assert_array_equal(cached.geom_size, fresh.geom_size)
    np.testing.assert_array_equal(cached.body_mass, fresh.body_mass)
    monkeypatch.undo()
    monkeypatch.setenv(CACHE_ENV, "")
    _compile_model.cache_clear()
    assert model_module.model_cache_dir() is None
    _compile_model(path, mtime, spec.sole_sites)
    assert len(list((tmp_path / "cache").glob("*.mjb"))) == 1
    _compile_model.cache_clear()
