"""Bad or extreme input to `ismpc` is caught before anything runs, with one line naming the flag,
file or key (issue 17, cases 5-8, 10-12, 14)."""

import json
import sys
from pathlib import Path

import pytest

from robust_ismpc.cli import main


def _run(argv, capsys) -> tuple[int, str]:
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse errors
        code = exc.code
    return code, capsys.readouterr().err.strip()


def _refused(argv, capsys, *words: str) -> str:
    """``argv`` exits 2 with one stderr line holding ``words``, before any simulation."""
    code, err = _run(argv, capsys)
    assert code == 2, err
    assert len(err.splitlines()) == 1, err
    assert "Traceback" not in err and " t = " not in err
    for word in words:
        assert word in err, err
    return err


@pytest.mark.parametrize("argv,words", [
    (["run", "--duration", "1e9"], ("--duration", "at most 3600 s")),
    (["compare", "--duration", "7200"], ("--duration", "at most 3600 s")),
    (["soak", "--minutes", "1e9"], ("--minutes", "at most 60 minutes")),
    (["sweep", "--impulse-max", "5", "--duration", "1e9"], ("--duration", "at most 3600 s")),
    (["calibrate", "--duration", "1e6"], ("--duration", "at most 3600 s")),
], ids=["run", "compare", "soak", "sweep", "calibrate"])
def test_durations_are_bounded(tmp_path, capsys, argv, words):
    """Case 5: simulated time beyond the documented bound is refused with the bound."""
    _refused([*argv, "--out", str(tmp_path / "o")], capsys, *words)
    assert not (tmp_path / "o").exists()


def _out_locations(tmp_path: Path) -> dict[str, str]:
    afile = tmp_path / "afile"
    afile.write_text("x")
    return {"proc": "/proc/x", "file-parent": str(afile / "sub"), "dev-full": "/dev/full/x", "empty": "",
            "a-file": str(afile)}


@pytest.mark.parametrize("where", ["proc", "file-parent", "dev-full", "empty", "a-file"])
@pytest.mark.parametrize("command", [["run"], ["compare"], ["soak"], ["sweep", "--impulse-max", "5"]],
                         ids=["run", "compare", "soak", "sweep"])
def test_unusable_out_is_refused_before_simulating(tmp_path, capsys, where, command):
    """Case 6 (and 10, `--out ""`): an --out that cannot be a writable folder exits 2 with one
    line naming --out."""
    _refused([*command, "--out", _out_locations(tmp_path)[where]], capsys, "--out")


@pytest.mark.skipif(not hasattr(__import__("os"), "geteuid") or __import__("os").geteuid() == 0,
                    reason="root writes into read-only folders")
def test_read_only_out_is_refused(tmp_path, capsys):
    """Case 6: a read-only folder is refused before simulating."""
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        _refused(["run", "--out", str(folder)], capsys, "--out", "not writable")
        _refused(["run", "--out", str(folder / "sub")], capsys, "--out")
    finally:
        folder.chmod(0o755)


def _bad_robot(tmp_path: Path, old: str, new: str) -> Path:
    from robust_ismpc.robots.robot_file import BUILTIN_DIR

    text = (BUILTIN_DIR / "g1.toml").read_text()
    assert old in text
    path = tmp_path / "mybot.toml"
    path.write_text(text.replace(old, new))
    return path


@pytest.mark.parametrize("old,new,key", [
    ("sole_length_m = 0.17", 'sole_length_m = "low"', "sole_length_m"),
    ("swing_height_m = 0.03", 'swing_height_m = "low"', "gait.swing_height_m"),
    ("left_knee_joint = 1.2443", "left_knee_joint = true", "standing_posture.left_knee_joint"),
])
def test_robot_toml_with_a_wrong_type_names_file_and_key(tmp_path, capsys, old, new, key):
    """Case 7: a robot TOML with a string (or bool) where a number belongs exits 2 naming both."""
    pytest.importorskip("mujoco")
    path = _bad_robot(tmp_path, old, new)
    _refused(["calibrate", "--robot", str(path), "--out", str(tmp_path / "o")], capsys, str(path), key)


TINY_SWEEP = ["sweep", "--controllers", "nominal", "--direction", "90", "--phase", "0.5", "--impulse-max", "5",
              "--iterations", "1", "--workers", "1", "--quiet"]


