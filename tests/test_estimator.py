"""The estimator: the MPC's start state from the measurement, and the measured disturbance."""

from __future__ import annotations

import numpy as np
import pytest

from robust_ismpc.core.lip import discretise
from robust_ismpc.estimation.estimator import (
    DisturbanceEstimator,
    EstimatorParams,
    StateEstimator,
    disturbance_gain,
    disturbance_noise_std,
    steady_state_gain,
)
from robust_ismpc.estimation.filters import MidrangeFilter, MidrangeParams, PersistenceFilter
from robust_ismpc.exceptions import ParameterError

ETA = np.sqrt(9.81 / 0.71)
DT = 0.01
ROBOT_NOISE = EstimatorParams(com_pos_noise_m=0.005, com_vel_noise_mps=0.05, acc_noise_mps2=0.5)


def test_an_exact_measurement_is_taken_as_it_is():
    """Zero measurement noise: K = I, the corrected state is the measurement."""
    np.testing.assert_array_equal(steady_state_gain(EstimatorParams(), ETA, DT), np.eye(2))
    estimator = StateEstimator(EstimatorParams(), ETA, DT)
    corrected = estimator.correct(np.array([[0.1, 0.2], [0.3, 0.4]]), np.array([1.0, 2.0]), np.array([3.0, 4.0]))
    np.testing.assert_array_equal(corrected, [[1.0, 2.0], [3.0, 4.0]])


def test_the_steady_state_gain_solves_the_riccati_equation():
    """K = P (P + R)⁻¹ with P the fixed point of P = A (I - K) P Aᵀ + Q (the predicted covariance)."""
    K = steady_state_gain(ROBOT_NOISE, ETA, DT)
    lip = discretise(ETA, DT)
    A, G = lip.A[:2, :2], lip.E[:2].reshape(2, 1)
    Q = ROBOT_NOISE.acc_noise_mps2**2 * G @ G.T
    R = np.diag([ROBOT_NOISE.com_pos_noise_m**2, ROBOT_NOISE.com_vel_noise_mps**2])
    # P from K: K (P + R) = P gives P = (I - K)⁻¹ K R
    P = np.linalg.inv(np.eye(2) - K) @ K @ R
    np.testing.assert_allclose(A @ (np.eye(2) - K) @ P @ A.T + Q, P, rtol=1e-8, atol=1e-14)
    # the filter's error dynamics (I - K) A are stable
    assert np.max(np.abs(np.linalg.eigvals((np.eye(2) - K) @ A))) < 1.0


def test_a_filtered_estimate_converges_to_a_steady_measurement():
    """A model that is off by 2 cm and 0.1 m/s is pulled onto a measurement that follows the
    same LIP: the error decays with (I - K) A."""
    lip = discretise(ETA, DT)
    estimator = StateEstimator(ROBOT_NOISE, ETA, DT)
    true = np.array([[0.0, 0.0], [0.1, 0.0], [0.0, 0.0]])  # rows CoM, velocity, ZMP; columns x, y
    model = true.copy()
    model[0] += [0.02, -0.01]
    model[1] += [0.1, 0.05]
    errors = []
    for _ in range(300):
        model[:2] = estimator.correct(model[:2], true[0], true[1])
        errors.append(np.max(np.abs(model[:2] - true[:2])))
        true = lip.A @ true
        model = lip.A @ model
    assert errors[-1] < 1e-4 * errors[0]


def _lip_walk(w_of_t, seconds: float):
    """A LIP swaying under a ZMP sine, yielding (t, CoM velocity, period-mean contact acceleration)
    as lip_sim measures them, with the disturbance w_of_t(t) per axis."""
    lip = discretise(ETA, DT)
    state = np.zeros((3, 2))
    contact_acc = np.zeros(2)
    for k in range(int(round(seconds / DT))):
        t = k * DT
        yield t, state[1].copy(), contact_acc.copy()
        zmp_vel = 0.05 * 2 * np.pi * np.array([np.cos(2 * np.pi * t), -np.sin(2 * np.pi * t)])
        w = np.asarray(w_of_t(t), float)
        previous_vel = state[1]
        state = lip.A @ state + np.outer(lip.B, zmp_vel) + np.outer(lip.E, w)
        contact_acc = (state[1] - previous_vel) / DT - w


