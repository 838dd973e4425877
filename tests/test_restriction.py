"""Tests of robust_ismpc.core.restriction: formulas, limits, and recursive feasibility under bounded disturbances."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.optimize
from feasibility_reference import build_axis_program

from robust_ismpc.core.feasibility import AxisFeasibilityInputs, feasibility_bounds_at
from robust_ismpc.core.params import GRAVITY_MPS2
from robust_ismpc.core.restriction import (
    checked_restriction_rate,
    deviation_effect,
    max_tolerable_deviation,
    one_step_margin,
    restriction_profile,
    restriction_rate,
)
from robust_ismpc.exceptions import ParameterError


def _eta(h: float) -> float:
    return math.sqrt(GRAVITY_MPS2 / h)


def test_rate_makes_first_margin_term_equal_deviation_effect():
    """With r from the formula the margin's first term equals the disturbance effect and m(r) >= it."""
    rng = np.random.default_rng(0)
    for _ in range(200):
        eta, delta, T_c = _eta(rng.uniform(0.2, 1.0)), rng.choice([0.005, 0.01, 0.05]), rng.uniform(0.5, 2.0)
        delta_max, dwm = rng.uniform(0, 0.2), rng.uniform(0, 0.003)
        r = restriction_rate(delta_max, eta, delta, T_c, dwm)
        lam, lam_p = math.exp(-eta * delta), math.exp(-eta * (T_c - delta))
        effect = deviation_effect(delta_max, eta, delta, dwm)
        assert r * (1 - lam) * (1 - lam_p) / eta == pytest.approx(effect, rel=1e-12)
        d_z = 2 * r * T_c / rng.uniform(0.1, 1.0)  # any box with r T_c <= d_z / 2
        assert one_step_margin(r, d_z, eta, delta, T_c) >= effect * (1 - 1e-12)
        # Equality exactly when the restricted box closes at the end of the horizon.
        assert one_step_margin(r, 2 * r * T_c, eta, delta, T_c) == pytest.approx(effect, rel=1e-12)


def test_continuous_time_limit():
    """As δ → 0 (Δw_m = 0) r tends to Δ_max / (η (1 − e^{−η T_c}))."""
    eta, T_c = _eta(0.71), 1.0
    limit = 0.1 / (eta * (1 - math.exp(-eta * T_c)))
    assert restriction_rate(0.1, eta, 1e-6, T_c) == pytest.approx(limit, rel=1e-5)
    assert restriction_rate(0.1, eta, 1e-3, T_c) == pytest.approx(limit, rel=1e-2)


@pytest.mark.parametrize("h, d_z, T_c, expected", [
    (0.71, 0.08, 1.0, 0.1396),  # robust code
    (0.78, 0.04, 1.6, 0.0426),  # T-RO HRP-4 sim
    (0.23, 0.03, 1.0, 0.0916),  # T-RO NAO
])
def test_spec_table_of_tolerable_deviations(h, d_z, T_c, expected):
    """max_tolerable_deviation reproduces the table of spec §12.2 and inverts restriction_rate."""
    eta = _eta(h)
    dev = max_tolerable_deviation(d_z, eta, 0.01, T_c)
    assert dev == pytest.approx(expected, abs=5e-5)
    assert restriction_rate(dev, eta, 0.01, T_c) * T_c == pytest.approx(d_z / 2, rel=1e-12)


def test_profile():
    """R_i = r (i + 1) δ for the rows at t_{k+i+1}."""
    assert np.allclose(restriction_profile(0.04, 0.01, 100), 0.04 * 0.01 * np.arange(1, 101))
    with pytest.raises(ParameterError):
        restriction_profile(0.04, 0.01, 0)


def test_checked_rate_reports_largest_guaranteed_deviation():
    """Asking for more than the foot and horizon allow raises one line naming the largest Δ_max."""
    eta = _eta(0.71)
    ok = checked_restriction_rate(0.1, eta, 0.01, 1.0, 0.08, 0.08)
    assert ok == pytest.approx(restriction_rate(0.1, eta, 0.01, 1.0))
    with pytest.raises(ParameterError, match=r"largest guaranteed delta_max .* < 0\.1396") as info:
        checked_restriction_rate(0.2, eta, 0.01, 1.0, 0.10, 0.08)
    assert "\n" not in str(info.value)
    # The preview condition tightens the limit: T_p = T_c leaves no room for a 0.8 m/s ZMP tail.
    with pytest.raises(ParameterError, match="preview"):
        checked_restriction_rate(0.1, eta, 0.01, 1.0, 0.08, 0.08, preview_horizon_s=1.2, max_zmp_speed_mps=0.8)
    checked_restriction_rate(0.1, eta, 0.01, 1.0, 0.08, 0.08, preview_horizon_s=2.5, max_zmp_speed_mps=0.8)
    with pytest.raises(ParameterError):
        restriction_rate(-0.1, eta, 0.01, 1.0)


