"""A robot file path works wherever a robot name does, and a built-in robot is its file alone."""

import json
from pathlib import Path

import pytest

from robust_ismpc.cli import main

pytest.importorskip("mujoco")
pytest.importorskip("mink")

from robust_ismpc.robots import BUILTIN_ROBOTS
from robust_ismpc.sim.model import load_robot  # noqa: E402

BUILTIN_DIR = Path(__file__).resolve().parents[1] / "robust_ismpc" / "robots"


@pytest.fixture(scope="module")
def op3_copy(tmp_path_factory) -> Path:
    """OP3's built-in robot file copied to a user folder under another name ("mybot")."""
    text = (BUILTIN_DIR / "op3.toml").read_text().replace('name = "op3"', 'name = "mybot"')
    path = tmp_path_factory.mktemp("robots") / "mybot.toml"
    path.write_text(text)
    return path


def test_a_builtin_robot_is_its_file(op3_copy):
    """A copy of a built-in robot file, under another name, gives the same reduced model and
    simulation settings: nothing about a built-in robot is kept outside its file."""
    for name in BUILTIN_ROBOTS:
        text = (BUILTIN_DIR / f"{name}.toml").read_text().replace(f'name = "{name}"', 'name = "renamed"')
        copy = op3_copy.parent / f"{name}_copy.toml"
        copy.write_text(text)
        builtin, user = load_robot(name), load_robot(str(copy))
        assert user.params() == builtin.params().with_values(name="renamed")
        assert (user.foot_friction, user.servo_dynamic_feedforward, user.physics_step_s,
                user.inverse_dynamics_rate_hz, user.sensors) == (
            builtin.foot_friction, builtin.servo_dynamic_feedforward, builtin.physics_step_s,
            builtin.inverse_dynamics_rate_hz, builtin.sensors)


@pytest.mark.parametrize("value,message", [
    ('"fast"', "simulation.physics_step_s must be a number"),
    ("0", "physics_step_s must be a finite number > 0"),
    ("0.02", "physics_step_s must divide the 0.01 s control period"),
])
def test_a_bad_physics_step_is_refused_naming_the_file(op3_copy, value, message):
    """[simulation] physics_step_s must be a number that divides the control period; the error
    names the file."""
    from robust_ismpc.exceptions import ParameterError

    path = op3_copy.parent / "bad_step.toml"
    assert "[simulation]" not in op3_copy.read_text()
    path.write_text(op3_copy.read_text() + f"\n[simulation]\nphysics_step_s = {value}\n")
    with pytest.raises(ParameterError, match=message) as error:
        load_robot(str(path))
    assert str(path) in str(error.value)


@pytest.mark.parametrize("value,message", [
    ('"fast"', "simulation.inverse_dynamics_rate_hz must be a number"),
    ("-100", "inverse_dynamics_rate_hz must be a finite number > 0"),
])
def test_a_bad_inverse_dynamics_rate_is_refused_naming_the_file(op3_copy, value, message):
    from robust_ismpc.exceptions import ParameterError

    path = op3_copy.parent / "bad_rate.toml"
    path.write_text(op3_copy.read_text() + f"\n[simulation]\ninverse_dynamics_rate_hz = {value}\n")
    with pytest.raises(ParameterError, match=message) as error:
        load_robot(str(path))
    assert str(path) in str(error.value)
    path.write_text(op3_copy.read_text() + "\n[simulation]\ninverse_dynamics_rate_hz = 100\n")
    assert load_robot(str(path)).inverse_dynamics_rate_hz == 100.0


@pytest.mark.parametrize("line,message", [
    ("compass_noise = 0.1", "unknown key sensors.compass_noise"),
    ("gyro_noise_radps = -0.1", "sensors.gyro_noise_radps must be a finite number >= 0"),
    ('accel_bias_mps2 = "low"', "sensors.accel_bias_mps2 must be a number"),
])
def test_bad_sensors_are_refused_naming_the_file(op3_copy, line, message):
    from robust_ismpc.exceptions import ParameterError

    path = op3_copy.parent / "bad_sensors.toml"
    path.write_text(op3_copy.read_text().replace("[sensors]\n", f"[sensors]\n{line}\n"))
    with pytest.raises(ParameterError, match=message) as error:
        load_robot(str(path))
    assert str(path) in str(error.value)


