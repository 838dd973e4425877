"""IS-MPC walking the full robots in MuJoCo through the run API (robust_ismpc.runs.mujoco)."""
# ruff: noqa: F811  (pytest fixtures imported from mujoco_fixtures are redefined as arguments)

from __future__ import annotations

import json
import math

import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("mink")

from robust_ismpc.core.planner import WalkCommand  # noqa: E402
from robust_ismpc.exceptions import ParameterError  # noqa: E402
from robust_ismpc.runs.forces import ForceWindow  # noqa: E402
from robust_ismpc.runs.mujoco import COP_TOLERANCE_M, run_mujoco_spec  # noqa: E402
from robust_ismpc.runs.run import run  # noqa: E402
from robust_ismpc.runs.spec import RunSpec

ROBOTS = ("g1", "op3")
#: Cruise speeds [m/s] (docs/robots.md, "Walking in MuJoCo").
CRUISE = {"g1": 0.2, "op3": 0.15}

SUMMARY_KEYS = {
    "robot", "sim", "controller", "fell", "failure", "duration_s", "distance_m", "steps_taken",
    "qp_infeasible_count", "max_zmp_violation_m", "mpc_solve_ms", "cycle_ms", "realtime_factor",
    "time_per_tick_ms", "cop_outside_s",
}


def _spec(robot: str, command: WalkCommand, duration_s: float, forces=()) -> RunSpec:
    return RunSpec(robot=robot, sim="mujoco", command=command, duration_s=duration_s, forces=forces)


@pytest.mark.parametrize("robot", ROBOTS)
def test_short_forward_walk(robot: str) -> None:
    """A 5 s forward walk at cruise speed: no fall, no infeasible QP, steps taken, summary complete."""
    result = run(_spec(robot, WalkCommand(CRUISE[robot]), 5.0))
    s = result.summary
    assert s["fell"] is False, s["failure"]
    assert s["qp_infeasible_count"] == 0
    assert s["steps_taken"] >= 3
    assert SUMMARY_KEYS <= set(s)
    assert s["duration_s"] == pytest.approx(5.0)
    assert s["sim"] == "mujoco" and s["robot"] == robot
    json.dumps(s)  # serialisable as summary.json
    assert len(result.trace) == 500
    assert np.isfinite(result.trace["com_m"]).all()
    assert result.trace["com_m"][-1, 0] > result.trace["com_m"][0, 0]  # it went forward
    assert set(np.unique(result.trace["support"])) == {-1.0, 0.0, 1.0}


def test_unknown_mujoco_robot_lists_the_available_ones() -> None:
    """A robot with LIP parameters but no MuJoCo model is refused with the list of MuJoCo robots."""
    with pytest.raises(ParameterError, match="g1, op3"):
        run_mujoco_spec(_spec("hrp4", WalkCommand(0.1), 1.0))


def test_force_reaches_the_trace() -> None:
    """A force window on the torso shows up as w = F / m in the trace, only inside its window."""
    result = run(_spec("op3", WalkCommand(0.0), 1.0, forces=(ForceWindow(3.0, 0.0, 0.3, 0.5),)))
    w = result.trace["disturbance_true_mps2"]
    t = result.trace["t_s"]
    mass = result.trace.meta["mass_kg"]
    inside = (t >= 0.31) & (t < 0.49)
    assert np.allclose(w[inside, 0], 3.0 / mass)
    assert np.allclose(w[t < 0.29], 0.0) and np.allclose(w[t > 0.51], 0.0)


# Long walks. The CoP bound: the measured CoP is a weighted mean of contact points, so it can
# only leave the nominal sole outline when a foot tilts onto an edge (contact points of the
# spheres / box corners move by a few mm); we allow COP_TOLERANCE_M before counting a tick as
# "outside", and at most 10 % of the run outside (short transients at touchdown).
LONG_WALKS = [
    ("g1", WalkCommand(0.2)),
    ("g1", WalkCommand(-0.15)),
    ("g1", WalkCommand(0.0, 0.1)),
    ("g1", WalkCommand(0.0, 0.0, 0.3)),
    ("op3", WalkCommand(0.15)),
    ("op3", WalkCommand(-0.1)),
    ("op3", WalkCommand(0.0, 0.05)),
    ("op3", WalkCommand(0.0, 0.0, 0.2)),
    ("op3", WalkCommand(0.0, 0.0, 0.3)),
]


@pytest.mark.slow
@pytest.mark.parametrize("robot,command", LONG_WALKS, ids=lambda v: v if isinstance(v, str) else
                         f"{v.vx_mps}-{v.vy_mps}-{v.omega_radps}")