# ---------------------------------------------------------------------------------------------
# Recursive feasibility on the QP's own constraint set (fixed footsteps, straight gait).


class _Gait:
    """Straight walk along one axis with fixed footsteps: p_j = j L, ramp j starts at T_ss + (j−1) T_s."""

    def __init__(self, step_m: float, T_ss: float, T_ds: float, n: int = 80):
        self.pos = step_m * np.arange(n + 1)
        self.ramp = T_ss + (T_ss + T_ds) * np.arange(n)  # ramp j+1 (footstep j -> j+1)
        self.T_ds, self.T_s = T_ds, T_ss + T_ds

    def inputs(self, t: float, zmp: float, r: float, cfg: dict) -> tuple[AxisFeasibilityInputs, float]:
        s = int(np.sum(self.ramp + self.T_ds <= t + 1e-9))  # completed ramps: support footstep s
        disp = np.diff(self.pos)[s:s + 12]
        inp = AxisFeasibilityInputs(
            support_pos_m=self.pos[s], zmp_pos_m=zmp, zmp_half_width_m=cfg["d_z"] / 2, restriction_rate_mps=r,
            disp_lo_m=disp, disp_hi_m=disp, disp_nominal_m=disp, T_ds_s=self.T_ds, step_periods_s=self.T_s,
            eta=cfg["eta"], sampling_period_s=cfg["delta"], control_horizon_s=cfg["T_c"],
            preview_horizon_s=cfg["T_p"],
        )
        return inp, float(self.ramp[s] - t)


def _run(cfg: dict, r: float, cycles: int, mode: str, rng: np.random.Generator, dwm: float = 0.0) -> tuple[int, float]:
    """Closed loop on the exact LIP; returns (first infeasible cycle or -1, smallest relative slack).

    mode "adversarial": the plan takes the extreme first ZMP velocity toward the nearer bound and
    the disturbance (and mid-range change ``dwm``) pushes the same way with full size.
    mode "random": a random feasible plan (random LP objective) and a uniform random deviation.
    """
    eta, delta = cfg["eta"], cfg["delta"]
    lam = math.exp(-eta * delta)
    w0 = 1 - (1 - lam) / (eta * delta)
    a1c = (1 - lam) / (eta * delta) - lam
    gait = _Gait(0.1, 0.3, 0.2)
    zmp = 0.0
    inp, a1 = gait.inputs(0.0, zmp, r, cfg)
    dcm = sum(feasibility_bounds_at(inp, a1)) / 2
    push = deviation_effect(cfg["delta_max"], eta, delta)
    worst = math.inf
    for k in range(cycles):
        t = k * delta
        inp, a1 = gait.inputs(t, zmp, r, cfg)
        lo, hi = feasibility_bounds_at(inp, a1)
        if not lo - 1e-12 <= dcm <= hi + 1e-12:
            return k, worst
        worst = min(worst, (dcm - lo) / (hi - lo), (hi - dcm) / (hi - lo))
        prog = build_axis_program(inp, a1)
        n = prog.A_ub.shape[1]
        if mode == "adversarial":
            sign = 1.0 if hi - dcm < dcm - lo else -1.0
            objective = np.zeros(n)
            objective[0] = sign  # upper side: smallest first ZMP velocity is worst, and vice versa
            eps, jump = sign * push, sign * dwm / eta**2
        else:
            objective = rng.normal(size=n)
            eps, jump = rng.uniform(-1, 1) * push, rng.uniform(-1, 1) * dwm / eta**2
        res = scipy.optimize.linprog(objective, A_ub=prog.A_ub, b_ub=prog.b_ub, A_eq=prog.dcm_row[None, :],
                                     b_eq=[dcm - prog.dcm_offset_m], bounds=(None, None), method="highs")
        assert res.status == 0, f"cycle {k}: the bounds said feasible but the LP found no plan"
        z1 = zmp + delta * res.x[0]
        dcm = math.exp(eta * delta) * (dcm - w0 * zmp - a1c * z1) + eps + jump
        zmp = z1
    return -1, worst


# h 0.62, d_z 0.05, T_c 1 s with Δ_max = 0.09 (96 % of the tolerable 0.0937): the case in which
# the earlier draft of the formula (η²δ in the denominator) lost feasibility (spec §12.2).
TIGHT = dict(eta=_eta(0.62), d_z=0.05, delta=0.01, T_c=1.0, T_p=2.5, delta_max=0.09)


