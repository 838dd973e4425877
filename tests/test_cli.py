"""CLI tests: runs write well-formed outputs; bad input exits 2 with one line; no overwrite."""

import json
import subprocess
import sys

import pytest

from robust_ismpc.cli import main

BAD_RUN_ARGS = [
    (["--robot", "nope"], "unknown robot 'nope'; built-in robots are"),
    (["--sim", "gazebo"], "unknown simulator"),
    (["--controller", "fancy"], "unknown controller"),
    (["--modules", "observer,magic"], "unknown module 'magic'"),
    (["--duration", "0"], "duration must be a finite number > 0"),
    (["--duration", "nan"], "duration must be a finite number > 0"),
    (["--duration", "-3"], "duration must be a finite number > 0"),
    (["--vx", "abc"], "vx must be a number"),
    (["--vx", "inf"], "vx must be finite"),
    (["--force", "10"], "expected 2 comma-separated numbers"),
    (["--force", "a,b"], "is not a list of numbers"),
    (["--force", "10,0@3"], "the window must be T0:T1"),
    (["--force", "10,0@3:1"], "must be after its start"),
    (["--force", "10,0@-1:2"], "--force '10,0@-1:2': the start time must be >= 0 s"),
    (["--push", "10,0"], "expected FX,FY@T:DUR"),
    (["--push", "10,0@1:0"], "duration must be > 0 s"),
    (["--push", "10,nan@1:0.1"], "values must be finite"),
    (["--seed", "-1"], "seed must be an integer >= 0"),
    (["--seed", "1.5"], "seed must be an integer >= 0"),
    (["--controller", "robust", "--delta-max", "-0.1"], "delta max must be a finite number >= 0"),
    (["--whole-body", "torque"], "--whole-body torque needs --sim mujoco"),
    (["--whole-body", "stiff"], "invalid choice: 'stiff'"),
]


@pytest.mark.parametrize("extra,message", BAD_RUN_ARGS)
def test_bad_run_input_exits_2_with_one_line(tmp_path, capsys, extra, message):
    """Each bad value gives exit status 2 and a single stderr line naming it."""
    with pytest.raises(SystemExit) as exc:
        code = main(["run", "--out", str(tmp_path / "o"), "--duration", "1", *extra])
        raise SystemExit(code)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert message in err
    assert "Traceback" not in err


