r"""ZMP constraint restriction from the disturbance bound (spec §12).

The ZMP box of the row at :math:`t_{k+i+1}` is shrunk on every side by
:math:`R_i = r\,(i+1)\,\delta`. With :math:`\lambda = e^{-\eta\delta}`,
:math:`\lambda' = e^{-\eta(T_c-\delta)}` and the anticipative centre tail, one MPC cycle of the
(fixed-footstep) problem leaves the exact margin (``docs/derivations.md`` §2)

.. math::

    m(r) = \frac{r(1-\lambda)(1-\lambda')}{\eta} + \Big(\frac{d_z}{2} - rT_c\Big)(1-\lambda)\lambda'

between the next shifted DCM of any feasible plan and the boundary of the next feasibility
region, while a deviation :math:`|w - \tilde w| \le Δ_{max}` over one sample and a mid-range
change :math:`|Δ\tilde w|` move the shifted DCM by at most
:math:`[Δ_{max}(e^{\eta\delta}-1) + |Δ\tilde w|]/\eta^2`. :func:`restriction_rate` returns the
smallest r whose first margin term alone covers that (the second term is kept for the preview
horizon); :func:`one_step_margin` is the exact margin.
"""

from __future__ import annotations

import math

import numpy as np

from ..exceptions import ParameterError
from ..validation import check_nonnegative, check_positive

__all__ = [
    "restriction_rate",
    "one_step_margin",
    "deviation_effect",
    "max_tolerable_deviation",
    "restriction_profile",
    "checked_restriction_rate",
]


def _horizon_check(sampling_period_s: float, control_horizon_s: float) -> None:
    if control_horizon_s < 2 * sampling_period_s - 1e-12:
        raise ParameterError(
            f"control_horizon_s ({control_horizon_s}) must span at least two samples of {sampling_period_s} s"
        )


def deviation_effect(
    delta_max_mps2: float, eta: float, sampling_period_s: float, max_midrange_change_mps2: float = 0.0
) -> float:
    r"""Largest one-sample displacement of the shifted DCM caused by the disturbance [m].

    .. math:: e = \frac{Δ_{max}(e^{\eta\delta} - 1) + |Δ\tilde w|_{max}}{\eta^2}

    Parameters
    ----------
    delta_max_mps2 : float
        Bound Δ_max on |w − w̃| [m/s²].
    eta : float
        LIP natural frequency [1/s].
    sampling_period_s : float
        δ [s].
    max_midrange_change_mps2 : float
        Bound on the change of w̃ between consecutive samples [m/s² per sample].
    """
    check_nonnegative("", delta_max_mps2=delta_max_mps2, max_midrange_change_mps2=max_midrange_change_mps2)
    check_positive("", eta=eta, sampling_period_s=sampling_period_s)
    return (delta_max_mps2 * math.expm1(eta * sampling_period_s) + max_midrange_change_mps2) / eta**2


def restriction_rate(
    delta_max_mps2: float,
    eta: float,
    sampling_period_s: float,
    control_horizon_s: float,
    max_midrange_change_mps2: float = 0.0,
) -> float:
    r"""Restriction rate r [m/s] that keeps the MPC recursively feasible (spec §12.2, corrected).

    .. math::

        r = \frac{Δ_{max}(e^{\eta\delta}-1) + |Δ\tilde w|_{max}}
                 {\eta\,(1-e^{-\eta\delta})\,(1-e^{-\eta(T_c-\delta)})}

    This makes the first term of :func:`one_step_margin` equal to :func:`deviation_effect`.
    It does not check that the restricted box stays non-empty: use
    :func:`checked_restriction_rate` for that.

    Parameters
    ----------
    delta_max_mps2 : float
        Δ_max [m/s²], bound on |w − w̃|.
    eta : float
        η [1/s].
    sampling_period_s : float
        δ [s].
    control_horizon_s : float
        T_c [s], at least 2δ.
    max_midrange_change_mps2 : float
        Largest |w̃_{k+1} − w̃_k| [m/s² per sample] (the mid-range filter's rate limit).

    Returns
    -------
    float
        r [m/s].
    """
    e = deviation_effect(delta_max_mps2, eta, sampling_period_s, max_midrange_change_mps2)
    check_positive("", control_horizon_s=control_horizon_s)
    _horizon_check(sampling_period_s, control_horizon_s)
    lam = math.exp(-eta * sampling_period_s)
    lam_p = math.exp(-eta * (control_horizon_s - sampling_period_s))
    return e * eta / ((1.0 - lam) * (1.0 - lam_p))


