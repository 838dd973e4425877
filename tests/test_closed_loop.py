"""The closed loop on the robot: the MPC plans from the measured state, by default."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robust_ismpc.core.planner import WalkCommand
from robust_ismpc.runs.forces import ForceWindow
from robust_ismpc.runs.run import run
from robust_ismpc.runs.spec import RunSpec

pytest.importorskip("mujoco")
pytest.importorskip("mink")

PUSH_T = 4.2  # the single support of G1's step 4 at 0.2 m/s starts here


def _g1(modules=(), forces=(), duration_s=4.6):
    return run(RunSpec(robot="g1", sim="mujoco", modules=modules, command=WalkCommand(0.2),
                       duration_s=duration_s, forces=tuple(forces)))


def test_a_push_changes_the_nominal_mpc_plan():
    """G1, nominal IS-MPC, default settings: a 3 N s sideways push changes the MPC's planned ZMP
    within 0.1 s of its start; before the push the two runs are identical."""
    pushed = _g1(forces=[ForceWindow(0.0, 30.0, PUSH_T, PUSH_T + 0.1)])
    calm = _g1()
    t = pushed.trace["t_s"]
    before, after = t < PUSH_T - 1e-9, (t >= PUSH_T + 0.05) & (t < PUSH_T + 0.1)
    zmp_pushed, zmp_calm = pushed.trace["zmp_ref_m"], calm.trace["zmp_ref_m"][: len(t)]
    np.testing.assert_array_equal(zmp_pushed[before], zmp_calm[before])
    assert np.max(np.abs(zmp_pushed[after, 1] - zmp_calm[after, 1])) > 2e-3  # [m]


def test_timing_adaptation_fires_on_the_robot_after_a_push():
    """G1, timing module alone, default settings: no re-timing before a 6 N s sideways push, at
    least one within 0.3 s after it starts."""
    result = _g1(modules=("timing",), forces=[ForceWindow(0.0, 60.0, PUSH_T, PUSH_T + 0.1)], duration_s=5.0)
    t, adapted = result.trace["t_s"], result.trace["timing_adapted"].astype(bool)
    assert not adapted[t < PUSH_T - 1e-9].any()
    assert adapted[(t >= PUSH_T) & (t < PUSH_T + 0.3)].any()


def _onset_failures(modules, force_n):
    """(force, onset) of the g1 LIP runs at 0.2 m/s in which a constant lateral force of
    ±``force_n`` switched on at one of 15 onsets across a stride (2.0-3.4 s) made the QP
    infeasible at least once."""
    failures = []
    for signed in (force_n, -force_n):
        for k in range(15):
            t0 = 2.0 + 0.1 * k
            summary = run(RunSpec(robot="g1", sim="lip", modules=modules, command=WalkCommand(0.2),
                                  duration_s=7.0, forces=(ForceWindow(0.0, signed, t0, math.inf),))).summary
            if summary["qp_infeasible_count"]:
                failures.append((signed, round(t0, 1)))
    return failures


def test_robust_holds_a_quarter_of_the_lateral_capacity_at_any_onset():
    """g1 LIP, robust controller: ±5.6 N lateral (a quarter of its 22.5 N lateral capacity,
    benchmarks/lip_envelope.py) switched on at any of 15 onsets across a stride never makes the
    QP infeasible. Forces that start late in a single support are first compensated in the
    double support that follows, where re-timing the coming single support keeps the QP
    feasible."""
    assert _onset_failures(("observer", "restriction", "timing"), 5.6) == []


@pytest.mark.xfail(strict=True, reason="not met: the fixed-timing gait has 0.08-0.16 m/s² of lateral "
                   "margin at the end of double support (docs/closed-loop.md, the LIP cases)")
def test_observer_alone_holds_a_quarter_of_the_lateral_capacity_at_any_onset():
    """As above with the observer alone (no timing adaptation)."""
    assert _onset_failures(("observer",), 5.6) == []
