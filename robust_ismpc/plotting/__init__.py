"""Plots (PNG files) of runs, comparisons and calibrations: the only package importing matplotlib.

matplotlib is imported on first use, with the Agg backend.
"""

from .figure import pyplot, save_figure
from .frontiers import plot_frontier_phase, plot_frontier_polar
from .runs import detail_window, plot_comparison, plot_run, plot_swing_cop_fit, run_outcome

__all__ = [
    "detail_window", "plot_comparison", "plot_frontier_phase", "plot_frontier_polar", "plot_run", "plot_swing_cop_fit",
    "pyplot", "run_outcome", "save_figure",
]
