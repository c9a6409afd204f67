"""Sankey diagram of one stride's energy chain: source -> driver output -> motor shaft -> moment arm -> joint,
each stage's loss flowing down (used by ``examples/table1.py`` and ``acausal compare``).

Arrow widths are proportional to joules per stride (``scale``: width per J, the same for diagrams drawn side by
side). A stage whose energy grows (a negative loss: only through stored energy) is drawn with zero loss and
named in a note, so that nothing is hidden.
"""
from __future__ import annotations

import logging

from matplotlib.sankey import Sankey


logging.getLogger("matplotlib.axes").setLevel(logging.ERROR)  # Sankey's equal aspect overrides fixed limits

LABELS = {"source": "source", "driver": "driver output", "motor": "motor shaft", "link": "moment arm (link)",
          "output": "joint (output)"}


def loss_names_from_groups(loss_groups: dict, link: str = "linkage") -> list:
    """``(point after the stage, label)`` of each stage's loss, from a model's loss groups (``{"driver": [...],
    "motor": [...], "gearing": [...], "output": [...]}`` of loss-power names such as ``"rect.loss_power"``, as
    :attr:`StrideResult.stages <acausal.models.ankle.protocol.StrideResult.stages>` holds them)."""
    def who(stage):
        names = [n.split(".")[0] for n in loss_groups.get(stage, [])]
        return f"\n({', '.join(names)})" if names and names != [stage] else ""
    return [("driver", "driver loss" + who("driver")), ("motor", "motor loss" + who("motor")),
            ("link", "gearing loss" + who("gearing")), ("output", f"output loss\n({link})")]


def sankey(ax, energy: dict, title: str, scale: float, loss_names: list, labels: dict = LABELS,
           lossless_note: str = "output loss 0 J\n(MACCEPA modelled\nlossless)"):
    """Draw ``energy`` (J per stride at each point, in chain order: source first, joint last) on ``ax``;
    ``scale``: arrow width per J."""
    points = list(energy)
    s = Sankey(ax=ax, scale=scale, unit=" J", format="%.1f", gap=0.35, head_angle=120, shoulder=0.02,
               offset=0.12)
    prior = None
    gained = []
    for i, (a, b) in enumerate(zip(points, points[1:])):
        loss = energy[a] - energy[b]
        if loss < -1e-6 * abs(energy["source"]):
            gained.append(f"{labels[b]} +{-loss:.2g} J")
        loss = max(loss, 0.0)
        name = loss_names[i][1]
        flows = [energy[a], -loss, -energy[b]]
        if loss < 1e-6 * abs(energy["source"]):
            flows[1], name = 0.0, None  # nothing lost here: drawn as a note below
        lab = [labels[a] if i == 0 else None, name, labels[b] if b == points[-1] else None]
        kw = dict(prior=prior, connect=(2, 0)) if prior is not None else {}
        s.add(flows=flows, orientations=[0, -1, 0], labels=lab, pathlengths=[0.25, 0.35, 0.25],
              trunklength=1.0, facecolor=f"C{i}", alpha=0.75, **kw)
        prior = i
    diagrams = s.finish()
    for d in diagrams:
        for t in d.texts:
            t.set_fontsize(8)
    # annotate the energy passed on at each intermediate point along the top edge of the band
    for i, b in enumerate(points[1:-1]):
        x, y = diagrams[i].tips[2]
        ax.annotate(f"{labels[b]}\n{energy[b]:.1f} J", (x, y + 0.5 * energy[b] * scale), xytext=(0, 6),
                    textcoords="offset points", ha="center", va="bottom", fontsize=8)
    last = energy[points[-2]] - energy[points[-1]]
    if abs(last) < 1e-6 * abs(energy["source"]) and lossless_note:
        x, y = diagrams[-1].tips[2]
        ax.annotate(lossless_note, (x, y), xytext=(0, -14), textcoords="offset points", ha="center", va="top",
                    fontsize=8, color="C3")
    if gained:
        ax.text(0.0, 0.0, "energy grows (stored energy released): " + "; ".join(gained), transform=ax.transAxes,
                fontsize=7, color="C3")
    ax.set_title(title, fontsize=10)
    ax.axis("off")
