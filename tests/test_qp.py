"""Tests of the QP layer: warm-started DAQP equals cold solves and saves work; contiguity; solver names."""

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


@pytest.mark.parametrize("omega", [0.0, 0.3])
def test_warm_started_daqp_equals_cold_solves_along_a_walk(omega):
    """Along 6 s of walking, straight (per-axis QPs sharing a workspace) and turning (coupled QPs),
    every solution from the previous cycle's shifted active set equals a cold solve."""
    controller = walking_controller("g1", 0.3, omega=omega, duration_s=6.0)
    checked = _Checked()
    controller.qp.solver = checked
    for k in range(600):
        controller.step(k * 0.01)
    assert checked.count >= 600  # one or two QPs per cycle
    assert checked.max_error < 1e-7
    assert checked.max_cost_gap < 1e-8


class _Counted:
    """A DAQP model that counts the constraint matrices handed to it."""

    def __init__(self, model, counts):
        self.model, self.counts = model, counts

    def update(self, **data):
        self.counts["A"] += "A" in data
        self.counts["updates"] += 1
        return self.model.update(**data)

    def solve(self):
        return self.model.solve()


class _Unshifted(DaqpSolver):
    """DAQP started from the previous cycle's active set row for row (no horizon shift)."""

    def solve(self, problem):
        problem.previous_rows = None
        return super().solve(problem)


def _walk_iterations(solver, seconds=6.0):
    controller = walking_controller("g1", 0.3, duration_s=seconds)
    controller.qp.solver = solver
    iterations = []
    solve = solver.solve

    def recording(problem):
        sol = solve(problem)
        iterations.append(sol.iterations)
        return sol

    solver.solve = recording
    for k in range(int(round(seconds / 0.01))):
        controller.step(k * 0.01)
    return np.array(iterations), controller


def test_shifted_warm_start_saves_solver_iterations():
    """Starting each cycle from the previous active set shifted by one sample (the rows of the
    sliding horizon) takes well under half the iterations of starting from it row for row,
    and removes the long solves."""
    shifted, _ = _walk_iterations(DaqpSolver())
    unshifted, _ = _walk_iterations(_Unshifted())
    assert shifted.sum() < 0.5 * unshifted.sum()
    assert np.percentile(shifted, 99) < np.percentile(unshifted, 99)


def test_the_two_axes_hand_their_shared_matrix_to_daqp_once_per_cycle():
    """The x and y QPs of a straight walk share one constraint matrix: DAQP reads it once per cycle."""
    solver = DaqpSolver()
    controller = walking_controller("g1", 0.3, duration_s=3.0)
    controller.qp.solver = solver
    counts = {"A": 0, "updates": 0}
    cycles = 0
    for k in range(300):
        controller.step(k * 0.01)
        for workspace in solver._workspaces.values():
            if not isinstance(workspace.model, _Counted):
                workspace.model = _Counted(workspace.model, counts)
        cycles += 1
    assert counts["updates"] > 2 * 250  # both axes of almost every cycle went through update()
    assert counts["A"] <= cycles
    assert counts["A"] >= 250


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
