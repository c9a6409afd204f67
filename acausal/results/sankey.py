"""Sankey diagram of an energy chain: the energy passed on at each measurement point (a power sensor), source
first, each stage's loss flowing down between two points (:meth:`acausal.Result.sankey` for any model with power
sensors; the paper's five-point chain in ``acausal paper`` and ``acausal compare``).

Arrow widths are proportional to joules (``scale``: width per J, the same for diagrams drawn side by
side). A stage whose energy grows (a negative loss: only through stored energy) is drawn with zero loss and
named in a note, so that nothing is hidden.
"""
from __future__ import annotations

import logging

from matplotlib.sankey import Sankey


logging.getLogger("matplotlib.axes").setLevel(logging.ERROR)  # Sankey's equal aspect overrides fixed limits

def sankey(ax, energy: dict, title: str, scale: float, loss_names: list, labels: dict | None = None,
           lossless_note: str = ""):
    """Draw ``energy`` (J at each point, in chain order: source first, load last) on ``ax``; ``scale``: arrow
    width per J; ``loss_names``: ``(point after the stage, label)`` per stage; ``labels``: point -> label
    (default: the point's name); ``lossless_note``: written under a last stage that loses nothing."""
    labels = labels or {k: k for k in energy}
    points = list(energy)
    s = Sankey(ax=ax, scale=scale, unit=" J", format="%.1f", gap=0.35, head_angle=120, shoulder=0.02,
               offset=0.12)
    prior = None
    gained = []
    for i, (a, b) in enumerate(zip(points, points[1:])):
        loss = energy[a] - energy[b]
        if loss < -1e-6 * abs(energy[points[0]]):
            gained.append(f"{labels[b]} +{-loss:.2g} J")
        loss = max(loss, 0.0)
        name = loss_names[i][1]
        flows = [energy[a], -loss, -energy[b]]
        if loss < 1e-6 * abs(energy[points[0]]):
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
    if abs(last) < 1e-6 * abs(energy[points[0]]) and lossless_note:
        x, y = diagrams[-1].tips[2]
        ax.annotate(lossless_note, (x, y), xytext=(0, -14), textcoords="offset points", ha="center", va="top",
                    fontsize=8, color="C3")
    if gained:
        ax.text(0.0, 0.0, "energy grows (stored energy released): " + "; ".join(gained), transform=ax.transAxes,
                fontsize=7, color="C3")
    ax.set_title(title, fontsize=10)
    ax.axis("off")


def balance_sankey(ax, inflows: dict, outflows: dict, title: str, small: float = 0.01):
    """One Sankey diagram of an energy balance with no measurement points: every ``inflows`` entry (J > 0:
    sources, boundary work delivered, stored energy released) enters from the left or the top, every
    ``outflows`` entry (J > 0: losses, energy stored, boundary work absorbed) leaves to the right (the largest)
    or downwards. Entries below ``small`` of the total are summed into one "other" arrow, labelled with the
    (largest three) entries it holds, so that every joule is drawn. Returns the residual (in - out) it could not draw,
    in J."""
    total = sum(inflows.values()) or 1.0

    def grouped(flows):
        big = {k: v for k, v in flows.items() if v >= small * total}
        rest = {k: v for k, v in flows.items() if k not in big}
        if sum(rest.values()) > 0:  # named, so that a small loss is not mistaken for a stored energy
            names = sorted(rest, key=lambda k: -rest[k])
            big["other: " + ", ".join(names[:3]) + (f" +{len(names) - 3}" if len(names) > 3 else "")] = \
                sum(rest.values())
        return dict(sorted(big.items(), key=lambda kv: -kv[1]))

    ins, outs = grouped(inflows), grouped(outflows)
    s = Sankey(ax=ax, scale=1.0 / total, unit=" J", format="%.3g", gap=0.45, head_angle=120, offset=0.15)
    flows = list(ins.values()) + [-v for v in outs.values()]
    orient = [0] + [1] * (len(ins) - 1) + [0] + [-1] * (len(outs) - 1)
    labels = list(ins) + list(outs)
    residual = sum(flows)
    side = [0.3] + [0.3 + 0.3 * i for i in range(len(ins) - 1)]  # staggered, so side labels do not overlap
    side += [0.3] + [0.3 + 0.3 * i for i in range(len(outs) - 1)]
    s.add(flows=flows, orientations=orient, labels=labels, pathlengths=side, trunklength=1.5, facecolor="C0",
          alpha=0.7)
    for d in s.finish():
        for t in d.texts:
            t.set_fontsize(8)
    ax.set_title(title, fontsize=10)
    ax.axis("off")
    return residual
