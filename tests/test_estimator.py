"""The estimator: the MPC's start state from the measurement, and the measured disturbance."""

from __future__ import annotations

import numpy as np
import pytest

from robust_ismpc.core.lip import discretise
from robust_ismpc.estimation.estimator import (
    DisturbanceEstimator,
    EstimatorParams,
    StateEstimator,
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
