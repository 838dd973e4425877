"""Figures of a push-recovery sweep's frontier (the ``frontier.json`` dict): polar and per gait phase."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .figure import pyplot, save_figure


def _label(frontier: dict, kind: str) -> str:
    config = frontier.get("config", {})
    sensing = config.get("sensing", "ideal")
    if sensing == "ideal":
        return f"largest survived {kind} [{frontier['units'][kind]}]"
    repeats = config.get("repeats", 1)
    held = f"survived by most of {repeats} trials" if repeats > 1 else "survived (one trial)"
    return f"largest {kind} {held} [{frontier['units'][kind]}], {sensing} sensing"


def plot_frontier_polar(frontier: dict, kind: str, path: Path) -> Path:
    """Polar frontier: per controller, radius = min over phases (solid) and mean over phases (dashed).

    Parameters
    ----------
    frontier : dict
        A sweep's ``frontier.json`` content (keys ``robot``, ``sim``, ``units``, ``frontier``).
    kind : str
        ``impulse`` or ``force``: a key of ``frontier["frontier"]``.
    path : path
        PNG file to write.
    """
    plt = pyplot()
    table = frontier["frontier"][kind]
    fig = plt.figure(figsize=(6, 6))
    ax = fig.add_subplot(projection="polar")
    for controller, ctrl_table in table.items():
        dirs = sorted(ctrl_table, key=float)
        theta = np.radians([float(d) for d in dirs])
        low = np.array([ctrl_table[d]["min"] for d in dirs])
        mean = np.array([ctrl_table[d]["mean"] for d in dirs])
        if len(dirs) >= 3:
            theta, low, mean = (np.append(a, a[0]) for a in (theta, low, mean))
        (line,) = ax.plot(theta, low, "o-", lw=1.5, ms=4, label=controller)
        if len(table[controller][dirs[0]]["per_phase"]) > 1:
            ax.plot(theta, mean, "--", lw=0.9, color=line.get_color(), alpha=0.7)
    ax.set_theta_zero_location("E")
    ax.set_theta_direction(1)
    ax.set_title(f"{frontier['robot']} / {frontier['sim']}: {_label(frontier, kind)}\n(solid: min over phases, dashed: mean; "
                 "0° = forward, 90° = left)", fontsize=9)
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8)
    save_figure(fig, path)
    plt.close(fig)
    return Path(path)


def plot_frontier_phase(frontier: dict, kind: str, path: Path) -> Path:
    """Per-phase frontier: one panel per direction, one line per controller.

    Parameters
    ----------
    frontier : dict
        A sweep's ``frontier.json`` content (keys ``robot``, ``sim``, ``units``, ``frontier``).
    kind : str
        ``impulse`` or ``force``: a key of ``frontier["frontier"]``.
    path : path
        PNG file to write.
    """
    plt = pyplot()
    table = frontier["frontier"][kind]
    dirs = sorted(next(iter(table.values())), key=float)
    cols = min(4, len(dirs))
    rows = int(math.ceil(len(dirs) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.6 * rows), squeeze=False, sharey=True)
    for ax, d in zip(axes.flat, dirs):
        for controller, ctrl_table in table.items():
            cell = ctrl_table[d]
            ax.plot(cell["phases"], cell["per_phase"], "o-", ms=3, lw=1.2, label=controller)
        ax.set_title(f"direction {d}°", fontsize=9)
        ax.set_xlabel("phase of single support", fontsize=8)
        ax.set_xlim(-0.05, 1.0)
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(dirs):]:
        ax.set_visible(False)
    for ax in axes[:, 0]:
        ax.set_ylabel(f"{kind} [{frontier['units'][kind]}]", fontsize=8)
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(f"{frontier['robot']} / {frontier['sim']}: {_label(frontier, kind)} per gait phase", fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
    return Path(path)
