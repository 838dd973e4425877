r"""Push-recovery sweep: the largest push each controller survives, per direction and gait phase.

For every controller (a set of robustness modules), push direction and gait phase, a bisection
finds the largest impulse [N s] the robot survives (a constant force over ``push_duration_s``
starting at that phase of the single support of one chosen step), and optionally the largest
constant force [N] switched on at the same instant and kept until the end. A trial fails when
the run fails (``summary["fell"]``: a fall, a diverged CoM or a persistent infeasible QP).

Organisation
------------
* A *task* is one bisection, keyed by (controller, direction, phase, kind). Its trial sequence
  is deterministic: trial 0 tries the maximum; if the robot survives the task is *saturated*,
  otherwise ``iterations`` bisection trials halve the bracket :math:`[lo, hi]`, starting from
  :math:`[0, max]`. The frontier is ``lo``, the largest survived magnitude (resolution
  :math:`max / 2^{iterations}`).
* Each finished trial is one row of ``runs.csv``, appended and flushed as it finishes. On a
  rerun with the same configuration (``sweep.json``), every task replays its finished trials from
  the CSV and only runs the missing ones, so an interrupted sweep resumes where it stopped.
* Trials of different tasks run in parallel on local processes
  (:class:`concurrent.futures.ProcessPoolExecutor`) or on Ray; a trial's seed is derived from the
  base seed and the trial key, so every run replays alone.

Bisection assumes that survival is monotonic in the magnitude; where it is not (a larger push may
trigger a step-timing adaptation that a smaller one does not), the frontier is the bisection's
answer, not the exact supremum: ``runs.csv`` keeps every trial for inspection.

Modules
-------
* :mod:`.config`: parsing of the user's lists, :class:`SweepConfig`, output file names and columns.
* :mod:`.trials`: :class:`TaskKey`, :func:`trial_seed`, :class:`Trial`, :class:`TrialResult`, :func:`run_trial`.
* :mod:`.bisection`: :class:`Bisection`, :func:`bisect`.
* :mod:`.storage`: ``runs.csv`` rows, ``sweep.json`` and the replay of finished trials (resume).
* :mod:`.backends`: serial, local process-pool and Ray executors of trials (:func:`make_backend`).
* :mod:`.report`: :class:`SweepResult`, ``frontier.json`` (:func:`frontier_summary`), tables, plots and
  ``report.md``.
* :mod:`.run`: :func:`run_sweep`, :class:`SweepProgress`.
"""

from ...control.modules import controller_modules, parse_controllers
from .backends import make_backend
from .bisection import Bisection, bisect
from .config import COLUMNS, DEFAULT_POST_PUSH_S, SweepConfig, parse_directions, parse_phases
from .report import SweepResult, format_report, frontier_summary, frontier_table, plot_frontiers
from .run import SweepProgress, run_sweep
from .storage import read_runs
from .trials import TaskKey, Trial, TrialResult, run_trial, trial_seed

__all__ = [
    "Bisection", "COLUMNS", "DEFAULT_POST_PUSH_S", "SweepConfig", "SweepProgress", "SweepResult", "TaskKey", "Trial",
    "TrialResult", "bisect", "controller_modules", "format_report", "frontier_summary", "frontier_table",
    "make_backend", "parse_controllers", "parse_directions", "parse_phases", "plot_frontiers", "read_runs",
    "run_sweep", "run_trial", "trial_seed",
]
