"""The base filter: IMU integration corrected by the soles in contact (estimation/base_filter.py)."""

from __future__ import annotations

import numpy as np
import pytest

from robust_ismpc.estimation.base_filter import GRAVITY_VECTOR_MPS2, BaseFilterParams, BaseStateFilter
from robust_ismpc.exceptions import ParameterError

DT = 0.002
LEVEL = np.eye(3)


def _yaw(angle_rad: float) -> np.ndarray:
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_without_contact_it_integrates_the_accelerometer_exactly():
    """Airborne, the filter is the accelerometer's double integral: under a constant world
    acceleration a, p = p0 + v0 t + a t² / 2 and v = v0 + a t (to rounding), in any orientation."""
    rotation = _yaw(0.7)
    acc = np.array([0.3, -0.2, 0.1])
    specific_force = rotation.T @ (acc - GRAVITY_VECTOR_MPS2)
    p0, v0 = np.array([1.0, 2.0, 0.7]), np.array([0.2, 0.0, -0.1])
    f = BaseStateFilter(BaseFilterParams(), DT, p0, v0)
    n = 500
    for _ in range(n):
        f.predict(rotation, specific_force)
        f.correct(rotation, np.zeros(3), {}, {})
    t = n * DT
    np.testing.assert_allclose(f.velocity_mps, v0 + acc * t, atol=1e-12)
    np.testing.assert_allclose(f.position_m, p0 + v0 * t + 0.5 * acc * t * t, atol=1e-12)


def test_a_sole_in_contact_removes_the_accelerometer_bias_from_the_velocity():
    """A base sliding at 0.3 m/s over a fixed sole (the sole recedes in the base frame), read by
    an accelerometer with a 0.2 m/s² bias (four times the realistic preset's): integrated alone
    the velocity would err by 0.2 m/s after a second; the sole keeps the error under a tenth of
    that (the bias is not in the state: what is left is the bias times the filter's time
    constant) and the position within 2 mm."""
    v_true = np.array([0.3, 0.0, 0.0])
    sole_world = np.array([0.1, 0.1, 0.0])
    p_true = np.array([0.0, 0.0, 0.7])
    bias = np.array([0.2, -0.2, 0.0])
    f = BaseStateFilter(BaseFilterParams(), DT, p_true.copy(), v_true.copy())
    for _ in range(500):
        p_true = p_true + v_true * DT
        f.predict(LEVEL, -GRAVITY_VECTOR_MPS2 + bias)
        r = sole_world - p_true
        f.correct(LEVEL, np.zeros(3), {"left": r}, {"left": -v_true})
    assert np.all(np.abs(f.velocity_mps - v_true) < 0.02)
    assert np.all(np.abs(f.position_m - p_true) < 0.002)


def test_the_base_velocity_from_a_rotating_base_includes_the_lever_arm():
    """A base yawing at ω over a fixed sole at r (base frame), joints still: the sole stays put only
    if the base circles it at v = -ω × R r. Started at rest, with an accelerometer that reads
    no acceleration at all, the filter finds that velocity from the sole alone."""
    omega = np.array([0.0, 0.0, 0.5])
    r = np.array([0.3, -0.1, -0.6])
    sole = np.array([0.3, -0.1, 0.0])
    f = BaseStateFilter(BaseFilterParams(acc_noise_mps2=5.0), DT, sole - r)
    for k in range(1, 301):
        rotation = _yaw(omega[2] * k * DT)
        f.predict(rotation, rotation.T @ -GRAVITY_VECTOR_MPS2)
        f.correct(rotation, omega, {"left": r}, {"left": np.zeros(3)})
    expected = -np.cross(omega, rotation @ r)
    np.testing.assert_allclose(f.velocity_mps, expected, atol=5e-3)
    np.testing.assert_allclose(f.position_m, sole - rotation @ r, atol=1e-3)


def test_a_touchdown_anchors_the_sole_on_the_floor_and_lift_off_releases_it():
    """The sole is anchored where the estimate puts it at touchdown, at the floor's height when
    the floor is flat; once it lifts off, the anchor is gone and a new touchdown anchors anew."""
    f = BaseStateFilter(BaseFilterParams(), DT, np.array([0.0, 0.0, 0.72]), floor_height_m=0.0)
    f.correct(LEVEL, np.zeros(3), {"right": np.array([0.05, -0.1, -0.7])}, {"right": np.zeros(3)})
    np.testing.assert_allclose(f.anchors_m["right"], [0.05, -0.1, 0.0])
    f.correct(LEVEL, np.zeros(3), {}, {})
    assert f.anchors_m == {}
    free = BaseStateFilter(BaseFilterParams(), DT, np.array([0.0, 0.0, 0.72]))
    free.correct(LEVEL, np.zeros(3), {"right": np.array([0.05, -0.1, -0.7])}, {"right": np.zeros(3)})
    np.testing.assert_allclose(free.anchors_m["right"], [0.05, -0.1, 0.02])


@pytest.mark.parametrize("bad", [dict(acc_noise_mps2=0.0), dict(leg_vel_noise_mps=-1.0),
                                 dict(leg_pos_noise_m=float("nan"))])
def test_bad_noise_is_refused(bad):
    with pytest.raises(ParameterError):
        BaseFilterParams(**bad)


def test_bad_filter_inputs_are_refused():
    with pytest.raises(ParameterError):
        BaseStateFilter(BaseFilterParams(), 0.0, np.zeros(3))
    with pytest.raises(ParameterError):
        BaseStateFilter(BaseFilterParams(), DT, np.zeros(2))
    with pytest.raises(ParameterError):
        BaseStateFilter(object(), DT, np.zeros(3))  # type: ignore[arg-type]


def test_the_update_is_the_textbook_kalman_update():
    """The written-out 2 × 2 update equals K = P (P + R)⁻¹, x += K (z − x), P = (I − K) P."""
    rng = np.random.default_rng(1)
    f = BaseStateFilter(BaseFilterParams(), DT, np.zeros(3))
    f.covariance = np.array([[2e-5, 3e-5], [3e-5, 4e-3]])
    P, p0, v0 = f.covariance.copy(), f.position_m.copy(), f.velocity_mps.copy()
    z_p, z_v = 0.01 * rng.standard_normal(3), 0.1 * rng.standard_normal(3)
    f._update(z_p, z_v, 1e-5, 2e-3)
    K = P @ np.linalg.inv(P + np.diag([1e-5, 2e-3]))
    correction = K @ np.stack([z_p - p0, z_v - v0])
    np.testing.assert_allclose(f.position_m, p0 + correction[0], atol=1e-15)
    np.testing.assert_allclose(f.velocity_mps, v0 + correction[1], atol=1e-15)
    np.testing.assert_allclose(f.covariance, (np.eye(2) - K) @ P, atol=1e-18)