def test_the_measured_disturbance_is_exact_on_the_lip_after_the_filter():
    """A constant force: the unfiltered estimate equals w from the second measurement on; the
    filtered one converges with its time constant (within 1 % after 0.2 s, about 6 τ: the
    discrete filter keeps 3/4 of its error per 10 ms period)."""
    w = np.array([0.8, -0.3])
    raw, filtered = DisturbanceEstimator(0.0), DisturbanceEstimator(0.03)
    for t, vel, acc in _lip_walk(lambda t: w, 0.5):
        a, b = raw.update(t, vel, acc), filtered.update(t, vel, acc)
        if t >= 2 * DT - 1e-9:
            np.testing.assert_allclose(a, w, atol=1e-9)
        if t >= 0.2 - 1e-9:
            np.testing.assert_allclose(b, w, rtol=0.01)


def test_the_estimate_of_a_push_ends_with_the_push():
    """A 0.1 s push: the estimate reaches 90 % of the push (1 - 0.75¹⁰ in ten periods) and is back
    below 5 % of it 0.1 s after the push has ended (the filter's 30 ms time constant)."""
    push = np.array([0.0, 1.5])
    estimator = DisturbanceEstimator(0.03)
    peak, after = 0.0, None
    for t, vel, acc in _lip_walk(lambda t: push if 1.0 <= t < 1.1 else np.zeros(2), 1.5):
        w = estimator.update(t, vel, acc)
        peak = max(peak, w[1])
        if abs(t - 1.21) < 1e-9:
            after = w[1]
    assert peak > 0.9 * push[1]
    assert after is not None and abs(after) < 0.05 * push[1]


SENSOR_VEL_NOISE = 0.03  # m/s, the realistic preset's
SENSOR_ACC_NOISE = 0.02 * 9.81 * np.sqrt(2.0)  # m/s², force and moment at 2 % of the weight


def _noisy_estimates(estimator: DisturbanceEstimator, w: np.ndarray, seconds: float, seed: int,
                     moment_acc: np.ndarray | None = None, vel_noise: float = SENSOR_VEL_NOISE,
                     acc_noise: float = SENSOR_ACC_NOISE) -> np.ndarray:
    """Estimates of ``estimator`` for a CoM held against a constant ``w`` (its force part
    ``w - moment_acc`` balanced by the contacts, plus a 1 Hz sway of 0.5 m/s²), with sensor
    noise (the realistic preset's by default) added to the velocity and to the contact and
    moment accelerations."""
    rng = np.random.default_rng(seed)
    moment_acc = np.zeros(2) if moment_acc is None else moment_acc
    sigma_a = acc_noise / np.sqrt(2.0)
    force = np.asarray(w, float) - moment_acc
    vel = np.zeros(2)
    contact_acc = np.zeros(2)
    out = []
    for k in range(int(round(seconds / DT))):
        t = k * DT
        out.append(estimator.update(t, vel + vel_noise * rng.standard_normal(2),
                                    contact_acc + sigma_a * rng.standard_normal(2),
                                    moment_acc + sigma_a * rng.standard_normal(2)))
        contact_acc = -force + 0.5 * np.sin(2 * np.pi * t) * np.ones(2)
        vel = vel + DT * (contact_acc + force)
    return np.array(out)


def test_without_sensor_noise_the_gain_differentiates_the_velocity():
    np.testing.assert_allclose(disturbance_gain(0.0, 0.0, DT), [1.0, 1.0 / DT])


def test_the_disturbance_gain_is_the_steady_state_of_its_riccati_equation():
    """One more prediction-correction step from the covariance the gain implies leaves the gain
    unchanged, and the gain is a low-pass one (K_v < 1, 0 < K_w < 1/δ)."""
    k = disturbance_gain(SENSOR_VEL_NOISE, SENSOR_ACC_NOISE, DT)
    assert 0 < k[0] < 1 and 0 < k[1] < 1 / DT
    again = disturbance_gain(SENSOR_VEL_NOISE, SENSOR_ACC_NOISE, DT, iterations=20_000, tolerance=0.0)
    np.testing.assert_allclose(k, again, rtol=1e-9)


