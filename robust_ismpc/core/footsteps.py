r"""Footstep plan: footstep poses, step timing, support queries and moving-constraint weights.

Indexing (spec §3.1). Footstep 0 is a *virtual* footstep at the midpoint of the initial feet:
the robot starts in double support with the ZMP there. Step :math:`j \ge 1` moves the support
from footstep :math:`j-1` to footstep :math:`j`: a single support phase on footstep
:math:`j-1` of duration :math:`T_{ss}^j` during which the swing foot travels to footstep
:math:`j`, then a double support phase of duration :math:`T_{ds}^j` during which the ZMP box
slides from footstep :math:`j-1` to footstep :math:`j`. Step 1 has no single support: footstep 1
is the first support foot, already on the ground.

Times: step :math:`j` starts at ``ss_start_s[j]``; its touchdown (end of single support) is
``touchdown_s[j] = ss_start_s[j] + T_ss_s[j]``; the next step starts at
``touchdown_s[j] + T_ds_s[j]``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import overload

import numpy as np

from ..exceptions import ParameterError, PlanError

LEFT = 1
RIGHT = -1
VIRTUAL = 0


@dataclass
class FootstepPlan:
    """A mutable footstep plan (positions may be re-optimised, timing may be adapted).

    Attributes
    ----------
    pos_m : ndarray, shape (N, 2)
        Current footstep positions (landed, or the latest optimal value) [m].
    candidate_pos_m : ndarray, shape (N, 2)
        Candidate positions from the planner (the MPC's X̂_f) [m].
    yaw_rad : ndarray, shape (N,)
        Footstep yaws θ [rad] (precomputed, never optimised).
    side : ndarray of int, shape (N,)
        +1 left, -1 right, 0 for the virtual initial footstep.
    ss_start_s : ndarray, shape (N,)
        Start time of step j [s] (entry 0 unused, -inf).
    T_ss_s, T_ds_s : ndarray, shape (N,)
        Single/double support durations of step j [s] (entry 0 unused).
    box_half_m : ndarray, shape (N, 2)
        Half sides of the ZMP box on each footstep, in the footstep frame [m]. Real footsteps
        use the robot's ZMP box; the virtual initial footstep uses the hull of the two initial
        ZMP boxes (the robot stands in double support there). In double support the half sides
        are interpolated like the centre, which keeps the box inside the hull of the two feet.
    """

    pos_m: np.ndarray
    candidate_pos_m: np.ndarray
    yaw_rad: np.ndarray
    side: np.ndarray
    ss_start_s: np.ndarray
    T_ss_s: np.ndarray
    T_ds_s: np.ndarray
    box_half_m: np.ndarray

    def __post_init__(self) -> None:
        n = len(self.yaw_rad)
        if n < 2:
            raise ParameterError("a footstep plan needs the virtual footstep and at least one foot")
        for name in ("pos_m", "candidate_pos_m", "box_half_m"):
            arr = getattr(self, name)
            if arr.shape != (n, 2):
                raise ParameterError(f"FootstepPlan.{name} must have shape ({n}, 2), got {arr.shape}")
        for name in ("side", "ss_start_s", "T_ss_s", "T_ds_s"):
            if getattr(self, name).shape != (n,):
                raise ParameterError(f"FootstepPlan.{name} must have shape ({n},)")
        if np.any(self.T_ss_s[2:] <= 0) or np.any(self.T_ds_s[1:] <= 0) or self.T_ss_s[1] < 0:
            raise ParameterError("FootstepPlan durations must be > 0 (step 1 may have T_ss = 0)")
        if not np.all(np.isfinite(self.pos_m)) or not np.all(np.isfinite(self.yaw_rad)):
            raise ParameterError("FootstepPlan positions and yaws must be finite")
        if not np.all(self.box_half_m > 0):
            raise ParameterError("FootstepPlan.box_half_m must be > 0")
        self._check_chained()

    def _check_chained(self) -> None:
        end = self.ss_start_s[1:-1] + self.T_ss_s[1:-1] + self.T_ds_s[1:-1]
        if not np.allclose(end, self.ss_start_s[2:], atol=1e-9):
            raise ParameterError("FootstepPlan steps must follow each other without gaps")

    # ----------------------------------------------------------------------------------------
    @property
    def n_footsteps(self) -> int:
        """Number of footsteps N, the virtual one included."""
        return len(self.yaw_rad)

    @property
    def touchdown_s(self) -> np.ndarray:
        """Touchdown (end of single support) of every step [s], shape (N,)."""
        return self.ss_start_s + self.T_ss_s

    @property
    def end_s(self) -> float:
        """End of the last step's double support [s]: the plan covers times before it."""
        return float(self.ss_start_s[-1] + self.T_ss_s[-1] + self.T_ds_s[-1])

    @overload
    def step_at(self, t_s: float) -> int: ...

    @overload
    def step_at(self, t_s: np.ndarray) -> np.ndarray: ...

    def step_at(self, t_s: float | np.ndarray) -> np.ndarray | int:
        """Index j of the step under way at ``t_s`` (ss_start[j] <= t < next start).

        ``t_s`` may be a scalar or an increasing array.
        """
        if isinstance(t_s, (float, int)):  # one time: no array round trip (the per-cycle case)
            starts = self.ss_start_s
            if not starts[1] - 1e-12 <= t_s < self.end_s:  # NaN fails too
                raise PlanError(
                    f"time {t_s} is outside the footstep plan [{starts[1]}, {self.end_s}); "
                    "plan more steps (a longer walk) or shorten the preview horizon"
                )
            return int(np.searchsorted(starts, t_s + 1e-12, side="right")) - 1
        t = np.asarray(t_s, dtype=float)
        first = float(t.flat[0])
        last = float(t.flat[-1])
        if last >= self.end_s or first < self.ss_start_s[1] - 1e-12 or not (first == first and last == last):
            raise PlanError(
                f"time {t_s} is outside the footstep plan [{self.ss_start_s[1]}, {self.end_s}); "
                "plan more steps (a longer walk) or shorten the preview horizon"
            )
        j = np.searchsorted(self.ss_start_s[1:], t + 1e-12, side="right")
        return int(j) if j.ndim == 0 else j

    def is_frozen(self, j: int, t_s: float, freeze_s: float) -> bool:
        """True once footstep j is no longer a decision of the MPC: its touchdown is at most
        ``freeze_s`` after ``t_s`` (:attr:`~robust_ismpc.core.params.MpcParams.footstep_freeze_s`)."""
        return bool(t_s >= self.ss_start_s[j] + self.T_ss_s[j] - freeze_s - 1e-9)

    def in_single_support(self, t_s: float) -> bool:
        """True if the robot is in single support at ``t_s``."""
        j = self.step_at(t_s)
        return bool(t_s < self.touchdown_s[j] - 1e-12)

    def time_to_touchdown(self, t_s: float) -> float:
        """Remaining single-support time of the step under way at ``t_s`` [s] (0 in DS)."""
        j = self.step_at(t_s)
        return max(0.0, float(self.touchdown_s[j] - t_s))

    def centre_weights(self, times_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Convex weights of the moving ZMP constraint centre (spec §3.2).

        Parameters
        ----------
        times_s : ndarray, shape (M,)
            Increasing query times [s].

        Returns
        -------
        first : ndarray of int, shape (M,)
            Footstep index j-1 carrying weight ``1 - alpha``; index j carries ``alpha``.
        alpha : ndarray, shape (M,)
            Double-support progress in [0, 1] (0 in single support).
        """
        j = self.step_at(times_s)
        alpha = np.clip((times_s - self.touchdown_s[j]) / self.T_ds_s[j], 0.0, 1.0)
        return j - 1, alpha

    def weight_matrix(
        self, times_s: np.ndarray, first: int, count: int, weights: tuple[np.ndarray, np.ndarray] | None = None
    ) -> np.ndarray:
        """Dense weights over footsteps ``first .. first+count-1``, shape (M, count).

        Row m holds the convex combination giving the ZMP box centre at ``times_s[m]``.
        ``weights`` may pass ``centre_weights(times_s)`` when the caller already has it.
        """
        lo, alpha = self.centre_weights(times_s) if weights is None else weights
        rows = np.arange(len(lo))
        W = np.zeros((len(lo), count))
        W[rows, lo - first] = 1.0 - alpha
        hi = lo + 1 - first
        if hi[-1] >= count and alpha[-1] > 0:  # hi is non-decreasing: the last row is the widest
            raise PlanError("weight_matrix: footstep range too short for the query times")
        inside = hi < count
        W[rows[inside], hi[inside]] += alpha[inside]
        return W

    def interpolate(self, values: np.ndarray, weights: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        """Per-footstep ``values`` (N, ...) interpolated with ``weights = centre_weights(times)``."""
        lo, alpha = weights
        a = alpha.reshape(-1, *([1] * (values.ndim - 1)))
        return (1.0 - a) * values[lo] + a * values[lo + 1]

    def box_at(self, t_s: float) -> tuple[np.ndarray, np.ndarray, float]:
        """The ZMP box at one time: centre (2,) [m], half sides (2,) [m] and yaw [rad], as
        :meth:`centre`, :meth:`box_half` and :meth:`centre_yaw` give them."""
        j = self.step_at(float(t_s))
        touchdown = float(self.ss_start_s[j] + self.T_ss_s[j])
        alpha = min(1.0, max(0.0, (t_s - touchdown) / float(self.T_ds_s[j])))
        lo = j - 1
        centre = (1.0 - alpha) * self.pos_m[lo] + alpha * self.pos_m[lo + 1]
        half = (1.0 - alpha) * self.box_half_m[lo] + alpha * self.box_half_m[lo + 1]
        yaw = (1.0 - alpha) * float(self.yaw_rad[lo]) + alpha * float(self.yaw_rad[lo + 1])
        return centre, half, yaw

    def centre(self, times_s: np.ndarray, positions: np.ndarray | None = None) -> np.ndarray:
        """ZMP box centre at each time, shape (M, 2), from ``positions`` (default ``pos_m``)."""
        pos = self.pos_m if positions is None else positions
        lo, alpha = self.centre_weights(np.asarray(times_s, dtype=float))
        return (1.0 - alpha)[:, None] * pos[lo] + alpha[:, None] * pos[lo + 1]

    def box_half(self, times_s: np.ndarray) -> np.ndarray:
        """Half sides of the ZMP box at each time, interpolated like the centre [m], shape (M, 2)."""
        lo, alpha = self.centre_weights(np.asarray(times_s, dtype=float))
        return (1.0 - alpha)[:, None] * self.box_half_m[lo] + alpha[:, None] * self.box_half_m[lo + 1]

    def centre_yaw(self, times_s: np.ndarray) -> np.ndarray:
        """Yaw of the ZMP box at each time, interpolated like the centre [rad], shape (M,)."""
        lo, alpha = self.centre_weights(np.asarray(times_s, dtype=float))
        return (1.0 - alpha) * self.yaw_rad[lo] + alpha * self.yaw_rad[lo + 1]

    def retime_touchdown(self, j: int, touchdown_s: float) -> float:
        """Move the touchdown of step ``j``, keeping T_ds and every later duration.

        Every later step start shifts by the same amount (spec §13.4).

        Returns
        -------
        float
            The shift applied [s].
        """
        if not 2 <= j < self.n_footsteps:
            raise ParameterError(f"step {j} has no single support to retime")
        new_T_ss = touchdown_s - self.ss_start_s[j]
        if new_T_ss <= 0:
            raise ParameterError(
                f"touchdown {touchdown_s} s would precede the start of step {j} ({self.ss_start_s[j]} s)"
            )
        shift = float(new_T_ss - self.T_ss_s[j])
        self.T_ss_s[j] = new_T_ss
        self.ss_start_s[j + 1 :] += shift
        return shift

    def retime_start(self, t_s: float, first_ss_start_s: float) -> float:
        """Move the first single support (step 2's) to start at ``first_ss_start_s``, keeping
        the ZMP box at ``t_s`` where it is and every later duration.

        ``t_s`` must be in step 1, the initial stance. Before the initial double support (the
        box sliding from the feet's midpoint to footstep 1) has begun, it keeps its duration if
        that fits and the stance on the midpoint is shortened or lengthened; if it does not fit,
        it begins at ``t_s`` and is compressed into the time left. Once under way, its progress
        at ``t_s`` is kept and the rest runs faster; a later start is then refused.

        Parameters
        ----------
        t_s : float
            Current time [s], in step 1.
        first_ss_start_s : float
            New start of the first single support [s], after ``t_s``; not after the current one
            once the initial double support has begun.

        Returns
        -------
        float
            The shift of every later step start [s].
        """
        if self.step_at(float(t_s)) != 1:
            raise ParameterError(f"time {t_s} s is not in the initial stance (step 1)")
        start_now = float(self.ss_start_s[2])
        touchdown = float(self.ss_start_s[1] + self.T_ss_s[1])
        T_ds = float(self.T_ds_s[1])
        progress = min(1.0, max(0.0, (t_s - touchdown) / T_ds))
        if not t_s < first_ss_start_s or (progress > 0.0 and first_ss_start_s > start_now + 1e-12):
            raise ParameterError(
                f"first single support at {first_ss_start_s} s must be after {t_s} s, and not after {start_now} s "
                "once the initial double support is under way"
            )
        left_s = first_ss_start_s - t_s
        if progress == 0.0:  # the box is still on the midpoint
            new_T_ds = min(T_ds, left_s)
            new_touchdown = first_ss_start_s - new_T_ds
        else:
            new_T_ds = left_s / (1.0 - progress)
            new_touchdown = t_s - progress * new_T_ds
        self.T_ss_s[1] = max(0.0, new_touchdown - float(self.ss_start_s[1]))
        self.T_ds_s[1] = first_ss_start_s - float(self.ss_start_s[1]) - self.T_ss_s[1]
        shift = float(first_ss_start_s - start_now)
        self.ss_start_s[2:] += shift
        return shift

    def foot_before(self, j: int) -> int:
        """Index of the footstep that the swing foot of step ``j`` lifts off from.

        Returns -1 when that foot is still on its initial (pre-plan) position.
        """
        return j - 2 if j - 2 >= 1 else -1