def test_long_walk(robot: str, command: WalkCommand) -> None:
    """30 s walks (forward, backward, sideways, turning) do not fall and keep the CoP in the support polygon."""
    duration = 30.0
    result = run(_spec(robot, command, duration))
    s = result.summary
    assert s["fell"] is False, s["failure"]
    assert s["qp_infeasible_count"] == 0
    assert s["cop_outside_s"] <= 0.1 * duration
    violation = result.trace["zmp_violation_m"]
    assert np.nanmax(violation) < 0.01
    # the summary's time outside counts exactly the traced ticks beyond the tolerance
    dt = float(np.median(np.diff(result.trace["t_s"])))
    assert s["cop_outside_s"] == pytest.approx(np.count_nonzero(violation > COP_TOLERANCE_M) * dt, abs=1e-9)


NEW_BUILTINS = [(robot, name, command, modules)
                for robot in ("t1", "apollo")
                for name, command in (("forward", WalkCommand(0.1)), ("sideways", WalkCommand(0.0, 0.05)),
                                      ("turning", WalkCommand(0.1, 0.0, 0.2)))
                for modules in ((), ("observer", "restriction", "timing"))]


@pytest.mark.slow
@pytest.mark.parametrize("robot,name,command,modules", NEW_BUILTINS,
                         ids=[f"{r}-{n}-{'robust' if m else 'nominal'}" for r, n, _, m in NEW_BUILTINS])
def test_builtins_drafted_by_the_wizard_walk_30_s(robot, name, command, modules) -> None:
    """T1 and Apollo, whose robot files `ismpc robot init` drafted: 30 s forward, sideways and
    turning, nominal and robust, default settings: no fall, no infeasible QP."""
    s = run(RunSpec(robot=robot, sim="mujoco", modules=modules, command=command, duration_s=30.0)).summary
    assert s["fell"] is False, s["failure"]
    assert s["qp_infeasible_count"] == 0


def test_inverse_dynamics_feedforward_at_rest_is_static() -> None:
    """At rest the inverse-dynamics feedforward equals the static torques, and its contact CoP is the
    CoM projection; a swing-leg acceleration moves that CoP (the effect the feedforward supplies)."""
    from robust_ismpc.sim.model import load_robot
    from robust_ismpc.sim.whole_body.ik import WholeBodyIk

    ik = WholeBodyIk(load_robot("g1"))
    nv = ik.model.nv
    static = ik.static_torques(0.5)
    dynamic = ik.inverse_dynamics_torques(np.zeros(nv), np.zeros(nv), 0.5)
    np.testing.assert_allclose(dynamic, static, atol=1e-9)
    np.testing.assert_allclose(ik.last_contact_cop_m, ik.com_m()[:2], atol=1e-9)
    qacc = np.zeros(nv)
    qacc[ik.model.joint("right_hip_pitch_joint").dofadr[0]] = -20.0  # swing the right thigh forward
    ik.inverse_dynamics_torques(np.zeros(nv), qacc, 1.0, True, False)
    assert abs(ik.last_contact_cop_m[0] - ik.com_m()[0]) > 0.01


def test_dynamic_feedforward_adds_servo_damping_term() -> None:
    """With dynamic_feedforward a position servo's target carries + kd q̇_ref / kp."""
    from robust_ismpc.sim.loop import LoopSettings, MujocoSimulation
    from robust_ismpc.sim.model import load_robot

    sim = MujocoSimulation(load_robot("g1"), settings=LoopSettings(dynamic_feedforward=True))
    act = sim.actuators
    assert np.all(act.kd[act.is_position] > 0)
    sim._target_vel = np.full(sim.model.nu, 0.1)
    sim._apply_targets()
    expected = sim._targets + (sim._feedforward + act.kd * 0.1) / act.kp
    np.testing.assert_allclose(sim.data.ctrl, expected)


def _gl_available() -> str | None:
    try:
        import mujoco

        from robust_ismpc.sim.model import compile_model, load_robot

        model = compile_model(load_robot("op3"))
        renderer = mujoco.Renderer(model, height=48, width=64)
        renderer.close()
    except Exception as exc:  # noqa: BLE001  (any GL failure means: skip)
        return f"{type(exc).__name__}: {exc}"
    return None


def test_cli_run_mujoco_with_video(tmp_path) -> None:
    """`ismpc run --sim mujoco --robot g1 --duration 3 --video` writes summary.json, gait.png and an mp4."""
    reason = _gl_available()
    if reason is not None:
        pytest.skip(f"no offscreen OpenGL backend (MUJOCO_GL={__import__('os').environ.get('MUJOCO_GL')}): {reason}")
    pytest.importorskip("imageio")
    from robust_ismpc.cli import main

    out = tmp_path / "run"
    code = main(["run", "--sim", "mujoco", "--robot", "g1", "--vx", "0.2", "--duration", "3", "--video",
                 "--quiet", "--out", str(out)])
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["sim"] == "mujoco" and summary["fell"] is False
    assert summary["video_frames"] >= 80  # 30 frames/s over 3 s
    assert math.isfinite(summary["render_fps"]) and summary["render_fps"] > 0
    assert (out / "gait.png").stat().st_size > 0
    assert (out / "trace.npz").stat().st_size > 0
    assert (out / "video.mp4").stat().st_size > 1000