def test_one_step_worst_case_margin_equals_formula():
    """Over all feasible plans, the smallest next-cycle slack on either side equals one_step_margin (LP, 1e-10)."""
    # T_p = 2.2 s puts t + T_p in single support for these t, so the held end of the tail does not
    # move between the two cycles (with T_p = 2.5 s = 5 steps it would, by up to ~3e-7 m).
    cfg = {**TIGHT, "T_p": 2.2}
    eta, delta = cfg["eta"], cfg["delta"]
    lam = math.exp(-eta * delta)
    w0 = 1 - (1 - lam) / (eta * delta)
    a1c = (1 - lam) / (eta * delta) - lam
    e = math.exp(eta * delta)
    gait = _Gait(0.1, 0.3, 0.2)
    tight = {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}
    for r in (0.0, 0.012, restriction_rate(cfg["delta_max"], eta, delta, cfg["T_c"])):
        expected = one_step_margin(r, cfg["d_z"], eta, delta, cfg["T_c"])
        for t in (0.05, 0.31, 0.42):  # single support, ramp start, mid double support
            inp, a1 = gait.inputs(t, 0.0, r, cfg)
            prog = build_axis_program(inp, a1)
            nxt, a1n = gait.inputs(t + delta, 0.0, r, cfg)
            lower0, upper0 = feasibility_bounds_at(nxt, a1n)  # bounds at k+1 are w0 z_1 + these
            # x̄_u(k+1) = e^{ηδ}(x̄_u − w0 x_z − α z_1), z_1 = x_z + δ u_0, x_z = 0, x̄_u = row·v + off.
            d_next = -e * prog.dcm_row
            d_next[0] += (w0 + e * a1c) * delta  # slack_upper = d_next·v + upper0 − e·off
            res_up = scipy.optimize.linprog(d_next, A_ub=prog.A_ub, b_ub=prog.b_ub, bounds=(None, None),
                                            method="highs", options=tight)
            res_lo = scipy.optimize.linprog(-d_next, A_ub=prog.A_ub, b_ub=prog.b_ub, bounds=(None, None),
                                            method="highs", options=tight)
            slack_up = res_up.fun + upper0 - e * prog.dcm_offset_m
            slack_lo = res_lo.fun - lower0 + e * prog.dcm_offset_m
            assert slack_up == pytest.approx(expected, abs=1e-10)
            assert slack_lo == pytest.approx(expected, abs=1e-10)


def test_recursive_feasibility_with_formula_rate():
    """With r from the formula the QP stays feasible for 300 cycles under worst-case and random deviations."""
    rng = np.random.default_rng(7)
    r = restriction_rate(TIGHT["delta_max"], TIGHT["eta"], TIGHT["delta"], TIGHT["T_c"])
    failed, worst = _run(TIGHT, r, 300, "adversarial", rng)
    assert failed == -1 and worst >= -1e-9
    failed, _ = _run(TIGHT, r, 300, "random", rng)
    assert failed == -1


def test_recursive_feasibility_with_midrange_change():
    """The |Δw_m| term of the formula covers worst-case mid-range jumps on top of the deviation (δ = 0.05 s)."""
    cfg = dict(eta=_eta(0.71), d_z=0.08, delta=0.05, T_c=1.0, T_p=2.5, delta_max=0.05)
    dwm = 0.01
    r = restriction_rate(cfg["delta_max"], cfg["eta"], cfg["delta"], cfg["T_c"], dwm)
    assert r * cfg["T_c"] < cfg["d_z"] / 2
    assert _run(cfg, r, 200, "adversarial", np.random.default_rng(0), dwm=dwm)[0] == -1
    r_without = restriction_rate(cfg["delta_max"], cfg["eta"], cfg["delta"], cfg["T_c"])
    assert _run(cfg, r_without, 200, "adversarial", np.random.default_rng(0), dwm=dwm)[0] >= 0


def test_no_restriction_loses_feasibility():
    """Without restriction (r = 0) a worst-case deviation of the same size makes the QP infeasible."""
    failed, _ = _run(TIGHT, 0.0, 300, "adversarial", np.random.default_rng(0))
    assert 0 <= failed < 300


def test_slightly_smaller_rate_loses_feasibility():
    """The earlier draft's denominator (η²δ instead of η(1 − e^{−ηδ}), ~2 % smaller r) fails in the worst case."""
    eta, delta, T_c = TIGHT["eta"], TIGHT["delta"], TIGHT["T_c"]
    draft = TIGHT["delta_max"] * math.expm1(eta * delta) / (eta**2 * delta * (1 - math.exp(-eta * (T_c - delta))))
    assert draft < restriction_rate(TIGHT["delta_max"], eta, delta, T_c)
    failed, _ = _run(TIGHT, draft, 300, "adversarial", np.random.default_rng(0))
    assert 0 <= failed < 300
