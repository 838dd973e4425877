"""What comparison.json says about a pair of runs (experiments/scenarios/compare.py)."""

from __future__ import annotations

import numpy as np
import pytest

from robust_ismpc.control.modules import controller_modules
from robust_ismpc.core.planner import WalkCommand
from robust_ismpc.experiments.scenarios.compare import compare_results
from robust_ismpc.runs.forces import ForceWindow
from robust_ismpc.runs.run import run
from robust_ismpc.runs.spec import RunSpec, gait_params


def test_the_planned_and_the_measured_disturbance_are_reported_apart():
    """Under 10 N forward from 3 s on the LIP: the robust run's measured ŵ averages the applied
    F/m over the last half (the LIP's measurement is exact), its planned w̃ is reported beside it,
    and nominal, which has no observer, measures nothing (None) and plans with zero."""
    command = WalkCommand(0.2)
    force = (ForceWindow(10.0, 0.0, 3.0, float("inf")),)
    results = {label: run(RunSpec(robot="g1", sim="lip", modules=controller_modules(label), command=command,
                                  duration_s=10.0, forces=force))
               for label in ("nominal", "robust")}
    out = compare_results(results, command, None)
    applied = 10.0 / gait_params("g1", "lip").mass_kg
    robust, nominal = out["robust"], out["nominal"]
    assert not robust["fell"]
    assert robust["disturbance_applied_mean_mps2"] == pytest.approx([applied, 0.0], abs=1e-6)
    assert robust["disturbance_measured_mean_mps2"] == pytest.approx([applied, 0.0], abs=0.01)
    assert robust["disturbance_measured_final_mps2"] == pytest.approx([applied, 0.0], abs=0.02)
    assert robust["disturbance_planned_mean_mps2"][0] == pytest.approx(applied, abs=0.05)
    assert nominal["disturbance_measured_mean_mps2"] is None and nominal["disturbance_measured_final_mps2"] is None
    assert nominal["disturbance_planned_mean_mps2"] == [0.0, 0.0]


def _walk_trace(lateral_m, touchdowns_s, dt=0.01):
    """A trace whose CoM moves forward at 0.2 m/s with the lateral offsets ``lateral_m``."""
    from robust_ismpc.runs.trace import Trace

    lateral = np.asarray(lateral_m, dtype=float)
    t = dt * np.arange(len(lateral))
    com = np.column_stack([0.2 * t, lateral])
    n = len(touchdowns_s)
    return Trace(channels={"t_s": t, "com_m": com}, footsteps_m=np.zeros((n, 2)),
                 candidate_footsteps_m=np.zeros((n, 2)), footstep_touchdown_s=np.asarray(touchdowns_s, float),
                 footstep_side=np.zeros(n), footstep_yaw_rad=np.zeros(n))


def test_the_path_is_the_stride_average_from_the_first_touchdown():
    """Standing 1 s, a 6 cm weight shift onto the first stance foot until the first touchdown at
    2 s, then a symmetric ±5 cm sway of period 1 s (a stride): on its line. The weight shift is not
    a deviation of the path; a 2 cm offset of the sway is, and the stride average finds it."""
    from robust_ismpc.core.planner import WalkCommand
    from robust_ismpc.experiments.scenarios.compare import path_deviation

    t = 0.01 * np.arange(1000)
    shift = np.where(t < 1.0, 0.0, -0.06 * np.clip(t - 1.0, 0.0, 1.0))
    sway = 0.05 * np.sin(2 * np.pi * (t - 2.0))
    touchdowns = [np.nan, 1.0] + [2.0 + 0.5 * k for k in range(20)]
    on_line = path_deviation(_walk_trace(np.where(t < 2.0, shift, sway), touchdowns), WalkCommand(0.2))
    assert on_line["max_m"] < 1e-3 and on_line["raw_max_m"] == pytest.approx(0.06, abs=1e-3)
    off_line = path_deviation(_walk_trace(np.where(t < 2.0, shift, sway + 0.02), touchdowns), WalkCommand(0.2))
    assert off_line["max_m"] == pytest.approx(0.02, abs=1e-3) and off_line["final_signed_m"] == pytest.approx(0.02, abs=1e-3)
    short = path_deviation(_walk_trace(shift[:250], touchdowns), WalkCommand(0.2))
    assert short["max_m"] is None
