"""The output directory of a sweep: ``runs.csv`` rows, ``sweep.json``, and the replay of finished trials."""

from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import json
import logging
import signal
import threading
from collections.abc import Sequence
from pathlib import Path

from ...exceptions import ParameterError
from ...io import atomic_write_bytes, atomic_write_json
from ...runs.outputs import is_scratch
from .bisection import Bisection
from .config import COLUMNS, KINDS, OUTPUT_FILES, RUNS_CSV, SWEEP_FORMAT, SWEEP_JSON, UNITS, SweepConfig
from .trials import TaskKey, Trial, TrialResult

LOGGER = logging.getLogger("robust_ismpc")


@contextlib.contextmanager
def _sigint_deferred():
    """Hold SIGINT (Ctrl-C) back while a row is written, so no half row reaches the file."""
    can_block = hasattr(signal, "pthread_sigmask") and threading.current_thread() is threading.main_thread()
    if not can_block:
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _csv_line(values: Sequence) -> str:
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\n").writerow(values)
    return buffer.getvalue()


def trial_row(trial: Trial, result: TrialResult) -> dict:
    """The ``runs.csv`` row of a finished trial (floats in ``repr`` form: they read back exactly)."""
    fx, fy = trial.force_components()
    return {
        "controller": trial.key.controller,
        "modules": "+".join(trial.modules) or "-",
        "direction_deg": repr(trial.key.direction_deg),
        "phase": repr(trial.key.phase),
        "kind": trial.key.kind,
        "iteration": str(trial.iteration),
        "magnitude": repr(float(trial.magnitude)),
        "unit": UNITS[trial.key.kind],
        "fx_n": f"{fx:.6g}",
        "fy_n": f"{fy:.6g}",
        "t_push_s": f"{trial.t_push_s:.6g}",
        "push_duration_s": f"{trial.push_duration_s:.6g}" if trial.key.kind == "impulse" else "inf",
        "survived": "1" if result.survived else "0",
        "failure": "" if result.failure is None else result.failure.replace("\n", " ")[:200],
        "seed": str(trial.seed),
        "duration_s": f"{trial.duration_s:.6g}",
        "sim_time_s": f"{result.sim_time_s:.6g}",
        "wall_time_s": f"{result.wall_time_s:.4f}",
        "timing_adaptations": str(result.timing_adaptations),
    }


def read_runs(path: Path) -> list[dict]:
    """Complete rows of ``runs.csv`` (as dicts of strings); repairs a torn last line.

    A last line without its newline (a process killed mid-write) is cut off and the file
    rewritten atomically; so are rows with the wrong number of fields.

    Raises
    ------
    ParameterError
        If the header is not :data:`COLUMNS` (not a sweep file of this version).
    """
    path = Path(path)
    if not path.exists():
        return []
    data = path.read_bytes()
    if not data:
        return []
    complete = data if data.endswith(b"\n") else data[: data.rfind(b"\n") + 1]
    try:
        lines = complete.decode().splitlines(keepends=True)
    except UnicodeDecodeError as exc:
        line = complete[: exc.start].count(b"\n") + 1
        raise ParameterError(f"{path} line {line} is not text (the file is corrupted); delete that line (its "
                             "trial runs again) or pass --overwrite to start the sweep again") from None
    if not lines:
        atomic_write_bytes(path, b"")
        return []
    header = next(csv.reader([lines[0]]))
    if tuple(header) != COLUMNS:
        raise ParameterError(f"{path} does not have the columns of a sweep's runs.csv; pass --overwrite to start again")
    rows, kept = [], [lines[0]]
    for number, line in enumerate(lines[1:], start=2):
        values = next(csv.reader([line]), [])
        if len(values) != len(COLUMNS):
            LOGGER.warning("dropping a malformed row of %s: %r", path, line[:80])
            continue
        rows.append(_check_row(path, number, dict(zip(COLUMNS, values))))
        kept.append(line)
    if len(kept) != len(lines) or complete != data:
        LOGGER.warning("repaired %s: kept %d complete rows", path, len(rows))
        atomic_write_bytes(path, "".join(kept).encode())
    return rows


def _check_row(path: Path, number: int, row: dict) -> dict:
    """``row`` (line ``number`` of ``path``) if the values a resume reads parse; else ParameterError."""
    checks = {"direction_deg": float, "phase": float, "magnitude": float, "iteration": int,
              "kind": KINDS.index, "survived": ("0", "1").index}
    for column, parse in checks.items():
        try:
            parse(row[column])
        except ValueError:
            raise ParameterError(
                f"{path} line {number}: {column} {row[column]!r} is not valid (the file is corrupted); delete that "
                "line (its trial runs again) or pass --overwrite to start the sweep again"
            ) from None
    return row


