"""Named scenarios (the paper's three experiments): definitions, scene objects, one comparison."""

from __future__ import annotations

import json
import math

import pytest

pytest.importorskip("mujoco")

from robust_ismpc.cli import main  # noqa: E402
from robust_ismpc.control.modules import MODULES  # noqa: E402
from robust_ismpc.exceptions import ParameterError  # noqa: E402
from robust_ismpc.experiments.scenarios import (
    SCENARIOS,
    BallSpec,
    ScaledForce,
    Scenario,
    Variation,
    expected_outcome,
    get_scenario,
    pendulum_swing_time,
    realise,
    run_scenario,
)


def test_scenario_definitions_are_valid() -> None:
    """The three paper scenarios exist, use known modules and robots, and realise for several seeds."""
    assert set(SCENARIOS) == {"paper-bag", "paper-ball", "paper-push"}
    assert get_scenario("paper-ball").robust_modules == ("timing",)
    for scenario in SCENARIOS.values():
        assert set(scenario.robust_modules) <= set(MODULES)
        run = realise(scenario, seed=0)
        assert run.nominal.modules == () and run.robust.modules == scenario.robust_modules
        assert run.nominal.forces == run.robust.forces


def test_unknown_scenario_lists_valid_names(tmp_path) -> None:
    """An unknown name raises ParameterError naming the scenarios; the CLI exits 2."""
    with pytest.raises(ParameterError, match="paper-bag, paper-ball, paper-push"):
        get_scenario("paper-kick")
    assert main(["compare", "paper-kick", "--out", str(tmp_path / "x")]) == 2


def test_invalid_definitions_raise() -> None:
    """Frozen dataclasses validate their fields."""
    with pytest.raises(ParameterError):
        Scenario(name="x", summary="", paper="", robot="op3", command=get_scenario("paper-bag").command,
                 duration_s=1.0, robust_modules=("teleport",))
    with pytest.raises(ParameterError):
        ScaledForce(1.0, 0.0, reference_mass_kg=0.0)
    with pytest.raises(ParameterError):
        Variation(magnitude_fraction=1.5)
    with pytest.raises(ParameterError):
        BallSpec(release_angle_rad=2.0)


def test_masses_and_forces_scale_with_robot_mass() -> None:
    """Bag, ball and pushes are the paper's values times m_robot / m_paper_robot."""
    bag = realise("paper-bag").details
    assert bag["bag"]["mass_kg"] == pytest.approx(0.67 * bag["robot_mass_kg"] / 5.4, rel=1e-3)
    ball = realise("paper-ball").details
    assert ball["ball"]["mass_kg"] == pytest.approx(0.265 * ball["robot_mass_kg"] / 5.4, rel=1e-3)
    push = realise("paper-push").details
    k = push["robot_mass_kg"] / 40.0
    assert push["forces"][0]["fx_n"] == pytest.approx(45.0 * k, rel=1e-3)
    assert push["forces"][1]["fy_n"] == pytest.approx(85.0 * k, rel=1e-3)


def test_seed_varies_push_time_and_magnitude() -> None:
    """Seed 0 is the paper's value; other seeds shift and scale within the declared bounds, reproducibly."""
    base = realise("paper-push", seed=0).details["forces"][1]
    seen = set()
    for seed in (1, 2, 3):
        d = realise("paper-push", seed=seed).details
        f = d["forces"][1]
        assert abs(f["t_start_s"] - base["t_start_s"]) <= 0.2 + 1e-9
        assert 0.9 - 1e-9 <= f["fy_n"] / base["fy_n"] <= 1.1 + 1e-9
        assert d == realise("paper-push", seed=seed).details
        seen.add(f["t_start_s"])
    assert len(seen) == 3


def test_pendulum_swing_time_matches_small_angle_limit() -> None:
    """For small amplitudes the swing to the bottom is a quarter of 2π sqrt(L/g)."""
    t = pendulum_swing_time(0.5, 0.02, 0.0)
    assert t == pytest.approx(0.5 * math.pi * math.sqrt(0.5 / 9.81), rel=1e-3)
    assert pendulum_swing_time(0.5, 1.0, 0.0) > t  # large amplitudes are slower


def _sim_with(items, duration_s: float, walk: bool):
    """Run op3 (standing still or walking forward 0.15 m/s) with scene items; return the RunResult."""
    from robust_ismpc.core.planner import WalkCommand
    from robust_ismpc.runs.mujoco import run_mujoco_spec
    from robust_ismpc.runs.spec import RunSpec

    spec = RunSpec(robot="op3", sim="mujoco", command=WalkCommand(0.15 if walk else 0.0), duration_s=duration_s)
    return run_mujoco_spec(spec, scene_items=items)


