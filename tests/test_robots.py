"""Tests of robot descriptions (robust_ismpc.robots)."""
# ruff: noqa: F811  (pytest fixtures imported from mujoco_fixtures are redefined as arguments)

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mujoco_fixtures import robot_spec  # noqa: F401  (fixture; skips without mujoco)

from robust_ismpc.exceptions import ModelError, ParameterError
from robust_ismpc.robots import BUILTIN_ROBOTS, RobotSpec
from robust_ismpc.robots.robot_file import BUILTIN_DIR
from robust_ismpc.sim.model import load_robot

EXPECTED_MASS_KG = {"g1": (33.0, 0.15), "op3": (3.0, 0.20)}
EXPECTED_COM_HEIGHT_M = {"g1": (0.55, 0.62), "op3": (0.20, 0.26)}


def _user_toml(tmp_path: Path, **changes: str) -> Path:
    """Copy of the built-in g1 description with an absolute model path and some lines replaced."""
    spec = load_robot("g1")
    text = (BUILTIN_DIR / "g1.toml").read_text()
    lines = []
    for line in text.splitlines():
        key = line.split("=")[0].strip()
        if key == "model_package":
            continue
        if key == "model":
            line = f'model = "{spec.model_path}"'
        if key in changes:
            line = f"{key} = {changes[key]}"
        lines.append(line)
    path = tmp_path / "my_robot.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_builtin_masses_are_plausible(robot_spec: RobotSpec) -> None:
    """The model mass of each built-in robot is within tolerance of the published mass."""
    nominal, tol = EXPECTED_MASS_KG[robot_spec.name]
    assert abs(robot_spec.mass_kg - nominal) <= tol * nominal


def test_standing_com_height_is_bent_knee(robot_spec: RobotSpec) -> None:
    """The standing posture puts the CoM at the intended bent-knee height, below the base."""
    low, high = EXPECTED_COM_HEIGHT_M[robot_spec.name]
    assert low <= robot_spec.com_height_m <= high
    assert robot_spec.com_height_m < robot_spec.base_height_m + 0.3


def test_params_use_measured_values_and_fit_zmp_box(robot_spec: RobotSpec) -> None:
    """RobotParams carry the measured mass, CoM height, soles and spacing; the ZMP box fits the sole."""
    params = robot_spec.params()
    assert params.mass_kg == robot_spec.mass_kg
    assert params.com_height_m == robot_spec.com_height_m
    assert params.foot_spacing_m == robot_spec.foot_spacing_m
    assert params.zmp_box_x_m <= robot_spec.sole_length_m
    assert params.zmp_box_y_m <= robot_spec.sole_width_m
    assert params.foot_spacing_m > robot_spec.sole_width_m  # feet do not overlap


def test_standing_qpos_puts_soles_on_floor(robot_spec: RobotSpec) -> None:
    """In the standing configuration both soles are flat at z = 0 (within 10 µm)."""
    import mujoco

    from robust_ismpc.sim.model import compile_model
    from robust_ismpc.sim.robot import MujocoRobot, standing_state

    model = compile_model(robot_spec)
    data = mujoco.MjData(model)
    standing_state(robot_spec, model, data)
    robot = MujocoRobot(robot_spec, model, data)
    for side in ("left", "right"):
        pose = robot.sole_pose(side)
        assert abs(pose.pos_m[2]) < 1e-5
        assert robot.sole_rotation(side)[2, 2] > np.cos(np.radians(1.0))


def test_unknown_name_lists_builtins() -> None:
    """An unknown robot name raises ParameterError naming the built-in robots."""
    with pytest.raises(ParameterError) as info:
        load_robot("asimo")
    for name in BUILTIN_ROBOTS:
        assert name in str(info.value)


def test_user_toml_loads_same_robot(tmp_path: Path) -> None:
    """A user TOML pointing at the G1 model gives the same measured values as the built-in."""
    spec = load_robot(_user_toml(tmp_path, name='"my_g1"'))
    builtin = load_robot("g1")
    assert spec.name == "my_g1"
    assert spec.mass_kg == pytest.approx(builtin.mass_kg)
    assert spec.com_height_m == pytest.approx(builtin.com_height_m)
    params = spec.params()  # not a built-in name: scaled gait defaults
    assert params.zmp_box_x_m < spec.sole_length_m


def test_relative_model_path_is_relative_to_toml(tmp_path: Path) -> None:
    """A relative model path is resolved from the TOML file's folder."""
    model_dir = load_robot("g1").model_path.parent
    path = _user_toml(tmp_path)
    text = path.read_text().replace(str(model_dir), str(Path("models")))
    (tmp_path / "models").symlink_to(model_dir)
    path.write_text(text)
    assert load_robot(path).model_path.name == "scene.xml"


def test_missing_model_file_names_it(tmp_path: Path) -> None:
    """A model path that does not exist raises ModelError naming the value."""
    with pytest.raises(ModelError, match="nowhere.xml"):
        load_robot(_user_toml(tmp_path, model='"nowhere.xml"'))


def test_absent_foot_name_is_reported(tmp_path: Path) -> None:
    """A foot site missing in the model raises ModelError naming the foot."""
    with pytest.raises(ModelError, match="left_toe"):
        load_robot(_user_toml(tmp_path, left_foot='"left_toe"'))


def test_unknown_key_is_rejected(tmp_path: Path) -> None:
    """An unknown top-level key raises ParameterError."""
    path = _user_toml(tmp_path)
    path.write_text('colour = "red"\n' + path.read_text())
    with pytest.raises(ParameterError, match="colour"):
        load_robot(path)


BAD_TOML_VALUES = [
    ("sole_length_m", "0", "sole_length_m must be a finite number > 0"),
    ("sole_length_m", "nan", "sole_length_m must be a finite number > 0"),
    ("sole_length_m", "-0.1", "sole_length_m must be a finite number > 0"),
    ("sole_width_m", "0", "sole_width_m must be a finite number > 0"),
    ("left_sole_offset_m", "[0.0, 0.0]", "left_sole_offset_m must be 3 finite numbers"),
    ("swing_height_m", "-0.01", "swing_height_m must be a finite number >= 0"),
    ("swing_height_m", "nan", "swing_height_m must be a finite number >= 0"),
    ("root_body", '"nobody"', "root_body 'nobody' not found in the model"),
    ("foot_frame_type", '"wheel"', "foot_frame_type must be 'site' or 'body'"),
    ("swing_cop_gain_s2", '"big"', "gait.swing_cop_gain_s2 must be a number"),
]


@pytest.mark.parametrize("key,value,message", BAD_TOML_VALUES, ids=[f"{k}={v}" for k, v, _ in BAD_TOML_VALUES])
def test_bad_toml_value_raises_our_exception(tmp_path: Path, key: str, value: str, message: str) -> None:
    """Each bad value in a robot file raises ParameterError or ModelError naming it, on one line."""
    pytest.importorskip("mujoco")
    path = _user_toml(tmp_path, **{key: value})
    with pytest.raises((ParameterError, ModelError)) as info:
        load_robot(path).params()
    assert message in str(info.value) and "\n" not in str(info.value)
    assert str(path) in str(info.value)


def test_an_unknown_gait_key_names_the_file_and_the_key(tmp_path: Path) -> None:
    """A [gait] key that is not a settable RobotParams field: one line naming the file and key."""
    path = _user_toml(tmp_path)
    path.write_text(path.read_text().replace("[gait]\n", "[gait]\nstep_height_m = 0.04\n"))
    with pytest.raises(ParameterError, match="gait.step_height_m cannot be set") as info:
        load_robot(path)
    assert str(path) in str(info.value)
