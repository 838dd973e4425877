r"""Dense QP data, solutions and swappable solvers.

Problems have the form

.. math::
    \min_x \tfrac12 x^T H x + g^T x \quad\text{s.t.}\quad l \le A x \le u

where rows with ``equality[i]`` set have :math:`l_i = u_i`. :class:`DaqpSolver` calls DAQP
directly, keeps one workspace per problem shape and starts each solve from the active set of the
previous problem of the same family; :class:`QpsolversSolver` goes through ``qpsolvers`` to any
installed backend (OSQP, proxsuite, quadprog, ...).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..exceptions import InfeasibleMpc, ParameterError, SolverError


@dataclass
class QpProblem:
    """A dense QP with two-sided row constraints.

    Attributes
    ----------
    H : ndarray, shape (n, n)
        Positive definite Hessian.
    g : ndarray, shape (n,)
        Linear cost.
    A : ndarray, shape (m, n)
        Constraint rows (C-contiguous).
    lower, upper : ndarray, shape (m,)
        Row bounds; equal for equality rows.
    equality : ndarray of bool, shape (m,)
        Which rows are equalities.
    tag : str
        Identifies a family of problems solved in sequence (e.g. the x-axis QP); a warm-starting
        solver starts from the active set of the family's previous problem.
    previous_rows : ndarray of int, shape (m,), optional
        Row ``i`` of this problem is row ``previous_rows[i]`` of the family's previous problem
        (-1: a new row), e.g. shifted by one sample as an MPC horizon slides. Only a warm-start
        hint: it changes the solver's work, never the solution. If omitted, rows are taken to
        correspond one to one when the shapes agree.
    matrix_version : int
        Problems with the same ``H`` and ``A`` objects and the same non-negative version have
        identical ``H`` and ``A`` (e.g. the two axes of one MPC cycle), so a solver may skip
        reading them again. -1: always read them.
    """

    H: np.ndarray
    g: np.ndarray
    A: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    equality: np.ndarray
    tag: str = ""
    previous_rows: np.ndarray | None = None
    matrix_version: int = -1

    def copy(self) -> QpProblem:
        """Deep copy (problems built by IsmpcQp share buffers that the next cycle overwrites)."""
        rows = None if self.previous_rows is None else self.previous_rows.copy()
        return QpProblem(self.H.copy(), self.g.copy(), self.A.copy(), self.lower.copy(), self.upper.copy(),
                         self.equality.copy(), self.tag, rows)

    @property
    def n(self) -> int:
        return self.H.shape[0]

    def objective(self, x: np.ndarray) -> float:
        """Cost ½xᵀHx + gᵀx."""
        return float(0.5 * x @ self.H @ x + self.g @ x)

    def violation(self, x: np.ndarray) -> float:
        """Largest constraint violation of ``x`` (0 if feasible)."""
        ax = self.A @ x
        return float(max(0.0, np.max(self.lower - ax, initial=0.0), np.max(ax - self.upper, initial=0.0)))


@dataclass
class QpSolution:
    """Result of one solve.

    Attributes
    ----------
    x : ndarray, shape (n,)
        Primal solution.
    solve_time_s : float
        Wall-clock time spent in the solver call [s].
    iterations : int
        Solver iterations (-1 if unknown).
    """

    x: np.ndarray
    solve_time_s: float
    iterations: int = -1


class QpSolver:
    """Interface: ``solve(problem) -> QpSolution`` or raise :class:`InfeasibleMpc`."""

    name = "abstract"

    def solve(self, problem: QpProblem) -> QpSolution:  # pragma: no cover - interface
        raise NotImplementedError

    def reset(self) -> None:
        """Forget any warm-start information."""


# DAQP's constraint sense flags, and the flag of a row by the sign of its dual (- lower, + upper)
_ACTIVE, _LOWER, _EQUALITY = 1, 2, 5
_FLAGS_BY_SIGN = np.array([_ACTIVE | _LOWER, 0, _ACTIVE], dtype=np.int32)


@dataclass
class _Workspace:
    """One DAQP model and the H and A it holds."""

    model: Any  # daqp.Model (the core imports daqp on first use)
    H: np.ndarray
    A: np.ndarray
    matrix_version: int


@dataclass
class DaqpSolver(QpSolver):
    """DAQP called directly: one workspace per problem shape, warm-started per problem family.

    Each solve starts from the active set of the previous solution of the same ``tag``, carried
    through ``previous_rows``; families of one shape (the x and y QPs of an MPC cycle) share a
    workspace, and ``H``/``A`` are handed to it only when they are not the ones it holds (see
    :attr:`QpProblem.matrix_version`). DAQP reads the raw buffers of its inputs, so every array
    handed to it is made C-contiguous float64 first (a non-contiguous view silently gives wrong
    answers).
    """

    name = "daqp"
    primal_tol: float = 1e-8
    iter_limit: int = 1000
    _workspaces: dict = field(default_factory=dict, repr=False)
    _active: dict = field(default_factory=dict, repr=False)

    def reset(self) -> None:
        self._workspaces.clear()
        self._active.clear()

    def _start_sense(self, problem: QpProblem) -> np.ndarray:
        """DAQP sense flags: the family's previous active set mapped to these rows, and the equalities."""
        m = problem.A.shape[0]
        previous = self._active.get(problem.tag)  # flags of the previous rows, then a 0
        rows = problem.previous_rows
        if previous is None:
            sense = np.zeros(m, dtype=np.int32)
        elif rows is None:
            sense = previous[:m].copy() if previous.shape[0] == m + 1 else np.zeros(m, dtype=np.int32)
        elif rows.shape == (m,) and rows.max(initial=-1) < previous.shape[0] - 1:
            sense = previous[rows]  # row -1 reads the trailing 0
        else:
            sense = np.zeros(m, dtype=np.int32)
        sense[problem.equality] = _EQUALITY
        return sense

    def solve(self, problem: QpProblem) -> QpSolution:
        import daqp

        g = np.ascontiguousarray(problem.g, dtype=np.float64)
        upper = np.ascontiguousarray(problem.upper, dtype=np.float64)
        lower = np.ascontiguousarray(problem.lower, dtype=np.float64)
        start = time.perf_counter()
        key = problem.A.shape
        workspace = self._workspaces.get(key)
        sense = self._start_sense(problem)
        if workspace is None:
            H = np.ascontiguousarray(problem.H, dtype=np.float64)
            A = np.ascontiguousarray(problem.A, dtype=np.float64)
            model = daqp.Model()
            model.settings = {"primal_tol": self.primal_tol, "iter_limit": self.iter_limit}
            flag, _ = model.setup(H, g, A, upper, lower, sense)
            if flag < 0:
                raise SolverError(f"DAQP setup failed with exit flag {flag}", problem.copy(), flag)
            workspace = _Workspace(model, problem.H, problem.A, problem.matrix_version)
            self._workspaces[key] = workspace
        else:
            update: dict = {"f": g, "bupper": upper, "blower": lower, "sense": sense}
            same_H = workspace.H is problem.H
            same_A = (same_H and workspace.A is problem.A and problem.matrix_version >= 0
                      and workspace.matrix_version == problem.matrix_version)
            if not same_H:
                update["H"] = np.ascontiguousarray(problem.H, dtype=np.float64)
            if not same_A:
                update["A"] = np.ascontiguousarray(problem.A, dtype=np.float64)
            workspace.model.update(**update)
            workspace.H, workspace.A, workspace.matrix_version = problem.H, problem.A, problem.matrix_version
        x, _, exitflag, info = workspace.model.solve()
        elapsed = time.perf_counter() - start
        if exitflag < 0:
            # Drop the workspace and the family's active set: they belong to a failed problem.
            self._workspaces.pop(key, None)
            self._active.pop(problem.tag, None)
            if exitflag == -1:
                raise InfeasibleMpc("IS-MPC QP is infeasible (DAQP exit flag -1)", problem.copy(), exitflag)
            raise SolverError(f"DAQP failed with exit flag {exitflag}", problem.copy(), exitflag)
        active = np.zeros(problem.A.shape[0] + 1, dtype=np.int32)
        active[:-1] = _FLAGS_BY_SIGN[np.sign(info["lam"]).astype(np.intp) + 1]
        self._active[problem.tag] = active
        return QpSolution(x=np.array(x), solve_time_s=elapsed, iterations=int(info.get("iterations", -1)))