@pytest.mark.parametrize("vel_noise, acc_noise", [(SENSOR_VEL_NOISE, 0.0), (0.015, 0.0), (0.0, SENSOR_ACC_NOISE)])
def test_a_disturbance_gain_with_one_signal_exact_still_estimates(vel_noise, acc_noise):
    """Noise on one signal only (the other exact) gives a low-pass gain with K_w > 0 that is the
    Riccati steady state, and the estimate reaches a constant w; with an exact contact force the
    Riccati iteration's first gain is 0, which once stopped it there and left ŵ at 0 for good."""
    k = disturbance_gain(vel_noise, acc_noise, DT)
    assert 0 < k[1] <= 1 / DT and 0 < k[0] <= 1
    np.testing.assert_allclose(k, disturbance_gain(vel_noise, acc_noise, DT, iterations=20_000, tolerance=0.0),
                               rtol=1e-9)
    w = np.array([0.6, -0.2])
    estimates = _noisy_estimates(DisturbanceEstimator(0.03, DT, vel_noise, acc_noise), w, 10.0, seed=4,
                                 vel_noise=vel_noise, acc_noise=acc_noise)[200:]
    np.testing.assert_allclose(estimates.mean(axis=0), w, atol=0.03)


def test_with_noisy_sensors_the_filter_is_unbiased_and_ten_times_quieter_than_differentiating():
    """A constant w under the realistic sensor noise: after 1 s the filter's estimate is centred on
    w (mean over 30 s within 0.02 m/s²) with a standard deviation below 0.1 m/s²; differentiating the noisy
    velocity (the exact gain, same 30 ms low-pass) gives more than ten times that."""
    w = np.array([0.6, -0.2])
    filtered = DisturbanceEstimator(0.03, DT, SENSOR_VEL_NOISE, SENSOR_ACC_NOISE)
    differentiated = DisturbanceEstimator(0.03, DT)
    a = _noisy_estimates(filtered, w, 30.0, seed=1)[100:]
    b = _noisy_estimates(differentiated, w, 30.0, seed=1)[100:]
    np.testing.assert_allclose(a.mean(axis=0), w, atol=0.02)
    assert np.all(a.std(axis=0) < 0.1)
    assert np.all(b.std(axis=0) > 10 * a.std(axis=0))


def test_the_estimates_noise_is_the_filters_stationary_one():
    """The standard deviation of ŵ under a constant w and white sensor noise, over 60 s, is the
    one :func:`disturbance_noise_std` computes from the filter (within 10 %); exact signals: 0."""
    estimator = DisturbanceEstimator(0.03, DT, SENSOR_VEL_NOISE, SENSOR_ACC_NOISE)
    estimates = _noisy_estimates(estimator, np.array([0.3, -0.1]), 60.0, seed=7)[100:]
    assert estimator.noise_std_mps2 == disturbance_noise_std(SENSOR_VEL_NOISE, SENSOR_ACC_NOISE, DT, 0.03)
    np.testing.assert_allclose(estimates.std(axis=0), estimator.noise_std_mps2, rtol=0.1)
    assert DisturbanceEstimator(0.03, DT).noise_std_mps2 == 0.0


def test_with_noisy_sensors_a_moment_is_estimated_like_a_force():
    """Half of w as a moment about the CoM (it moves the ZMP, not the CoM): the same estimate."""
    w = np.array([0.4, 0.3])
    estimator = DisturbanceEstimator(0.03, DT, SENSOR_VEL_NOISE, SENSOR_ACC_NOISE)
    a = _noisy_estimates(estimator, w, 30.0, seed=2, moment_acc=0.5 * w)[100:]
    np.testing.assert_allclose(a.mean(axis=0), w, atol=0.02)


