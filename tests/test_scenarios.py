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
    HRP4_DART,
    SCENARIOS,
    BallSpec,
    PaperRobot,
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
        PaperRobot("x", mass_kg=0.0, com_height_m=0.7, sole_length_m=0.25)
    with pytest.raises(ParameterError):
        ScaledForce(1.0, 0.0, paper_robot=40.0)
    with pytest.raises(ParameterError):
        ScaledForce(1.0, 0.0, HRP4_DART).window(30.0, 0.0, 0.17)
    with pytest.raises(ParameterError):
        Variation(magnitude_fraction=1.5)
    with pytest.raises(ParameterError):
        BallSpec(release_angle_rad=2.0)


def test_masses_scale_with_robot_mass() -> None:
    """Bag and ball masses are the paper's values times m_robot / m_paper_robot."""
    bag = realise("paper-bag").details
    assert bag["bag"]["mass_kg"] == pytest.approx(0.67 * bag["robot_mass_kg"] / 5.4, rel=1e-3)
    ball = realise("paper-ball").details
    assert ball["ball"]["mass_kg"] == pytest.approx(0.265 * ball["robot_mass_kg"] / 5.4, rel=1e-3)


def test_the_load_factor_scales_the_scenarios_own_disturbances_only() -> None:
    """load_factor multiplies the bag's and the ball's masses (the ball's speed and hit kept) and
    the scenario's forces, not the forces a user adds; it must be a finite number > 0."""
    from robust_ismpc.runs.forces import ForceWindow

    for name, key in (("paper-bag", "bag"), ("paper-ball", "ball")):
        base, heavy = realise(name, seed=3).details, realise(name, seed=3, load_factor=2.5).details
        assert heavy[key]["mass_kg"] == pytest.approx(2.5 * base[key]["mass_kg"], rel=1e-3)  # both rounded to 0.1 g
        assert heavy["load_factor"] == 2.5 and base["load_factor"] == 1.0
    ball, heavy_ball = realise("paper-ball", seed=3).details["ball"], realise("paper-ball", seed=3, load_factor=2.5).details["ball"]
    assert heavy_ball["hit_s"] == ball["hit_s"] and heavy_ball["expected_impact_speed_mps"] == ball["expected_impact_speed_mps"]
    extra = ForceWindow(5.0, 0.0, 1.0, 1.1)
    base = realise("paper-push", seed=2, extra_forces=(extra,)).nominal.forces
    half = realise("paper-push", seed=2, extra_forces=(extra,), load_factor=0.5).nominal.forces
    for own, scaled in zip(base[:-1], half[:-1]):
        assert (scaled.fx_n, scaled.fy_n) == pytest.approx((0.5 * own.fx_n, 0.5 * own.fy_n))
        assert (scaled.t_start_s, scaled.t_end_s) == (own.t_start_s, own.t_end_s)
    assert half[-1] == base[-1] == extra
    for bad in (0.0, -1.0, math.inf, math.nan, "2"):
        with pytest.raises(ParameterError, match="load_factor"):
            realise("paper-push", load_factor=bad)


def test_compare_refuses_a_bad_load_factor_before_it_writes(tmp_path, capsys) -> None:
    """``--load-factor`` needs a scenario and a finite number > 0; refused with exit status 2 and no
    output folder."""
    for argv in (["compare", "paper-ball", "--load-factor", "0"], ["compare", "paper-ball", "--load-factor", "nan"],
                 ["compare", "--load-factor", "2"]):
        out = tmp_path / "x"
        assert main([*argv, "--out", str(out)]) == 2
        assert not out.exists()
    assert "load" in capsys.readouterr().err


