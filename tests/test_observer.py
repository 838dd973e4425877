"""Tests of robust_ismpc.observer: exact discretisation, pole placement, convergence, mid-range filter."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

from robust_ismpc.exceptions import ParameterError
from robust_ismpc.observer import (
    DisturbanceObserver,
    MidrangeFilter,
    MidrangeParams,
    ObserverParams,
    observer_gain,
    observer_matrices,
)
from robust_ismpc.params import GRAVITY_MPS2

REFERENCE_GAIN_XC_COLUMN = np.array([0.90131, 26.18387, 239.94774])  # HRP4-Robust-ISMPC, h 0.71, δ 0.01


def _continuous(eta: float) -> tuple[np.ndarray, np.ndarray]:
    A = np.zeros((4, 4))
    A[0, 1] = 1.0
    A[1, 0], A[1, 2], A[1, 3] = eta**2, -eta**2, 1.0
    return A, np.array([0.0, 0.0, 1.0, 0.0])


def _simulate(obs: DisturbanceObserver, w_true: np.ndarray, seconds: float, rng=None, noise=(0.0, 0.0),
              zmp_available: bool = True) -> np.ndarray:
    """Exact LIP (matrix exponential of the continuous model) under a stabilising DCM law plus a ZMP
    sweep, so the motion stays bounded and excites the observer; returns the ŵ history."""
    p = obs.params
    eta, delta = p.eta, p.sampling_period_s
    A, B = _continuous(eta)
    M = np.zeros((5, 5))
    M[:4, :4], M[:4, 4] = A, B
    Phi = scipy.linalg.expm(M * delta)
    x = np.zeros((2, 4))
    x[:, 3] = w_true
    x[:, 0] = 0.01
    obs.reset(np.array([0.01, 0.01]), np.zeros(2), np.zeros(2))
    history = []
    u = np.zeros(2)
    for k in range(int(round(seconds / delta))):
        com = x[:, 0] + (rng.normal(0, noise[0], 2) if rng is not None else 0.0)
        zmp = x[:, 2] + (rng.normal(0, noise[1], 2) if rng is not None else 0.0)
        history.append(obs.update(com, zmp if zmp_available else None, u))
        dcm = x[:, 0] + x[:, 1] / eta + x[:, 3] / eta**2
        zmp_target = 2.0 * dcm + 0.02 * np.array([math.sin(3 * k * delta), math.cos(2 * k * delta)])
        u = 20.0 * (zmp_target - x[:, 2])  # ZMP velocity [m/s]
        x = x @ Phi[:4, :4].T + np.outer(u, Phi[:4, 4])
    return np.array(history)


@pytest.mark.parametrize("h, delta", [(0.71, 0.01), (0.23, 0.005), (0.9, 0.05)])
def test_discretisation_is_matrix_exponential(h, delta):
    """A_od and B_od equal expm of the continuous extended LIP augmented with B."""
    eta = math.sqrt(GRAVITY_MPS2 / h)
    A_od, B_od, C_o = observer_matrices(eta, delta)
    A, B = _continuous(eta)
    M = np.zeros((5, 5))
    M[:4, :4], M[:4, 4] = A, B
    Phi = scipy.linalg.expm(M * delta)
    assert np.allclose(A_od, Phi[:4, :4], rtol=0, atol=1e-12)
    assert np.allclose(B_od, Phi[:4, 4], rtol=0, atol=1e-12)
    assert np.array_equal(C_o, [[1, 0, 0, 0], [0, 0, 1, 0]])


@pytest.mark.parametrize("h, delta, poles, zmp_pole", [
    (0.71, 0.01, (0.6, 0.7, 0.8), 0.5),
    (0.78, 0.005, (0.6, 0.7, 0.8), 0.5),
    (0.23, 0.01, (0.3, 0.5, 0.9), 0.2),
    (1.0, 0.05, (0.1, 0.2, 0.4), 0.0),
])
def test_error_dynamics_have_requested_poles(h, delta, poles, zmp_pole):
    """The eigenvalues of A_od − G C_o are exactly the requested discrete poles."""
    obs = DisturbanceObserver(ObserverParams(com_height_m=h, sampling_period_s=delta, poles=poles, zmp_pole=zmp_pole))
    eig = np.sort(np.linalg.eigvals(obs.A_od - obs.G @ obs.C_o).real)
    assert np.allclose(eig, np.sort([*poles, zmp_pole]), atol=1e-8)
    assert np.max(np.abs(np.linalg.eigvals(obs.A_od - obs.G @ obs.C_o).imag)) < 1e-8


def test_reference_gain_reproduced_with_euler_disturbance_column():
    """With the reference code's Euler w-column the x_c column equals its gain to 1e-3 relative."""
    eta = math.sqrt(GRAVITY_MPS2 / 0.71)
    A_euler, _, _ = observer_matrices(eta, 0.01, "euler_disturbance")
    G = observer_gain(A_euler, (0.6, 0.7, 0.8), 0.5)
    assert np.allclose(G[[0, 1, 3], 0], REFERENCE_GAIN_XC_COLUMN, rtol=1e-3, atol=0)
    assert G[2, 1] == pytest.approx(0.5)
    # With the exact discretisation the same poles need a different CoM-velocity gain (~24.99).
    G_exact = DisturbanceObserver(ObserverParams(com_height_m=0.71)).G
    assert np.allclose(G_exact[[0, 3], 0], REFERENCE_GAIN_XC_COLUMN[[0, 2]], rtol=1e-3, atol=0)
    assert G_exact[1, 0] == pytest.approx(24.9947, rel=1e-4)


