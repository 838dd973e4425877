"""Weighing the robot from its vertical contact force (estimation/weight.py)."""

from __future__ import annotations

import math

import pytest

from robust_ismpc.core.params import GRAVITY_MPS2
from robust_ismpc.estimation.weight import WEIGHING_TIME_CONSTANT_S, weigh
from robust_ismpc.exceptions import ParameterError

MODEL_KG = 30.0


def _after(seconds: float, force_n: float, start_kg: float = MODEL_KG, period_s: float = 0.01) -> float:
    mass = start_kg
    for _ in range(round(seconds / period_s)):
        mass = weigh(mass, force_n, MODEL_KG, period_s)
    return mass


def test_a_constant_weight_is_reached_with_the_filters_time_constant():
    """From the model's 30 kg, feet bearing 33 kg: 63 % of the way after τ, all of it after 10 τ."""
    force = 33.0 * GRAVITY_MPS2
    after_tau = _after(WEIGHING_TIME_CONSTANT_S, force)
    assert after_tau == pytest.approx(30.0 + 3.0 * (1 - math.exp(-1)), abs=0.01)
    assert _after(10 * WEIGHING_TIME_CONSTANT_S, force) == pytest.approx(33.0, abs=1e-3)


def test_the_bounce_of_a_walk_averages_out():
    """A vertical force swinging ±30 % at a step's frequency (2 Hz) weighs the mean, up to the
    filter's residual ripple 0.3 / sqrt(1 + (2π f τ)²) = 1.2 %."""
    mass, period = MODEL_KG, 0.01
    for k in range(3000):
        force = MODEL_KG * GRAVITY_MPS2 * (1 + 0.3 * math.sin(2 * math.pi * 2.0 * k * period))
        mass = weigh(mass, force, MODEL_KG, period)
    assert mass == pytest.approx(MODEL_KG, rel=0.3 / math.hypot(1, 2 * math.pi * 2.0 * WEIGHING_TIME_CONSTANT_S) + 1e-3)


def test_samples_that_bear_less_than_half_the_weight_are_not_weighings():
    assert weigh(31.0, 0.0, MODEL_KG, 0.01) == 31.0
    assert weigh(31.0, 0.49 * MODEL_KG * GRAVITY_MPS2, MODEL_KG, 0.01) == 31.0
    assert weigh(31.0, 0.6 * MODEL_KG * GRAVITY_MPS2, MODEL_KG, 0.01) < 31.0


@pytest.mark.parametrize("model_kg, period_s, tau_s", [(0.0, 0.01, 2.0), (30.0, 0.0, 2.0), (30.0, 0.01, -1.0)])
def test_bad_arguments_raise(model_kg, period_s, tau_s):
    with pytest.raises(ParameterError):
        weigh(30.0, 300.0, model_kg, period_s, tau_s)
