"""Tests of the stability-constraint coefficients and tails against brute-force integrals (spec §6)."""

import numpy as np
import pytest
from scipy.integrate import quad

from robust_ismpc.core.stability import stability_coefficients

ETA, DT, C, P = 3.6, 0.05, 12, 30


def _zmp_integral(x0, u, tail_samples):
    """η ∫_0^∞ e^{-ητ} x_z(τ) dτ for a piecewise-linear ZMP: velocities u over C samples from x0,
    then the linearly interpolated tail samples (times Cδ..Pδ), held after Pδ."""
    t_tail = DT * np.arange(C, P + 1)

    def zmp(t):
        if t < C * DT:
            i = int(t // DT)
            return x0 + DT * np.sum(u[:i]) + u[i] * (t - i * DT)
        if t < P * DT:
            return np.interp(t, t_tail, tail_samples)
        return tail_samples[-1]

    total = 0.0
    edges = np.concatenate([DT * np.arange(P + 1), [P * DT + 40.0 / ETA]])
    for a, b in zip(edges[:-1], edges[1:]):
        total += quad(lambda t: ETA * np.exp(-ETA * t) * zmp(t), a, b, epsabs=1e-13)[0]
    total += tail_samples[-1] * np.exp(-ETA * edges[-1])
    return total


def test_anticipative_position_form_equals_integral():
    """a_u·u + c_z x_z^k + τ·x̃ equals the brute-force stability integral for random data."""
    rng = np.random.default_rng(1)
    coef = stability_coefficients(ETA, DT, C, P, "anticipative")
    for _ in range(3):
        x0, u, tail = rng.normal(), rng.normal(size=C), rng.normal(size=P - C + 1)
        lhs = coef.zmp_vel @ u + coef.zmp_now * x0 + coef.tail @ tail
        assert lhs == pytest.approx(_zmp_integral(x0, u, tail), abs=1e-9)


def test_truncated_tail_equals_held_zmp_integral():
    """Truncated form: Σ(1-λ)λ^i/η u_i + x_z^k equals the integral with x_z held at x_z^{k+C}."""
    rng = np.random.default_rng(2)
    coef = stability_coefficients(ETA, DT, C, P, "truncated")
    x0, u = rng.normal(), rng.normal(size=C)
    held = np.full(P - C + 1, x0 + DT * u.sum())
    assert coef.zmp_vel @ u + coef.zmp_now * x0 == pytest.approx(_zmp_integral(x0, u, held), abs=1e-9)


def test_periodic_tail_equals_repeated_velocity_sum():
    """Periodic form equals x_z^k + ((1-λ)/η) Σ_{i≥0} λ^i u_{i mod C} (spec eq. 14)."""
    rng = np.random.default_rng(3)
    lam = np.exp(-ETA * DT)
    coef = stability_coefficients(ETA, DT, C, P, "periodic")
    x0, u = rng.normal(), rng.normal(size=C)
    brute = x0 + (1 - lam) / ETA * sum(lam**i * u[i % C] for i in range(40 * C))
    assert coef.zmp_vel @ u + coef.zmp_now * x0 == pytest.approx(brute, abs=1e-12)


def test_anticipative_reduces_to_truncated_when_tail_is_held():
    """With x̃ ≡ x_z^{k+C} the anticipative equality is the truncated one (spec §6.3 check)."""
    rng = np.random.default_rng(4)
    a = stability_coefficients(ETA, DT, C, P, "anticipative")
    t = stability_coefficients(ETA, DT, C, P, "truncated")
    x0, u = rng.normal(), rng.normal(size=C)
    held = np.full(P - C + 1, x0 + DT * u.sum())
    assert a.zmp_vel @ u + a.zmp_now * x0 + a.tail @ held == pytest.approx(t.zmp_vel @ u + t.zmp_now * x0, abs=1e-13)
