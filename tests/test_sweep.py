"""Push-recovery sweep: input parsing, bisection, outputs, resume after interruption, determinism."""

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from robust_ismpc.cli import main
from robust_ismpc.exceptions import ParameterError
from robust_ismpc.experiments.sweep import (
    COLUMNS,
    Bisection,
    SweepConfig,
    TaskKey,
    bisect,
    controller_modules,
    parse_controllers,
    parse_directions,
    parse_phases,
    read_runs,
    run_sweep,
    trial_seed,
)
from robust_ismpc.experiments.sweep import backends as sweep_backends


def tiny_config(**changes) -> SweepConfig:
    """A sweep of a few short LIP runs: pushed step 1, 1 s after the push, 3 bisection steps."""
    values = dict(robot="g1", controllers=("nominal",), directions_deg=(90.0,), phases=(0.5,),
                  impulse_max_ns=16.0, iterations=3, pushed_step=1, post_push_s=1.0, seed=3)
    values.update(changes)
    return SweepConfig(**values)


def csv_rows(path):
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def exit_code(argv) -> int:
    """Exit status of ``ismpc ARGV`` (argparse errors exit through SystemExit)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


def entries_by_key(frontier: dict) -> dict:
    return {(e["controller"], e["direction_deg"], e["phase"], e["kind"]): (e["max_survived"], e["trials"])
            for e in frontier["entries"]}


# ----------------------------------------------------------------------------------------------
def test_phase_spec_parsing():
    """START:STOP:STEPS gives STEPS evenly spaced phases in [START, STOP); lists are taken as given."""
    assert parse_phases("0:1:4") == (0.0, 0.25, 0.5, 0.75)
    assert parse_phases("0:1:1") == (0.0,)
    assert parse_phases("0.2:0.6:2") == (0.2, 0.4)
    assert parse_phases("0.5") == (0.5,)
    assert parse_phases("0, 0.3,0.9") == (0.0, 0.3, 0.9)
    assert parse_directions("0:360:8") == (0, 45, 90, 135, 180, 225, 270, 315)
    assert parse_directions("0,90,-90") == (0.0, 90.0, -90.0)


def test_controller_names_map_to_module_sets():
    """nominal = none, robust = all three, a module name = that module, a+b = both."""
    assert controller_modules("nominal") == ()
    assert controller_modules("robust") == ("observer", "restriction", "timing")
    assert controller_modules("timing") == ("timing",)
    assert controller_modules("timing+observer") == ("observer", "timing")
    assert parse_controllers("nominal, observer,restriction,timing,robust") == (
        "nominal", "observer", "restriction", "timing", "robust")


BAD_LISTS = [
    (parse_phases, "0:1", "START:STOP:STEPS"),
    (parse_phases, "0:1:0", "STEPS must be an integer >= 1"),
    (parse_phases, "0:1:x", "STEPS must be an integer"),
    (parse_phases, "a:1:2", "START and STOP must be numbers"),
    (parse_phases, "0.5:0.2:3", "STOP must be greater than START"),
    (parse_phases, "0:1.5:3", "in [0, 1)"),
    (parse_phases, "1", "in [0, 1)"),
    (parse_phases, "-0.1", "in [0, 1)"),
    (parse_phases, "0.5,0.5", "distinct"),
    (parse_phases, "", "expected a comma-separated list"),
    (parse_directions, "north", "'north' is not a number"),
    (parse_directions, "0,nan", "must be finite"),
    (parse_directions, "0,360", "repeats another direction"),
    (parse_controllers, "nominal,fancy", "unknown controller 'fancy'"),
    (parse_controllers, "observer+observer", "unknown controller"),
    (parse_controllers, "robust,observer+restriction+timing", "repeats 'robust'"),
    (parse_controllers, " , ", "at least one"),
]


@pytest.mark.parametrize("parse,text,message", BAD_LISTS)
def test_bad_lists_raise_one_line_parameter_errors(parse, text, message):
    """Malformed controller, direction and phase lists raise ParameterError naming the problem."""
    with pytest.raises(ParameterError) as exc:
        parse(text)
    assert message in str(exc.value)
    assert "\n" not in str(exc.value)


BAD_CONFIGS = [
    (dict(impulse_max_ns=0.0), "impulse_max_ns must be a finite number > 0"),
    (dict(impulse_max_ns=-5.0), "impulse_max_ns must be a finite number > 0"),
    (dict(impulse_max_ns=math.inf), "impulse_max_ns must be a finite number > 0"),
    (dict(force_max_n=0.0), "force_max_n must be a finite number > 0"),
    (dict(push_duration_s=0.0), "push_duration_s must be a finite number > 0"),
    (dict(post_push_s=-1.0), "post_push_s must be a finite number > 0"),
    (dict(iterations=0), "iterations must be an integer in [1, 30]"),
    (dict(pushed_step=0), "pushed_step must be an integer >= 1"),
    (dict(seed=-1), "seed must be an integer >= 0"),
    (dict(robot="nope"), "unknown robot 'nope'"),
    (dict(sim="gazebo"), "unknown simulator 'gazebo'"),
    (dict(controllers=("nominal", "magic")), "unknown controller 'magic'"),
    (dict(phases=(1.0,)), "in [0, 1)"),
    (dict(phases=()), "at least one phase"),
    (dict(whole_body="torque"), "needs the mujoco simulator"),
    (dict(whole_body="stiff"), "whole_body must be one of servo, torque"),
]


@pytest.mark.parametrize("changes,message", BAD_CONFIGS)
def test_bad_config_raises_parameter_error(changes, message):
    """Each invalid SweepConfig field raises a one-line ParameterError."""
    with pytest.raises(ParameterError) as exc:
        tiny_config(**changes)
    assert message in str(exc.value)
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize("extra,message", [
    (["--impulse-max", "0"], "--impulse-max must be a finite number > 0"),
    (["--impulse-max", "abc"], "impulse-max must be a number"),
    (["--impulse-max", "5", "--force-max", "-1"], "--force-max must be a finite number > 0"),
    (["--impulse-max", "5", "--controllers", "nominal,fancy"], "unknown controller 'fancy'"),
    (["--impulse-max", "5", "--direction", "0,east"], "'east' is not a number"),
    (["--impulse-max", "5", "--phase", "0:1"], "START:STOP:STEPS"),
    (["--impulse-max", "5", "--backend", "slurm"], "unknown backend 'slurm'"),
    (["--impulse-max", "5", "--workers", "0"], "workers must be an integer >= 1"),
])
def test_cli_bad_sweep_input_exits_2(tmp_path, capsys, extra, message):
    """`ismpc sweep` with a bad value exits 2 with one stderr line and writes nothing."""
    out = tmp_path / "s"
    assert exit_code(["sweep", "--out", str(out), "--quiet", *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert message in err
    assert not (out / "runs.csv").exists()


# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("threshold", [0.0, 0.3, 1.7, 3.14159, 7.99, 8.0, 9.5, 15.9, 16.0, 40.0])
def test_bisection_brackets_a_monotone_threshold(threshold):
    """With survival iff magnitude <= threshold, the frontier is within one resolution below it."""
    b = bisect(lambda m: m <= threshold, 16.0, 6)
    resolution = 16.0 / 2**6
    if threshold >= 16.0:
        assert b.saturated and b.frontier == 16.0 and len(b.trials) == 1
    else:
        assert not b.saturated and len(b.trials) == 7
        assert b.frontier <= threshold < b.frontier + resolution + 1e-12
        assert b.hi - b.lo == pytest.approx(resolution)
    assert all(survived == (m <= threshold) for m, survived in b.trials)


def test_bisection_frontier_is_monotone_in_the_threshold():
    """A higher survival threshold never gives a lower frontier."""
    thresholds = [0.05 * k for k in range(0, 420)]
    frontiers = [bisect(lambda m, t=t: m <= t, 20.0, 8).frontier for t in thresholds]
    assert all(a <= b for a, b in zip(frontiers, frontiers[1:]))
    assert frontiers[0] == 0.0 and frontiers[-1] == 20.0


def test_bisection_refuses_an_unexpected_magnitude():
    """Recording a trial the bisection did not ask for is an error (it protects resume)."""
    b = Bisection(10.0, 3)
    with pytest.raises(ParameterError):
        b.record(5.0, True)
    b.record(10.0, False)
    assert b.next_magnitude() == 5.0


def test_trial_seed_depends_on_the_cell_magnitude_and_repeat_only():
    """Trial seeds are reproducible, differ between trials, repeats and base seeds, and are the
    same for every controller (each meets the same noise at the same push)."""
    key = TaskKey("robust", 90.0, 0.25, "impulse")
    assert trial_seed(0, key, 5.0) == trial_seed(0, key, 5.0)
    assert trial_seed(0, key, 5.0) != trial_seed(1, key, 5.0)
    assert trial_seed(0, key, 5.0) != trial_seed(0, key, 2.5)
    assert trial_seed(0, key, 5.0, 0) != trial_seed(0, key, 5.0, 1)
    assert trial_seed(0, key, 5.0) == trial_seed(0, TaskKey("nominal", 90.0, 0.25, "impulse"), 5.0)
    assert trial_seed(0, key, 5.0) != trial_seed(0, TaskKey("robust", 90.0, 0.5, "impulse"), 5.0)
    assert 0 <= trial_seed(7, key, 1.0) < 2**31


def test_with_repeats_a_magnitude_is_held_by_a_majority_and_decided_early():
    """Three trials per magnitude: two alike decide it (the third is not run), a split is decided
    by the third; the bisection moves on the majority, not on single outcomes."""
    outcomes = {16.0: [False, False], 8.0: [True, False, True], 12.0: [False, True, False], 10.0: [True, True]}
    b = Bisection(16.0, 3, repeats=3)
    assert b.remaining_max == 12
    while (m := b.next_magnitude()) is not None:
        b.record(m, outcomes[m].pop(0))
    assert all(not left for left in outcomes.values())
    assert [m for m, _ in b.trials] == [16.0, 16.0, 8.0, 8.0, 8.0, 12.0, 12.0, 12.0, 10.0, 10.0]
    assert [(m, held) for m, held, _, _ in b.steps] == [(16.0, False), (8.0, True), (12.0, False), (10.0, True)]
    assert [(s, n) for _, _, s, n in b.steps] == [(0, 2), (2, 3), (1, 3), (2, 2)]
    assert b.frontier == 10.0 and b.hi == 12.0 and b.remaining_max == 0


def test_with_repeats_the_frontier_of_a_noisy_threshold_is_the_majority_one():
    """Survival with probability 0.8 below 6 and 0.2 above: one trial per magnitude wanders, the
    majority of five misses the threshold by less than 0.6 of its mean error."""
    rng = np.random.default_rng(0)

    def survives(m: float) -> bool:
        return bool(rng.random() < (0.8 if m <= 6.0 else 0.2))

    def error(repeats: int) -> float:
        return float(np.mean([abs(bisect(survives, 16.0, 5, repeats).frontier - 6.0) for _ in range(200)]))

    assert error(5) < 0.6 * error(1)


@pytest.mark.parametrize("repeats", [0, 2, -1, 1.0, True])
def test_repeats_must_be_an_odd_count(repeats):
    with pytest.raises(ParameterError, match="odd integer"):
        Bisection(10.0, 3, repeats=repeats)


def test_a_sweep_repeats_magnitudes_under_noisy_sensing_only():
    assert tiny_config().repeats == 1
    assert SweepConfig(sensing="realistic").repeats == 3
    assert SweepConfig(sensing="realistic", repeats=1).repeats == 1
    assert SweepConfig(sensing="realistic").max_trials == 3 * SweepConfig().max_trials
    with pytest.raises(ParameterError, match="must be 1 under ideal sensing"):
        SweepConfig(repeats=3)


# ----------------------------------------------------------------------------------------------
def test_tiny_sweep_writes_sane_outputs(tmp_path):
    """One controller, direction and phase, 3 bisection steps: CSV, frontier, plots and report agree."""
    config = tiny_config()
    result = run_sweep(config, tmp_path, workers=1, command_line="ismpc sweep --test")
    rows = csv_rows(tmp_path / "runs.csv")
    assert tuple(rows[0].keys()) == COLUMNS
    assert 1 <= len(rows) <= 4 and result.trials_total == len(rows) == result.trials_new
    assert [int(r["iteration"]) for r in rows] == list(range(len(rows)))
    assert float(rows[0]["magnitude"]) == 16.0
    for r in rows:
        assert r["controller"] == "nominal" and r["kind"] == "impulse" and r["unit"] == "N s"
        assert 0 <= float(r["magnitude"]) <= 16.0 and r["survived"] in ("0", "1")
        assert (r["failure"] == "") == (r["survived"] == "1")
        assert float(r["fy_n"]) == pytest.approx(float(r["magnitude"]) / 0.1) and float(r["fx_n"]) == 0.0
        assert int(r["seed"]) == trial_seed(3, TaskKey("nominal", 90.0, 0.5, "impulse"), float(r["magnitude"]), 0)
        assert float(r["sim_time_s"]) <= float(r["duration_s"]) + 1e-9
    start, T_ss = config.pushed_step_window()
    assert float(rows[0]["t_push_s"]) == pytest.approx(start + 0.5 * T_ss)
    frontier = json.loads((tmp_path / "frontier.json").read_text())
    (entry,) = frontier["entries"]
    survived = [float(r["magnitude"]) for r in rows if r["survived"] == "1"]
    assert entry["max_survived"] == (max(survived) if survived else 0.0)
    assert entry["complete"] and frontier["complete"] and frontier["resolution"]["impulse"] == 2.0
    assert frontier["frontier"]["impulse"]["nominal"]["90"]["min"] == entry["max_survived"]
    assert result.frontier == frontier
    for name in ("frontier_polar.png", "frontier_phase.png"):
        data = (tmp_path / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5_000
    report = (tmp_path / "report.md").read_text()
    for text in ("ismpc sweep --test", "Machine:", "Versions:", "sources sha256", "runs/s", "base seed 3", "| 90 |"):
        assert text in report
    assert json.loads((tmp_path / "sweep.json").read_text())["config"] == json.loads(json.dumps(config.to_dict()))


def test_a_noisy_sweep_runs_each_magnitude_until_a_majority_and_resumes(tmp_path):
    """Under realistic sensing every magnitude gets 2 or 3 trials, each with its repeat's seed,
    until two agree; frontier.json records the tallies, and a rerun resumes with nothing to do."""
    config = tiny_config(sensing="realistic", iterations=2)
    run_sweep(config, tmp_path, workers=1)
    rows = csv_rows(tmp_path / "runs.csv")
    key = TaskKey("nominal", 90.0, 0.5, "impulse")
    groups: list[list[dict]] = []
    for r in rows:
        if groups and groups[-1][0]["magnitude"] == r["magnitude"] and len(groups[-1]) < 3 and not (
                len(groups[-1]) == 2 and groups[-1][0]["survived"] == groups[-1][1]["survived"]):
            groups[-1].append(r)
        else:
            groups.append([r])
    assert len(groups) == 3
    steps = json.loads((tmp_path / "frontier.json").read_text())["entries"][0]["magnitudes"]
    for group, (magnitude, held, survived, run) in zip(groups, steps):
        assert len(group) == run in (2, 3) and float(group[0]["magnitude"]) == magnitude
        outcomes = [r["survived"] == "1" for r in group]
        assert sum(outcomes) == survived and held == (survived >= 2)
        for repeat, r in enumerate(group):
            assert int(r["seed"]) == trial_seed(3, key, magnitude, repeat)
    again = run_sweep(config, tmp_path, workers=1)
    assert again.trials_new == 0 and again.trials_resumed == len(rows)



def test_force_bisection_and_ratios(tmp_path):
    """With --force-max a second bisection per cell is run; ratios to nominal are reported."""
    config = tiny_config(controllers=("nominal", "timing"), iterations=1, force_max_n=200.0)
    result = run_sweep(config, tmp_path, workers=1)
    kinds = {e["kind"] for e in result.frontier["entries"]}
    assert kinds == {"impulse", "force"}
    rows = csv_rows(tmp_path / "runs.csv")
    force_rows = [r for r in rows if r["kind"] == "force"]
    assert force_rows and all(r["push_duration_s"] == "inf" and r["unit"] == "N" for r in force_rows)
    assert set(result.frontier["ratios"]) == {"impulse", "force"}
    assert "timing/nominal" in result.frontier["ratios"]["impulse"]
    assert (tmp_path / "frontier_force_polar.png").exists() and (tmp_path / "frontier_force_phase.png").exists()


def test_resume_after_interruption_gives_the_same_frontier(tmp_path):
    """Truncating runs.csv (half its rows and a torn line) and rerunning completes the same sweep
    without duplicate rows, running only the missing trials."""
    config = tiny_config(phases=(0.0, 0.5))
    first = run_sweep(config, tmp_path / "a", workers=1)
    path = tmp_path / "a" / "runs.csv"
    lines = path.read_text().splitlines(keepends=True)
    n = len(lines) - 1
    half = n // 2
    path.write_text("".join(lines[: 1 + half]) + lines[1 + half][:15])  # a torn last row
    assert len(read_runs(path)) == half and path.read_text().endswith("\n")  # repaired
    second = run_sweep(config, tmp_path / "a", workers=1)
    assert second.trials_resumed == half and second.trials_new == n - half
    assert entries_by_key(second.frontier) == entries_by_key(first.frontier)
    rows = csv_rows(path)
    keys = [(r["controller"], r["direction_deg"], r["phase"], r["kind"], r["iteration"]) for r in rows]
    assert len(keys) == len(set(keys)) == n
    third = run_sweep(config, tmp_path / "a", workers=1)  # complete: nothing to run
    assert third.trials_new == 0 and entries_by_key(third.frontier) == entries_by_key(first.frontier)


def test_interrupt_keeps_complete_rows_and_exits_130(tmp_path, capsys, monkeypatch):
    """Ctrl-C during a sweep leaves only complete rows, exits 130, and the same command resumes."""
    out = tmp_path / "s"
    args = ["sweep", "--robot", "g1", "--controllers", "nominal", "--direction", "90", "--phase", "0.5",
            "--impulse-max", "16", "--iterations", "3", "--pushed-step", "1", "--duration", "1", "--seed", "3",
            "--workers", "1", "--out", str(out), "--quiet"]
    real = sweep_backends.run_trial
    calls = []

    def interrupted(trial):
        calls.append(trial)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(trial)

    monkeypatch.setattr(sweep_backends, "run_trial", interrupted)
    assert main(args) == 130
    assert "rerun the same command to resume" in capsys.readouterr().err
    assert len(read_runs(out / "runs.csv")) == 2
    monkeypatch.setattr(sweep_backends, "run_trial", real)
    assert main(args) == 0
    rows = read_runs(out / "runs.csv")
    reference = run_sweep(tiny_config(), tmp_path / "ref", workers=1)
    assert len(rows) == reference.trials_total
    assert json.loads((out / "frontier.json").read_text())["entries"] == reference.frontier["entries"]


def test_same_seed_same_frontier_and_processes_agree(tmp_path):
    """The same configuration gives the same frontier and trial rows, in-process or on 2 processes."""
    config = tiny_config(controllers=("nominal", "timing"))
    a = run_sweep(config, tmp_path / "a", workers=1)
    b = run_sweep(config, tmp_path / "b", workers=2)
    assert entries_by_key(a.frontier) == entries_by_key(b.frontier)
    strip = ("wall_time_s",)

    def rows(path):
        return sorted(tuple(v for k, v in r.items() if k not in strip) for r in csv_rows(path / "runs.csv"))

    assert rows(tmp_path / "a") == rows(tmp_path / "b")


def test_different_configuration_is_refused_without_overwrite(tmp_path, capsys):
    """An --out holding another sweep is refused (exit 2); --overwrite replaces it; same config resumes."""
    out = tmp_path / "s"
    base = ["sweep", "--controllers", "nominal", "--direction", "90", "--phase", "0.5", "--iterations", "1",
            "--pushed-step", "1", "--duration", "1", "--workers", "1", "--out", str(out), "--quiet"]
    assert main([*base, "--impulse-max", "8"]) == 0
    capsys.readouterr()
    assert main([*base, "--impulse-max", "9"]) == 2
    err = capsys.readouterr().err
    assert "different configuration (differs in: impulse_max_ns)" in err and len(err.strip().splitlines()) == 1
    assert main([*base, "--impulse-max", "8"]) == 0
    assert "0 run now" in capsys.readouterr().out
    assert main([*base, "--impulse-max", "9", "--overwrite"]) == 0
    assert json.loads((out / "sweep.json").read_text())["config"]["impulse_max_ns"] == 9.0
    rows = read_runs(out / "runs.csv")
    assert float(rows[0]["magnitude"]) == 9.0
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    assert main([*base[:-3], "--out", str(other), "--quiet", "--impulse-max", "8"]) == 2
    assert "holds no sweep" in capsys.readouterr().err


def test_ray_backend_matches_local(tmp_path):
    """The Ray backend (local instance) runs the same trials to the same frontier."""
    pytest.importorskip("ray")
    config = tiny_config(iterations=2)
    local = run_sweep(config, tmp_path / "local", workers=1)
    on_ray = run_sweep(config, tmp_path / "ray", workers=1, backend="ray")
    assert entries_by_key(on_ray.frontier) == entries_by_key(local.frontier)


def test_sigint_stops_worker_processes_and_exits_130(tmp_path):
    """SIGINT to `ismpc sweep` on 2 processes: exit 130 within seconds, only complete rows, no workers left."""
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "s"
    # large enough (288 trials) that it cannot finish before the signal on a fast machine
    cmd = [sys.executable, "-m", "robust_ismpc.cli", "sweep", "--controllers", "nominal,timing", "--direction",
           "0:360:8", "--phase", "0:1:2", "--impulse-max", "16", "--iterations", "8", "--workers", "2",
           "--out", str(out), "--quiet"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if (out / "runs.csv").exists() and len((out / "runs.csv").read_text().splitlines()) >= 3:
            break
        time.sleep(0.05)
    assert proc.poll() is None, "the sweep finished before it could be interrupted"
    proc.send_signal(signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise
    assert proc.returncode == 130, err
    assert "rerun the same command to resume" in err
    text = (out / "runs.csv").read_text()
    assert text.endswith("\n")
    rows = read_runs(out / "runs.csv")
    assert 2 <= len(rows) < 2 * 2 * 2 * 7
    assert all(len(r) == len(COLUMNS) for r in rows)
    time.sleep(0.5)
    left = []
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        try:
            if str(out).encode() in cmdline.read_bytes():
                left.append(cmdline.parent.name)
        except OSError:
            pass
    assert not left, f"worker processes still running: {left}"


def test_mujoco_sweeps_watch_longer_after_the_push(tmp_path):
    """`ismpc sweep --sim mujoco` runs each trial 6 s past the push (the full G1 can fall 4.5 s after
    a small push); the LIP keeps 3 s; --duration overrides both."""
    pytest.importorskip("mujoco")
    from robust_ismpc.cli import main

    common = ["sweep", "--controllers", "nominal", "--direction", "0", "--phase", "0", "--impulse-max", "1",
              "--iterations", "1", "--workers", "1", "--quiet"]
    for sim, extra, expected in (("mujoco", [], 6.0), ("lip", [], 3.0), ("lip", ["--duration", "2"], 2.0)):
        out = tmp_path / f"{sim}{len(extra)}"
        assert main([*common, "--sim", sim, *extra, "--out", str(out)]) == 0
        config = json.loads((out / "sweep.json").read_text())["config"]
        assert config["post_push_s"] == expected