@dataclass
class QpsolversSolver(QpSolver):
    """Any ``qpsolvers`` backend (cold start each call)."""

    backend: str = "osqp"
    options: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        try:
            import qpsolvers
        except ImportError:
            raise ParameterError(
                f"QP solver {self.backend!r} goes through qpsolvers, which is not installed: "
                "pip install 'robust-ismpc[solvers]' (or use the default, daqp)"
            ) from None
        if self.backend not in qpsolvers.available_solvers:
            raise ParameterError(
                f"QP solver {self.backend!r} is not installed; available: "
                f"daqp (direct), {', '.join(sorted(qpsolvers.available_solvers))}"
            )
        self.name = self.backend

    def solve(self, problem: QpProblem) -> QpSolution:
        import qpsolvers

        eq = problem.equality
        ineq = ~eq
        G = np.vstack([problem.A[ineq], -problem.A[ineq]])
        h = np.concatenate([problem.upper[ineq], -problem.lower[ineq]])
        finite = np.isfinite(h)
        start = time.perf_counter()
        defaults = {"osqp": {"eps_abs": 1e-7, "eps_rel": 1e-7, "max_iter": 20000, "polish": True}}
        opts = {**defaults.get(self.backend, {}), **self.options}
        sol = qpsolvers.solve_problem(
            qpsolvers.Problem(
                problem.H, problem.g, G[finite], h[finite],
                problem.A[eq] if eq.any() else None, problem.upper[eq] if eq.any() else None,
            ),
            solver=self.backend,
            **opts,
        )
        elapsed = time.perf_counter() - start
        if not sol.found or sol.x is None:
            raise InfeasibleMpc(f"IS-MPC QP not solved by {self.backend}", problem.copy(), None)
        return QpSolution(x=np.asarray(sol.x), solve_time_s=elapsed)


def make_solver(name: str) -> QpSolver:
    """Solver by name: ``daqp`` (direct) or a qpsolvers backend name."""
    if not isinstance(name, str) or not name:
        raise ParameterError(f"solver name must be a non-empty string, got {name!r}")
    if name == "daqp":
        return DaqpSolver()
    return QpsolversSolver(backend=name)
