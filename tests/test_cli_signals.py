"""Ctrl-C, SIGTERM, SIGKILL and a second process on the same --out: what finished is written,
nothing half-written remains, nothing blocks a rerun, no worker outlives its sweep (issue 17,
cases 1-4)."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from robust_ismpc.cli import main
from robust_ismpc.experiments.sweep import COLUMNS, read_runs

ENV = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}


def _start(*args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "robust_ismpc.cli", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=ENV)


def _wait_for(proc: subprocess.Popen, text: str) -> None:
    """Read the progress on stderr until a line contains ``text`` (the run is simulating)."""
    seen = []
    for line in proc.stderr:
        seen.append(line)
        if text in line:
            return
    raise AssertionError(f"no {text!r} in stderr (exit {proc.wait()}): {''.join(seen)}")


def _finish(proc: subprocess.Popen, sig: int = signal.SIGINT) -> tuple[int, str]:
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    return proc.returncode, err


def _hidden(out: Path) -> list[str]:
    return sorted(p.name for p in out.iterdir() if p.name.startswith("."))


RUNS = [
    pytest.param(["--duration", "60"], "t =    6.0", id="lip"),
    pytest.param(["--sim", "mujoco", "--whole-body", "torque", "--duration", "20"], "t =    0.0", id="mujoco-torque"),
    pytest.param(["--sim", "mujoco", "--video", "--duration", "20"], "t =    0.0", id="mujoco-video"),
]


@pytest.mark.parametrize("extra,progress", RUNS)
def test_ctrl_c_during_run_writes_the_finished_part(tmp_path, extra, progress):
    """Case 1: Ctrl-C while `ismpc run` simulates exits 130 and leaves summary.json (failure
    "interrupted"), trace.npz, gait.png (and a complete video.mp4), no temporary file, no lock."""
    if "mujoco" in extra:
        pytest.importorskip("mujoco")
    out = tmp_path / "run"
    proc = _start("run", *extra, "--out", str(out))
    _wait_for(proc, progress)
    code, err = _finish(proc)
    assert code == 130, err
    assert "interrupted" in err.strip().splitlines()[-1]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["failure"] == "interrupted" and summary["fell"] is False
    duration = float(extra[extra.index("--duration") + 1])
    assert 0 < summary["duration_s"] < duration
    assert (out / "trace.npz").stat().st_size > 0 and (out / "gait.png").stat().st_size > 10_000
    if "--video" in extra:
        assert (out / "video.mp4").stat().st_size > 1000 and summary["video_frames"] > 0
    assert _hidden(out) == []


def test_ctrl_c_during_compare_writes_the_finished_run(tmp_path):
    """Case 1: Ctrl-C during the nominal run of `ismpc compare` writes it (interrupted), starts no
    robust run and writes no comparison."""
    out = tmp_path / "cmp"
    proc = _start("compare", "--duration", "60", "--out", str(out))
    _wait_for(proc, "nominal: t =    6.0")
    code, err = _finish(proc)
    assert code == 130, err
    assert json.loads((out / "nominal" / "summary.json").read_text())["failure"] == "interrupted"
    assert (out / "nominal" / "gait.png").exists() and (out / "nominal" / "trace.npz").exists()
    assert not (out / "robust").exists() and not (out / "comparison.json").exists()
    assert _hidden(out) == []


def test_ctrl_c_during_soak_writes_soak_json(tmp_path):
    """Case 1: Ctrl-C during `ismpc soak` writes soak.json (failure "interrupted") and the run."""
    out = tmp_path / "soak"
    proc = _start("soak", "--minutes", "1", "--out", str(out))
    _wait_for(proc, "soak: t =    6.0")
    code, err = _finish(proc)
    assert code == 130, err
    report = json.loads((out / "soak.json").read_text())
    assert report["failure"] == "interrupted" and not report["fell"] and report["simulated_s"] < 60
    assert (out / "summary.json").exists() and (out / "gait.png").exists()


SWEEP = ["sweep", "--controllers", "nominal", "--direction", "0:360:4", "--phase", "0:1:2", "--impulse-max", "8",
         "--iterations", "4", "--workers", "2"]


def _children(pid: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                found.append(int(entry.name))
    return found


def _gone(pids: list[int], timeout_s: float = 20.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        alive = []
        for p in pids:
            try:
                state = (Path("/proc") / str(p) / "stat").read_text().rsplit(")", 1)[1].split()[0]
            except OSError:
                continue
            if state != "Z":
                alive.append(p)
        if not alive:
            return True
        time.sleep(0.2)
    return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGKILL], ids=["int", "term", "kill"])
def test_signal_to_a_sweep_leaves_no_workers_and_resumable_rows(tmp_path, sig):
    """Cases 1 and 3: SIGINT and SIGTERM stop a sweep (exit 130) and SIGKILL kills it; in every
    case its worker processes end too, and runs.csv holds only complete rows."""
    out = tmp_path / "sweep"
    proc = _start(*SWEEP, "--out", str(out))
    _wait_for(proc, "sweep: ")
    workers = _children(proc.pid)
    assert workers
    code, err = _finish(proc, sig)
    assert code == (-signal.SIGKILL if sig == signal.SIGKILL else 130), err
    assert _gone(workers), f"workers still running: {workers}"
    rows = read_runs(out / "runs.csv")
    assert rows and all(len(row) == len(COLUMNS) for row in rows)


def test_second_run_into_the_same_out_is_refused(tmp_path, capsys):
    """Case 2: while one `ismpc run` writes into --out, a second one (even with --overwrite) exits
    2 with one line; the first one still finishes its outputs."""
    out = tmp_path / "run"
    proc = _start("run", "--duration", "60", "--out", str(out))
    _wait_for(proc, "t =    6.0")
    try:
        assert main(["run", "--duration", "1", "--out", str(out), "--overwrite", "--quiet"]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "in use by another ismpc process" in err and "--out" in err
    finally:
        code, _ = _finish(proc)
    assert code == 130
    assert json.loads((out / "summary.json").read_text())["duration_s"] > 6


def test_second_sweep_into_the_same_out_is_refused_and_rows_are_unique(tmp_path, capsys):
    """Case 2: a second identical sweep into a folder a sweep is writing exits 2; the rows of
    runs.csv stay unique."""
    out = tmp_path / "sweep"
    proc = _start(*SWEEP, "--out", str(out))
    _wait_for(proc, "sweep: ")
    try:
        assert main([*SWEEP, "--out", str(out), "--quiet"]) == 2
        assert "in use by another ismpc process" in capsys.readouterr().err
    finally:
        code, _ = _finish(proc)
    assert code == 130
    keys = [tuple(r[c] for c in ("controller", "direction_deg", "phase", "kind", "iteration"))
            for r in read_runs(out / "runs.csv")]
    assert keys and len(keys) == len(set(keys))


def test_sigkill_during_a_video_run_does_not_block_the_rerun(tmp_path):
    """Case 4: a run killed while writing its video leaves only hidden files (the lock, the
    partial video); a rerun into the same --out without --overwrite succeeds and removes them."""
    pytest.importorskip("mujoco")
    out = tmp_path / "run"
    proc = _start("run", "--sim", "mujoco", "--video", "--duration", "20", "--out", str(out))
    _wait_for(proc, "t =    0.0")
    proc.kill()
    proc.communicate(timeout=60)
    assert not [p for p in out.iterdir() if not p.name.startswith(".")]
    assert any(".tmp" in name for name in _hidden(out))
    assert main(["run", "--duration", "1", "--out", str(out), "--quiet"]) == 0
    assert _hidden(out) == [] and (out / "summary.json").exists()


def test_leftover_temporary_files_do_not_block_a_rerun(tmp_path):
    """Case 4: temporary files of an atomic write killed half-way (`.summary.json.XXXX.tmp`) and
    a stale lock count as empty and are removed by the next run."""
    out = tmp_path / "run"
    out.mkdir()
    (out / ".summary.json.abc123.tmp").write_text("{")
    (out / ".lock").write_text("12345\n")
    assert main(["run", "--duration", "1", "--out", str(out), "--quiet"]) == 0
    assert _hidden(out) == []
    assert json.loads((out / "summary.json").read_text())["failure"] is None
