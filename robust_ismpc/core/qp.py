r"""Dense QP data, solutions and swappable solvers.

Problems have the form

.. math::
    \min_x \tfrac12 x^T H x + g^T x \quad\text{s.t.}\quad l \le A x \le u

where rows with ``equality[i]`` set have :math:`l_i = u_i`. :class:`DaqpSolver` calls DAQP
directly and keeps one warm-started workspace per problem shape; :class:`QpsolversSolver`
goes through ``qpsolvers`` to any installed backend (OSQP, proxsuite, quadprog, ...).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

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
        Identifies a family of problems solved in sequence (e.g. the x-axis QP), so that a
        warm-starting solver keeps one workspace per family.
    """

    H: np.ndarray
    g: np.ndarray
    A: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    equality: np.ndarray
    tag: str = ""

    def copy(self) -> QpProblem:
        """Deep copy (problems built by IsmpcQp share buffers that the next cycle overwrites)."""
        return QpProblem(self.H.copy(), self.g.copy(), self.A.copy(), self.lower.copy(), self.upper.copy(),
                         self.equality.copy(), self.tag)

    @property
    def n(self) -> int:
        return self.H.shape[0]

    @property
    def workspace_key(self) -> tuple[str, int, int]:
        return (self.tag, self.A.shape[0], self.A.shape[1])

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


@dataclass
class DaqpSolver(QpSolver):
    """DAQP called directly, one warm-started workspace per problem family and shape.

    DAQP reads the raw buffers of its inputs, so every array handed to it is made
    C-contiguous float64 first (a non-contiguous view silently gives wrong answers). The
    Hessian is handed to a workspace again only when it is a different object from the one
    it holds: re-passing H makes DAQP refactorise and forget the active set.
    """

    name = "daqp"
    primal_tol: float = 1e-8
    iter_limit: int = 1000
    _models: dict = field(default_factory=dict, repr=False)

    def reset(self) -> None:
        self._models.clear()

    def solve(self, problem: QpProblem) -> QpSolution:
        import daqp

        H = np.ascontiguousarray(problem.H, dtype=np.float64)
        g = np.ascontiguousarray(problem.g, dtype=np.float64)
        A = np.ascontiguousarray(problem.A, dtype=np.float64)
        upper = np.ascontiguousarray(problem.upper, dtype=np.float64)
        lower = np.ascontiguousarray(problem.lower, dtype=np.float64)
        start = time.perf_counter()
        key = problem.workspace_key
        entry = self._models.get(key)
        if entry is None:
            sense = np.ascontiguousarray(np.where(problem.equality, 5, 0), dtype=np.int32)
            model = daqp.Model()
            model.settings = {"primal_tol": self.primal_tol, "iter_limit": self.iter_limit}
            flag, _ = model.setup(H, g, A, upper, lower, sense)
            if flag < 0:
                raise SolverError(f"DAQP setup failed with exit flag {flag}", problem.copy(), flag)
            self._models[key] = (model, problem.H)
        else:
            model, held_H = entry
            if held_H is problem.H:
                model.update(f=g, A=A, bupper=upper, blower=lower)
            else:
                model.update(H=H, f=g, A=A, bupper=upper, blower=lower)
                self._models[key] = (model, problem.H)
        x, _, exitflag, info = model.solve()
        elapsed = time.perf_counter() - start
        if exitflag == -1:
            # Drop the workspace: its active set belongs to an infeasible problem.
            self._models.pop(key, None)
            raise InfeasibleMpc("IS-MPC QP is infeasible (DAQP exit flag -1)", problem.copy(), exitflag)
        if exitflag < 0:
            self._models.pop(key, None)
            raise SolverError(f"DAQP failed with exit flag {exitflag}", problem.copy(), exitflag)
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
