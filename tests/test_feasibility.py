"""Tests of robust_ismpc.core.feasibility: closed-form feasibility bounds, LP check, affine estimate."""

from __future__ import annotations

import math

import numpy as np
import pytest
from feasibility_reference import feasibility_bounds_lp, straight_gait_inputs

from robust_ismpc.core.feasibility import (
    AxisFeasibilityInputs,
    affine_inner_estimate,
    feasibility_bounds,
    feasibility_bounds_at,
    feasibility_bounds_at_axes,
    feasibility_breakpoints,
    zmp_row_weights,
)
from robust_ismpc.core.params import GRAVITY_MPS2
from robust_ismpc.exceptions import ParameterError

DELTA = 0.01


def _random_inputs(rng: np.random.Generator, axis: str, tail_anchor: str, delta: float = DELTA) -> AxisFeasibilityInputs:
    """A random but grid-aligned configuration (every breakpoint on the δ grid)."""
    n = 8
    eta = math.sqrt(GRAVITY_MPS2 / rng.uniform(0.25, 0.9))
    T_ds = delta * rng.integers(3, 30)
    periods = T_ds + delta * rng.integers(10, 80, size=n - 1)
    T_c = delta * rng.integers(30, 160)
    T_p = T_c + delta * rng.integers(0, 200)
    half = rng.uniform(0.01, 0.05)
    if axis == "x":
        nominal = rng.uniform(-0.05, 0.2, n)
        lo, hi = np.full(n, -rng.uniform(0.05, 0.2)), np.full(n, rng.uniform(0.2, 0.3))
    else:  # alternating sides s_j ℓ ± d_ay/2
        sides = rng.choice([-1.0, 1.0]) * (-1.0) ** np.arange(n)
        ell, d_ay = rng.uniform(0.1, 0.25), rng.uniform(0.04, 0.16)
        nominal = sides * ell + rng.uniform(-d_ay / 2, d_ay / 2, n)
        lo, hi = sides * ell - d_ay / 2, sides * ell + d_ay / 2
    return AxisFeasibilityInputs(
        support_pos_m=rng.uniform(-0.2, 0.2),
        zmp_pos_m=rng.uniform(-0.3, 0.3),
        zmp_half_width_m=half,
        restriction_rate_mps=rng.uniform(0.0, 0.95) * half / T_c,
        disp_lo_m=lo,
        disp_hi_m=hi,
        disp_nominal_m=nominal,
        T_ds_s=T_ds,
        step_periods_s=periods,
        eta=eta,
        sampling_period_s=delta,
        control_horizon_s=T_c,
        preview_horizon_s=T_p,
        tail_anchor=tail_anchor,
    )


def _hrp4_inputs(axis: str, **changes) -> AxisFeasibilityInputs:
    kwargs = dict(
        eta=math.sqrt(GRAVITY_MPS2 / 0.78), sampling_period_s=DELTA, control_horizon_s=1.0,
        preview_horizon_s=2.5, T_ss_s=0.3, T_ds_s=0.2, num_footsteps=8, restriction_rate_mps=0.01,
        zmp_box_m=0.04, kin_box_m=0.30 if axis == "x" else 0.07, step_length_m=0.1,
        foot_spacing_m=0.18, next_foot_sign=1,
    )
    kwargs.update(changes)
    return straight_gait_inputs(axis, **kwargs)


@pytest.mark.parametrize("tail_anchor", ["candidate", "decision"])
def test_both_axes_at_once_equal_each_axis_alone(tail_anchor):
    """``feasibility_bounds_at_axes`` (the timing evaluated once for both axes) equals
    ``feasibility_bounds_at`` per axis, in single and double support, and refuses axes whose
    timings differ."""
    inputs_x, inputs_y = _hrp4_inputs("x", tail_anchor=tail_anchor), _hrp4_inputs("y", tail_anchor=tail_anchor)
    for a1 in np.arange(-0.19, 0.6, 0.01):
        (lx, ux), (ly, uy) = feasibility_bounds_at_axes(inputs_x, inputs_y, float(a1))
        assert (lx, ux) == pytest.approx(feasibility_bounds_at(inputs_x, float(a1)), abs=1e-14)
        assert (ly, uy) == pytest.approx(feasibility_bounds_at(inputs_y, float(a1)), abs=1e-14)
    with pytest.raises(ParameterError, match="different timings"):
        feasibility_bounds_at_axes(inputs_x, _hrp4_inputs("y", T_ds_s=0.1, tail_anchor=tail_anchor), 0.1)


