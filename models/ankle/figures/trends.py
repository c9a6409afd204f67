"""The sentence a figure's caption gives for each trend the paper's text states about that figure: whether the model
shows it, what the paper says, what the model gives (its numbers, computed from the figure's own data) and, where the
model differs, the mechanism in the model that makes it differ. Nothing is forced: a trend the model does not show is
reported as differing, with its reason.

Every such sentence starts ``**Fig. N, <trend>: as in the paper.**`` or ``**Fig. N, <trend>: differs from the
paper.**``, so a reader (and a test) finds the verdicts of a caption by that pattern (:data:`VERDICT`).
"""
from __future__ import annotations

import re

#: the head of a verdict sentence: figure, trend, "as in the paper" | "differs from the paper"
VERDICT = re.compile(r"\*\*(Figs?\. [0-9][0-9a-z()-]*), ([^*]+?): (as in the paper|differs from the paper)\.\*\*")


def verdict(figure: str, trend: str, agrees: bool, paper: str, model: str, why: str = "") -> str:
    """One verdict sentence (markdown). ``figure``: e.g. ``"Fig. 7"``; ``trend``: what is compared, in a few words;
    ``paper``: what the paper's text says; ``model``: what the model gives (with its numbers); ``why``: the
    mechanism in the model that makes it differ (required when it differs)."""
    if not agrees and not why:
        raise ValueError(f"{figure}, {trend}: a trend that differs from the paper needs its reason")
    head = "as in the paper" if agrees else "differs from the paper"
    text = f"**{figure}, {trend}: {head}.** Paper: {paper}. Model: {model}."
    return text + (f" Why: {why}." if why else "")


def verdicts(markdown: str) -> dict:
    """``{(figure, trend): agrees}`` of every verdict sentence in ``markdown``."""
    return {(m.group(1), m.group(2)): m.group(3) == "as in the paper" for m in VERDICT.finditer(markdown)}


def verdict_rows(markdown: str) -> list[dict]:
    """Every verdict sentence of ``markdown`` as a row: ``figure``, ``trend``, ``as_in_the_paper`` ("yes"/"no") and
    ``text`` (the sentence with what follows it up to the next verdict or the paragraph's end, bold marks removed):
    the rows of ``figure_verdicts.csv``."""
    heads = list(VERDICT.finditer(markdown))
    rows = []
    for m, nxt in zip(heads, [*heads[1:], None]):
        end = markdown.find("\n\n", m.start())
        end = len(markdown) if end < 0 else end
        if nxt is not None:
            end = min(end, nxt.start())
        rows.append(dict(figure=m.group(1), trend=m.group(2),
                         as_in_the_paper="yes" if m.group(3) == "as in the paper" else "no",
                         text=" ".join(markdown[m.start():end].replace("**", "").split())))
    return rows


def phase_of(t_frac: float, push_off: tuple) -> str:
    """Where in the stride a time (fraction of the stride from heel strike) lies relative to push-off
    (``(start, end)`` as fractions): ``"before push-off"``, ``"push-off"`` or ``"after push-off (early swing)"``
    (up to 0.15 of the stride after it ends; later ``"late swing"``)."""
    a, b = push_off
    if t_frac < a:
        return "before push-off"
    if t_frac <= b:
        return "push-off"
    return "after push-off (early swing)" if t_frac <= b + 0.15 else "late swing"


def push_off_span(t, joint_power) -> tuple:
    """Push-off as the stride's fractions ``(start, end)``: the positive lobe of the joint power around its largest
    value (the ankle's push-off burst, where it delivers its work). ``t`` from heel strike over one stride."""
    import numpy as np

    t, p = np.asarray(t, float), np.asarray(joint_power, float)
    T = t[-1] - t[0]
    k = int(np.argmax(p))
    a = k
    while a > 0 and p[a - 1] > 0:
        a -= 1
    b = k
    while b < len(p) - 1 and p[b + 1] > 0:
        b += 1
    return (t[a] - t[0]) / T, (t[b] - t[0]) / T
