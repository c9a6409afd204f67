"""The sections every diagnosis report shares: its warnings, the samples the recordings' screening masked and the
recordings it left out, what the diagnosis could not see (detection limits), the confusable pairs with their
evidence, the drift of the baseline over the session (table and figure), and the residual over
time per recording (not folded over a cycle, so a drift shows)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .figures import save_figure
from .tables import md_table


def warning_lines(d) -> list:
    """The diagnosis's data and fit warnings, as a markdown list (nothing when there are none)."""
    if not d.warnings:
        return []
    return ["**Warnings** (data or fit problems the verdict does not cover):", "",
            *[f"- {w}" for w in d.warnings], ""]


def screening_lines(d) -> list:
    """Every sample the recordings' screening masked and every recording it left out
    (:mod:`acausal.identify.masking`), as markdown (nothing when the data were clean)."""
    sc = getattr(d, "screening", {}) or {}
    masked, left = sc.get("masked", []), sc.get("left_out", [])
    if not masked and not left:
        return []
    out = ["**Screened samples**: what no sensor or motion can produce was masked (left out of the residual, the "
           "replay's inputs held across it) or, where too much of a recording was, the recording left out; a "
           "recording with rows missing (a gap) is split there where the model can restart its replay (kind "
           "`gap`); the raw files are untouched (`--strict` refuses such a set instead).", ""]
    if left:
        out += [md_table(["recording left out", "why"], [[x["recording"], x["why"]] for x in left]), ""]
    if masked:
        out += [md_table(["recording", "line", "column", "t [s]", "kind", "why"],
                         [[m["recording"], str(m["line"]), m["column"] or "(the row)", f"{m['t']:.6g}", m["kind"],
                           m["why"]] for m in masked]), ""]
    return out


def _size(v, unit: str) -> str:
    return "-" if v is None else f"{v:.3g} {unit}".rstrip()


def detection_lines(d, readings: dict | None = None) -> list:
    """Markdown: the detection limit of every candidate (and, when nothing was named, a sentence saying how large
    an effect could have gone unseen); ``readings``: id -> a physical reading of its limit (optional words)."""
    lims = d.detection_limits
    if not lims:
        return []
    readings = readings or {}
    rows = [[f"`{cid}`", f"`{x['parameter']}`", _size(x["size"], x["unit"]),
             "-" if x.get("value") is None else f"{x['value']:.4g}", x.get("binding", ""),
             readings.get(cid, "") or x.get("note", "")] for cid, x in lims.items()]
    th = d.thresholds
    md = ["## What this data could not see: detection limits", "",
          f"The smallest size of each candidate that would have been named at this data's noise (a held-out gain of "
          f"{100 * th.min_gain:.0f} % once refitted, linearised from its fingerprint; the BIC test where it binds "
          "instead):", "",
          md_table(["candidate", "parameter", "size (departure from none)", "parameter value", "binding test",
                    "reading"], rows), ""]
    if not d.causes:
        seen = [f"`{cid}` below {_size(x['size'], x['unit'])}" for cid, x in lims.items() if x["size"] is not None]
        md += ["Nothing was named. That does not mean nothing is there: at this data's noise an effect could have "
               "gone unseen up to " + "; ".join(seen) + ".", ""]
    return md


def confusable_lines(d) -> list:
    """Markdown: the confusable pairs with the evidence that separated them (or the statement that it cannot)."""
    if not d.confusable:
        th = d.thresholds
        return [f"No confusable pair: no two candidates both count in the first step with fingerprints correlated "
                f"beyond |cos| = {th.related:g}, and none are collinear beyond |cos| = {th.confusable:g}.", ""]
    md = ["Confusable pairs and what separated them:", ""]
    for c in d.confusable:
        md.append(f"- `{c['a']}` / `{c['b']}` (|cos| = {c['cos']:.2f}, {c['kind']}): {c['evidence']}"
                  + ("" if c["separated"] else " **(not separated)**") + ".")
    return md + [""]