class _RunsWriter:
    """Appends rows to ``runs.csv``, one flushed line at a time."""

    def __init__(self, path: Path):
        new = not path.exists() or path.stat().st_size == 0
        self._handle = open(path, "a", newline="", encoding="utf-8")
        if new:
            self._write(_csv_line(COLUMNS))

    def _write(self, line: str) -> None:
        with _sigint_deferred():
            self._handle.write(line)
            self._handle.flush()

    def append(self, row: dict) -> None:
        self._write(_csv_line([row[c] for c in COLUMNS]))

    def close(self) -> None:
        self._handle.close()


def _row_key(row: dict) -> tuple[TaskKey, int]:
    key = TaskKey(row["controller"], float(row["direction_deg"]), float(row["phase"]), row["kind"])
    return key, int(row["iteration"])


def _config_diff(old: dict, new: dict) -> list[str]:
    return sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k))


def code_digest() -> dict:
    """Package version and a digest of its Python sources: which code produced the trials."""
    from importlib import metadata

    root = Path(__file__).resolve().parents[2]  # the robust_ismpc package
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(str(path.relative_to(root)).encode())
        digest.update(path.read_bytes())
    try:
        version = metadata.version("robust-ismpc")
    except metadata.PackageNotFoundError:
        version = "unknown"
    return {"version": version, "sources_sha256": digest.hexdigest()[:16]}


def prepare_out(config: SweepConfig, out: Path, overwrite: bool) -> dict | None:
    """Check or create the output directory and its ``sweep.json``.

    An existing directory holding the same configuration (``sweep.json``) resumes; with
    ``overwrite`` the sweep's own files are removed first (other files are left alone).

    Returns
    -------
    dict or None
        When an earlier sweep is resumed, the code that started it (:func:`code_digest`);
        None for a new sweep.

    Raises
    ------
    ParameterError
        ``out`` is a file; or it is non-empty, and holds a different sweep or no sweep, and
        ``overwrite`` is false.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ParameterError(f"--out {str(out)!r} exists and is not a directory")
    wanted = json.loads(json.dumps(config.to_dict()))
    previous = None
    if out.exists() and any(not is_scratch(p.name) for p in out.iterdir()):
        if overwrite:
            for name in OUTPUT_FILES:
                (out / name).unlink(missing_ok=True)
        else:
            stored_path = out / SWEEP_JSON
            if not stored_path.exists():
                raise ParameterError(
                    f"--out {str(out)!r} is not empty and holds no sweep ({SWEEP_JSON}); "
                    "pass --overwrite to write into it or choose another directory"
                )
            try:
                stored_file: dict = json.loads(stored_path.read_text())
                stored = stored_file["config"]
            except (OSError, ValueError, KeyError, TypeError):
                stored_file, stored = {}, {}
            if isinstance(stored, dict) and "sensing" not in stored:  # stored before sensing was recorded
                stored = {**stored, "sensing": "ideal"}
            if isinstance(stored, dict) and "repeats" not in stored:  # stored before repeats: one trial each
                stored = {**stored, "repeats": 1}
            if stored != wanted:
                diff = _config_diff(stored, wanted) if isinstance(stored, dict) else ["all"]
                raise ParameterError(
                    f"--out {str(out)!r} holds a sweep with a different configuration (differs in: "
                    f"{', '.join(diff)}); pass --overwrite to replace it or choose another directory"
                )
            previous = stored_file.get("code") or {"version": "unknown", "sources_sha256": "unknown"}
    if previous is None:
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_json(out / SWEEP_JSON, {"format": SWEEP_FORMAT, "config": wanted, "code": code_digest()})
    return previous


def _replay(config: SweepConfig, rows: list[dict]) -> tuple[dict[TaskKey, Bisection], int]:
    """Bisections of every task with their finished trials replayed from ``rows``."""
    finished: dict[tuple[TaskKey, int], dict] = {}
    for row in rows:
        try:
            rk = _row_key(row)
        except (ValueError, KeyError):
            LOGGER.warning("ignoring an unreadable row of %s", RUNS_CSV)
            continue
        finished.setdefault(rk, row)
    bisections: dict[TaskKey, Bisection] = {}
    replayed = 0
    for key in config.tasks():
        b = Bisection(config.max_magnitude(key.kind), config.iterations, config.repeats)
        while (m := b.next_magnitude()) is not None:
            done_row = finished.get((key, len(b.trials)))
            if done_row is None:
                break
            row = done_row
            if float(row["magnitude"]) != m:
                raise ParameterError(
                    f"{RUNS_CSV} does not follow this sweep's bisection ({key.controller}, {key.direction_deg:g}°, "
                    f"phase {key.phase:g}, {key.kind}, trial {len(b.trials)}: {row['magnitude']} instead of {m!r}); "
                    "pass --overwrite to start again"
                )
            b.record(m, row["survived"] == "1")
            replayed += 1
        bisections[key] = b
    return bisections, replayed