def test_a_robot_s_own_sensors_replace_the_preset_s_and_the_summary_records_them(op3_copy, tmp_path, capsys):
    """OP3's file names its servos' 12-bit encoders: under ``realistic`` a run uses them (and the
    preset's IMU), under ``ideal`` the truth; ``summary.json`` says which values a run used."""
    from robust_ismpc.robots.sensing import SENSING_PRESETS, robot_sensing

    sensors = dict(load_robot("op3").sensors)
    assert sensors["joint_pos_resolution_rad"] == pytest.approx(2 * 3.14159265 / 4096, rel=1e-4)
    realistic = robot_sensing("realistic", load_robot("op3").sensors)
    assert realistic.joint_pos_resolution_rad == sensors["joint_pos_resolution_rad"]
    assert realistic.gyro_bias_radps == SENSING_PRESETS["realistic"].gyro_bias_radps
    assert robot_sensing("ideal", load_robot("op3").sensors) == SENSING_PRESETS["ideal"]
    for sensing in ("realistic", "ideal"):
        out = tmp_path / sensing
        code, _ = _main(["run", "--sim", "mujoco", "--robot", str(op3_copy), "--vx", "0", "--duration", "0.2",
                         "--sensing", sensing, "--out", str(out)], capsys)
        assert code == 0
        recorded = json.loads((out / "summary.json").read_text())["sensing"]
        expected = sensors["joint_pos_resolution_rad"] if sensing == "realistic" else 0.0
        assert recorded["joint_pos_resolution_rad"] == expected


def _main(argv, capsys):
    code = main(argv)
    return code, capsys.readouterr()


def test_run_takes_a_robot_file_on_both_simulators(op3_copy, tmp_path, capsys):
    """``ismpc run --robot FILE`` walks on the LIP and in MuJoCo; summary.json keeps the file's
    absolute path (to rerun it) and the robot's name."""
    for sim in ("lip", "mujoco"):
        out = tmp_path / sim
        code, captured = _main(["run", "--sim", sim, "--robot", str(op3_copy), "--vx", "0.1", "--duration", "2",
                                "--out", str(out)], capsys)
        assert code == 0, captured.err
        summary = json.loads((out / "summary.json").read_text())
        assert summary["robot"] == str(op3_copy.resolve())
        assert summary["robot_name"] == "mybot"
        assert not summary["fell"]
        assert captured.out.startswith(f"mybot/{sim}/nominal")


@pytest.mark.parametrize("argv,written", [
    (["compare", "--duration", "2"], "comparison.json"),
    (["sweep", "--direction", "0", "--phase", "0.5", "--iterations", "1", "--impulse-max", "1"], "frontier.json"),
    (["soak", "--minutes", "0.1"], "soak.json"),
    (["calibrate", "--vx", "0.1", "--duration", "3"], "calibration.json"),
    (["bench", "--horizons", "50", "--cycles", "20"], "bench.json"),
])
def test_every_command_takes_a_robot_file(op3_copy, tmp_path, capsys, argv, written):
    """compare, sweep, soak, calibrate and bench accept a robot file path for --robot."""
    out = tmp_path / "out"
    code, captured = _main(argv + ["--robot", str(op3_copy), "--out", str(out)], capsys)
    assert code == 0, captured.err
    assert (out / written).is_file()
    recorded = [p for p in out.rglob("*.json") if str(op3_copy.resolve()) in p.read_text()]
    assert recorded, "no output names the robot file"


@pytest.mark.parametrize("robot,message", [
    ("missing.toml", "robot description file"),
    ("hrp4", "robots available with --sim mujoco"),
])
def test_a_bad_robot_exits_2_with_one_line(tmp_path, capsys, robot, message):
    """An unknown name on MuJoCo or a missing file: exit 2, one line naming it."""
    code, captured = _main(["run", "--sim", "mujoco", "--robot", robot, "--out", str(tmp_path / "o")], capsys)
    assert code == 2
    assert message in captured.err and len(captured.err.strip().splitlines()) == 1


def test_a_scenario_runs_on_a_robot_file_of_its_robots_size(op3_copy, tmp_path, capsys):
    """``compare paper-bag --robot FILE`` runs the scenario on the file's robot (the bag found
    at the end of its right arm, mass scaled with the robot); a robot of another size is refused
    with one line giving both CoM heights."""
    out = tmp_path / "bag"
    code, captured = _main(["compare", "paper-bag", "--robot", str(op3_copy), "--duration", "0.5",
                            "--out", str(out)], capsys)
    assert code == 0, captured.err
    comparison = json.loads((out / "comparison.json").read_text())
    assert comparison["realised"]["robot"] == str(op3_copy.resolve())
    assert comparison["realised"]["bag"]["link"] == "r_el_link"
    code, captured = _main(["compare", "paper-push", "--robot", str(op3_copy), "--out", str(tmp_path / "push")],
                           capsys)
    assert code == 2
    assert "0.60 m" in captured.err and "0.23 m" in captured.err and len(captured.err.strip().splitlines()) == 1
