"""Checks of command-line input that need more than one flag or some knowledge of the robot.

Every check raises :class:`~robust_ismpc.exceptions.ParameterError` with one line naming the flag
(``--vx``, ``--push``, ...) and what to do, or returns the warnings the command prints and records.
The CLI calls them before anything is simulated. Nothing here prints.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..core.planner import command_limits
from ..exceptions import ParameterError

#: Longest simulated time of one run [s]. A run keeps its trace in memory (about 0.5 kB per
#: 10 ms tick, 180 MB per hour) and the footstep plan covers the whole walk; an hour is plenty
#: for a soak (``ismpc soak --minutes`` at most 60).
MAX_SIM_DURATION_S = 3600.0

#: The command-line flag of each field of :class:`~robust_ismpc.core.planner.WalkCommand`.
COMMAND_FIELDS = {"--vx": "vx_mps", "--vy": "vy_mps", "--omega": "omega_radps"}


def limit_command(robot: str, params, requested: dict[str, float]) -> tuple[dict[str, float], list[str]]:
    """Clip the velocity command to what the robot's steps allow.

    Parameters
    ----------
    robot : str
        Robot name, for the messages.
    params : RobotParams
        Its gait parameters (:func:`gait_params`).
    requested : dict
        Flag (``--vx``, ``--vy``, ``--omega``) -> requested value.

    Returns
    -------
    applied : dict
        Flag -> the value walked.
    warnings : list of str
        One line per clipped flag, naming it and the value applied.
    """
    limits = command_limits(params)
    applied, warnings = {}, []
    for flag, value in requested.items():
        limit, why = limits[COMMAND_FIELDS[flag]]
        unit = "rad/s" if flag == "--omega" else "m/s"
        applied[flag] = max(-limit, min(limit, value))
        if abs(value) > limit * (1 + 1e-9):
            warnings.append(f"{flag} {value:g} {unit} is beyond {robot}'s step limit ({why}); "
                            f"walking at {applied[flag]:.3f} {unit}")
    return applied, warnings


def check_forces_in_run(flagged: Sequence[tuple[str, str, object]], duration_s: float) -> None:
    """Refuse a ``--force``/``--push`` whose window starts when the run has ended.

    ``flagged`` holds (flag, text as given, ForceWindow).
    """
    for flag, text, window in flagged:
        if window.t_start_s >= duration_s:
            raise ParameterError(
                f"{flag} {text!r} starts at {window.t_start_s:g} s, when the run has ended (--duration "
                f"{duration_s:g}); move it earlier or lengthen the run"
            )


def check_modules_flags(modules: tuple[str, ...], modules_text: str | None, delta_max: float | None,
                        modules_flag: str = "--modules") -> None:
    """Refuse an empty module list and a ``--delta-max`` that no restriction module uses."""
    if modules_text is not None and not modules:
        instead = "use --controller nominal" if modules_flag == "--modules" else f"drop {modules_flag} for all three"
        raise ParameterError(f"{modules_flag} is empty; name some of observer,restriction,timing (or {instead})")
    if delta_max is not None and "restriction" not in modules:
        raise ParameterError(
            "--delta-max sets the ZMP restriction's bound and this controller has no restriction module; "
            "add --controller robust or --modules ...,restriction, or drop --delta-max"
        )


def check_whole_body_flag(whole_body: str | None, sim: str) -> None:
    """``--whole-body torque`` needs ``--sim mujoco``."""
    if whole_body not in (None, "servo") and sim != "mujoco":
        raise ParameterError(f"--whole-body {whole_body} needs --sim mujoco (the LIP has no joints)")
