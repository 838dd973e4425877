"""The sensor model on the full robot in MuJoCo: the controller reads noisy, biased, late signals."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("mink")

from robust_ismpc.control.modules import controller_modules  # noqa: E402
from robust_ismpc.core.planner import WalkCommand  # noqa: E402
from robust_ismpc.robots.sensing import SENSING_PRESETS, SensingParams, Sensors  # noqa: E402
from robust_ismpc.runs.run import run  # noqa: E402
from robust_ismpc.runs.spec import RunSpec, gait_params  # noqa: E402

VX = 0.2  # G1's cruise speed [m/s]


def _walk(controller: str, sensing: str, seed: int, seconds: float = 8.0):
    return run(RunSpec(robot="g1", sim="mujoco", modules=controller_modules(controller), command=WalkCommand(VX),
                       duration_s=seconds, sensing=sensing, seed=seed))


def _true_com_m(result) -> np.ndarray:
    return np.asarray(result.trace["com_m"])


def test_a_com_bias_is_the_whole_body_s_too_so_the_walk_does_not_drift(monkeypatch):
    """A CoM bias is an error of the controller's mass model: the planner and the whole body both
    read the CoM 1 cm off. Seed 1 draws it backwards. If only the planner read it, every re-plan
    would move the CoM the whole body tracks by the bias, and the robot would walk backwards
    (measured before the whole body shared it: -1.1 m in 5 s). Both controllers walk forward at
    the commanded speed."""
    monkeypatch.setitem(SENSING_PRESETS, "bias-only", SensingParams(name="bias-only", com_pos_bias_m=0.01))
    bias = Sensors(SENSING_PRESETS["bias-only"], 0.01, gait_params("g1", "mujoco").eta, 1).com_bias_m
    assert bias[0] < -0.009  # the seed's direction, as the docstring says
    for controller in ("nominal", "robust"):
        result = _walk(controller, "bias-only", seed=1)
        assert not result.summary["fell"], (controller, result.summary["failure"])
        com = _true_com_m(result)
        t = np.asarray(result.trace["t_s"])
        walking = (t > 3.0)  # after the start (the first step lands at about 2.6 s)
        speed = np.polyfit(t[walking], com[walking, 0], 1)[0]
        assert 0.7 * VX < speed < 1.3 * VX, (controller, speed)


@pytest.mark.parametrize("controller", ["nominal", "robust"])
def test_g1_walks_under_the_realistic_sensing_preset(controller):
    """Noise, a 1 cm CoM bias and 10 ms of latency: G1 walks 8 s at the commanded speed, and the
    disturbance estimate the robust controller measures stays quiet (undisturbed)."""
    result = _walk(controller, "realistic", seed=2)
    assert not result.summary["fell"], result.summary["failure"]
    assert result.summary["distance_m"] > 0.6 * VX * (8.0 - 2.6)
    if controller == "robust":
        w = np.asarray(result.trace["disturbance_measured_mps2"])[300:]
        assert np.all(np.nanstd(w, axis=0) < 0.2)
