"""Shared fixtures and helpers of the MuJoCo-layer tests (import from here)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from robust_ismpc.core.reference import GaitReference, Measurement

mujoco = pytest.importorskip("mujoco")
pytest.importorskip("mink")

from robust_ismpc.experiments.robot_check import still_reference as double_support_reference  # noqa: E402
from robust_ismpc.robots import RobotSpec
from robust_ismpc.sim.loop import initial_state  # noqa: E402
from robust_ismpc.sim.model import load_robot  # noqa: E402

ROBOT_NAMES = ("g1", "op3")


class StandingController:
    """Returns a fixed double-support reference at the standing CoM with the initial feet."""

    def __init__(self, spec: RobotSpec) -> None:
        self.com_pos_m, self.left, self.right = initial_state(spec)
        self.calls = 0

    def step(self, t_s: float, measurement: Measurement) -> GaitReference:
        self.calls += 1
        return double_support_reference(t_s + 0.01, self.com_pos_m, self.left, self.right)


class ComShiftController(StandingController):
    """Moves the CoM reference by ``shift_m`` (x, y) with a smooth ramp from t_start_s over ramp_s."""

    def __init__(self, spec: RobotSpec, shift_m: tuple[float, float], t_start_s: float = 0.3,
                 ramp_s: float = 0.7) -> None:
        super().__init__(spec)
        self.shift_m = np.array([shift_m[0], shift_m[1], 0.0])
        self.t_start_s = t_start_s
        self.ramp_s = ramp_s

    def target(self, t_s: float) -> np.ndarray:
        s = np.clip((t_s - self.t_start_s) / self.ramp_s, 0.0, 1.0)
        s = s * s * (3 - 2 * s)
        return self.com_pos_m + s * self.shift_m

    def step(self, t_s: float, measurement: Measurement) -> GaitReference:
        self.calls += 1
        return double_support_reference(t_s + 0.01, self.target(t_s + 0.01), self.left, self.right)


@pytest.fixture(scope="session", params=ROBOT_NAMES)
def robot_spec(request: pytest.FixtureRequest) -> RobotSpec:
    """Each built-in robot."""
    return load_robot(request.param)


@pytest.fixture(scope="session")
def g1_spec() -> RobotSpec:
    return load_robot("g1")


@pytest.fixture(scope="session")
def op3_spec() -> RobotSpec:
    return load_robot("op3")


@dataclass
class SteppedRun:
    """What :func:`step_simulation` recorded, one row per control period."""

    com_pos_m: np.ndarray
    ref_com_pos_m: np.ndarray
    left_contact: np.ndarray
    right_contact: np.ndarray
    applied_force_n: np.ndarray
    zmp_outside_m: np.ndarray
    fallen: bool
    fall_time_s: float | None
    render_s: float

    @property
    def max_zmp_outside_m(self) -> float:
        """Largest distance of the measured CoP outside the support polygon [m] (0 inside)."""
        finite = self.zmp_outside_m[np.isfinite(self.zmp_outside_m)]
        return float(finite.max()) if finite.size else 0.0


def step_simulation(sim, controller, duration_s: float, recorder=None, stop_on_fall: bool = True) -> SteppedRun:
    """Step ``sim`` with ``controller`` (``step(t_s, measurement) -> GaitReference``) for
    ``duration_s``, one control period at a time, as the product loop does."""
    from robust_ismpc.sim.polygon import distance_outside

    period = sim.settings.control_period_s
    rows = {k: [] for k in ("com", "ref", "left", "right", "force", "outside")}
    fallen, fall_time, render_s = False, None, 0.0
    for _ in range(int(round(duration_s / period))):
        measurement, contacts = sim.measure()
        reference = controller.step(float(sim.data.time), measurement)
        sim.command(reference)
        force, render = sim.advance(recorder)
        render_s += render
        polygon = sim.robot.support_polygon(contacts)
        rows["com"].append(measurement.com_pos_m)
        rows["ref"].append(reference.com_pos_m)
        rows["left"].append(contacts.left_in_contact)
        rows["right"].append(contacts.right_in_contact)
        rows["force"].append(force)
        rows["outside"].append(np.nan if contacts.cop_m is None else distance_outside(contacts.cop_m, polygon))
        if sim.has_fallen():
            fallen, fall_time = True, float(sim.data.time)
            if stop_on_fall:
                break
    if recorder is not None:
        recorder.close()
    return SteppedRun(np.array(rows["com"]), np.array(rows["ref"]), np.array(rows["left"]), np.array(rows["right"]),
                      np.array(rows["force"]), np.array(rows["outside"]), fallen, fall_time, render_s)


#: The newcomer's robot (issue 29): its model's own timestep [s], the visual mesh under each ankle
#: (x from, to; y half-width [m]) and the colliding sole box (centre in the ankle frame, half sizes [m]).
NEWCOMER_TIMESTEP_S = 0.01
NEWCOMER_MESH_X_M, NEWCOMER_MESH_HALF_Y_M = (-0.087, 0.127), 0.066
NEWCOMER_BOX_POS_M, NEWCOMER_BOX_HALF_M = (0.02, 0.0, -0.06), (0.125, 0.065, 0.01)


def newcomer_scene(folder: Path) -> Path:
    """A 40 kg humanoid MJCF scene that is not one of ours, as a new user brings it (issue 29).

    Six-joint legs under a pelvis; each foot is an ankle body whose only geom is a visual mesh
    (collisions off) 21.4 x 13.2 cm, whose lowest point is as low as the box of its child body
    ``l_sole``/``r_sole``, the only geom that collides with the floor (25 x 13 cm); the sole
    bodies are placeholders (1 kg, 1 kg m² on each axis); the timestep is 10 ms; motors on every
    joint. Writes ``folder/scene.xml`` and returns its path.
    """
    box = " ".join(str(v) for v in NEWCOMER_BOX_HALF_M)
    box_pos = " ".join(str(v) for v in NEWCOMER_BOX_POS_M)
    legs = []
    for side, y in (("l", 0.1), ("r", -0.1)):
        legs.append(f"""
      <body name="{side}_hip_yaw_link" pos="0 {y} -0.05">
        <joint name="{side}_hip_yaw" axis="0 0 1" range="-0.8 0.8"/>
        <inertial pos="0 0 0" mass="1" diaginertia="0.001 0.001 0.001"/>
        <geom class="visual" type="sphere" size="0.05"/>
        <body name="{side}_hip_roll_link">
          <joint name="{side}_hip_roll" axis="1 0 0" range="-0.6 0.6"/>
          <inertial pos="0 0 0" mass="1" diaginertia="0.001 0.001 0.001"/>
          <geom class="visual" type="sphere" size="0.05"/>
          <body name="{side}_thigh">
            <joint name="{side}_hip_pitch" axis="0 1 0" range="-2 1"/>
            <inertial pos="0 0 -0.2" mass="4" diaginertia="0.055 0.055 0.005"/>
            <geom class="visual" type="capsule" fromto="0 0 0 0 0 -0.4" size="0.05"/>
            <body name="{side}_shin" pos="0 0 -0.4">
              <joint name="{side}_knee" axis="0 1 0" range="0 2.4"/>
              <inertial pos="0 0 -0.2" mass="3" diaginertia="0.04 0.04 0.004"/>
              <geom class="visual" type="capsule" fromto="0 0 0 0 0 -0.4" size="0.04"/>
              <body name="{side}_ankle_pitch_link" pos="0 0 -0.4">
                <joint name="{side}_ankle_pitch" axis="0 1 0" range="-1 1"/>
                <inertial pos="0 0 0" mass="0.5" diaginertia="0.0002 0.0002 0.0002"/>
                <geom class="visual" type="sphere" size="0.03"/>
                <body name="{side}_ankle">
                  <joint name="{side}_ankle_roll" axis="1 0 0" range="-0.5 0.5"/>
                  <inertial pos="0.02 0 -0.04" mass="1.5" diaginertia="0.002 0.005 0.006"/>
                  <geom class="visual" type="mesh" mesh="ankle_shell"/>
                  <body name="{side}_sole" pos="{box_pos}">
                    <inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>
                    <geom name="{side}_sole_box" type="box" size="{box}"/>
                  </body>
                </body>
              </body>
            </body>
          </body>
        </body>
      </body>""")
    joints = [f"{s}_{j}" for s in "lr" for j in ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")]
    motors = "\n".join(f'    <motor joint="{j}" ctrlrange="-150 150"/>' for j in joints)
    bottom = NEWCOMER_BOX_POS_M[2] - NEWCOMER_BOX_HALF_M[2]  # the mesh reaches as low as the box
    ys = (-NEWCOMER_MESH_HALF_Y_M, NEWCOMER_MESH_HALF_Y_M)
    vertices = " ".join(f"{x} {y} {z}" for x in NEWCOMER_MESH_X_M for y in ys for z in (bottom, 0.0))
    xml = f"""<mujoco model="newcomer">
  <compiler angle="radian"/>
  <option timestep="{NEWCOMER_TIMESTEP_S}"/>
  <default>
    <joint damping="1" armature="0.01"/>
    <default class="visual"><geom contype="0" conaffinity="0" group="2"/></default>
  </default>
  <asset><mesh name="ankle_shell" vertex="{vertices}"/></asset>
  <worldbody>
    <geom name="floor" type="plane" size="0 0 0.05"/>
    <body name="pelvis" pos="0 0 0.92">
      <freejoint/>
      <inertial pos="0 0 0.15" mass="16" diaginertia="0.333 0.267 0.173"/>
      <geom class="visual" type="box" pos="0 0 0.15" size="0.1 0.15 0.2"/>{"".join(legs)}
    </body>
  </worldbody>
  <actuator>
{motors}
  </actuator>
</mujoco>
"""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "scene.xml"
    path.write_text(xml)
    return path
