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
from scipy.linalg import solve_discrete_lyapunov

from ..core.lip import discretise
from ..exceptions import ParameterError
from ..validation import check_nonnegative, check_positive


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
    sensor_vel_noise_mps : float
        Noise of the CoM velocity sensor alone [m/s], per axis and sample: what the disturbance
        filter (:class:`DisturbanceEstimator`, which uses the measured contact force rather than
        the LIP's prediction) must average out.
    sensor_contact_acc_noise_mps2 : float
        Noise of the measured contact force per unit mass [m/s²], per axis and sample.
    """

    com_pos_noise_m: float = 0.0
    com_vel_noise_mps: float = 0.0
    acc_noise_mps2: float = 1.0
    sensor_vel_noise_mps: float = 0.0
    sensor_contact_acc_noise_mps2: float = 0.0

    def __post_init__(self) -> None:
        check_nonnegative("EstimatorParams", com_pos_noise_m=self.com_pos_noise_m,
                          com_vel_noise_mps=self.com_vel_noise_mps, acc_noise_mps2=self.acc_noise_mps2,
                          sensor_vel_noise_mps=self.sensor_vel_noise_mps,
                          sensor_contact_acc_noise_mps2=self.sensor_contact_acc_noise_mps2)
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
    G = lip.E[:2].reshape(2, 1)
    Q = params.acc_noise_mps2**2 * (G @ G.T)
    R = np.diag([params.com_pos_noise_m**2, params.com_vel_noise_mps**2])
    return _steady_state_kalman_gain(lip.A[:2, :2], np.eye(2), Q, R, iterations, tolerance)


def _steady_state_kalman_gain(A: np.ndarray, H: np.ndarray, Q: np.ndarray, R: np.ndarray, iterations: int,
                              tolerance: float) -> np.ndarray:
    """Gain K, shape (n, m), of the Riccati iteration of x' = A x + noise (covariance Q, n x n),
    y = H x + noise (covariance R, m x m), from the predicted covariance Q, until two successive
    gains differ by less than ``tolerance`` or after ``iterations``."""
    n = A.shape[0]
    P = Q.copy()  # predicted covariance
    K: np.ndarray | None = None
    for _ in range(iterations):
        S = H @ P @ H.T + R
        K_next = np.linalg.solve(S.T, (P @ H.T).T).T  # P Hᵀ S⁻¹
        corrected = (np.eye(n) - K_next @ H) @ P
        P = A @ corrected @ A.T + Q
        # (compared from the second gain on: where Q leaves a measured state without noise, the
        # first gain is 0 whatever the steady state)
        if K is not None and np.max(np.abs(K_next - K)) < tolerance:
            return K_next
        K = K_next
    assert K is not None
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


#: How fast the disturbance estimate's model lets the disturbance change: a random walk of
#: this many m/s² per second per square root of a sample (σ_w = rate · δ per sample). With the
#: realistic sensors (3 cm/s, 2 % of the weight) it gives an estimate 63 % of the way to a step in
#: 0.14 s with 0.08 m/s² of noise (docs/closed-loop.md, "Sensing").
DISTURBANCE_RATE_MPS3 = 5.0


def disturbance_gain(vel_noise_mps: float, contact_acc_noise_mps2: float, period_s: float,
                     iterations: int = 10_000, tolerance: float = 1e-12) -> np.ndarray:
    r"""Steady-state Kalman gain (K_v, K_w), shape (2,), of the disturbance filter.

    Per axis the filter's state is the CoM velocity and the disturbance, :math:`(\dot x_c, w)`:

    .. math::

        \dot x_c^{k} = \dot x_c^{k-1} + \delta\,(\bar a_k + w_{k-1} + \nu_a), \qquad
        w_k = w_{k-1} + \nu_w,

    with :math:`\bar a_k` the measured contact acceleration, :math:`\nu_a \sim \mathcal N(0,
    \sigma_a^2)` its noise, :math:`\nu_w \sim \mathcal N(0, (\rho\delta)^2)` the disturbance's
    random walk (:data:`DISTURBANCE_RATE_MPS3`), and the measured velocity :math:`y = \dot x_c +
    \epsilon`, :math:`\epsilon \sim \mathcal N(0, \sigma_v^2)`. Without noise the gain is
    :math:`(1, 1/\delta)`: the estimate is the velocity's change over the period minus the contact
    acceleration.

    Parameters
    ----------
    vel_noise_mps : float
        σ_v, noise of the measured CoM velocity [m/s].
    contact_acc_noise_mps2 : float
        σ_a, noise of the measured contact acceleration [m/s²].
    period_s : float
        δ [s].
    """
    if vel_noise_mps == 0 and contact_acc_noise_mps2 == 0:
        return np.array([1.0, 1.0 / period_s])
    A = np.array([[1.0, period_s], [0.0, 1.0]])
    Q = np.diag([(period_s * contact_acc_noise_mps2) ** 2, (DISTURBANCE_RATE_MPS3 * period_s) ** 2])
    gain = _steady_state_kalman_gain(A, np.array([[1.0, 0.0]]), Q, np.array([[vel_noise_mps**2]]), iterations, tolerance)
    return gain[:, 0]


def disturbance_noise_std(vel_noise_mps: float, contact_acc_noise_mps2: float, period_s: float,
                          time_constant_s: float) -> float:
    r"""Standard deviation [m/s²] of the estimate ŵ of :class:`DisturbanceEstimator` under a
    constant disturbance, per axis, from the sensors' white noise alone.

    The filter's error :math:`e = (\dot x_c - \hat{\dot x}_c, w - w_k)` evolves as
    :math:`e_k = (I - K H)(A e_{k-1} + G \nu_a) - K \epsilon` (:func:`disturbance_gain`), and
    the low-pass output's error as :math:`l_k = (1 - \alpha) l_{k-1} + \alpha e_{w,k}` with
    :math:`\alpha = \delta / (\tau + \delta)`; the stationary covariance of this linear system
    (a discrete Lyapunov equation) gives the value. 0 for exact signals.

    Parameters
    ----------
    vel_noise_mps, contact_acc_noise_mps2 : float
        Noise of the measured CoM velocity [m/s] and contact acceleration [m/s²].
    period_s : float
        δ [s].
    time_constant_s : float
        τ of the low-pass filter [s].
    """
    if vel_noise_mps == 0 and contact_acc_noise_mps2 == 0:
        return 0.0
    k_v, k_w = disturbance_gain(vel_noise_mps, contact_acc_noise_mps2, period_s)
    gain = np.array([[k_v], [k_w]])
    closed = np.eye(2) - gain @ np.array([[1.0, 0.0]])
    alpha = period_s / (time_constant_s + period_s)
    error = closed @ np.array([[1.0, period_s], [0.0, 1.0]])
    F = np.zeros((3, 3))
    F[:2, :2] = error
    F[2, :2] = alpha * error[1]
    F[2, 2] = 1.0 - alpha
    G = np.zeros((3, 2))  # inputs: the contact acceleration's noise, the velocity's
    G[:2, 0] = closed @ np.array([period_s, 0.0])
    G[:2, 1] = -gain[:, 0]
    G[2] = alpha * G[1]
    covariance = solve_discrete_lyapunov(F, G @ np.diag([contact_acc_noise_mps2**2, vel_noise_mps**2]) @ G.T)
    return float(np.sqrt(covariance[2, 2]))


class DisturbanceEstimator:
    r"""The CoM acceleration the contacts do not explain: a Kalman filter on velocity and disturbance.

    Newton's law for the horizontal CoM motion, :math:`m \ddot x_c = f_{xy} + m w`, over one
    control period :math:`\delta` predicts the CoM velocity from the previous one, the measured
    contact force per unit mass averaged over the period, :math:`\bar a_k`
    (:attr:`~robust_ismpc.core.reference.Measurement.contact_acc_mps2`; on the LIP
    :math:`\eta^2 (x_c - x_z)` averaged), and the disturbance estimate; the measured velocity
    corrects both (gain :func:`disturbance_gain`):

    .. math::

        e_k = \dot x_c^k - \big(\hat{\dot x}_c^{k-1} + \delta (\bar a_k + \hat w_{k-1})\big), \qquad
        \hat{\dot x}_c^k = \hat{\dot x}_c^{k-1} + \delta (\bar a_k + \hat w_{k-1}) + K_v e_k, \qquad
        w_k = \hat w_{k-1} + K_w e_k .

    With exact signals :math:`K = (1, 1/\delta)` and :math:`w_k` is the velocity's change over the
    period minus the contact acceleration; with noisy ones the filter integrates the velocity
    rather than differentiating it. An external moment about the CoM (a push above the CoM, a
    load hanging off an arm) needs the ZMP to move just like a force does; when the measurement
    carries it as an acceleration
    (:attr:`~robust_ismpc.core.reference.Measurement.external_moment_acc_mps2`) it is added to
    :math:`w_k`. Nothing else enters: a robot's own swinging and spinning move its centre of
    pressure, not its CoM's acceleration, so undisturbed the estimate stays near zero. The
    estimate :math:`\hat w` is :math:`w_k` low-pass filtered with time constant
    ``time_constant_s``; :attr:`moment_estimate_mps2` is the measured moment alone, low-pass
    filtered with the same time constant (not through the noise filter, which estimates the sum):
    a whole body needs to know which part of the disturbance is a moment, since it moves the
    centre of pressure without pushing the CoM.

    Parameters
    ----------
    time_constant_s : float
        Time constant of the first-order low-pass filter [s] (0: none).
    period_s : float
        Control period δ [s] the gain is computed for.
    vel_noise_mps, contact_acc_noise_mps2 : float
        Noise of the measured CoM velocity [m/s] and contact acceleration [m/s²] (0: exact).
    """

    def __init__(self, time_constant_s: float, period_s: float = 0.01, vel_noise_mps: float = 0.0,
                 contact_acc_noise_mps2: float = 0.0) -> None:
        check_nonnegative("DisturbanceEstimator", time_constant_s=time_constant_s, vel_noise_mps=vel_noise_mps,
                          contact_acc_noise_mps2=contact_acc_noise_mps2)
        check_positive("DisturbanceEstimator", period_s=period_s)
        self.time_constant_s = float(time_constant_s)
        self.gain = disturbance_gain(vel_noise_mps, contact_acc_noise_mps2, period_s)
        self.exact = vel_noise_mps == 0 and contact_acc_noise_mps2 == 0
        #: standard deviation of the estimate from the sensors' noise alone [m/s²]
        #: (:func:`disturbance_noise_std`)
        self.noise_std_mps2 = disturbance_noise_std(vel_noise_mps, contact_acc_noise_mps2, period_s,
                                                    self.time_constant_s)
        self.reset()

    def reset(self) -> None:
        """Forget the previous measurement; the estimate restarts from zero."""
        self.estimate_mps2 = np.zeros(2)
        self.moment_estimate_mps2 = np.zeros(2)
        self._w = np.zeros(2)
        self._previous: tuple[float, np.ndarray] | None = None  # time, filtered velocity

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
        if previous is None or contact_acc_mps2 is None or not t_s > previous[0]:
            self._previous = (float(t_s), vel)
            return self.estimate_mps2.copy()
        period = t_s - previous[0]
        contact_acc = np.asarray(contact_acc_mps2, float)[:2]
        moment_acc = np.zeros(2) if moment_acc_mps2 is None else np.asarray(moment_acc_mps2, float)[:2]
        if self.exact:  # K = (1, 1/δ) written out, for the period that passed
            self._previous = (float(t_s), vel)
            raw = (vel - previous[1]) / period - contact_acc + moment_acc
        else:
            # the filter's w is the force part plus the moment part: the velocity changes by
            # (contact_acc + force part) = (contact_acc - moment_acc) + w
            predicted = previous[1] + period * (contact_acc - moment_acc + self._w)
            innovation = vel - predicted
            k_v, k_w = self.gain
            self._previous = (float(t_s), predicted + k_v * innovation)
            self._w = self._w + k_w * innovation
            raw = self._w
        alpha = period / (self.time_constant_s + period)
        self.estimate_mps2 = self.estimate_mps2 + alpha * (raw - self.estimate_mps2)
        self.moment_estimate_mps2 = self.moment_estimate_mps2 + alpha * (moment_acc - self.moment_estimate_mps2)
        return self.estimate_mps2.copy()


__all__ = ["DISTURBANCE_RATE_MPS3", "DisturbanceEstimator", "EstimatorParams", "StateEstimator", "disturbance_gain",
           "disturbance_noise_std", "steady_state_gain"]
