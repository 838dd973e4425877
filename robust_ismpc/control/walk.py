"""Start a walk: the controller with its modules, the footstep plan from the initial soles.

The one place where a controller is built and reset on a plan; the LIP and MuJoCo runs, the
scenarios, the sweeps, the bench and the calibration all start their walks here.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from ..core.footsteps import FootstepPlan
from ..core.params import MpcParams, RobotParams
from ..core.planner import WalkCommand, plan_footsteps
from .controller import IsmpcController
from .modules import check_modules


def make_controller(
    robot: RobotParams,
    mpc: MpcParams | None = None,
    modules: Iterable[str] = (),
    delta_max_mps2: float | None = None,
    **controller_options,
) -> IsmpcController:
    """Nominal IS-MPC plus ``modules``.

    Parameters
    ----------
    robot : RobotParams
    mpc : MpcParams, optional
        MPC settings (the controller's default when None).
    modules : iterable of str
        Robustness modules (:data:`~robust_ismpc.control.modules.MODULES`); none gives the nominal
        :class:`IsmpcController`.
    delta_max_mps2 : float, optional
        Deviation bound of the restriction [m/s²] (module default when None).
    controller_options
        Passed to the controller (``estimator``, ``solver``, and for the robust one ``params``).
    """
    names = check_modules(modules)
    if not names:
        return IsmpcController(robot, mpc, **controller_options)
    from .robust import RobustIsmpcController

    return RobustIsmpcController(robot, mpc, modules=names, delta_max_mps2=delta_max_mps2, **controller_options)


def lip_start_soles(robot: RobotParams) -> tuple[np.ndarray, np.ndarray]:
    """Initial left and right sole (x, y) of a reduced-model walk: the feet side by side at the
    origin, ``foot_spacing_m`` apart [m]."""
    left = np.array([0.0, 0.5 * robot.foot_spacing_m])
    return left, -left


def start_walk(
    controller: IsmpcController,
    command: WalkCommand,
    duration_s: float,
    left_sole_m: np.ndarray | None = None,
    right_sole_m: np.ndarray | None = None,
    yaw_rad: float = 0.0,
    com_pos_m: np.ndarray | None = None,
) -> FootstepPlan:
    """Plan the footsteps of a ``duration_s`` walk and reset ``controller`` on them at t = 0.

    Parameters
    ----------
    controller : IsmpcController
    command : WalkCommand
    duration_s : float
        Walk length [s]; the plan covers it plus the controller's preview.
    left_sole_m, right_sole_m : ndarray, shape (2,), optional
        Initial soles [m]. None (both): :func:`lip_start_soles`, with the CoM at the origin.
    yaw_rad : float
        Initial heading [rad].
    com_pos_m : ndarray, shape (2,), optional
        Initial CoM [m]; needed with the soles.

    Returns
    -------
    FootstepPlan
        The plan the controller walks (it adapts it in place).
    """
    robot = controller.robot
    horizon_s = controller.plan_duration_s(duration_s)
    if left_sole_m is None or right_sole_m is None:
        left, right = lip_start_soles(robot)
        plan = plan_footsteps(robot, command, horizon_s, left, right)
        controller.reset(plan, np.zeros(2))
        return plan
    left, right = np.asarray(left_sole_m, float)[:2], np.asarray(right_sole_m, float)[:2]
    plan = plan_footsteps(robot, command, horizon_s, left, right, yaw_rad)
    com = 0.5 * (left + right) if com_pos_m is None else np.asarray(com_pos_m, float)[:2]
    controller.reset(plan, com, np.zeros(2), left_foot_m=left, right_foot_m=right)
    return plan
