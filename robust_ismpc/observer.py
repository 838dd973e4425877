r"""Disturbance observer on the extended LIP, and the mid-range filter (spec §11).

Per horizontal axis the observer estimates the extended state
:math:`\xi = (x_c, \dot x_c, x_z, w)` of

.. math::

    \dot\xi = A_o \xi + B_o \dot x_z, \qquad
    A_o = \begin{bmatrix} 0&1&0&0\\ \eta^2&0&-\eta^2&1\\ 0&0&0&0\\ 0&0&0&0\end{bmatrix},\quad
    B_o = (0, 0, 1, 0)^T,

from the measured CoM position and ZMP (the contact centre of pressure),
:math:`y = C_o \xi = (x_c, x_z)`. The model is discretised exactly (zero-order hold on
:math:`\dot x_z` and constant :math:`w` over one sample) and the gain ``G`` of the
predictor-form Luenberger observer

.. math::

    \hat\xi_{k+1|k} = A_{od}\hat\xi_{k|k-1} + B_{od}\dot x_z^k + G\,(y_k - C_o\hat\xi_{k|k-1})

places the eigenvalues of :math:`A_{od} - G C_o` at the requested discrete poles. The ZMP is
measured directly, so ``G`` has a block structure: the ZMP channel gets the scalar gain
:math:`1 - p_z` (eigenvalue :math:`p_z`), and the (CoM, CoM velocity, disturbance) subsystem,
observable from the CoM alone, gets a single-output pole placement (unique, equal to Ackermann's
formula). See ``docs/derivations.md`` §1.

Both axes share the same matrices and are handled together (state array of shape (2, 4), rows
x and y).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import place_poles

from .exceptions import ParameterError
from .params import GRAVITY_MPS2

__all__ = [
    "ObserverParams",
    "DisturbanceObserver",
    "MidrangeParams",
    "MidrangeFilter",
    "observer_matrices",
    "observer_gain",
]

_DISCRETISATIONS = ("exact", "euler_disturbance")


@dataclass(frozen=True)
class ObserverParams:
    """Settings of the disturbance observer.

    Attributes
    ----------
    com_height_m : float
        Constant CoM height h [m]; η = sqrt(g / h).
    sampling_period_s : float
        Observer period δ [s] (one update per MPC cycle).
    poles : tuple of float, length 3
        Discrete eigenvalues for the (CoM position, CoM velocity, disturbance) error dynamics.
        Real, distinct, in [0, 1) (non-negative real poles give a non-oscillating estimate).
        Default (0.6, 0.7, 0.8), the robust reference code's design (spec §11.3).
    zmp_pole : float
        Discrete eigenvalue of the ZMP error dynamics, in [0, 1); default 0.5.
    discretisation : str
        ``"exact"`` (default): the disturbance column of A_od is the exact
        ((cosh ηδ − 1)/η², sinh(ηδ)/η). ``"euler_disturbance"``: the reference code's
        first-order column (0, δ), kept only to reproduce its gain (spec §11.2–11.3).
    """

    com_height_m: float
    sampling_period_s: float = 0.01
    poles: tuple[float, float, float] = (0.6, 0.7, 0.8)
    zmp_pole: float = 0.5
    discretisation: str = "exact"

    def __post_init__(self) -> None:
        for name in ("com_height_m", "sampling_period_s"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
                raise ParameterError(f"ObserverParams.{name} must be a finite number > 0, got {value!r}")
        try:
            poles = tuple(float(p) for p in self.poles)
        except (TypeError, ValueError):
            raise ParameterError(f"ObserverParams.poles must be three real numbers, got {self.poles!r}") from None
        if len(poles) != 3:
            raise ParameterError(f"ObserverParams.poles must have exactly 3 entries, got {len(poles)}")
        object.__setattr__(self, "poles", poles)
        for p in (*poles, self.zmp_pole):
            if not isinstance(p, (int, float)) or not math.isfinite(p) or not 0.0 <= p < 1.0:
                raise ParameterError(
                    f"ObserverParams: every pole must be real and in [0, 1) (stable, non-oscillating), got {p!r}"
                )
        if min(abs(a - b) for i, a in enumerate(poles) for b in poles[i + 1:]) < 1e-6:
            raise ParameterError(f"ObserverParams.poles must be distinct (by > 1e-6), got {poles}")
        if self.discretisation not in _DISCRETISATIONS:
            raise ParameterError(
                f"ObserverParams.discretisation must be one of {', '.join(_DISCRETISATIONS)}; "
                f"got {self.discretisation!r}"
            )

    @property
    def eta(self) -> float:
        """LIP natural frequency η = sqrt(g / h) [1/s]."""
        return math.sqrt(GRAVITY_MPS2 / self.com_height_m)


def observer_matrices(
    eta: float, sampling_period_s: float, discretisation: str = "exact"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Discrete extended-LIP matrices of the observer (spec §11.2).

    Parameters
    ----------
    eta : float
        LIP natural frequency η [1/s].
    sampling_period_s : float
        Sampling period δ [s].
    discretisation : str
        ``"exact"`` or ``"euler_disturbance"`` (see :class:`ObserverParams`).

    Returns
    -------
    A_od : ndarray, shape (4, 4)
        State matrix on (x_c [m], ẋ_c [m/s], x_z [m], w [m/s²]).
    B_od : ndarray, shape (4,)
        Input column for ẋ_z [m/s].
    C_o : ndarray, shape (2, 4)
        Output matrix selecting (x_c, x_z).
    """
    d = sampling_period_s
    ch, sh = math.cosh(eta * d), math.sinh(eta * d)
    A_od = np.array(
        [
            [ch, sh / eta, 1.0 - ch, (ch - 1.0) / eta**2],
            [eta * sh, ch, -eta * sh, sh / eta],
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )
    if discretisation == "euler_disturbance":
        A_od[0, 3], A_od[1, 3] = 0.0, d
    elif discretisation != "exact":
        raise ParameterError(f"discretisation must be one of {', '.join(_DISCRETISATIONS)}; got {discretisation!r}")
    B_od = np.array([d - sh / eta, 1.0 - ch, d, 0.0])
    C_o = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    return A_od, B_od, C_o


def observer_gain(A_od: np.ndarray, poles: tuple[float, float, float], zmp_pole: float) -> np.ndarray:
    """Observer gain placing the eigenvalues of ``A_od − G C_o`` (spec §11.3).

    The (x_c, ẋ_c, w) block is observable from x_c alone: its gain comes from
    :func:`scipy.signal.place_poles` on the dual single-output pair (unique, = Ackermann). The
    ZMP row gets 1 − ``zmp_pole``. Cross terms are zero, so ``A_od − G C_o`` is block triangular
    and its spectrum is exactly ``poles ∪ {zmp_pole}``.

    Parameters
    ----------
    A_od : ndarray, shape (4, 4)
        Discrete state matrix from :func:`observer_matrices`.
    poles : tuple of 3 floats
        Discrete poles for (x_c, ẋ_c, w).
    zmp_pole : float
        Discrete pole for x_z.

    Returns
    -------
    G : ndarray, shape (4, 2)
        Gain; column 0 multiplies the CoM innovation [m], column 1 the ZMP innovation [m].
    """
    idx = [0, 1, 3]
    A_sub = A_od[np.ix_(idx, idx)]
    C_sub = np.array([[1.0, 0.0, 0.0]])
    placed = place_poles(A_sub.T, C_sub.T, np.asarray(poles, dtype=float))
    G = np.zeros((4, 2))
    G[idx, 0] = placed.gain_matrix[0]
    G[2, 1] = 1.0 - zmp_pole
    return G


class DisturbanceObserver:
    r"""Luenberger observer of (x_c, ẋ_c, x_z, w) for both horizontal axes (spec §11).

    The recursion is the predictor form of the spec,
    :math:`\hat\xi_{k+1|k} = A\hat\xi_{k|k-1} + B u_k + G(y_k - C\hat\xi_{k|k-1})`, computed in
    two halves so that the estimate returned at tick k already uses the measurement y_k: the
    stored filtered state is :math:`\hat\xi_{k|k} = \hat\xi_{k|k-1} + A^{-1}G(y_k - C\hat\xi_{k|k-1})`,
    and the next update first propagates it with the ZMP velocity applied in between. The
    sequence of predictions is identical to the predictor form; the disturbance component of
    :math:`A^{-1}G` equals that of G, so the returned :math:`\hat w_{k|k}` equals the predictor
    form's :math:`\hat w_{k+1|k}`.

    Parameters
    ----------
    params : ObserverParams
        Model and pole settings.

    Attributes
    ----------
    A_od : ndarray, shape (4, 4)
    B_od : ndarray, shape (4,)
    C_o : ndarray, shape (2, 4)
    G : ndarray, shape (4, 2)
        Predictor-form gain.
    """

    def __init__(self, params: ObserverParams):
        if not isinstance(params, ObserverParams):
            raise ParameterError(f"DisturbanceObserver needs ObserverParams, got {type(params).__name__}")
        self.params = params
        self.A_od, self.B_od, self.C_o = observer_matrices(params.eta, params.sampling_period_s, params.discretisation)
        self.G = observer_gain(self.A_od, params.poles, params.zmp_pole)
        # Filter-form gain L = A^{-1} G (same error spectrum, see class docstring).
        self._L = np.linalg.solve(self.A_od, self.G)
        self._state = np.zeros((2, 4))  # rows: x, y
        self._propagate_next = False

    @property
    def state(self) -> np.ndarray:
        """Current filtered estimate, shape (2, 4): rows (x, y), columns (x_c, ẋ_c, x_z, w)."""
        return self._state.copy()

    @property
    def w_hat(self) -> np.ndarray:
        """Current disturbance estimate (ŵ_x, ŵ_y) [m/s²], shape (2,)."""
        return self._state[:, 3].copy()

    def reset(
        self,
        com_pos_xy: np.ndarray,
        com_vel_xy: np.ndarray,
        zmp_xy: np.ndarray,
        w_xy: np.ndarray | float = 0.0,
    ) -> None:
        """Set the estimate; the next :meth:`update` treats it as its prior (no propagation).

        Parameters
        ----------
        com_pos_xy, com_vel_xy, zmp_xy : array_like, shape (2,)
            CoM position [m], CoM velocity [m/s], ZMP [m] (x, y).
        w_xy : array_like, shape (2,) or float
            Initial disturbance estimate [m/s²].
        """
        cols = [_xy(com_pos_xy, "com_pos_xy"), _xy(com_vel_xy, "com_vel_xy"), _xy(zmp_xy, "zmp_xy"),
                _xy(np.broadcast_to(np.asarray(w_xy, dtype=float), (2,)), "w_xy")]
        self._state = np.stack(cols, axis=1)
        self._propagate_next = False

    def update(
        self,
        com_meas_xy: np.ndarray,
        zmp_meas_xy: np.ndarray | None,
        zmp_vel_applied_xy: np.ndarray,
    ) -> np.ndarray:
        """Process the measurement of the current tick and return the disturbance estimate.

        Parameters
        ----------
        com_meas_xy : array_like, shape (2,)
            Measured CoM position (x, y) [m].
        zmp_meas_xy : array_like, shape (2,), or None
            Measured ZMP = contact centre of pressure [m]. ``None`` (no contact force sensing or
            no foot in contact): the ZMP innovation is set to zero, i.e. the model's own
            predicted ZMP is used.
        zmp_vel_applied_xy : array_like, shape (2,)
            ZMP velocity [m/s] applied since the previous update (ignored on the first update
            after :meth:`reset`).

        Returns
        -------
        w_hat_xy : ndarray, shape (2,)
            Disturbance estimate (ŵ_x, ŵ_y) [m/s²].
        """
        com = _xy(com_meas_xy, "com_meas_xy")
        u = _xy(zmp_vel_applied_xy, "zmp_vel_applied_xy")
        if self._propagate_next:
            prior = self._state @ self.A_od.T + np.outer(u, self.B_od)
        else:
            prior = self._state
        innovation = np.empty((2, 2))
        innovation[:, 0] = com - prior[:, 0]
        innovation[:, 1] = 0.0 if zmp_meas_xy is None else _xy(zmp_meas_xy, "zmp_meas_xy") - prior[:, 2]
        self._state = prior + innovation @ self._L.T
        self._propagate_next = True
        return self._state[:, 3].copy()


@dataclass(frozen=True)
class MidrangeParams:
    r"""Saturation and rate limit that turn the observer estimate ŵ into the mid-range w̃ (§11.5).

    Attributes
    ----------
    max_change_mps2 : float
        Largest change of w̃ between two consecutive samples [m/s² per sample], > 0. The same
        number must be passed as ``max_midrange_change_mps2`` to
        :func:`robust_ismpc.restriction.restriction_rate`: a mid-range change of Δw̃ per sample
        moves the shifted DCM by Δw̃/η², which the restriction must absorb. Default 0.002 m/s²
        per sample (0.2 m/s³ at δ = 0.01 s): at h = 0.71 m, T_c = 1 s it costs
        r ≈ 0.015 m/s, about 38 % of the largest restriction of a 0.08 m ZMP box, and it tracks a
        change of 1 m/s² (40 N on 40 kg) in 5 s. Faster changes (pushes) are STA's job.
        See ``docs/derivations.md`` §2.4.
    band_centre_mps2 : tuple of float or None
        Mid-range centre (w_m,x, w_m,y) of the admissible band [m/s²]; None: no band.
    band_half_width_mps2 : float or None
        Half width Δ of the band [m/s²]: w̃ is saturated to [w_m − Δ, w_m + Δ]. None: no band.
    """

    max_change_mps2: float = 0.002
    band_centre_mps2: tuple[float, float] | None = None
    band_half_width_mps2: float | None = None

    def __post_init__(self) -> None:
        v = self.max_change_mps2
        if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
            raise ParameterError(f"MidrangeParams.max_change_mps2 must be a finite number > 0, got {v!r}")
        if (self.band_centre_mps2 is None) != (self.band_half_width_mps2 is None):
            raise ParameterError(
                "MidrangeParams: give both band_centre_mps2 and band_half_width_mps2, or neither"
            )
        if self.band_half_width_mps2 is not None:
            hw = self.band_half_width_mps2
            if not isinstance(hw, (int, float)) or not math.isfinite(hw) or hw < 0:
                raise ParameterError(f"MidrangeParams.band_half_width_mps2 must be a finite number >= 0, got {hw!r}")
            centre = tuple(float(c) for c in np.broadcast_to(np.asarray(self.band_centre_mps2, dtype=float), (2,)))
            if not all(math.isfinite(c) for c in centre):
                raise ParameterError(f"MidrangeParams.band_centre_mps2 must be finite, got {self.band_centre_mps2!r}")
            object.__setattr__(self, "band_centre_mps2", centre)


class MidrangeFilter:
    r"""Saturate and rate-limit the disturbance estimate: ŵ → w̃ (spec §11.5).

    Per axis, :math:`\tilde w_k = \mathrm{clip}(\mathrm{clip}(\hat w_k, w_m - Δ, w_m + Δ),
    \tilde w_{k-1} - ρ, \tilde w_{k-1} + ρ)`: the closed form of the reference code's 1-D
    saturation QP, with the rate limit ρ expressed in m/s² per sample (the reference's limit mixes
    units). The rate limit is applied last so that |w̃_k − w̃_{k−1}| ≤ ρ always holds, which is
    what the restriction guarantee needs; the band is therefore reached at most ρ per sample.

    Parameters
    ----------
    params : MidrangeParams
    """

    def __init__(self, params: MidrangeParams | None = None):
        self.params = params if params is not None else MidrangeParams()
        self._value = np.zeros(2)

    @property
    def value(self) -> np.ndarray:
        """Current mid-range w̃ (x, y) [m/s²], shape (2,)."""
        return self._value.copy()

    def reset(self, w_xy: np.ndarray | float = 0.0) -> None:
        """Set w̃ (x, y) [m/s²] without rate limit."""
        self._value = _xy(np.broadcast_to(np.asarray(w_xy, dtype=float), (2,)), "w_xy").copy()

    def update(self, w_hat_xy: np.ndarray) -> np.ndarray:
        """Return the new mid-range w̃ (x, y) [m/s²], shape (2,), from the estimate ŵ (x, y)."""
        target = _xy(w_hat_xy, "w_hat_xy")
        p = self.params
        if p.band_half_width_mps2 is not None:
            centre = np.asarray(p.band_centre_mps2)
            target = np.clip(target, centre - p.band_half_width_mps2, centre + p.band_half_width_mps2)
        rho = p.max_change_mps2
        self._value = np.clip(target, self._value - rho, self._value + rho)
        return self._value.copy()


def _xy(value: np.ndarray, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (2,) or not np.all(np.isfinite(arr)):
        raise ParameterError(f"{name} must be a finite array of shape (2,), got {value!r}")
    return arr


class PersistenceFilter:
    r"""Keep only the persistent part of the disturbance estimate (a sliding-window erosion).

    Per axis, the output is the estimate of smallest magnitude over the last ``window``
    samples when they all have the same sign, and 0 otherwise. A disturbance shorter than the
    window (an impulsive push) therefore never reaches the mid-range w̃, where the modified
    stability constraint would treat it as lasting forever, while a persistent force passes
    after one window. Pushes are the job of the step timing adaptation (spec §13).

    Parameters
    ----------
    window : int
        Number of samples (>= 1; 1 passes the estimate through unchanged).
    """

    def __init__(self, window: int):
        if not isinstance(window, (int, np.integer)) or window < 1:
            raise ParameterError(f"PersistenceFilter window must be an integer >= 1, got {window!r}")
        self.window = int(window)
        self._buffer = np.zeros((self.window, 2))
        self._count = 0

    def reset(self) -> None:
        self._buffer[:] = 0.0
        self._count = 0

    def update(self, w_hat_xy: np.ndarray) -> np.ndarray:
        """Push ŵ (x, y) [m/s²] and return its persistent part, shape (2,)."""
        self._buffer[self._count % self.window] = _xy(w_hat_xy, "w_hat_xy")
        self._count += 1
        buf = self._buffer
        same_sign = np.all(buf > 0, axis=0) | np.all(buf < 0, axis=0)
        smallest = buf[np.argmin(np.abs(buf), axis=0), [0, 1]]
        return np.where(same_sign, smallest, 0.0)


class MovingAverage:
    r"""Mean of the last ``window`` samples of a 2-D signal (the mean of the samples so far
    while fewer have arrived).

    Used on a walking robot between the persistence filter and the mid-range filter with a
    window of one stride: the part of the estimate that comes from the mismatch between the
    robot and the LIP repeats with the gait and averages out over a stride, a persistent force
    does not (G1 in MuJoCo, forward 0.1 m/s, no force: ŵ has std 0.19 / 0.09 m/s² in x / y,
    which moves the shifted DCM by up to 2.3 / 1.1 cm, against a ZMP box of ±4 / ±1.5 cm).

    Parameters
    ----------
    window : int
        Number of samples (>= 1; 1 passes the signal through unchanged).
    """

    def __init__(self, window: int):
        if not isinstance(window, (int, np.integer)) or window < 1:
            raise ParameterError(f"MovingAverage window must be an integer >= 1, got {window!r}")
        self.window = int(window)
        self._buffer = np.zeros((self.window, 2))
        self._sum = np.zeros(2)
        self._count = 0

    def reset(self) -> None:
        self._buffer[:] = 0.0
        self._sum[:] = 0.0
        self._count = 0

    def update(self, value_xy: np.ndarray) -> np.ndarray:
        """Push a sample (x, y) and return the mean of the window, shape (2,)."""
        value = _xy(value_xy, "value_xy")
        slot = self._count % self.window
        self._sum += value - self._buffer[slot]
        self._buffer[slot] = value
        self._count += 1
        if self._count % (16 * self.window) == 0:  # re-sum now and then against round-off drift
            self._sum = self._buffer.sum(axis=0)
        return self._sum / min(self._count, self.window)
