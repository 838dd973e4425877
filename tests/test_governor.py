"""Feasibility governor of the mid-range disturbance (robust_ismpc.estimation.governor and its use)."""


import math

import numpy as np
import pytest

from robust_ismpc.control.modules import MODULES
from robust_ismpc.control.robust import RobustIsmpcController, RobustParams
from robust_ismpc.core.params import MpcParams, robot_params
from robust_ismpc.core.planner import WalkCommand, plan_footsteps
from robust_ismpc.estimation.governor import admissible_disturbance, governed_disturbance
from robust_ismpc.exceptions import ParameterError
from robust_ismpc.runs.forces import ForceWindow
from robust_ismpc.runs.lip import run_lip

ROBOT = robot_params("g1")
PUSH_T = 4.25  # 0.05 s into the single support of step 5


pytestmark = pytest.mark.usefixtures("quiet_logs")


def test_governed_target_lies_between_persistent_and_fresh_and_inside_the_interval():
    """Random cases: the target is between the persistent part and the fresh estimate; when the
    persistent part is admissible the target is admissible and as close to the fresh one as the
    interval allows; otherwise it is the persistent part."""
    rng = np.random.default_rng(0)
    for _ in range(2000):
        persistent, fresh = rng.normal(0.0, 1.0, 2), rng.normal(0.0, 1.0, 2)
        low = rng.normal(-0.5, 0.7, 2)
        high = low + rng.uniform(-0.2, 1.5, 2)
        target = governed_disturbance(persistent, fresh, low, high)
        assert np.all(target >= np.minimum(persistent, fresh) - 1e-12)
        assert np.all(target <= np.maximum(persistent, fresh) + 1e-12)
        inside = (persistent >= low) & (persistent <= high)
        np.testing.assert_array_equal(target[~inside], persistent[~inside])
        assert np.all(target[inside] >= low[inside] - 1e-12) and np.all(target[inside] <= high[inside] + 1e-12)
        np.testing.assert_allclose(target[inside], np.clip(fresh, low, high)[inside])


def test_admissible_interval_keeps_the_shifted_dcm_inside_the_bounds():
    """x_u + w/η² at both ends of the interval is exactly on the bounds."""
    eta = ROBOT.eta
    dcm, lower, upper = np.array([0.02, -0.01]), np.array([-0.05, -0.04]), np.array([0.06, 0.01])
    low, high = admissible_disturbance(dcm, lower, upper, eta)
    np.testing.assert_allclose(dcm + low / eta**2, lower)
    np.testing.assert_allclose(dcm + high / eta**2, upper)
    with pytest.raises(ParameterError):
        admissible_disturbance([0.0, np.nan], lower, upper, eta)
    with pytest.raises(ParameterError):
        admissible_disturbance(dcm, lower, upper, -1.0)


def test_governor_must_be_a_bool():
    with pytest.raises(ParameterError, match="governor"):
        RobustParams(governor="yes")


def _walk(forces, params=None, duration_s=9.0, cls=RobustIsmpcController):
    mpc = MpcParams()
    controller = cls(ROBOT, mpc, modules=MODULES, params=params)
    left = np.array([0.0, 0.5 * ROBOT.foot_spacing_m])
    plan = plan_footsteps(ROBOT, WalkCommand(0.2), duration_s + mpc.preview_horizon_s + 1.0, left, -left)
    controller.reset(plan, np.zeros(2))
    outcome, rec = run_lip(controller, duration_s, forces)
    return outcome, rec.finish(controller.plan, {}), controller


class _Checked(RobustIsmpcController):
    """Records, in single support, whether the governed target keeps the shifted DCM inside the
    feasibility bounds on every axis where it differs from the persistent part."""

    def reset(self, *args, **kwargs):
        super().reset(*args, **kwargs)
        self.checked = 0
        self.violations = []

    def _disturbance_target(self, t_s, dcm_m, state):
        target = super()._disturbance_target(t_s, dcm_m, state)
        plan = self.plan
        j = plan.step_at(t_s)
        if j >= 2 and t_s < plan.touchdown_s[j] - 1e-9:
            bx, by, R, origin = self._current_bounds(t_s, j, state, plan.touchdown_s[j] - t_s)
            shifted = R.T @ (dcm_m + target / self.eta**2 - origin)
            governed = np.abs(R.T @ (target - self.persistent_disturbance_mps2)) > 1e-12
            for axis, (lo, hi) in enumerate((bx, by)):
                if governed[axis]:
                    self.checked += 1
                    if not lo - 1e-9 <= shifted[axis] <= hi + 1e-9:
                        self.violations.append((t_s, axis, lo, shifted[axis], hi))
        return target


def test_fresh_part_never_moves_the_shifted_dcm_out_of_the_feasibility_region():
    """A 30 N coronal push in single support and a sagittal constant force: whenever the fresh
    estimate enters the target, the target's shifted DCM is within the exact bounds."""
    forces = [ForceWindow(20.0, 0.0, 3.0), ForceWindow(0.0, 30.0, PUSH_T, PUSH_T + 0.1)]
    outcome, _, controller = _walk(forces, cls=_Checked)
    assert not outcome.fell
    assert controller.checked > 20
    assert controller.violations == []


def test_governor_compensates_a_constant_force_sooner():
    """15 N sagittal from 3 s, the fresh estimate taken as lasting (T = inf): w̃ reaches 90 % of
    F/m sooner with the governor than with the persistent part only."""
    force = [ForceWindow(15.0, 0.0, 3.0)]
    times = []
    for governor in (True, False):
        outcome, trace, _ = _walk(force, RobustParams(governor=governor, transient_time_constant_s=math.inf),
                                  duration_s=5.0)
        assert not outcome.fell
        reached = trace["t_s"][trace["disturbance_est_mps2"][:, 0] >= 0.9 * 15.0 / ROBOT.mass_kg]
        times.append(reached.min())
    assert times[0] < times[1] - 0.05


def test_governor_survives_a_constant_force_the_persistent_part_alone_does_not():
    """g1 LIP, 30 N constant +x from 3 s, the fresh estimate taken as lasting (T = inf): the
    governed robust controller walks, the persistent part alone falls (it waits the persistence
    window before compensating). (With the default T = 0.1 s the fresh part enters at 28 % and
    the governed controller holds 29 N.) A 60 N, 0.1 s
    lateral push, which the persistent part alone did not survive with the Luenberger
    observer's estimate, it survives with the measured one (the estimate ends with the push)."""
    forces = [ForceWindow(30.0, 0.0, 3.0)]
    governed, _, _ = _walk(forces, RobustParams(transient_time_constant_s=math.inf))
    persistent_only, _, _ = _walk(forces, RobustParams(governor=False, transient_time_constant_s=math.inf))
    assert not governed.fell
    assert persistent_only.fell
