"""Figures of every report: one way to lay out, save and close a matplotlib figure."""
from __future__ import annotations

from pathlib import Path


def save_figure(fig, path, shows: str = "", dpi: int = 110) -> Path:
    """Tight layout, save ``fig`` as ``path`` (PNG at ``dpi``), close it; returns the path. ``shows``: which model
    and parameter set the figure shows, written small in its lower left corner."""
    import matplotlib.pyplot as plt

    path = Path(path)
    fig.tight_layout(rect=(0, 0.03, 1, 1) if shows else None)
    if shows:
        fig.text(0.005, 0.005, shows, fontsize=7, color="0.3", ha="left", va="bottom")
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path
