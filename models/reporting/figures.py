"""Figures of every report: one way to lay out, save and close a matplotlib figure."""
from __future__ import annotations

from pathlib import Path


def save_figure(fig, path, dpi: int = 110) -> Path:
    """Tight layout, save ``fig`` as ``path`` (PNG at ``dpi``), close it; returns the path."""
    import matplotlib.pyplot as plt

    path = Path(path)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path