@pytest.mark.parametrize("tail_anchor", ["candidate", "decision"])
@pytest.mark.parametrize("axis", ["x", "y"])
def test_closed_form_equals_lp(axis, tail_anchor):
    """The closed-form bounds equal the LP over the QP's constraints to 1e-9 (SS and DS timings)."""
    rng = np.random.default_rng(1 if axis == "x" else 2)
    worst = 0.0
    for _ in range(12):
        inp = _random_inputs(rng, axis, tail_anchor)
        k_min = -int(round(inp.T_ds_s / DELTA)) + 1  # in double support, footstep 1 landed
        for a1 in DELTA * rng.integers(k_min, int(round(inp.control_horizon_s / DELTA)) + 40, size=5):
            lo_c, hi_c = feasibility_bounds_at(inp, a1)
            lo_l, hi_l = feasibility_bounds_lp(inp, a1)
            worst = max(worst, abs(lo_c - lo_l), abs(hi_c - hi_l))
    assert worst < 1e-9


@pytest.mark.parametrize("axis", ["x", "y"])
def test_row_offsets_shift_both_bounds_by_weighted_sum(axis):
    """Bounding x_z + o instead of x_z on the ZMP rows moves the LP's bounds by exactly
    −Σ κ_i o_i (zmp_row_weights), in single and double support."""
    rng = np.random.default_rng(5 if axis == "x" else 6)
    worst = 0.0
    for _ in range(8):
        inp = _random_inputs(rng, axis, "candidate")
        weights = zmp_row_weights(inp.eta, inp.sampling_period_s, inp.control_horizon_s)
        k_min = -int(round(inp.T_ds_s / DELTA)) + 1
        for a1 in DELTA * rng.integers(k_min, inp.C + 20, size=3):
            # a swing-like offset: a sine of up to ±4 cm with random phase and frequency
            offset = 0.04 * rng.uniform() * np.sin(rng.uniform(0, 2 * np.pi) + np.arange(inp.C) * rng.uniform(0.05, 0.3))
            shift = float(weights @ offset)
            lo_c, hi_c = feasibility_bounds_at(inp, a1)
            lo_l, hi_l = feasibility_bounds_lp(inp, a1, offset)
            worst = max(worst, abs(lo_c - shift - lo_l), abs(hi_c - shift - hi_l))
    assert worst < 1e-9


def test_row_weights_reproduce_box_and_restriction_terms():
    """The row weights are >= 0, sum to 1 − w0 − μ_c (the box's coefficient in the closed form),
    and weighting the restriction r δ i gives its closed-form shrink r[(1 − μ_c)/η − T_c μ_c]."""
    eta, delta, T_c = math.sqrt(GRAVITY_MPS2 / 0.62), DELTA, 1.0
    weights = zmp_row_weights(eta, delta, T_c)
    assert weights.shape == (100,) and np.all(weights >= 0.0)
    lam = math.exp(-eta * delta)
    w0 = 1 - (1 - lam) / (eta * delta)
    mu_c = math.exp(-eta * T_c)
    assert weights.sum() == pytest.approx(1 - w0 - mu_c, abs=1e-14)
    restriction = 0.02 * delta * np.arange(1, 101)
    assert weights @ restriction == pytest.approx(0.02 * ((1 - mu_c) / eta - T_c * mu_c), rel=1e-12)
    with pytest.raises(ParameterError, match="whole multiple"):
        zmp_row_weights(eta, delta, 0.995)
    with pytest.raises(ParameterError):
        zmp_row_weights(-1.0, delta, T_c)


def test_closed_form_equals_lp_coarse_sampling():
    """The closed form also matches the LP at δ = 0.05 s (first-interval term matters more)."""
    rng = np.random.default_rng(3)
    for axis in ("x", "y"):
        inp = _random_inputs(rng, axis, "candidate", delta=0.05)
        for a1 in 0.05 * rng.integers(1, 20, size=4):
            assert np.allclose(feasibility_bounds_at(inp, a1), feasibility_bounds_lp(inp, a1), atol=1e-9, rtol=0)


def test_matches_spec_anticipative_formula():
    """With the decision-anchored tail and ramps completed before T_p, the bounds equal spec §13.1's verified formula."""
    inp = _hrp4_inputs("x", tail_anchor="decision", preview_horizon_s=3.0, zmp_pos_m=0.004)
    eta, T_c, h, r = inp.eta, 1.0, 0.02, inp.restriction_rate_mps
    lam = math.exp(-eta * DELTA)
    w0 = 1 - (1 - lam) / (eta * DELTA)
    kappa = (1 - math.exp(-eta * inp.T_ds_s)) / (eta * inp.T_ds_s)
    mu_c = math.exp(-eta * T_c)
    for a1 in (0.05, 0.12, 0.25):
        mu = np.exp(-eta * (a1 + inp.ramp_offsets_s))
        inside = mu > mu_c
        mu = np.where(mu > math.exp(-eta * (inp.preview_horizon_s - inp.T_ds_s)), mu, 0.0)  # completed ramps
        shrink = r * ((1 - mu_c) / eta - T_c * mu_c)
        upper = h * (1 - mu_c) - shrink + kappa * np.sum(mu * np.where(inside, 0.15, 0.1)) - w0 * (h - 0.004)
        lower = -h * (1 - mu_c) + shrink + kappa * np.sum(mu * np.where(inside, -0.15, 0.1)) + w0 * (0.004 + h)
        assert feasibility_bounds_at(inp, a1) == pytest.approx((lower, upper), abs=1e-12)


