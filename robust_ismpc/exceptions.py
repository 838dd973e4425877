"""Exception family of robust-ismpc.

Every error raised on purpose by the library derives from :class:`IsmpcError`, so a caller
can catch one type. Messages name the offending value and what is allowed.
"""

from __future__ import annotations

from typing import Any


class IsmpcError(Exception):
    """Base class of every error raised by robust-ismpc."""


class ParameterError(IsmpcError, ValueError):
    """A parameter or argument has a value that is not allowed."""


class PlanError(IsmpcError):
    """A footstep plan cannot serve the request (e.g. it ends before the preview horizon)."""


class SolverError(IsmpcError):
    """The QP solver failed for a reason other than infeasibility."""

    def __init__(self, message: str, problem: Any = None, exitflag: int | None = None):
        super().__init__(message)
        self.problem = problem
        self.exitflag = exitflag


class InfeasibleMpc(SolverError):
    """The IS-MPC quadratic program has no solution.

    Attributes
    ----------
    problem : QpProblem
        The problem that could not be solved (matrices and vectors), for inspection.
    exitflag : int
        The solver's own status code.
    """


class ControllerFailure(IsmpcError):
    """The controller cannot produce a reference any more.

    Attributes
    ----------
    reason : str
        ``"qp_infeasible"`` (infeasible longer than the fallback allows) or
        ``"bad_measurement"`` (NaN or inf in the measurement).
    """

    def __init__(self, message: str, reason: str = "qp_infeasible"):
        super().__init__(message)
        self.reason = reason


class ModelError(IsmpcError):
    """A robot model or robot description file is missing or inconsistent."""
