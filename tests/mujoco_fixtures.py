"""Shared fixtures and helpers of the MuJoCo-layer tests (import from here)."""

from __future__ import annotations

from dataclasses import dataclass

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
    from robust_ismpc.sim.robot import distance_outside

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