def test_push_forces_keep_the_papers_dimensionless_load() -> None:
    """paper-push's forces load G1 as the paper's loaded HRP-4: F h / (m g l) (l the half sole) is
    the paper's 45 N and 85 N on HRP-4 in DART (40.05 kg, CoM 0.71 m, sole 0.25 m), and the
    constant push is there from t = 0."""
    push = realise("paper-push").details
    m, h, half_sole = push["robot_mass_kg"], push["robot_com_height_m"], 0.5 * push["robot_sole_length_m"]
    assert (m, h, half_sole) == pytest.approx((33.34, 0.60, 0.085), rel=2e-3)  # the G1 robot file

    def load(force_n, mass_kg, com_height_m, half_sole_m):
        return force_n * com_height_m / (mass_kg * 9.81 * half_sole_m)

    constant, impulse = push["forces"]
    assert load(constant["fx_n"], m, h, half_sole) == pytest.approx(load(45.0, 40.05, 0.71, 0.125), rel=1e-3)
    assert load(impulse["fy_n"], m, h, half_sole) == pytest.approx(load(85.0, 40.05, 0.71, 0.125), rel=1e-3)
    assert constant["fy_n"] == 0.0 and impulse["fx_n"] == 0.0
    assert constant["t_start_s"] == 0.0 and constant["t_end_s"] is None
    assert impulse["t_end_s"] - impulse["t_start_s"] == pytest.approx(0.1)


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


def test_ball_is_released_from_the_horizontal_on_every_seed() -> None:
    """paper-ball's rule for the ball's speed: released from the horizontal (0.01 rad below it, for
    the holding force); the seeds change the impact speed by at most 10 % through the rope length."""
    base = realise("paper-ball", seed=0).details["ball"]
    assert base["release_angle_deg"] == pytest.approx(90.0, abs=0.6)
    assert base["expected_impact_speed_mps"] == pytest.approx(math.sqrt(2 * 9.81 * 0.5), rel=0.01)
    for seed in (1, 2, 3):
        ball = realise("paper-ball", seed=seed).details["ball"]
        assert ball["release_angle_deg"] == base["release_angle_deg"]
        ratio = ball["expected_impact_speed_mps"] / base["expected_impact_speed_mps"]
        assert 0.9 - 1e-3 <= ratio <= 1.1 + 1e-3
        assert ratio == pytest.approx(math.sqrt(ball["rope_length_m"] / base["rope_length_m"]), rel=1e-3)


def test_bag_hangs_from_an_arm_along_the_body() -> None:
    """OP3 stands with its arms hanging along its body: the bag's attachment (the right elbow) is
    below the shoulder and at most 10 cm from the body's centre line, and no arm geom touches the
    torso or the legs in the standing posture."""
    import mujoco

    from robust_ismpc.sim.model import compile_model, load_robot
    from robust_ismpc.sim.robot import standing_state

    bag = realise("paper-bag").details["bag"]
    assert bag["link"] == "r_el_link" and bag["lever_m"] <= 0.10
    spec = load_robot("op3")
    model = compile_model(spec)
    data = mujoco.MjData(model)
    standing_state(spec, model, data)
    for side in ("l", "r"):
        shoulder, elbow = data.xpos[model.body(f"{side}_sho_roll_link").id], data.xpos[model.body(f"{side}_el_link").id]
        assert shoulder[2] - elbow[2] >= 0.08  # the upper arm (9 cm) hangs down
        arm = {model.body(f"{side}_sho_roll_link").id, model.body(f"{side}_el_link").id}
        collides = [g for g in range(model.ngeom) if model.geom_contype[g] or model.geom_conaffinity[g]]
        for g in (g for g in collides if model.geom_bodyid[g] in arm):
            for o in (o for o in collides if model.geom_bodyid[o] not in arm | {0}
                      and model.body(model.geom_bodyid[o]).name != f"{side}_sho_pitch_link"):
                assert mujoco.mj_geomDistance(model, data, g, o, 0.05, None) > 0.003


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
    """paper-ball is an OP3-sized scenario (standing CoM 0.23 m): --robot g1 (0.60 m, more than
    twice as tall) is a usage error that names the sizes."""
    assert main(["compare", "paper-ball", "--robot", "g1", "--out", str(tmp_path / "x")]) == 2
    assert "op3's size" in capsys.readouterr().err


