"""Detect a simulation that blew up, so that a run reports it instead of a fall.

A huge force (``--push 1e9,0@1:0.1``) makes MuJoCo's accelerations non-finite; MuJoCo then warns,
*resets the whole state* (robot back at its model pose, clock at 0) and carries on, so the run
would later "fall" at a time before the push. :func:`simulation_failure` reads MuJoCo's warning
counters and the state after every control period; the loop stops with failure
``simulator_unstable``.

Importing this module routes MuJoCo's own warning messages (which it otherwise prints on stderr
and appends to ``MUJOCO_LOG.TXT`` in the working directory) to the ``robust_ismpc`` logger.
"""

from __future__ import annotations

import logging

import mujoco
import numpy as np

logger = logging.getLogger("robust_ismpc")

#: MuJoCo warnings that mean the state is no longer a simulation of the robot.
UNSTABLE_WARNINGS = {
    mujoco.mjtWarning.mjWARN_BADQPOS: "bad joint positions",
    mujoco.mjtWarning.mjWARN_BADQVEL: "bad joint velocities",
    mujoco.mjtWarning.mjWARN_BADQACC: "bad accelerations",
}


def _log_mujoco_warning(message: str) -> None:
    logger.warning("MuJoCo: %s", message.strip())


mujoco.set_mju_user_warning(_log_mujoco_warning)


def simulation_failure(data: mujoco.MjData, t_s: float) -> str | None:
    """``"simulator_unstable: ..."`` if the simulation blew up by ``t_s``, else None.

    Parameters
    ----------
    data : mujoco.MjData
        The simulation after a control period.
    t_s : float
        Simulated time at the end of that period [s]. On a blow-up MuJoCo has reset
        ``data.time``; it is set back to ``t_s`` so that the run's duration is when it failed.
    """
    problems = [name for code, name in UNSTABLE_WARNINGS.items() if data.warning[int(code)].number > 0]
    if not all(np.isfinite(a).all() for a in (data.qpos, data.qvel, data.qacc)):
        problems.append("non-finite state")
    if not problems:
        return None
    data.time = t_s
    return (f"simulator_unstable: MuJoCo reported {', '.join(problems)} by t = {t_s:.2f} s (forces or "
            "speeds too large for its time step); the robot did not fall, the simulation failed")