@pytest.mark.parametrize("corrupt", ["value", "binary"])
def test_corrupted_runs_csv_names_file_and_line(tmp_path, capsys, corrupt):
    """Case 7: resuming a sweep whose runs.csv has a corrupted row exits 2 naming file and line."""
    out = tmp_path / "sweep"
    assert main([*TINY_SWEEP, "--out", str(out)]) == 0
    capsys.readouterr()
    runs = out / "runs.csv"
    lines = runs.read_bytes().split(b"\n")
    if corrupt == "value":
        lines[1] = lines[1].replace(b",impulse,", b",impulse?,")
    else:
        lines[1] = b"\xff\xfe" + lines[1][2:]
    runs.write_bytes(b"\n".join(lines))
    _refused([*TINY_SWEEP, "--out", str(out)], capsys, str(runs), "line 2", "--overwrite")


@pytest.mark.parametrize("module,extra,argv", [
    ("matplotlib", "plot", ["run"]),
    ("matplotlib", "plot", ["sweep", "--impulse-max", "5"]),
    ("mujoco", "sim", ["run", "--sim", "mujoco"]),
    ("mujoco", "sim", ["compare", "paper-bag"]),
    ("imageio", "sim", ["run", "--sim", "mujoco", "--video"]),
], ids=["run-plot", "sweep-plot", "run-mujoco", "scenario-mujoco", "video"])
def test_missing_extra_is_named_before_running(tmp_path, capsys, monkeypatch, module, extra, argv):
    """Case 8: without an extra's package, the command exits 2 naming the pip install command and
    creates no output folder."""
    monkeypatch.setitem(sys.modules, module, None)
    out = tmp_path / "o"
    _refused([*argv, "--out", str(out)], capsys, f"pip install 'robust-ismpc[{extra}]'", module)
    assert not out.exists()


@pytest.mark.parametrize("flag,value,applied", [("--vx", "5", 0.25 / 0.7), ("--vy", "-1", -0.05 / 0.7),
                                                ("--omega", "10", 0.3 / 0.7), ("--vx", "1e308", 0.25 / 0.7)])
def test_command_beyond_the_step_limits_is_said_and_recorded(tmp_path, capsys, flag, value, applied):
    """Cases 10 and 12: a command beyond the robot's steps is walked at the limit; one stderr line
    names the flag and the value applied, and summary.json records request, command and warning."""
    out = tmp_path / "o"
    code, err = _run(["run", flag, value, "--duration", "1", "--out", str(out), "--quiet"], capsys)
    assert code == 0, err
    assert err.count("\n") == 0 and err.startswith(f"ismpc: warning: {flag} ") and f"{abs(applied):.3f}" in err
    summary = json.loads((out / "summary.json").read_text())
    key = {"--vx": "vx_mps", "--vy": "vy_mps", "--omega": "omega_radps"}[flag]
    assert summary["command"][key] == pytest.approx(applied)
    assert summary["command_requested"][key] == float(value)
    assert summary["warnings"] == [err.removeprefix("ismpc: warning: ")]


@pytest.mark.parametrize("argv,words", [
    (["run", "--push", "0,30@12:0.1"], ("--push '0,30@12:0.1'", "when the run has ended")),
    (["run", "--force", "10,0@10:"], ("--force '10,0@10:'", "when the run has ended")),
    (["run", "--delta-max", "0.1"], ("--delta-max", "no restriction module")),
    (["run", "--modules", "observer", "--delta-max", "0.1"], ("--delta-max", "no restriction module")),
    (["run", "--controller", "robust", "--modules", ""], ("--modules is empty",)),
    (["compare", "--robust-modules", ""], ("--robust-modules is empty",)),
    (["bench", "--solvers", "foo"], ("--solvers 'foo'", "installed: daqp")),
    (["bench", "--solvers", ","], ("--solvers",)),
    (["run", "--force", "10,0@-1:2"], ("--force '10,0@-1:2'",)),
    (["run", "--force", "10,0@3:1"], ("--force '10,0@3:1'",)),
    (["run", "--video"], ("--video needs --sim mujoco",)),
    (["run", "--whole-body", "torque"], ("--whole-body torque needs --sim mujoco",)),
    (["sweep", "--impulse-max", "-10"], ("--impulse-max must be",)),
    (["sweep", "--impulse-max", "10", "--iterations", "0"], ("--iterations must be",)),
    (["sweep", "--impulse-max", "10", "--workers", "0"], ("--workers must be",)),
    (["soak", "--push-max", "-3"], ("--push-max must be",)),
], ids=lambda v: " ".join(v) if isinstance(v, list) else None)
def test_ignored_or_misnamed_input_is_refused_naming_the_flag(tmp_path, capsys, argv, words):
    """Cases 10 and 12: input that used to be ignored is refused, and no message names an
    internal class or field instead of the flag."""
    err = _refused([*argv, "--out", str(tmp_path / "o")], capsys, *words)
    for internal in ("ForceWindow", "SweepConfig", "RunSpec", "SoakSpec", "t_start_s", "_ns ", "_n "):
        assert internal not in err