def test_bag_body_exists_and_swings() -> None:
    """The bag is a real body on a ball joint under the right elbow, and it swings while OP3 walks."""
    import mujoco

    from robust_ismpc.sim.model import load_robot
    from robust_ismpc.sim.scene import build_scene, payload_body_names

    run = realise("paper-bag")
    model = build_scene(load_robot("op3"), run.scene_items)
    name = payload_body_names(run.scene_items)[0]
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
    assert body >= 0
    assert model.body(model.body_parentid[body]).name == "r_el_link"
    assert model.body_subtreemass[body] == pytest.approx(run.details["bag"]["mass_kg"], abs=1e-4)
    joint = model.body_jntadr[body]
    assert model.jnt_type[joint] == mujoco.mjtJoint.mjJNT_BALL
    result = _sim_with(run.scene_items, 3.0, walk=True)
    swing = result.summary["scene"]["payloads"][0]
    assert swing["max_swing_rad"] > 0.05  # starts hanging straight; walking sets it swinging
    assert swing["swing_std_rad"] > 0.01


def test_ball_hits_robot_in_the_intended_window() -> None:
    """The released ball touches the robot within 20 ms of the planned hit and delivers a forward impulse."""
    run = realise("paper-ball")
    ball = run.details["ball"]
    assert ball["time_to_step_at_hit_s"] == pytest.approx(0.25)
    assert 0 < ball["release_s"] < ball["hit_s"]
    result = _sim_with(run.scene_items, ball["hit_s"] + 0.3, walk=True)
    hit = result.summary["scene"]["balls"][0]
    assert hit["hit"]
    # Contact is first seen at the end of the control tick (10 ms) in which it starts.
    assert ball["hit_s"] - 0.005 <= hit["first_contact_s"] <= ball["hit_s"] + 0.02
    assert hit["impact_speed_mps"] == pytest.approx(ball["expected_impact_speed_mps"], rel=0.05)
    assert hit["impulse_ns"][0] > 0.5 * ball["ball_momentum_ns"]
    assert abs(hit["impulse_ns"][1]) < 0.2 * hit["impulse_ns"][0]