CLOSED_LOOP_GAP = ("closed loop: the nominal MPC, replanning from the measured state, holds about twice the ball "
                   "(docs/scenarios.md, Frontiers)")


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
    from about 0.25 s to at most 0.15 s and walks on. (Closed loop, measured: both walk; the
    robust run adapts nothing after the hit.)"""
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


@pytest.mark.xfail(strict=True, reason="the robust OP3 re-times one of its first steps (a double support at 2.12 s), "
                                        "which the paper's NAO does not (docs/scenarios.md)")
def test_paper_bag_shows_the_papers_outcome(paper_bag_8s) -> None:
    """paper-bag on OP3 (seed 0, 8 s), the paper's Fig. 2 and its mechanism: the nominal robot
    falls or drifts off its path under the swinging bag (at least 3 cm and twice the robust
    deviation, ``expected_outcome``); the robust one leans against the bag (its planned
    disturbance points to the bag, -y), keeps the path within 3 cm, and needs neither a
    step-timing adaptation nor a replayed plan; the bag does swing."""
    comparison = paper_bag_8s
    robust = comparison["robust"]
    assert not robust["fell"]
    assert robust["scene"]["payloads"][0]["max_swing_rad"] > 0.1  # the bag does swing
    assert robust["disturbance_planned_mean_mps2"][1] < -0.3  # towards the bag (-y)
    assert robust["timing_adaptations"] == 0 and robust["qp_infeasible_count"] == 0
    assert robust["path_deviation"]["max_m"] < 0.03
    assert comparison["robust_keeps_path"] and comparison["expected_outcome"]


def test_paper_bag_robust_walks_and_swings_the_bag_no_more_than_nominal(paper_bag_8s) -> None:
    """paper-bag on OP3 (seed 0, 8 s): the robust robot walks as the nominal one does, with no
    infeasible QP, leaning against the bag, and its steps do not pump the bag (its swing no larger
    than under nominal, within 20 %). Re-timed steps that did not return to their nominal length
    swung it 3-4 times as much, and the run turned infeasible (docs/scenarios.md)."""
    nominal, robust = paper_bag_8s["nominal"], paper_bag_8s["robust"]
    assert not nominal["fell"] and not robust["fell"]
    assert robust["qp_infeasible_count"] == 0
    assert robust["disturbance_planned_mean_mps2"][1] < -0.3
    swing = {name: run["scene"]["payloads"][0]["swing_std_rad"] for name, run in (("nominal", nominal), ("robust", robust))}
    assert swing["robust"] <= 1.2 * swing["nominal"]


def test_paper_push_shows_the_papers_outcome_on_seed_0() -> None:
    """paper-push on G1 (torque control), seed 0, the paper's Fig. 4: the robust robot walks the
    10 s under the constant push without an infeasible QP, its planned disturbance the push's
    (within 5 %); the nominal one falls (here standing, under the constant push alone, which the
    paper does not time). The re-timing after the impulse is checked over ten seeds below: seed 0
    absorbs its impulse without one."""
    comparison = run_scenario("paper-push", seed=0).comparison
    assert comparison["whole_body"] == "torque"
    nominal, robust = comparison["nominal"], comparison["robust"]
    assert nominal["fell"]
    assert not robust["fell"] and robust["qp_infeasible_count"] == 0
    applied_x = robust["disturbance_applied_mean_mps2"][0]
    assert abs(robust["disturbance_planned_mean_mps2"][0] - applied_x) < 0.05 * applied_x
    assert comparison["expected_outcome"]


@pytest.mark.slow
def test_paper_push_shows_the_papers_mechanism_on_eight_of_ten_seeds() -> None:
    """paper-push, seeds 0-9 (issue 27's bar): on at least 8 the nominal G1 falls, the robust one
    walks, plans with the push's disturbance (within 5 %) and re-times a step within 0.2 s of the
    sideways impulse."""
    shown = 0
    for seed in range(10):
        comparison = run_scenario("paper-push", seed=seed).comparison
        robust = comparison["robust"]
        applied_x = robust["disturbance_applied_mean_mps2"][0]
        shown += bool(
            comparison["expected_outcome"]
            and abs(robust["disturbance_planned_mean_mps2"][0] - applied_x) < 0.05 * applied_x
            and robust["adaptations_after_hit"] >= 1
            and 0.0 <= robust["first_adaptation_s"] - robust["event_s"] <= 0.2
        )
    assert shown >= 8


def test_disturbance_events_name_the_ball_hit_and_each_force() -> None:
    """Figure markers: the planned hit for paper-ball; the constant force then the push for paper-push."""
    from robust_ismpc.experiments.scenarios import disturbance_events

    ball = realise("paper-ball")
    assert disturbance_events(ball) == [("ball hit (planned)", ball.details["ball"]["hit_s"])]
    push = realise("paper-push")
    labels, times = zip(*disturbance_events(push))
    assert labels == ("constant force 30 N", "push 57 N")
    assert times == (0.0, 6.0)


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