def test_converges_to_constant_disturbance_within_half_a_second():
    """From ŵ = 0 the estimate of a constant w reaches 2 % within 0.5 s (measured: 0.22 s) and stays there."""
    obs = DisturbanceObserver(ObserverParams(com_height_m=0.71))
    w_true = np.array([0.6, -0.3])
    hist = _simulate(obs, w_true, 2.0)
    err = np.max(np.abs(hist - w_true) / np.abs(w_true), axis=1)
    settled = np.flatnonzero(err > 0.02)
    t_settle = (settled[-1] + 1) * 0.01
    assert t_settle <= 0.5
    assert np.max(np.abs(hist[-50:] - w_true)) < 1e-9


def test_converges_without_zmp_measurement():
    """Without ZMP measurements (prediction used instead) the CoM alone still recovers w within 0.5 s."""
    obs = DisturbanceObserver(ObserverParams(com_height_m=0.71))
    w_true = np.array([-0.4, 0.25])
    hist = _simulate(obs, w_true, 1.5, zmp_available=False)
    assert np.max(np.abs(hist[50:] - w_true) / np.abs(w_true)) < 0.02


def test_estimate_stays_zero_without_disturbance():
    """With exact measurements, a correct initial state and w = 0, ŵ stays at zero."""
    obs = DisturbanceObserver(ObserverParams(com_height_m=0.71))
    hist = _simulate(obs, np.zeros(2), 3.0)
    assert np.max(np.abs(hist)) < 1e-10


def test_estimate_bounded_under_measurement_noise():
    """With 1 mm CoM and 5 mm CoP white noise ŵ stays bounded and unbiased; the mid-range filter smooths it."""
    obs = DisturbanceObserver(ObserverParams(com_height_m=0.71))
    w_true = np.array([0.5, 0.0])
    hist = _simulate(obs, w_true, 20.0, rng=np.random.default_rng(0), noise=(0.001, 0.005))
    err = hist[100:] - w_true
    # Measured: max 0.94, RMS 0.28 m/s² (CoM noise dominates: the poles give a ~50 rad/s bandwidth).
    assert np.max(np.abs(err)) < 1.5
    assert np.sqrt(np.mean(err**2)) < 0.4
    assert np.all(np.abs(np.mean(err, axis=0)) < 0.02)  # unbiased
    filt = MidrangeFilter(MidrangeParams())
    smoothed = np.array([filt.update(w) for w in hist])
    assert np.sqrt(np.mean((smoothed[600:] - w_true) ** 2)) < 0.03  # measured 0.014


def test_observer_params_validation():
    """ObserverParams rejects poles outside [0, 1), repeated poles and bad sizes, with a named field."""
    for bad in (dict(poles=(0.6, 0.7, 1.0)), dict(poles=(0.6, 0.6, 0.8)), dict(poles=(0.6, 0.7)),
                dict(zmp_pole=-0.1), dict(com_height_m=0.0), dict(sampling_period_s=-0.01),
                dict(discretisation="euler")):
        with pytest.raises(ParameterError):
            ObserverParams(**{"com_height_m": 0.7, **bad})
    with pytest.raises(ParameterError, match="com_meas_xy"):
        DisturbanceObserver(ObserverParams(com_height_m=0.7)).update(np.zeros(3), None, np.zeros(2))


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


def test_moving_average_removes_a_periodic_part_and_passes_a_constant():
    """Over one period of the window, a gait-periodic estimate averages to its mean; a constant
    force added to it is passed in full once one window has elapsed."""
    from robust_ismpc.observer import MovingAverage

    window = 140  # one G1 stride at δ = 0.01 s
    k = np.arange(5 * window)
    periodic = np.column_stack([0.3 * np.sin(2 * np.pi * k / window), 0.1 * np.cos(2 * np.pi * k / (window / 2))])
    bias = np.array([0.04, -0.01])
    step = np.where(k[:, None] >= 2 * window, np.array([1.1, 0.0]), 0.0)
    average = MovingAverage(window)
    out = np.array([average.update(bias + periodic[i] + step[i]) for i in k])
    np.testing.assert_allclose(out[window - 1], bias, atol=1e-12)
    np.testing.assert_allclose(out[2 * window - 1], bias, atol=1e-12)
    np.testing.assert_allclose(out[-1], bias + [1.1, 0.0], atol=1e-12)
    # half a window after the step, half of it has passed
    np.testing.assert_allclose(out[2 * window + window // 2 - 1, 0], bias[0] + 0.55, atol=1e-12)


def test_moving_average_of_one_sample_passes_through_and_validates():
    from robust_ismpc.observer import MovingAverage

    average = MovingAverage(1)
    for value in ([0.3, -0.2], [1.0, 2.0]):
        np.testing.assert_array_equal(average.update(np.array(value)), value)
    for bad in (0, -3, 2.5):
        with pytest.raises(ParameterError):
            MovingAverage(bad)