def test_simulator_blow_up_is_reported_as_such(tmp_path, capsys, monkeypatch):
    """Case 11: a 1e9 N push in MuJoCo ends the run with failure "simulator_unstable" at the push
    (not a fall before it), and MuJoCo's own warning neither reaches stderr nor a log file."""
    pytest.importorskip("mujoco")
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "o"
    code, err = _run(["run", "--sim", "mujoco", "--push", "1e9,0@1:0.1", "--duration", "1.5", "--out", str(out),
                      "--quiet"], capsys)
    assert code == 0, err
    assert err == ""
    summary = json.loads((out / "summary.json").read_text())
    assert summary["failure"].startswith("simulator_unstable")
    assert 1.0 <= summary["duration_s"] <= 1.02
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_soak_exits_0_when_the_robot_falls(tmp_path, capsys):
    """Case 12: a soak whose robot falls is an outcome (soak.json), exit 0."""
    out = tmp_path / "soak"
    code, err = _run(["soak", "--minutes", "0.5", "--push-max", "3000", "--out", str(out)], capsys)
    assert code == 0, err
    report = json.loads((out / "soak.json").read_text())
    assert report["fell"] is True and report["failure"] != "interrupted"


def test_viewer_without_a_display_is_refused(tmp_path, capsys, monkeypatch):
    """Case 14: --viewer with no DISPLAY/WAYLAND_DISPLAY exits 2 with a line saying so."""
    pytest.importorskip("mujoco")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    _refused(["run", "--sim", "mujoco", "--viewer", "--out", str(tmp_path / "o")], capsys, "--viewer", "display")
    _refused(["run", "--viewer", "--out", str(tmp_path / "o")], capsys, "--viewer needs --sim mujoco")


def test_out_created_for_a_failing_command_is_removed(tmp_path, capsys):
    """An --out created for a command that then fails (here: a scenario too short for its plan) is
    removed again, lock included."""
    pytest.importorskip("mujoco")
    out = tmp_path / "new"
    _refused(["compare", "paper-ball", "--duration", "0.5", "--out", str(out)], capsys)
    assert not out.exists()


@pytest.mark.parametrize("command", [["run"], ["compare"]])
@pytest.mark.parametrize("flag,value", [("--force", "-45,0@3:"), ("--force", "-45,-10"), ("--force", "-5.5,0@1:2"),
                                        ("--push", "-20,0@2:0.1"), ("--push", "-.5,-30@4.2:0.1")])
def test_negative_force_values_need_no_equals_sign(command, flag, value):
    """Issue 29: the documented `--force -45,0@3:` parses as `--force=-45,0@3:` does (argparse
    took the value for a flag: "expected one argument")."""
    from robust_ismpc.cli.args import build_parser

    parser = build_parser()
    spaced = parser.parse_args([*command, flag, value, flag, "10,0", "--out", "o"])
    joined = parser.parse_args([*command, f"{flag}={value}", flag, "10,0", "--out", "o"])
    assert getattr(spaced, flag[2:]) == [value, "10,0"] == getattr(joined, flag[2:])


def test_a_negative_value_is_applied_and_a_flag_is_still_a_flag(tmp_path, capsys):
    """`--force -45,0@0.5:` reaches the run as a backward force; other flags with a value take
    negative lists too (`--direction -90,90`); a flag after a flag that needs a value is still an
    error naming it."""
    from robust_ismpc.cli.args import build_parser

    out = tmp_path / "back"
    assert main(["run", "--force", "-45,0@0.5:", "--push", "0,-30@0.2:0.1", "--duration", "1", "--out", str(out),
                 "--quiet"]) == 0
    forces = json.loads((out / "summary.json").read_text())["forces"]
    assert [(f["fx_n"], f["fy_n"]) for f in forces] == [(-45.0, 0.0), (0.0, -30.0)]
    assert build_parser().parse_args(["sweep", "--direction", "-90,90", "--impulse-max", "5", "--out", "o"]).direction \
        == "-90,90"
    _refused(["run", "--force", "--quiet", "--out", str(tmp_path / "o")], capsys, "--force", "expected one argument")
