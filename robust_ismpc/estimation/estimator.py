r"""From the robot's measurement: the MPC's start state, and the disturbance.

:class:`StateEstimator`: a steady-state Kalman filter per axis on the CoM and its velocity.
:class:`DisturbanceEstimator`: the external force per unit mass, measured (see its docstring).

Per horizontal axis the state filter estimates :math:`x = (x_c, \dot x_c)`, the CoM position and
velocity, on the LIP whose ZMP :math:`x_z` is the MPC's own (the ZMP the controller commanded,
integrated from its velocity):

.. math::

    \begin{bmatrix} x_c \\ \dot x_c \\ x_z \end{bmatrix}_{k+1}
    = A \begin{bmatrix} x_c \\ \dot x_c \\ x_z \end{bmatrix}_k + B\,\dot x_z^k + E\,w_k
    \quad\text{(the exact LIP discretisation, :mod:`robust_ismpc.core.lip`)},

with a white acceleration :math:`\nu \sim \mathcal N(0, \sigma_a^2)` entering like :math:`w`, and
the measurement :math:`y = (x_c, \dot x_c) + \epsilon`, :math:`\epsilon \sim \mathcal N(0,
\mathrm{diag}(\sigma_p^2, \sigma_v^2))`. The prediction is the controller's internal model
(:class:`~robust_ismpc.control.controller.IsmpcController` propagates its state with the applied ZMP
velocity and disturbance), so this module only corrects it:

.. math::

    \hat x_{k|k} = \hat x_{k|k-1} + K\,(y_k - \hat x_{k|k-1}),

with :math:`K` the steady-state Kalman gain (2 x 2, the same for both axes). The measured ZMP is
not used: on a robot the centre of pressure differs from the LIP's ZMP by the swing leg and the
angular momentum, and the MPC's ZMP is the one it constrains (the reference code barely trusts the
measured ZMP for the same reason). Zero measurement noise (the default) gives :math:`K = I`: the
MPC starts from the measurement as it is, the right choice for a perfect sensor (the LIP
simulation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.lip import discretise
from ..exceptions import ParameterError
from ..validation import check_nonnegative


@dataclass(frozen=True)
class EstimatorParams:
    """Noise model of the state estimator.

    Attributes
    ----------
    com_pos_noise_m : float
        σ_p, standard deviation of the measured CoM position [m].
    com_vel_noise_mps : float
        σ_v, standard deviation of the measured CoM velocity [m/s].
    acc_noise_mps2 : float
        σ_a, standard deviation of the CoM acceleration the model does not predict, per sample
        [m/s²]. Must be > 0 when a measurement noise is.
    """

    com_pos_noise_m: float = 0.0
    com_vel_noise_mps: float = 0.0
    acc_noise_mps2: float = 1.0

    def __post_init__(self) -> None:
        check_nonnegative("EstimatorParams", com_pos_noise_m=self.com_pos_noise_m,
                          com_vel_noise_mps=self.com_vel_noise_mps, acc_noise_mps2=self.acc_noise_mps2)
        if self.acc_noise_mps2 == 0 and (self.com_pos_noise_m > 0 or self.com_vel_noise_mps > 0):
            raise ParameterError(
                "EstimatorParams.acc_noise_mps2 must be > 0 when a measurement noise is: a model without "
                "process noise would ignore the measurement"
            )

    @property
    def exact(self) -> bool:
        """True when the measurement is taken as it is (K = I)."""
        return self.com_pos_noise_m == 0 and self.com_vel_noise_mps == 0


def steady_state_gain(params: EstimatorParams, eta: float, period_s: float, iterations: int = 10_000,
                      tolerance: float = 1e-14) -> np.ndarray:
    """Steady-state Kalman gain K, shape (2, 2), of the filter described in the module docstring.

    Parameters
    ----------
    params : EstimatorParams
    eta : float
        LIP natural frequency sqrt(g / h) [1/s].
    period_s : float
        Sampling period δ [s].

    Returns
    -------
    ndarray, shape (2, 2)
        Gain on the innovation (position, velocity) [-]; the identity for an exact measurement.
    """
    if params.exact:
        return np.eye(2)
    lip = discretise(eta, period_s)
    A = lip.A[:2, :2]
    G = lip.E[:2].reshape(2, 1)
    Q = params.acc_noise_mps2**2 * (G @ G.T)
    R = np.diag([params.com_pos_noise_m**2, params.com_vel_noise_mps**2])
    P = Q.copy()  # predicted covariance
    K = np.zeros((2, 2))
    for _ in range(iterations):
        S = P + R
        K_next = np.linalg.solve(S.T, P.T).T  # P S^-1 (H = I)
        corrected = (np.eye(2) - K_next) @ P
        P = A @ corrected @ A.T + Q
        if np.max(np.abs(K_next - K)) < tolerance:
            return K_next
        K = K_next
    return K


class StateEstimator:
    """Corrects the controller's predicted (CoM, CoM velocity) with the measurement.

    Parameters
    ----------
    params : EstimatorParams
    eta : float
        LIP natural frequency [1/s].
    period_s : float
        Sampling period δ [s].
    """

    def __init__(self, params: EstimatorParams, eta: float, period_s: float) -> None:
        if not isinstance(params, EstimatorParams):
            raise ParameterError(f"estimator must be EstimatorParams, got {type(params).__name__}")
        self.params = params
        self.gain = steady_state_gain(params, eta, period_s)

    def correct(self, predicted: np.ndarray, com_pos_m: np.ndarray, com_vel_mps: np.ndarray) -> np.ndarray:
        """Filtered (CoM, CoM velocity).

        Parameters
        ----------
        predicted : ndarray, shape (2, 2)
            Rows CoM position [m] and velocity [m/s], columns x and y: the model's prediction.
        com_pos_m, com_vel_mps : ndarray, shape (2,)
            Measured CoM position [m] and velocity [m/s] (world frame).

        Returns
        -------
        ndarray, shape (2, 2)
            Same layout as ``predicted``.
        """
        innovation = np.vstack([com_pos_m, com_vel_mps]) - predicted
        return predicted + self.gain @ innovation


class DisturbanceEstimator:
    r"""The CoM acceleration the contacts do not explain, measured over each control period.

    Between two measurements :math:`k-1` and :math:`k`, :math:`\delta` apart, Newton's law for the
    horizontal CoM motion, :math:`m \ddot x_c = f_{xy} + m w`, averaged over the period gives

    .. math::

        w_k = \frac{\dot x_c^k - \dot x_c^{k-1}}{\delta} - \bar a_k,

    with :math:`\bar a_k` the horizontal contact force per unit mass averaged over the period
    (:attr:`~robust_ismpc.core.reference.Measurement.contact_acc_mps2`; on the LIP
    :math:`\eta^2 (x_c - x_z)` averaged). An external moment about the CoM (a push above the
    CoM, a load hanging off an arm) needs the ZMP to move just like a force does; when the
    measurement carries it as an acceleration
    (:attr:`~robust_ismpc.core.reference.Measurement.external_moment_acc_mps2`) it is added. Nothing
    else enters: a robot's own swinging and spinning
    move its centre of pressure, not its CoM's acceleration, so undisturbed the estimate stays
    near zero, and a push shows at the next measurement. The raw value is low-pass filtered with
    time constant ``time_constant_s`` (the estimate of a 0.1 s push ends about that long after
    the push).

    Parameters
    ----------
    time_constant_s : float
        Time constant of the first-order low-pass filter [s] (0: none).
    """

    def __init__(self, time_constant_s: float) -> None:
        check_nonnegative("DisturbanceEstimator", time_constant_s=time_constant_s)
        self.time_constant_s = float(time_constant_s)
        self.reset()

    def reset(self) -> None:
        """Forget the previous measurement; the estimate restarts from zero."""
        self.estimate_mps2 = np.zeros(2)
        self._previous: tuple[float, np.ndarray] | None = None

    def update(self, t_s: float, com_vel_mps: np.ndarray, contact_acc_mps2: np.ndarray | None,
               moment_acc_mps2: np.ndarray | None = None) -> np.ndarray:
        """Estimate ŵ [m/s²], shape (2,), after the measurement at ``t_s`` [s].

        Parameters
        ----------
        com_vel_mps : ndarray, shape (2,) or (3,)
            Measured CoM velocity [m/s] (world frame; a third component is ignored).
        contact_acc_mps2 : ndarray, shape (2,) or None
            Horizontal contact force per unit mass over the period that ended at ``t_s``
            [m/s²]; None: not measured, the estimate holds.
        moment_acc_mps2 : ndarray, shape (2,) or None
            The external moment about the CoM over the same period as an LIP acceleration
            (:attr:`~robust_ismpc.core.reference.Measurement.external_moment_acc_mps2`) [m/s²],
            added to the estimate; None: 0.
        """
        vel = np.asarray(com_vel_mps, float)[:2].copy()
        previous = self._previous
        self._previous = (float(t_s), vel)
        if previous is None or contact_acc_mps2 is None or not t_s > previous[0]:
            return self.estimate_mps2.copy()
        period = t_s - previous[0]
        raw = (vel - previous[1]) / period - np.asarray(contact_acc_mps2, float)[:2]
        if moment_acc_mps2 is not None:
            raw = raw + np.asarray(moment_acc_mps2, float)[:2]
        alpha = period / (self.time_constant_s + period)
        self.estimate_mps2 = self.estimate_mps2 + alpha * (raw - self.estimate_mps2)
        return self.estimate_mps2.copy()


__all__ = ["DisturbanceEstimator", "EstimatorParams", "StateEstimator", "steady_state_gain"]