def one_step_margin(
    r_mps: float, zmp_box_m: float, eta: float, sampling_period_s: float, control_horizon_s: float
) -> float:
    r"""Exact one-cycle margin of the restricted problem [m] (spec §12.2; derivations §2.2).

    .. math::

        m(r) = \frac{r(1-\lambda)(1-\lambda')}{\eta} + \Big(\frac{d_z}{2} - rT_c\Big)(1-\lambda)\lambda'

    For any feasible plan at t_k, the next shifted DCM without disturbance lies at least m(r)
    inside the next feasibility region (fixed footsteps and timing, centre tail, preview long
    enough that the tail's held end does not move; see the preview condition). The worst case
    is attained by the plan on the boundary.

    Parameters
    ----------
    r_mps : float
        Restriction rate r [m/s].
    zmp_box_m : float
        Full side d_z of the ZMP box along the axis [m].
    eta, sampling_period_s, control_horizon_s : float
        η [1/s], δ [s], T_c [s].
    """
    check_nonnegative("", r_mps=r_mps)
    check_positive("", zmp_box_m=zmp_box_m, eta=eta, sampling_period_s=sampling_period_s, control_horizon_s=control_horizon_s)
    _horizon_check(sampling_period_s, control_horizon_s)
    lam = math.exp(-eta * sampling_period_s)
    lam_p = math.exp(-eta * (control_horizon_s - sampling_period_s))
    return r_mps * (1 - lam) * (1 - lam_p) / eta + (zmp_box_m / 2 - r_mps * control_horizon_s) * (1 - lam) * lam_p


def max_tolerable_deviation(
    zmp_box_m: float,
    eta: float,
    sampling_period_s: float,
    control_horizon_s: float,
    max_midrange_change_mps2: float = 0.0,
) -> float:
    r"""Supremum of the Δ_max that a linear restriction can guarantee [m/s²] (spec §12.2).

    With r → d_z/(2T_c) (restricted box empty at the end of the horizon):

    .. math::

        Δ_{max} < \frac{d_z}{2T_c}\,\eta\,e^{-\eta\delta}(1 - e^{-\eta(T_c-\delta)})
                  - \frac{|Δ\tilde w|_{max}}{e^{\eta\delta} - 1}

    This is also the supremum under the exact margin of :func:`one_step_margin` whenever that
    margin grows with r (always for ηT_c ≳ 1). Returns 0 when the mid-range change alone
    exceeds the budget.

    Parameters
    ----------
    zmp_box_m : float
        Full side d_z of the ZMP box [m] (use the smaller of the two axes).
    eta, sampling_period_s, control_horizon_s : float
        η [1/s], δ [s], T_c [s].
    max_midrange_change_mps2 : float
        Largest mid-range change per sample [m/s² per sample].
    """
    check_positive("", zmp_box_m=zmp_box_m, eta=eta, sampling_period_s=sampling_period_s, control_horizon_s=control_horizon_s)
    check_nonnegative("", max_midrange_change_mps2=max_midrange_change_mps2)
    _horizon_check(sampling_period_s, control_horizon_s)
    r_sup = zmp_box_m / (2 * control_horizon_s)
    return _deviation_for_rate(r_sup, eta, sampling_period_s, control_horizon_s, max_midrange_change_mps2)


def _deviation_for_rate(r: float, eta: float, delta: float, T_c: float, dwm: float) -> float:
    """Inverse of :func:`restriction_rate` in Δ_max (clipped at 0)."""
    lam = math.exp(-eta * delta)
    lam_p = math.exp(-eta * (T_c - delta))
    return max(0.0, (r * eta * (1 - lam) * (1 - lam_p) - dwm) / math.expm1(eta * delta))