def drift_lines(d, figure: Path | None = None) -> list:
    """Markdown: the per-recording baseline and its trend over the session."""
    dr = d.drift
    if not dr or not dr.get("recordings"):
        return ["## Drift over the session", "", f"Not judged: {dr.get('note', 'no recordings')}.", ""] if dr else []
    names = list(dr["trends"])
    md = ["## Drift over the session", "",
          "The final model (baseline and named effects) refitted on each recording alone (parameter combinations "
          f"one recording does not determine stay at the pooled fit), against {dr['axis']}; a trend counts as drift "
          "when its slope is significant (p <= 0.01, Student t on the scatter about the line) and it changes the "
          "parameter by 1 % or more over the session.", "",
          md_table(["recording", dr["axis"], *[f"`{n}`" + _unit(dr, n, " [{}]") for n in names]],
                   [[r["experiment"], f"{r['x']:.4g}", *[f"{r[n]:.4g}" for n in names]] for r in dr["recordings"]]),
          "",
          md_table(["parameter", "unit", "first", "last", "change over the session", "t", "p", "drift"],
                   [[f"`{n}`", _unit(dr, n, "{}") or "-", f"{tr['first']:.4g}", f"{tr['last']:.4g}", f"{tr['change']:+.3g}",
                     "-" if tr["t"] is None else f"{tr['t']:.1f}", "-" if tr["p"] is None else f"{tr['p']:.2g}",
                     "**yes**" if n in dr["drifting"] else "no"] for n, tr in dr["trends"].items()]), ""]
    for n in dr["drifting"]:
        by = dr["explained_by"].get(n) or []
        md.append(f"`{n}` drifts over the session" + (": a candidate that explains it is "
                                                      + ", ".join(f"`{c}`" for c in by) if by else
                                                      ": no candidate explains a drift of it") + ".")
    if dr["drifting"]:
        md.append("")
    if figure is not None:
        md += [f"![per-recording baseline]({Path(figure).name})", ""]
    return md


def _unit(dr: dict, name: str, form: str) -> str:
    """``form`` filled with the drift's unit of ``name``, or "" where it has none (a ratio, or unknown)."""
    u = (dr.get("units") or {}).get(name, "")
    return form.format(u) if u and u != "1" else ""


def drift_figure(path, d, shows: str = "") -> Path | None:
    """The final model's parameters fitted on each recording alone (dashed: the pooled fit) against the session
    axis."""
    import matplotlib.pyplot as plt

    dr = d.drift
    if not dr or not dr.get("recordings"):
        return None
    names = list(dr["trends"])
    x = np.array([r["x"] for r in dr["recordings"]])
    fig, axes = plt.subplots(1, len(names), figsize=(3.2 * len(names), 2.6), squeeze=False)
    for ax, n in zip(axes[0], names):
        y = np.array([r[n] for r in dr["recordings"]])
        ax.plot(x, y, "o-", color="C3" if n in dr["drifting"] else "C0", ms=4)
        ax.axhline(d.final.values[n], color="k", lw=0.6, ls="--")
        ax.set_title(f"{n}" + (" (drifts)" if n in dr["drifting"] else ""), fontsize=8)
        ax.set_xlabel(dr["axis"], fontsize=8)
        ax.set_ylabel(_unit(dr, n, "{}") or "fitted on one recording", fontsize=8)
    fig.suptitle("Drift check, each parameter fitted on one recording (dashed: the pooled fit): "
                 + (", ".join(dr["drifting"]) + " drift" if dr["drifting"] else "no drift"),
                 fontsize=9)
    return save_figure(fig, path, shows)


def residual_time_figure(path, problem, fit, units: dict | None = None, shows: str = "") -> Path:
    """Measured - simulated over time, one panel per signal, recordings one after another in their session order
    (each drawn in its own colour, with its mean per stride as a line), so a drift between or within recordings
    shows where a residual folded over the cycle hides it."""
    import matplotlib.pyplot as plt

    units = units or {}
    signals = list(problem.signals)
    fig, axes = plt.subplots(len(signals), 1, figsize=(8, 2.2 * len(signals)), sharex=True, squeeze=False)
    preds = {e.name: e.predict(fit.values) for e in fit.exps}
    offset = 0.0
    for k, e in enumerate(fit.exps):
        inner = e.train | e.test
        t = e.t[inner] - e.t[0] + offset
        for ax, s in zip(axes[:, 0], signals):
            r = (e.measured[s] - preds[e.name][s])[inner]
            ax.plot(t, r, ",", color=f"C{k % 10}", alpha=0.3)
            T = problem.period(e) or (t[-1] - t[0]) / 10
            b = np.floor((t - t[0]) / T).astype(int)
            means = np.bincount(b, r) / np.maximum(np.bincount(b), 1)
            ax.step(t[0] + T * np.arange(means.size), means, where="post", color=f"C{k % 10}", lw=1.2)
        offset = t[-1] + 0.05 * (t[-1] - t[0] + 1e-9)
    for ax, s in zip(axes[:, 0], signals):
        ax.axhline(0, color="k", lw=0.5)
        ax.set_ylabel(f"{s}\n[{units.get(s, '')}]", fontsize=8)
    axes[0, 0].set_title("measured - simulated over time, recordings in session order (lines: mean per stride)",
                         fontsize=9)
    axes[-1, 0].set_xlabel("time, recordings placed one after another [s]")
    return save_figure(fig, path, shows)
