"""What comparison.json says about a pair of runs (experiments/scenarios/compare.py)."""

from __future__ import annotations

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
