"""Figures of runs: the gait of one run, runs side by side, the swing-leg CoP fit."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..runs.trace import Trace
from .figure import finish_figure, pyplot

#: Runs longer than this [s] are drawn as their last :data:`DETAIL_S` seconds, with an overview
#: of the whole run (decimated to at most :data:`OVERVIEW_POINTS` points) below: the whole of a
#: 10-minute walk at one scale is metres of overlapping footsteps and solid bands.
LONG_RUN_S = 60.0
DETAIL_S = 20.0
OVERVIEW_POINTS = 2000


def _sole_outline(pos: np.ndarray, yaw: float, corners: np.ndarray) -> np.ndarray:
    """``corners`` (sole frame, shape (4, 2)) rotated by ``yaw`` and moved to ``pos`` [m]."""
    c, s = np.cos(yaw), np.sin(yaw)
    return pos + corners @ np.array([[c, s], [-s, c]])


def detail_window(trace: Trace) -> tuple[float, float]:
    """Time span [s] drawn in detail: the whole run, or its last :data:`DETAIL_S` seconds if it is
    longer than :data:`LONG_RUN_S`."""
    t = trace["t_s"]
    if not len(t):
        return 0.0, 0.0
    t_end = float(t[-1])
    return (max(float(t[0]), t_end - DETAIL_S) if t_end - float(t[0]) > LONG_RUN_S else float(t[0])), t_end


def _decimation(n: int) -> int:
    """Stride that leaves at most :data:`OVERVIEW_POINTS` of ``n`` samples."""
    return max(1, -(-n // OVERVIEW_POINTS))


def _footstep_patches(ax, trace: Trace, t_end: float, color: str, label: str | None, t_start: float = 0.0) -> None:
    from matplotlib.patches import Polygon

    L = trace.meta.get("sole_length_m", 0.2)
    W = trace.meta.get("sole_width_m", 0.1)
    corners = np.array([[L, W], [L, -W], [-L, -W], [-L, W]]) / 2
    steps = trace.footsteps_m
    done = np.ones(len(steps), dtype=bool)
    done[0] = False  # virtual midpoint
    done[2:] = trace.footstep_touchdown_s[2:] <= t_end + 1e-9
    if t_start > 0:  # only the steps that land in the window drawn
        done[1] = False
        done[2:] &= trace.footstep_touchdown_s[2:] >= t_start
    first = True
    for pos, yaw, side, ok in zip(steps, trace.footstep_yaw_rad, trace.footstep_side, done):
        if not ok:
            continue
        ax.add_patch(Polygon(_sole_outline(pos, yaw, corners), closed=True, fill=False, ec=color if side > 0 else "tab:gray", lw=1.0,
                             label=label if first else None))
        first = False
    cand = trace.candidate_footsteps_m[1:][done[1:]]
    ax.plot(cand[:, 0], cand[:, 1], "+", color="k", ms=5, alpha=0.5, label="candidate footsteps" if label else None)
    _measured_footprints(ax, trace, done, corners, color)


def _measured_footprints(ax, trace: Trace, done: np.ndarray, corners: np.ndarray, color: str) -> None:
    """Filled footprints where a full robot's feet really were, 0.05 s after each planned touchdown
    (the plan's footsteps are where the controller's internal model puts them)."""
    from matplotlib.patches import Polygon

    soles = trace.channels.get("sole_meas_m")
    if soles is None or not np.isfinite(soles).any():
        return
    yaws = trace.channels["sole_meas_yaw_rad"]
    t = trace["t_s"]
    first = True
    for j in np.flatnonzero(done[2:]) + 2:
        k = min(int(np.searchsorted(t, trace.footstep_touchdown_s[j] + 0.05)), len(t) - 1)
        column = 0 if trace.footstep_side[j] > 0 else 1
        pos, yaw = soles[k, 2 * column : 2 * column + 2], yaws[k, column]
        if not np.all(np.isfinite(pos)):
            continue
        ax.add_patch(Polygon(_sole_outline(pos, yaw, corners), closed=True, lw=0,
                             fc=color if column == 0 else "tab:gray", alpha=0.25,
                             label="real footsteps (measured)" if first else None))
        first = False


def run_outcome(trace: Trace) -> str:
    """What happened in a run, for its figure's title.

    ``fell at T s`` or ``walked T s`` (T the end of the trace), the number of step-timing
    adaptations (``meta["timing_adaptations"]``, else counted in the trace), and the path deviation
    when the run's ``meta["path_deviation_m"]`` gives one (in cm).
    """
    t = trace["t_s"]
    t_end = float(t[-1]) if len(t) else 0.0
    parts = [f"fell at {t_end:.2f} s" if trace.meta.get("fell") else f"walked {t_end:.1f} s"]
    adaptations = trace.meta.get("timing_adaptations")
    if adaptations is None:
        adaptations = int(np.count_nonzero(np.nan_to_num(trace["timing_adapted"]) > 0))
    parts.append(f"{adaptations} step-timing adaptation{'' if adaptations == 1 else 's'}")
    deviation = trace.meta.get("path_deviation_m")
    if deviation is not None:
        parts.append(f"path deviation {100.0 * deviation:.1f} cm")
    return ", ".join(parts)


def _draw_run(axes, trace: Trace, title: str) -> None:
    title = f"{title}\n{run_outcome(trace)}"
    t_start, t_end = detail_window(trace)
    if len(trace) and t_start > trace["t_s"][0]:
        title = f"{title} (last {t_end - t_start:.0f} s of {t_end:.0f} s)"
    trace = _window(trace, t_start)
    t = trace["t_s"]
    top, ax_x, ax_y, ax_w = axes
    _footstep_patches(top, trace, t_end, "tab:blue", "planned footsteps (left blue)", t_start)
    top.plot(trace["zmp_m"][:, 0], trace["zmp_m"][:, 1], color="tab:orange", lw=1, label="ZMP")
    top.plot(trace["com_m"][:, 0], trace["com_m"][:, 1], color="tab:green", lw=1.5, label="CoM")
    top.set_aspect("equal", adjustable="datalim")
    top.set_xlabel("x [m]")
    top.set_ylabel("y [m]")
    top.set_title(title, fontsize=9)
    top.legend(loc="best", fontsize=7)
    half = trace["box_half_m"]
    if not np.isfinite(half).any():
        half = np.tile(0.5 * np.array([trace.meta.get("zmp_box_x_m", np.nan), trace.meta.get("zmp_box_y_m", np.nan)]),
                       (len(t), 1))
    for axis, ax in ((0, ax_x), (1, ax_y)):
        name = "xy"[axis]
        centre = trace["box_centre_m"][:, axis]
        ax.fill_between(t, centre - half[:, axis], centre + half[:, axis], color="tab:orange", alpha=0.2,
                        label="ZMP bounds (box)")
        ax.plot(t, trace["zmp_m"][:, axis], color="tab:orange", lw=1, label="ZMP")
        ax.plot(t, trace["com_m"][:, axis], color="tab:green", lw=1.2, label="CoM")
        feas = trace["feasibility_m"][:, 2 * axis : 2 * axis + 2]
        if np.isfinite(feas).any():
            ax.plot(t, trace["dcm_m"][:, axis], color="tab:purple", lw=0.8, label="DCM (shifted)")
            ax.plot(t, feas[:, 0], "--", color="tab:red", lw=0.7, label="feasibility region")
            ax.plot(t, feas[:, 1], "--", color="tab:red", lw=0.7)
        adapted = np.nan_to_num(trace["timing_adapted"]) > 0
        if adapted.any():
            ax.plot(t[adapted], trace["com_m"][adapted, axis], "v", color="tab:red", ms=4,
                    label="step timing adapted")
        ax.set_ylabel(f"{name} [m]")
        ax.legend(loc="best", fontsize=7)
    ax_y.set_xlabel("t [s]")
    w_true = trace["disturbance_true_mps2"]
    w_est = trace["disturbance_est_mps2"]
    w_meas = trace.channels.get("disturbance_measured_mps2")
    if w_meas is not None and not np.isfinite(w_meas).any():
        w_meas = None  # nominal: no observer
    for axis, color in ((0, "tab:blue"), (1, "tab:red")):
        ax_w.plot(t, w_true[:, axis], color=color, lw=0.8, alpha=0.6, label=f"w_{'xy'[axis]} applied")
        if w_meas is not None:
            ax_w.plot(t, w_meas[:, axis], ":", color=color, lw=0.7, label=f"w_{'xy'[axis]} measured (ŵ)")
        ax_w.plot(t, w_est[:, axis], "--", color=color, lw=1.2, label=f"w_{'xy'[axis]} planned (w̃)")
    ax_w.set_ylabel("disturbance [m/s²]")
    ax_w.set_xlabel("t [s]")
    ax_w.legend(loc="best", fontsize=7)


def _draw_read_velocity(ax, trace: Trace) -> None:
    """The CoM velocity the controller read (its sensors and estimate) against the true one."""
    t = trace["t_s"]
    for axis, color in ((0, "tab:blue"), (1, "tab:red")):
        ax.plot(t, trace["com_vel_read_mps"][:, axis], color=color, lw=0.5, alpha=0.5, label=f"ċ_{'xy'[axis]} read")
        ax.plot(t, trace["com_vel_mps"][:, axis], color=color, lw=1.2, label=f"ċ_{'xy'[axis]} true")
    ax.set_ylabel("CoM velocity [m/s]")
    ax.set_xlabel("t [s]")
    ax.legend(loc="best", fontsize=7, ncol=2)


def _window(trace: Trace, t_start: float) -> Trace:
    """``trace`` from ``t_start`` on (the same object if that is all of it)."""
    t = trace["t_s"]
    if not len(t) or t_start <= t[0]:
        return trace
    keep = t >= t_start
    return replace(trace, channels={k: v[keep] for k, v in trace.channels.items()})


def _draw_overview(ax, trace: Trace, t_start: float) -> None:
    """CoM x and y over the whole run, decimated, with the detail window shaded."""
    step = _decimation(len(trace))
    t = trace["t_s"][::step]
    for axis, color in ((0, "tab:green"), (1, "tab:olive")):
        ax.plot(t, trace["com_m"][::step, axis], color=color, lw=1, label=f"CoM {'xy'[axis]}")
    ax.axvspan(t_start, float(trace["t_s"][-1]), color="tab:gray", alpha=0.2, label="drawn above")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("whole run [m]")
    ax.legend(loc="best", fontsize=7)


def plot_run(trace: Trace, path: str | Path, title: str | None = None) -> Path:
    """Write the gait figure of one run: top view; x, y over time with ZMP bounds, DCM and
    feasibility region; applied, measured (ŵ) and planned (w̃) disturbance; with sensing other
    than ``ideal``, the CoM velocity the controller read against the true one. The title is
    ``title`` (default: robot / simulator / controller) followed by what happened
    (:func:`run_outcome`). A run longer than :data:`LONG_RUN_S` is drawn over its last
    :data:`DETAIL_S` seconds, with the CoM of the whole run (decimated) in an extra panel."""
    plt = pyplot()
    t_start, _ = detail_window(trace)
    long_run = len(trace) > 0 and t_start > trace["t_s"][0]
    sensed = (trace.meta.get("sensing") or {}).get("name", "ideal") != "ideal"
    fig = plt.figure(figsize=(11, 10 + 2 * long_run + 2 * sensed))
    ratios = [1.4, 1, 1, 0.8] + ([0.8] if sensed else []) + ([0.8] if long_run else [])
    grid = fig.add_gridspec(len(ratios), 1, height_ratios=ratios)
    axes = [fig.add_subplot(grid[0])]
    axes.append(fig.add_subplot(grid[1]))
    axes.append(fig.add_subplot(grid[2], sharex=axes[1]))
    axes.append(fig.add_subplot(grid[3], sharex=axes[1]))
    if sensed:
        _draw_read_velocity(fig.add_subplot(grid[4], sharex=axes[1]), _window(trace, t_start))
    if long_run:
        _draw_overview(fig.add_subplot(grid[len(ratios) - 1]), trace, t_start)
    meta = trace.meta
    sim = meta.get("sim")
    if sim == "mujoco" and meta.get("whole_body", "servo") != "servo":
        sim = f"{sim} ({meta['whole_body']} control)"
    _draw_run(axes, trace, title or f"{meta.get('robot')} / {sim} / {meta.get('controller')}")
    return finish_figure(plt, fig, path)


def plot_comparison(traces: Sequence[Trace], labels: Sequence[str], path: str | Path, title: str = "",
                    events: Sequence[tuple[str, float]] = ()) -> Path:
    """Side-by-side gait figures of several runs on the same disturbances (one column each).

    Each column is titled with its label and what happened in its run (:func:`run_outcome`).

    ``events`` are (label, time [s]) pairs, e.g. a ball hit or the start of a push, drawn as
    vertical lines on every time axis.
    """
    plt = pyplot()
    n = len(traces)
    fig = plt.figure(figsize=(7 * n, 11))
    grid = fig.add_gridspec(4, n, height_ratios=[1.4, 1, 1, 0.8])
    for col, (trace, label) in enumerate(zip(traces, labels)):
        axes = [fig.add_subplot(grid[0, col])]
        axes.append(fig.add_subplot(grid[1, col]))
        axes.append(fig.add_subplot(grid[2, col], sharex=axes[1]))
        axes.append(fig.add_subplot(grid[3, col], sharex=axes[1]))
        _draw_run(axes, trace, label)
        for name, t_event in events:
            for ax in axes[1:]:
                ax.axvline(t_event, color="black", linestyle=":", linewidth=1.0)
            axes[1].annotate(name, (t_event, 1.0), xycoords=("data", "axes fraction"), xytext=(2, -10),
                             textcoords="offset points", fontsize=8)
    if title:
        fig.suptitle(title)
    return finish_figure(plt, fig, path)


def plot_swing_cop_fit(acceleration_mps2: np.ndarray, deviation_m: np.ndarray, gain_s2: float, offset_m: float,
                       path: str | Path, title: str = "") -> Path:
    """Scatter of the forward CoP deviation against the swing foot's forward acceleration, with
    the fitted line (:func:`robust_ismpc.sim.calibrate.fit_swing_cop_gain`)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 5))
    acc = np.asarray(acceleration_mps2, dtype=float)
    dev = np.asarray(deviation_m, dtype=float)
    ax.plot(acc, 100.0 * dev, ".", ms=3, alpha=0.5, label="single-support ticks")
    line = np.linspace(acc.min(), acc.max(), 2) if acc.size else np.zeros(2)
    ax.plot(line, 100.0 * (gain_s2 * line + offset_m), "-", color="black",
            label=f"fit: κ = {gain_s2:.4f} s²")
    ax.set_xlabel("swing foot forward acceleration [m/s²]")
    ax.set_ylabel("CoP − ZMP, forward [cm]")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best")
    if title:
        ax.set_title(title)
    return finish_figure(plt, fig, path)