def test_cli_lists_scenarios(capsys) -> None:
    """`ismpc scenarios` prints one line per scenario."""
    assert main(["scenarios"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert [line.split()[0] for line in lines] == list(SCENARIOS)


def test_compare_whole_body_flag_overrides_the_scenarios(tmp_path) -> None:
    """``--whole-body servo`` runs paper-push (torque, the MuJoCo default) on the servos; comparison.json says so."""
    import json

    out = tmp_path / "push"
    assert main(["compare", "paper-push", "--whole-body", "servo", "--duration", "1", "--out", str(out), "--quiet"]) == 0
    comparison = json.loads((out / "comparison.json").read_text())
    assert comparison["whole_body"] == "servo"
    assert json.loads((out / "robust" / "summary.json").read_text())["whole_body"] == "servo"


def test_compare_scenario_rejects_a_robot_of_another_size(tmp_path, capsys) -> None:
    """paper-ball is an OP3-sized scenario (standing CoM 0.24 m): --robot g1 (0.60 m, more than
    twice as tall) is a usage error that names the sizes."""
    assert main(["compare", "paper-ball", "--robot", "g1", "--out", str(tmp_path / "x")]) == 2
    assert "op3's size" in capsys.readouterr().err


CLOSED_LOOP_GAP = "closed loop: the paper's outcome does not reproduce yet (docs/closed-loop.md, paper scenarios)"


def test_compare_paper_ball_labels_its_timing_only_robust_run(tmp_path, capsys) -> None:
    """paper-ball's robust controller is timing-only, and every line printed says
    "robust (timing)" (issue 17, case 15); both runs see the ball hit."""
    assert main(["compare", "paper-ball", "--duration", "5", "--out", str(tmp_path), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "robust (timing)" in printed
    assert all("robust (timing)" in line for line in printed.splitlines() if "robust" in line and "wrote" not in line)
    comparison = json.loads((tmp_path / "comparison.json").read_text())
    for label in ("nominal", "robust"):
        assert comparison[label]["scene"]["balls"][0]["hit"]


@pytest.mark.xfail(strict=True, reason=CLOSED_LOOP_GAP)
def test_paper_ball_shows_the_papers_outcome_on_seed_0() -> None:
    """paper-ball on OP3 (seed 0, 5 s), the paper's Fig. 3: after the hit the nominal QP turns
    infeasible and the robot counts as fallen, the robust one (timing only) cuts the time to step
    from about 0.25 s to at most 0.15 s and walks on. (Closed loop, measured: both walk, the
    robust run adapts nothing.)"""
    comparison = run_scenario("paper-ball", seed=0, duration_s=5.0).comparison
    hit_s = comparison["realised"]["ball"]["hit_s"]
    nominal, robust = comparison["nominal"], comparison["robust"]
    assert nominal["fell"] and "infeasible" in nominal["failure"] and nominal["duration_s"] < hit_s + 0.5
    assert not robust["fell"] and robust["qp_infeasible_count"] == 0
    assert robust["time_to_step_at_hit_s"] >= 0.2
    assert robust["adaptations_before_hit"] == 0 and robust["adaptations_after_hit"] >= 1
    assert robust["min_time_to_step_after_hit_s"] <= 0.15
    assert comparison["expected_outcome"]


@pytest.fixture(scope="module")
def paper_bag_8s():
    """paper-bag on OP3, seed 0, shortened to 8 s: both runs and their comparison."""
    return run_scenario("paper-bag", seed=0, duration_s=8.0).comparison


@pytest.mark.xfail(strict=True, reason=CLOSED_LOOP_GAP)
def test_paper_bag_shows_the_papers_outcome(paper_bag_8s) -> None:
    """paper-bag on OP3 (seed 0, 8 s), the paper's Fig. 2: the nominal robot falls under the
    swinging bag; the robust one walks on along the planned path (stride-averaged deviation below
    3 cm), its observer reading the bag on the right elbow as a push to the right."""
    comparison = paper_bag_8s
    assert comparison["nominal"]["fell"]
    assert not comparison["robust"]["fell"]
    assert comparison["robust"]["scene"]["payloads"][0]["max_swing_rad"] > 0.1  # the bag does swing
    assert comparison["robust"]["disturbance_estimate_mean_mps2"][1] < -0.3  # towards the bag (-y)
    assert comparison["robust"]["path_deviation"]["max_m"] < 0.03
    assert comparison["robust_survives_nominal_fails"] and comparison["robust_keeps_path"]
    assert comparison["expected_outcome"]


@pytest.mark.xfail(strict=True, reason=CLOSED_LOOP_GAP)
def test_paper_push_shows_the_papers_outcome_on_seed_0() -> None:
    """paper-push on G1 (torque control), seed 0: the robust robot walks the 10 s through the
    constant push and the sideways impulse at 6 s, the nominal one falls after the impulse.
    (Closed loop, measured: the robust QP turns infeasible at 4.6 s under the constant push.)"""
    comparison = run_scenario("paper-push", seed=0).comparison
    assert comparison["whole_body"] == "torque"
    assert not comparison["robust"]["fell"]
    assert comparison["nominal"]["fell"] and comparison["nominal"]["duration_s"] > 6.0
    assert comparison["expected_outcome"]


def test_disturbance_events_name_the_ball_hit_and_each_force() -> None:
    """Figure markers: the planned hit for paper-ball; the constant force then the push for paper-push."""
    from robust_ismpc.experiments.scenarios import disturbance_events

    ball = realise("paper-ball")
    assert disturbance_events(ball) == [("ball hit (planned)", ball.details["ball"]["hit_s"])]
    push = realise("paper-push")
    labels, times = zip(*disturbance_events(push))
    assert labels == ("constant force 38 N", "push 71 N")
    assert times == (3.0, 6.0)


def _outcome(expect: str, nominal: tuple[bool, float], robust: tuple[bool, float]) -> bool:
    """expected_outcome of a scenario expecting ``expect`` for (fell, path deviation [m]) pairs."""
    scenario = get_scenario("paper-bag" if expect == "deviates" else "paper-push")
    assert scenario.expect == expect
    runs = {label: {"fell": fell, "path_deviation": {"max_m": dev}}
            for label, (fell, dev) in (("nominal", nominal), ("robust", robust))}
    return expected_outcome(scenario, runs)


@pytest.mark.parametrize("expect, nominal, robust, outcome", [
    ("falls", (True, 0.01), (False, 0.01), True),
    ("falls", (False, 0.20), (False, 0.01), False),  # a deviating nominal run is not a fall
    ("falls", (True, 0.01), (True, 0.01), False),
    ("deviates", (True, 0.01), (False, 0.01), True),
    ("deviates", (False, 0.08), (False, 0.02), True),
    ("deviates", (False, 0.05), (False, 0.029), False),  # nominal not 2x the robust deviation
    ("deviates", (True, 0.01), (False, 0.31), False),  # robust survives but leaves the path
    ("deviates", (False, 0.02), (False, 0.01), False),  # nominal keeps the path too
], ids=["falls", "falls-nominal-deviates", "falls-both-fall", "deviates-nominal-falls",
        "deviates", "deviates-ratio", "deviates-robust-off-path", "deviates-both-on-path"])
def test_expected_outcome_criteria(expect, nominal, robust, outcome) -> None:
    """The paper's outcome: robust survives (and, for the bag, keeps the path within 3 cm) while
    nominal falls (or, for the bag, deviates by >= 3 cm and >= 2x the robust deviation)."""
    assert _outcome(expect, nominal, robust) is outcome