def restriction_profile(r_mps: float, sampling_period_s: float, num_samples: int) -> np.ndarray:
    r"""Per-row restriction R_i = r (i + 1) δ [m], shape (C,), for the ZMP rows at t_{k+i+1}.

    Parameters
    ----------
    r_mps : float
        Restriction rate [m/s].
    sampling_period_s : float
        δ [s].
    num_samples : int
        C, the number of control-horizon samples.
    """
    check_nonnegative("", r_mps=r_mps)
    check_positive("", sampling_period_s=sampling_period_s)
    if not isinstance(num_samples, (int, np.integer)) or num_samples < 1:
        raise ParameterError(f"num_samples must be an integer >= 1, got {num_samples!r}")
    return r_mps * sampling_period_s * np.arange(1, num_samples + 1, dtype=float)


def checked_restriction_rate(
    delta_max_mps2: float,
    eta: float,
    sampling_period_s: float,
    control_horizon_s: float,
    zmp_box_x_m: float,
    zmp_box_y_m: float,
    *,
    preview_horizon_s: float | None = None,
    max_zmp_speed_mps: float | None = None,
    max_midrange_change_mps2: float = 0.0,
) -> float:
    r""":func:`restriction_rate`, raising when the requested Δ_max cannot be guaranteed.

    Checks (spec §12.2):

    - non-empty box at the end of the horizon: r T_c < min(d_zx, d_zy)/2;
    - if ``preview_horizon_s`` and ``max_zmp_speed_mps`` (v_z,max, e.g. step length / T_ds) are
      given, the preview condition
      :math:`T_p \ge T_c + \frac{1}{\eta}\ln\frac{v_{z,max}}{\eta(d_z/2 - rT_c)}`.

    Returns
    -------
    float
        r [m/s].

    Raises
    ------
    ParameterError
        One line naming the violated condition and the largest Δ_max that can be guaranteed
        with this foot, horizon and preview.
    """
    check_positive("", zmp_box_x_m=zmp_box_x_m, zmp_box_y_m=zmp_box_y_m)
    r = restriction_rate(delta_max_mps2, eta, sampling_period_s, control_horizon_s, max_midrange_change_mps2)
    half = min(zmp_box_x_m, zmp_box_y_m) / 2
    # Largest admissible r: the box must stay non-empty, and the preview condition caps it too.
    r_cap = half / control_horizon_s
    if preview_horizon_s is not None and max_zmp_speed_mps is not None:
        check_positive("", preview_horizon_s=preview_horizon_s, max_zmp_speed_mps=max_zmp_speed_mps)
        if preview_horizon_s < control_horizon_s - 1e-12:
            raise ParameterError(
                f"preview_horizon_s ({preview_horizon_s}) must be >= control_horizon_s ({control_horizon_s})"
            )
        needed_end_half = max_zmp_speed_mps * math.exp(-eta * (preview_horizon_s - control_horizon_s)) / eta
        r_cap = min(r_cap, (half - needed_end_half) / control_horizon_s)
    if r < r_cap:
        return r
    best = _deviation_for_rate(max(r_cap, 0.0), eta, sampling_period_s, control_horizon_s, max_midrange_change_mps2)
    if r * control_horizon_s >= half:
        reason = (
            f"restriction r = {r:.4g} m/s empties the ZMP box within T_c = {control_horizon_s} s "
            f"(r*T_c = {r * control_horizon_s:.4g} m >= d_z/2 = {half:.4g} m)"
        )
    else:
        reason = (
            f"the preview T_p = {preview_horizon_s} s is too short for v_z,max = {max_zmp_speed_mps} m/s "
            f"with restriction r = {r:.4g} m/s"
        )
    raise ParameterError(
        f"cannot guarantee delta_max = {delta_max_mps2} m/s^2: {reason}; the largest guaranteed "
        f"delta_max with this foot and horizon is < {best:.4g} m/s^2"
    )
