"""Tests of the QP layer: warm-started DAQP equals cold solves; contiguity; solver names."""

import numpy as np
import pytest
from fixtures import walking_controller

from robust_ismpc.core.qp import DaqpSolver, QpProblem, QpsolversSolver, make_solver
from robust_ismpc.exceptions import ParameterError


class _Checked(DaqpSolver):
    """Warm-started DAQP whose every answer is compared with a cold solve of a copy."""

    def __init__(self):
        super().__init__()
        self.max_error = 0.0
        self.count = 0

    def solve(self, problem):
        sol = super().solve(problem)
        cold = DaqpSolver().solve(problem.copy())
        # compare in constraint space (ZMP positions [m], footsteps [m]): the solver's
        # feasibility tolerance is on rows, so ZMP velocities alone may differ by ~tol/δ
        self.max_error = max(self.max_error, float(np.max(np.abs(problem.A @ (sol.x - cold.x)))))
        self.max_cost_gap = max(getattr(self, "max_cost_gap", 0.0),
                                abs(problem.objective(sol.x) - problem.objective(cold.x)))
        self.count += 1
        return sol


def test_warm_started_daqp_equals_cold_solves_along_a_walk():
    """Along 6 s of walking (workspace reused, Hessian not re-passed) every solution equals a cold solve."""
    controller = walking_controller("g1", 0.3, duration_s=6.0)
    checked = _Checked()
    controller.qp.solver = checked
    for k in range(600):
        controller.step(k * 0.01)
    assert checked.count >= 1000
    assert checked.max_error < 1e-7
    assert checked.max_cost_gap < 1e-8


def test_daqp_handles_non_contiguous_input():
    """A QP given as non-contiguous views is solved correctly (inputs are made contiguous)."""
    rng = np.random.default_rng(0)
    n = 6
    M = rng.normal(size=(n, n))
    H = M @ M.T + n * np.eye(n)
    big = rng.normal(size=(8, 2 * n))
    A = big[:, ::2]  # non-contiguous view
    assert not A.flags["C_CONTIGUOUS"]
    problem = QpProblem(H, rng.normal(size=n), A, -np.ones(8), np.ones(8), np.zeros(8, dtype=bool))
    x1 = DaqpSolver().solve(problem).x
    x2 = QpsolversSolver("quadprog").solve(problem).x
    np.testing.assert_allclose(x1, x2, atol=1e-8)


def test_unknown_solver_name_lists_available():
    """An unknown solver raises ParameterError naming the installed ones."""
    with pytest.raises(ParameterError, match="available"):
        make_solver("no-such-solver")
