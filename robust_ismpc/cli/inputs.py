"""Checks of command-line input that need more than one flag or some knowledge of the robot.

Every check raises :class:`~robust_ismpc.exceptions.ParameterError` with one line naming the flag
(``--vx``, ``--push``, ...) and what to do, or returns the warnings the command prints and records.
The CLI calls them before anything is simulated. Nothing here prints.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..core.planner import kinematic_box
from ..exceptions import ParameterError

#: Longest simulated time of one run [s]. A run keeps its trace in memory (about 0.5 kB per
#: 10 ms tick, 180 MB per hour) and the footstep plan covers the whole walk; an hour is plenty
#: for a soak (``ismpc soak --minutes`` at most 60).
MAX_SIM_DURATION_S = 3600.0

def command_limits(params) -> dict[str, tuple[float, str]]:
    """Largest |command| per flag that the footstep planner can realise, with the reason.

    The planner clips each step to the kinematic box and each turn to the largest yaw step, so
    faster commands are walked at these speeds.
    """
    T = params.T_step_s
    lower, upper = kinematic_box(params, 1)
    sideways_m = float(0.5 * (upper[1] - lower[1]))  # per step: the soles may not come closer than the box allows
    return {
        "--vx": (0.5 * params.kin_box_x_m / T, f"{0.5 * params.kin_box_x_m:g} m forward per {T:g} s step"),
        "--vy": (sideways_m / T, f"{sideways_m:.3g} m sideways per {T:g} s step"),
        "--omega": (params.max_yaw_step_rad / T, f"{params.max_yaw_step_rad:g} rad per {T:g} s step"),
    }


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
        limit, why = limits[flag]
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
