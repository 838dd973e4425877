"""Tests of robust_ismpc.control.step_timing: QP-STA closed form, rounding, trigger."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from feasibility_reference import straight_gait_inputs

from robust_ismpc.control.step_timing import StaParams, should_adapt, solve_sta, solve_sta_qp, timing_interval
from robust_ismpc.core.feasibility import AffineFeasibility, feasibility_bounds_at
from robust_ismpc.core.params import GRAVITY_MPS2
from robust_ismpc.exceptions import ParameterError

DELTA = 0.01
T_SS = 0.3
ETA = math.sqrt(GRAVITY_MPS2 / 0.78)


def _inputs(axis: str, **changes):
    kwargs = dict(
        eta=ETA, sampling_period_s=DELTA, control_horizon_s=1.0, preview_horizon_s=2.5, T_ss_s=T_SS,
        T_ds_s=0.2, num_footsteps=8, restriction_rate_mps=0.01, zmp_box_m=0.04,
        kin_box_m=0.30 if axis == "x" else 0.07, step_length_m=0.1, foot_spacing_m=0.18, next_foot_sign=1,
    )
    kwargs.update(changes)
    return straight_gait_inputs(axis, **kwargs)


def _nominal_dcm(ix, iy, time_to_touchdown):
    """Shifted DCM of the undisturbed gait (ZMP on the centre of the candidate plan)."""
    fixed = [replace(i, disp_lo_m=i.disp_nominal_m, disp_hi_m=i.disp_nominal_m) for i in (ix, iy)]
    return np.array([sum(feasibility_bounds_at(i, time_to_touchdown)) / 2 for i in fixed])


@pytest.mark.parametrize("t_k", [0.0, 0.05, 0.1, 0.15])
def test_nominal_timing_when_dcm_well_inside(t_k):
    """With the DCM at the undisturbed value QP-STA returns the candidate touchdown exactly."""
    ix, iy = _inputs("x"), _inputs("y")
    touchdown = 0.3
    res = solve_sta(t_k, touchdown, 0.0, T_SS, _nominal_dcm(ix, iy, touchdown - t_k), ix, iy)
    assert res.touchdown_time_s == touchdown
    assert not res.changed and res.hard_feasible and res.feasible
    assert res.delta_lambda == math.exp(-ETA * (touchdown - t_k))


def test_forward_push_steps_earlier_and_restores_feasibility():
    """A forward push beyond x_u^M(nominal) gives a larger Δλ (earlier step) inside the exact bounds."""
    ix, iy = _inputs("x"), _inputs("y")
    t_k, touchdown = 0.05, 0.3
    dcm = _nominal_dcm(ix, iy, touchdown - t_k)
    upper_nominal = feasibility_bounds_at(ix, touchdown - t_k)[1]
    dcm[0] = upper_nominal + 0.01
    assert should_adapt(dcm, feasibility_bounds_at(ix, 0.25), feasibility_bounds_at(iy, 0.25), 0.02,
                        in_single_support=True, time_to_touchdown_s=0.25, freeze_s=0.1)
    res = solve_sta(t_k, touchdown, 0.0, T_SS, dcm, ix, iy, StaParams(margin_m=0.01))
    assert res.changed and res.touchdown_time_s < touchdown
    assert res.delta_lambda > math.exp(-ETA * (touchdown - t_k))
    assert res.hard_feasible and res.feasible
    lo_x, hi_x = feasibility_bounds_at(ix, res.time_to_touchdown_s)
    lo_y, hi_y = feasibility_bounds_at(iy, res.time_to_touchdown_s)
    assert lo_x + 0.01 <= dcm[0] <= hi_x - 0.01 and lo_y <= dcm[1] <= hi_y
    assert abs(res.touchdown_time_s / DELTA - round(res.touchdown_time_s / DELTA)) < 1e-9


def test_backward_push_also_steps_earlier():
    """A backward push below x_u^m(nominal) is also recovered by stepping earlier."""
    ix, iy = _inputs("x"), _inputs("y")
    dcm = _nominal_dcm(ix, iy, 0.25)
    dcm[0] = feasibility_bounds_at(ix, 0.25)[0] - 0.01
    res = solve_sta(0.05, 0.3, 0.0, T_SS, dcm, ix, iy)
    assert res.touchdown_time_s < 0.3 and res.feasible


def test_lateral_push_away_from_swing_side_delays_step():
    """A lateral push toward the support side (away from the next swing foot) is met by a later touchdown."""
    ix, iy = _inputs("x"), _inputs("y")  # footstep 1 is a left foot (+y)
    dcm = _nominal_dcm(ix, iy, 0.2)
    dcm[1] = feasibility_bounds_at(iy, 0.2)[0] + 0.005
    res = solve_sta(0.1, 0.3, 0.0, T_SS, dcm, ix, iy)
    assert res.touchdown_time_s > 0.3 and res.feasible


def test_timing_bounds_respected():
    """For random pushes the adapted touchdown stays within the T_ss limits, the floor and the δ grid."""
    rng = np.random.default_rng(11)
    ix, iy = _inputs("x"), _inputs("y")
    params = StaParams(T_ss_min_s=0.2, T_ss_max_s=0.45)
    n_changed = 0
    for _ in range(200):
        t_k = DELTA * rng.integers(0, 20)
        dcm = _nominal_dcm(ix, iy, 0.3 - t_k) + rng.uniform(-0.08, 0.08, 2)
        res = solve_sta(t_k, 0.3, 0.0, T_SS, dcm, ix, iy, params)
        rem_min, rem_max = timing_interval(params, T_SS, t_k)
        assert rem_min - 1e-9 <= res.time_to_touchdown_s <= rem_max + 1e-9 or not res.changed
        assert res.time_to_touchdown_s >= params.floor_s - 1e-9
        assert abs(res.touchdown_time_s / DELTA - round(res.touchdown_time_s / DELTA)) < 1e-9
        if res.hard_feasible:
            assert res.feasible
        n_changed += res.changed
    assert 10 < n_changed < 200


def test_unrecoverable_push_reports_slack():
    """A push too large for any admissible timing is reported (hard_feasible False, slack > 0)."""
    ix, iy = _inputs("x"), _inputs("y")
    dcm = _nominal_dcm(ix, iy, 0.2) + np.array([0.5, 0.0])
    res = solve_sta(0.1, 0.3, 0.0, T_SS, dcm, ix, iy)
    assert not res.hard_feasible and not res.feasible
    assert res.slack_m[0] > 0.3
    assert res.time_to_touchdown_s == pytest.approx(StaParams().floor_s)  # earliest possible step


def test_qp_closed_form_matches_brute_force():
    """solve_sta_qp returns the hard solution when one exists, else the soft QP-STA minimum (grid check)."""
    rng = np.random.default_rng(4)
    n_hard = n_soft = 0
    for _ in range(400):
        lo, hi = sorted(rng.uniform(0.05, 1.0, 2))
        ests = []
        for _axis in range(2):
            off = np.sort(rng.normal(0, 0.05, 2))
            ests.append(AffineFeasibility(off[0], rng.normal(0, 0.1), off[1], rng.normal(0, 0.1), lo, hi))
        dcm = rng.normal(0, 0.05, 2)
        nom = rng.uniform(0.05, 1.0)
        rho = 10.0 ** rng.uniform(1, 6)
        x, hard, slack = solve_sta_qp(dcm, ests[0], ests[1], nom, 0.01, rho)
        grid = np.linspace(lo, hi, 20001)
        viol = [np.maximum.reduce([np.zeros_like(grid), u + 0.01 - e.upper(grid), e.lower(grid) + 0.01 - u])
                for e, u in zip(ests, dcm)]
        assert lo <= x <= hi
        if hard:
            n_hard += 1
            ok = (viol[0] <= 1e-12) & (viol[1] <= 1e-12)
            assert slack == (0.0, 0.0)
            assert abs(x - nom) <= np.min(np.abs(grid[ok] - nom)) + 1e-12
            assert all(u + 0.01 <= e.upper(x) + 1e-12 and e.lower(x) + 0.01 <= u + 1e-12 for e, u in zip(ests, dcm))
        else:
            n_soft += 1
            assert not np.any((viol[0] <= 0) & (viol[1] <= 0))
            cost = (grid - nom) ** 2 + rho * (viol[0] ** 2 + viol[1] ** 2)
            v_x = [max(0.0, u + 0.01 - e.upper(x), e.lower(x) + 0.01 - u) for e, u in zip(ests, dcm)]
            assert (x - nom) ** 2 + rho * (v_x[0] ** 2 + v_x[1] ** 2) <= cost.min() + 1e-12
            assert slack == pytest.approx(tuple(v_x), abs=1e-12)
    assert n_hard > 20 and n_soft > 20


def test_should_adapt_logic():
    """The trigger fires near or outside the bounds, or on QP infeasibility, never in DS or the freeze window."""
    bx, by = (-0.05, 0.05), (0.0, 0.1)
    kw = dict(in_single_support=True, time_to_touchdown_s=0.2, freeze_s=0.1)
    assert not should_adapt(np.array([0.0, 0.05]), bx, by, 0.02, **kw)
    assert should_adapt(np.array([0.04, 0.05]), bx, by, 0.02, **kw)
    assert should_adapt(np.array([0.0, 0.015]), bx, by, 0.02, **kw)
    assert should_adapt(np.array([0.0, 0.05]), bx, by, 0.02, qp_infeasible=True, **kw)
    assert not should_adapt(np.array([0.04, 0.05]), bx, by, 0.02, in_single_support=False,
                            time_to_touchdown_s=0.2, freeze_s=0.1)
    assert not should_adapt(np.array([0.04, 0.05]), bx, by, 0.02, in_single_support=True,
                            time_to_touchdown_s=0.05, freeze_s=0.1, qp_infeasible=True)


def test_sta_params_validation():
    """StaParams rejects non-positive or inconsistent settings, and derives T_ss limits from factors."""
    assert StaParams().ss_limits(0.4) == pytest.approx((0.2, 0.6))
    assert StaParams(T_ss_min_s=0.35, T_ss_max_s=1.1).ss_limits(0.7) == (0.35, 1.1)
    for bad in (dict(margin_m=-0.01), dict(floor_s=0.0), dict(slack_weight=0.0),
                dict(T_ss_min_s=0.5, T_ss_max_s=0.4), dict(T_ss_min_factor=1.2)):
        with pytest.raises(ParameterError):
            StaParams(**bad)
    assert timing_interval(StaParams(), 0.3, 0.2) == pytest.approx((0.05, 0.25))