def test_run_writes_summary_and_plot(tmp_path):
    """`ismpc run` on the LIP writes summary.json with the documented fields, gait.png and trace.npz."""
    out = tmp_path / "run"
    assert main(["run", "--robot", "g1", "--vx", "0.3", "--duration", "4", "--out", str(out), "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    for key in ("robot", "sim", "controller", "modules", "fell", "failure", "duration_s", "distance_m",
                "steps_taken", "qp_infeasible_count", "max_zmp_violation_m", "mpc_solve_ms", "cycle_ms",
                "timing_adaptations", "min_time_to_step_s", "disturbance_estimate_final"):
        assert key in summary
    assert summary["fell"] is False and summary["failure"] is None
    assert set(summary["cycle_ms"]) == {"median", "p99", "max"}
    assert summary["steps_taken"] >= 2
    assert (out / "gait.png").stat().st_size > 10_000
    assert (out / "trace.npz").exists()


def test_every_comparison_json_has_one_schema(tmp_path):
    """Issue 29: a free-form `ismpc compare` (LIP, a push) writes the keys of a named scenario's
    comparison.json (MuJoCo, paper-push on G1), at the top and per controller, with the run
    durations and the timing before and after the push."""
    free, named = tmp_path / "free", tmp_path / "named"
    assert main(["compare", "--push", "0,20@1:0.1", "--duration", "2", "--out", str(free), "--quiet"]) == 0
    assert main(["compare", "paper-push", "--duration", "0.5", "--out", str(named), "--quiet"]) == 0
    a, b = (json.loads((out / "comparison.json").read_text()) for out in (free, named))
    assert list(a) == list(b)
    for label in ("nominal", "robust"):
        assert list(a[label]) == list(b[label])
    assert a["scenario"] is None and b["scenario"] == "paper-push"
    assert a["robust"]["duration_s"] == 2.0 and a["robust"]["event_s"] == 1.0
    assert a["robust"]["adaptations_before_hit"] is not None and a["robust"]["adaptations_after_hit"] is not None


def test_existing_output_is_not_overwritten(tmp_path, capsys):
    """A non-empty --out is refused without --overwrite and accepted with it."""
    out = tmp_path / "run"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    assert main(["run", "--duration", "1", "--out", str(out), "--quiet"]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert main(["run", "--duration", "1", "--out", str(out), "--quiet", "--overwrite"]) == 0
    assert (out / "keep.txt").read_text() == "mine"


def test_console_script_help_documents_flags():
    """`ismpc run --help` lists every flag."""
    out = subprocess.run([sys.executable, "-m", "robust_ismpc.cli", "run", "--help"], capture_output=True, text=True)
    assert out.returncode == 0
    for flag in ("--sim", "--robot", "--controller", "--modules", "--vx", "--vy", "--omega", "--duration",
                 "--force", "--push", "--seed", "--delta-max", "--out", "--overwrite", "--video"):
        assert flag in out.stdout


def test_bench_writes_json(tmp_path):
    """`ismpc bench` prints a table and writes bench.json with build/solve stats per horizon."""
    assert main(["bench", "--horizons", "20", "--cycles", "50", "--solvers", "daqp,quadprog", "--out", str(tmp_path)]) == 0
    data = json.loads((tmp_path / "bench.json").read_text())
    h = data["horizons"][0]
    assert h["C"] == 20 and h["solve_ms"]["median"] > 0 and "quadprog" in h["solvers"]
    assert "commit" in data and data["speed"]["repeats"] == 1
    rows = data["speed"]["rows"]
    assert {"lip_cycle_nominal_median_ms", "lip_cycle_robust_p99_ms", "bench_robust_c200_median_ms",
            "process_lip_s"} <= set(rows)
    assert "mujoco_torque_tick_ms" not in rows  # only with --mujoco


def test_bench_times_the_robot_it_is_given(tmp_path):
    """--robot applies to the speed table too: its rows are op3's, named so in the table, and a
    baseline measured on another robot is refused."""
    argv = ["bench", "--robot", "op3", "--horizons", "20", "--cycles", "50", "--solvers", "daqp", "--out", str(tmp_path)]
    assert main(argv) == 0
    data = json.loads((tmp_path / "bench.json").read_text())
    assert data["robot"] == "op3" and data["speed"]["robot"] == "op3"
    assert "`ismpc run --sim lip --robot op3 --duration 10`" in (tmp_path / "bench.md").read_text()
    from robust_ismpc.exceptions import ParameterError
    from robust_ismpc.experiments.speed import compare_speed

    g1 = {"speed": {"robot": "g1", "rows": {"process_lip_s": 1.0}}}
    with pytest.raises(ParameterError, match="measured robot 'g1'"):
        compare_speed(data, g1)


def test_bench_compares_with_a_baseline(tmp_path, capsys):
    """--baseline prints each speed row's ratio and flags rows 10 % slower or more."""
    base = {"speed": {"repeats": 1, "rows": {"lip_cycle_nominal_median_ms": 1e-6, "process_lip_s": 1e6}}}
    (tmp_path / "base.json").write_text(json.dumps(base))
    argv = ["bench", "--horizons", "20", "--cycles", "50", "--solvers", "daqp", "--quiet",
            "--baseline", str(tmp_path / "base.json"), "--out", str(tmp_path / "b")]
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert "slower than the baseline by 10 % or more: lip_cycle_nominal_median_ms" in captured.err
    comparison = {c["row"]: c for c in json.loads((tmp_path / "b" / "bench.json").read_text())["comparison"]}
    assert comparison["lip_cycle_nominal_median_ms"]["regression"] is True
    assert comparison["process_lip_s"]["regression"] is False and comparison["process_lip_s"]["ratio"] < 1e-3
    assert set(comparison) == {"lip_cycle_nominal_median_ms", "process_lip_s"}


def test_calibrate_writes_the_fit_and_its_figure(tmp_path, capsys):
    """`ismpc calibrate` fits κ on G1 (close to the value in g1.toml) and writes JSON and a plot."""
    pytest.importorskip("mujoco")
    from robust_ismpc.sim.model import load_robot

    assert main(["calibrate", "--robot", "g1", "--duration", "5", "--out", str(tmp_path)]) == 0
    data = json.loads((tmp_path / "calibration.json").read_text())
    assert data["swing_cop_gain_s2"] == pytest.approx(load_robot("g1").params().swing_cop_gain_s2, rel=0.1)
    assert data["residual_rms_m"] < 0.5 * data["cop_deviation_rms_m"]
    assert (tmp_path / "calibration.png").stat().st_size > 10_000
    assert "swing_cop_gain_s2 =" in capsys.readouterr().out


BAD_OTHER_ARGS = [
    (["run", "--controller", "robust", "--delta-max", "5", "--duration", "1"], "the largest guaranteed --delta-max"),
    (["run", "--sim", "mujoco", "--robot", "hrp4", "--duration", "1"], "robots available with --sim mujoco: apollo, g1, op3, t1"),
    (["compare", "paper-nothing"], "scenarios are: paper-bag, paper-ball, paper-push"),
    (["compare", "paper-ball", "--vx", "0.3"], "--vx is not allowed"),
    (["soak", "--vx", "nan"], "vx must be finite"),
    (["soak", "--minutes", "0"], "minutes must be a finite number > 0"),
    (["soak", "--sim", "gazebo"], "unknown simulator 'gazebo'"),
    (["soak", "--push-max", "-3"], "--push-max must be a finite number >= 0"),
    (["soak", "--modules", "foo"], "unknown module 'foo'"),
    (["sweep", "--controllers", "nominal,zzz", "--impulse-max", "10"], "unknown controller 'zzz'"),
    (["sweep", "--impulse-max", "-10"], "--impulse-max must be a finite number > 0"),
    (["bench", "--horizons", "0"], "--horizons must be between 2 and 1000 samples"),
    (["bench", "--cycles", "5"], "--cycles must be between 10 and 100000"),
    (["bench", "--repeats", "0"], "--repeats must be from 1 to 50"),
    (["bench", "--baseline", "no-such-bench.json"], "--baseline 'no-such-bench.json': no such file"),
    (["bench", "--mujoco", "--robot", "hrp4"], "unknown robot 'hrp4' for MuJoCo"),
    (["calibrate", "--robot", "nao"], "unknown robot 'nao'"),
    (["calibrate", "--vx", "0", "--duration", "3"], "no forward swing motion"),
]


@pytest.mark.parametrize("argv,message", BAD_OTHER_ARGS, ids=[" ".join(a[:3]) for a, _ in BAD_OTHER_ARGS])
def test_bad_input_of_other_commands_exits_2_with_one_line(tmp_path, capsys, argv, message):
    """compare, soak, sweep and the robust/MuJoCo paths of run: exit status 2, one stderr line,
    nothing written."""
    out = tmp_path / "o"
    with pytest.raises(SystemExit) as exc:
        raise SystemExit(main([*argv, "--out", str(out)]))
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert message in err and "Traceback" not in err
    assert not out.exists() or not any(out.iterdir())


def test_speed_comparison_flags_rows_by_their_ratio():
    """compare_speed: ratio now / baseline per shared row; 1.1x or more is a regression."""
    from robust_ismpc.exceptions import ParameterError
    from robust_ismpc.experiments.speed import compare_speed

    now = {"speed": {"rows": {"lip_cycle_nominal_median_ms": 0.33, "process_lip_s": 1.2, "mujoco_torque_tick_ms": 5.0}}}
    base = {"speed": {"rows": {"lip_cycle_nominal_median_ms": 0.30, "process_lip_s": 2.4}}}
    rows = {c["row"]: c for c in compare_speed(now, base)}
    assert set(rows) == {"lip_cycle_nominal_median_ms", "process_lip_s"}
    assert rows["lip_cycle_nominal_median_ms"]["ratio"] == pytest.approx(1.1) and rows["lip_cycle_nominal_median_ms"]["regression"]
    assert rows["process_lip_s"]["ratio"] == pytest.approx(0.5) and not rows["process_lip_s"]["regression"]
    with pytest.raises(ParameterError, match="no speed table"):
        compare_speed(now, {"horizons": []})