def test_the_moment_part_of_the_estimate_is_kept_apart():
    """A push (the CoM accelerates 0.5 m/s² more than the contacts explain) and a moment of 0.3
    m/s² on the other axis (the CoM does not accelerate; the contacts' moment says it): ŵ holds
    both, and its moment part only the moment."""
    estimator = DisturbanceEstimator(0.03, DT)
    vel = np.zeros(2)
    for k in range(100):
        vel = vel + DT * np.array([0.5, 0.0])
        estimator.update(k * DT, vel, np.zeros(2), np.array([0.0, 0.3]))
    np.testing.assert_allclose(estimator.estimate_mps2, [0.5, 0.3], atol=1e-6)
    np.testing.assert_allclose(estimator.moment_estimate_mps2, [0.0, 0.3], atol=1e-6)


def test_with_noisy_sensors_the_estimate_follows_a_step_within_a_quarter_second():
    """The lag the noise costs: 63 % of a step in w within 0.25 s (noise-free: 0.04 s)."""
    step = np.array([1.0, 0.0])
    est = _noisy_estimates(DisturbanceEstimator(0.03, DT, SENSOR_VEL_NOISE, SENSOR_ACC_NOISE), step, 0.25, seed=3)
    assert np.mean(est[-3:, 0]) > 0.63


def test_without_a_contact_force_the_estimate_holds():
    estimator = DisturbanceEstimator(0.0)
    estimator.update(0.0, np.zeros(2), np.zeros(2))
    first = estimator.update(0.01, np.array([0.01, 0.0]), np.zeros(2))
    np.testing.assert_allclose(first, [1.0, 0.0])
    np.testing.assert_array_equal(estimator.update(0.02, np.array([0.5, 0.5]), None), first)


@pytest.mark.parametrize("kwargs, name", [
    ({"com_pos_noise_m": -1.0}, "com_pos_noise_m"),
    ({"com_vel_noise_mps": float("nan")}, "com_vel_noise_mps"),
    ({"com_pos_noise_m": 0.01, "acc_noise_mps2": 0.0}, "acc_noise_mps2"),
])
def test_bad_estimator_params_raise(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        EstimatorParams(**kwargs)


@pytest.mark.parametrize("bad", [-0.01, float("inf"), True])
def test_bad_disturbance_time_constant_raises(bad):
    with pytest.raises(ParameterError, match="time_constant_s"):
        DisturbanceEstimator(bad)


def test_persistence_passes_a_lasting_estimate_and_drops_a_short_one():
    window = 5
    persistence = PersistenceFilter(window)
    for _ in range(window - 1):
        np.testing.assert_array_equal(persistence.update(np.array([1.0, -1.0])), [0.0, 0.0])
    np.testing.assert_array_equal(persistence.update(np.array([1.0, -1.0])), [1.0, -1.0])
    np.testing.assert_array_equal(persistence.update(np.array([-0.5, -2.0])), [0.0, -1.0])


def test_midrange_filter_rate_limit_and_band():
    """The mid-range filter never changes by more than the rate limit per sample and stays in the band."""
    filt = MidrangeFilter(MidrangeParams(max_change_mps2=0.01, band_centre_mps2=(0.2, 0.0), band_half_width_mps2=0.25))
    rng = np.random.default_rng(1)
    prev = filt.value
    for _ in range(500):
        out = filt.update(rng.normal(0.0, 1.0, 2))
        assert np.all(np.abs(out - prev) <= 0.01 + 1e-15)
        assert np.all(out >= np.array([-0.05, -0.25]) - 1e-15) and np.all(out <= np.array([0.45, 0.25]) + 1e-15)
        prev = out
    filt.reset()
    for _ in range(100):
        out = filt.update(np.array([0.3, -0.1]))
    assert np.allclose(out, [0.3, -0.1])  # inside the band: tracked exactly once the ramp is over
    with pytest.raises(ParameterError):
        MidrangeParams(max_change_mps2=0.0)
    with pytest.raises(ParameterError):
        MidrangeParams(band_half_width_mps2=0.2)