def test_restriction_shrinks_each_side_by_spec_amount():
    """The restriction moves each bound inward by r[(1 − e^{−ηT_c})/η − T_c e^{−ηT_c}] (spec §12.3)."""
    base = _hrp4_inputs("y", restriction_rate_mps=0.0)
    restricted = _hrp4_inputs("y", restriction_rate_mps=0.015)
    eta = base.eta
    mu_c = math.exp(-eta)
    expected = 0.015 * ((1 - mu_c) / eta - mu_c)
    a1 = np.linspace(0.01, 0.5, 50)
    lo0, hi0 = feasibility_bounds_at(base, a1)
    lo1, hi1 = feasibility_bounds_at(restricted, a1)
    assert np.allclose(hi0 - hi1, expected, atol=1e-14)
    assert np.allclose(lo1 - lo0, expected, atol=1e-14)


def test_bounds_jump_only_at_reported_breakpoints():
    """Away from the reported breakpoints the bounds are affine in Δλ (zero second difference)."""
    inp = _hrp4_inputs("x", control_horizon_s=0.8)
    jumps, kinks = feasibility_breakpoints(inp)
    grid = np.linspace(0.05, 0.99, 4001)
    lower, upper = feasibility_bounds(inp, grid)
    step = grid[1] - grid[0]
    near = np.min(np.abs(grid[1:-1, None] - np.concatenate((jumps, kinks))[None, :]), axis=1) < 1.5 * step
    second = np.abs(upper[2:] - 2 * upper[1:-1] + upper[:-2])
    assert np.max(second[~near]) < 1e-12
    assert np.max(second[near]) > 1e-6  # there is at least one real breakpoint in range


@pytest.mark.parametrize("axis", ["x", "y"])
def test_affine_estimate_is_inner(axis):
    """a_M + b_M Δλ <= x_u^M and a_m + b_m Δλ >= x_u^m on a dense grid, also across jumps."""
    rng = np.random.default_rng(5)
    gaps = []
    for trial in range(20):
        inp = _random_inputs(rng, axis, ("candidate", "decision")[trial % 2])
        lo, hi = sorted(np.exp(-inp.eta * rng.uniform(0.02, 1.2, size=2)))
        est = affine_inner_estimate(inp, lo, hi, rng.uniform(lo, hi))
        grid = np.linspace(lo, hi, 5001)
        lower, upper = feasibility_bounds(inp, grid)
        assert np.all(est.upper(grid) <= upper)
        assert np.all(est.lower(grid) >= lower)
        gaps.append(np.mean(upper - est.upper(grid)))
    assert np.isfinite(gaps).all()


def test_affine_estimate_tight_at_anchor_without_jumps():
    """Without a footstep entering the horizon the estimate loses less than 0.1 mm (HRP-4, T_c = 1 s)."""
    for axis in ("x", "y"):
        inp = _hrp4_inputs(axis)
        lo, hi = math.exp(-inp.eta * 0.45), math.exp(-inp.eta * 0.05)
        assert feasibility_breakpoints(inp)[0][(feasibility_breakpoints(inp)[0] >= lo)].size == 0
        est = affine_inner_estimate(inp, lo, hi, math.exp(-inp.eta * 0.2))
        grid = np.linspace(lo, hi, 2001)
        lower, upper = feasibility_bounds(inp, grid)
        assert np.max(upper - est.upper(grid)) < 1e-4
        assert np.max(est.lower(grid) - lower) < 1e-4


def test_inputs_validation():
    """Inconsistent inputs raise ParameterError with the offending field named."""
    good = _hrp4_inputs("x")
    fields = dict(
        support_pos_m=0.0, zmp_pos_m=0.0, zmp_half_width_m=0.02, restriction_rate_mps=0.0,
        disp_lo_m=good.disp_lo_m, disp_hi_m=good.disp_hi_m, disp_nominal_m=good.disp_nominal_m,
        T_ds_s=0.2, step_periods_s=0.5, eta=good.eta, sampling_period_s=0.01,
        control_horizon_s=1.0, preview_horizon_s=2.5,
    )
    AxisFeasibilityInputs(**fields)
    for change, word in [
        (dict(disp_lo_m=good.disp_hi_m + 0.1), "disp_lo_m"),
        (dict(step_periods_s=0.1), "step_periods_s"),
        (dict(preview_horizon_s=0.5), "preview_horizon_s"),
        (dict(control_horizon_s=1.005), "control_horizon_s"),
        (dict(tail_anchor="periodic"), "tail_anchor"),
        (dict(restriction_rate_mps=-1.0), "restriction_rate_mps"),
        (dict(disp_nominal_m=np.zeros(3)), "same length"),
    ]:
        with pytest.raises(ParameterError, match=word):
            AxisFeasibilityInputs(**{**fields, **change})
    with pytest.raises(ParameterError):
        feasibility_bounds(good, 1.5)
    with pytest.raises(ParameterError):
        affine_inner_estimate(good, 0.5, 0.4)
