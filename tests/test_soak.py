"""Soak: long walks with random pushes inside the robust envelope (the 10-minute one is slow)."""

import pytest

from robust_ismpc.exceptions import ParameterError
from robust_ismpc.experiments.soak import SoakSpec, random_pushes, run_soak


def test_pushes_replay_from_seed():
    """The same seed draws the same pushes; another seed draws others."""
    import numpy as np

    spec = SoakSpec(duration_s=120.0)
    a = random_pushes(spec, np.random.default_rng(1))
    b = random_pushes(spec, np.random.default_rng(1))
    c = random_pushes(spec, np.random.default_rng(2))
    assert a == b and a != c and len(a) >= 25


def test_short_soak_walks_and_reports_memory():
    """A 30 s soak on the LIP does not fall and reports RSS samples and the trace size."""
    report, _ = run_soak(SoakSpec(duration_s=30.0, seed=3))
    assert report["fell"] is False and report["pushes"] >= 5
    assert len(report["rss_mb"]) >= 2 and report["trace_mb"] > 0


def test_the_default_push_moves_a_standing_dcm_by_half_the_sole():
    """The default largest push: J/(m η) = w/2 for a 0.1 s push, on every built-in robot."""
    import math

    import numpy as np

    from robust_ismpc.experiments.soak import PUSH_DURATION_S, default_push_max_n
    from robust_ismpc.runs.spec import gait_params

    for robot in ("g1", "op3", "nao", "hrp4"):
        params = gait_params(robot, "lip")
        impulse = default_push_max_n(params) * PUSH_DURATION_S
        assert impulse / (params.mass_kg * math.sqrt(9.81 / params.com_height_m)) == pytest.approx(
            0.5 * params.sole_width_m)
    pushes = random_pushes(SoakSpec(duration_s=600.0), np.random.default_rng(0))
    assert max(math.hypot(p.fx_n, p.fy_n) for p in pushes) <= default_push_max_n(gait_params("g1", "lip"))


def test_bad_soak_spec():
    """Bad durations and intervals raise ParameterError."""
    with pytest.raises(ParameterError):
        SoakSpec(duration_s=0.0)
    with pytest.raises(ParameterError):
        SoakSpec(push_interval_s=(3.0, 1.0))
    with pytest.raises(ParameterError, match="needs the mujoco simulator"):
        SoakSpec(sim="lip", whole_body="torque")


@pytest.mark.slow
def test_ten_minute_lip_soak():
    """10 simulated minutes on the g1 LIP with random pushes: no fall, no unhandled solver failure,
    memory growth bounded by the recorded trace."""
    report, _ = run_soak(SoakSpec(duration_s=600.0, seed=0))
    assert report["fell"] is False and report["failure"] is None
    growth = report["rss_mb"][-1]["rss_mb"] - report["rss_mb"][1]["rss_mb"]
    assert growth < 2 * report["trace_mb"] + 20


def test_soak_speed_defaults_per_simulator_and_validates():
    assert SoakSpec().vx_mps == 0.2
    assert SoakSpec(sim="mujoco").vx_mps == 0.1
    assert SoakSpec(sim="mujoco", vx_mps=0.15).vx_mps == 0.15
    with pytest.raises(ParameterError, match="forward speed"):
        SoakSpec(vx_mps=float("nan"))


@pytest.mark.slow
def test_ten_minute_g1_mujoco_soak():
    """10 simulated minutes of the robust controller on G1 in MuJoCo (0.1 m/s) with random pushes
    up to the default (33 N, soak.default_push_max_n): no fall, no infeasible QP, resident memory
    flat after the first minute (the samples from 60 s on may differ by the trace buffers only)."""
    pytest.importorskip("mujoco")
    report, _ = run_soak(SoakSpec(robot="g1", sim="mujoco", duration_s=600.0, seed=0))
    assert report["fell"] is False and report["failure"] is None
    assert report["qp_infeasible_count"] == 0 and report["pushes"] >= 150
    during = [s["rss_mb"] for s in report["rss_mb"] if s["t_s"] >= 60.0]
    assert max(during) - during[0] < 20.0
