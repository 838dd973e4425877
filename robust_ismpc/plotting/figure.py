"""Figure plumbing shared by every plot: matplotlib on the Agg backend, atomic PNG output."""

from __future__ import annotations

import io
from pathlib import Path

from ..io import atomic_write_bytes


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (imported on first use: it is slow to import)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: str | Path, crop: bool = True) -> None:
    """Write ``fig`` as a PNG at ``path``, atomically (a reader never sees half a file).

    ``crop`` trims the page to what is drawn (and keeps legends placed outside the axes); it
    costs a second drawing pass, so a figure already laid out with ``tight_layout`` skips it.
    """
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110, bbox_inches="tight" if crop else None)
    atomic_write_bytes(Path(path), buffer.getvalue())


def finish_figure(plt, fig, path: str | Path) -> Path:
    """Lay out (as ``tight_layout``), write and close ``fig``; returns the path.

    The layout is applied once, without leaving a layout engine on the figure: with one,
    ``savefig`` draws the whole figure an extra time before the drawing it saves.
    """
    from matplotlib.layout_engine import TightLayoutEngine

    TightLayoutEngine().execute(fig)
    save_figure(fig, Path(path), crop=False)
    plt.close(fig)
    return Path(path)
