"""``summary.json`` metrics computed from a trace: where the swing soles landed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robust_ismpc.runs.report import landing_errors_m, summarize
from robust_ismpc.runs.trace import CHANNELS, Trace


def _two_steps(sensing: str = "ideal") -> Trace:
    """Double support, the right foot swings (the left one stands), double support, the left foot
    swings, double support; 10 rows each. The right sole lands 2 mm behind and 1 mm left of its
    reference in the world, turned by 90°; the left one lands where the reference put it."""
    n = 50
    channels = {k: np.zeros((n, *shape)) for k, shape in CHANNELS.items()}
    channels["t_s"] = 0.01 * np.arange(n)
    support = np.zeros(n)
    support[10:20] = 1.0  # the left foot stands
    support[30:40] = -1.0  # the right foot stands
    channels["support"] = support
    channels["left_foot_m"][:, :2] = (0.5, 0.1)
    channels["right_foot_m"][:, :2] = (0.3, -0.1)
    channels["sole_meas_m"][:] = (0.5, 0.1, 0.3, -0.1)
    channels["sole_meas_m"][20:, 2:4] = (0.298, -0.099)
    channels["sole_meas_yaw_rad"][20:, 1] = math.pi / 2
    steps = np.zeros((4, 2))
    return Trace(channels=channels, footsteps_m=steps, candidate_footsteps_m=steps,
                 footstep_touchdown_s=np.array([0.0, 0.0, 0.2, 0.4]), footstep_side=np.array([1.0, -1.0, -1.0, 1.0]),
                 footstep_yaw_rad=np.zeros(4),
                 meta={"robot": "g1", "sim": "mujoco", "controller": "nominal", "sensing": {"name": sensing}})


def test_landing_errors_are_measured_at_each_touchdown_in_the_landed_soles_frame():
    errors = landing_errors_m(_two_steps())
    # the right sole's world error (-2, +1) mm seen from a sole turned by 90°: 1 mm forward,
    # 2 mm to its left; the left sole: none
    np.testing.assert_allclose(errors, [[0.001, 0.002], [0.0, 0.0]], atol=1e-12)


def test_the_summary_gives_the_mean_and_largest_landing_error_under_ideal_sensing_only():
    summary = summarize(_two_steps(), fell=False, failure=None, duration_s=0.5)
    assert summary["landing_error_mean_m"] == pytest.approx([0.0005, 0.001])
    assert summary["landing_error_max_m"] == pytest.approx([0.001, 0.002])
    # under noisy sensing the reference lives in the estimate's world, which the trace's true
    # soles are not in
    noisy = summarize(_two_steps("realistic"), fell=False, failure=None, duration_s=0.5)
    assert "landing_error_mean_m" not in noisy and "landing_error_max_m" not in noisy


def test_a_trace_without_measured_soles_has_no_landing_errors():
    trace = _two_steps()
    trace.channels["sole_meas_m"][:] = np.nan  # as on the reduced model
    assert landing_errors_m(trace).shape == (0, 2)
    assert "landing_error_mean_m" not in summarize(trace, fell=False, failure=None, duration_s=0.5)
