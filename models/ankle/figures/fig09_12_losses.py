"""Figs. 9-12 of the paper: the loss of each stage over precompression x stride time, each as a percentage of
the energy at the previous measurement point (driver: of the source; motor: of the driver output; gearing: of
the motor power k i w; output: of the moment arm), on the bench model as the paper measured them (the actuator under
its position controller: where the motor cannot follow, the arm lags). Conditions where the replay of the plan
needs more than the driver's duty limit (the motor cannot follow at 48 V) are hatched.

Writes ``fig09_driver_loss.png``, ``fig10_motor_loss.png``, ``fig11_gearing_loss.png``,
``fig12_output_loss.png``, each with its CSV.
Run: ``python -m acausal.models.ankle.figures.fig09_12_losses``
(into ``results/``; runs the bench and replay sweeps, 2 x 36 conditions).
"""
from __future__ import annotations

import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from acausal.models.ankle.paper import (BENCH, HEADLINE, comparison, followed, grid, grid_rows,  # noqa: E402
                                        heatmap, required_duty)
from acausal.models.ankle.published import PAPER  # noqa: E402
from acausal.models.reporting.tables import md_table, pct, write_csv  # noqa: E402
from acausal.models.reporting.figures import save_figure  # noqa: E402

# (file stem, point key of StrideResult.loss_fraction, stage, title, what the paper says, Table 1 at 8 mm/2 s)
FIGURES = [
    ("fig09_driver_loss", "driver", "driver",
     "Fig. 9: loss over the motor driver (supply, rectifier, driver), % of source",
     "paper: 28.6-49.3 %, optimum near 11 mm and 1.5 s/stride", PAPER["table1_loss"]["driver"]),
    ("fig10_motor_loss", "motor", "motor", "Fig. 10: loss over the motor (winding), % of driver output",
     "paper: grows with stride time and with precompression", PAPER["table1_loss"]["motor"]),
    ("fig11_gearing_loss", "link", "gearing",
     "Fig. 11: loss over rotor and gearing (planetary 86:1, helical 10:1), % of motor power",
     "paper: never below 50 %, over 65 % at high precompression and short strides", PAPER["table1_loss"]["link"]),
    ("fig12_output_loss", "output", "output (MACCEPA)",
     "Fig. 12: loss between moment arm and joint (MACCEPA), % of link",
     "paper: around 20 %, over 50 % at high precompression and short strides", PAPER["table1_loss"]["output"]),
]


def _trend(results, key, along: str, duty: dict) -> str:
    """Does the loss grow along stride time / precompression at every fixed other coordinate (feasible only)?"""
    ok = followed(results, duty)
    groups = {}
    for r in ok:
        fixed, moving = ((r.condition.P, r.condition.stride_time) if along == "T"
                         else (r.condition.stride_time, r.condition.P))
        groups.setdefault(fixed, []).append((moving, r.loss_fraction[key]))
    verdicts = []
    for vals in groups.values():
        if len(vals) < 2:
            continue
        d = np.diff(np.array([x for _, x in sorted(vals)]))
        verdicts.append("flat" if np.all(np.abs(d) < 1e-6) else "grows" if np.all(d > 0)
                        else "falls" if np.all(d < 0) else "mixed")
    if not verdicts:
        return "not determined"
    return trend_verdict(verdicts)


def trend_verdict(verdicts: list) -> str:
    """The rows' and columns' trends in one phrase: the trend most of them share (``"grows (4 of 6
    rows/columns)"``), or, where none holds a majority, each with its count, most first and ties by name
    (``"no majority (grows 3, mixed 3 of 6 rows/columns)"``): never a tie broken by the order of a set."""
    n = len(verdicts)
    ranked = sorted(((v, verdicts.count(v)) for v in set(verdicts)), key=lambda vc: (-vc[1], vc[0]))
    best, k = ranked[0]
    if 2 * k > n:
        return f"{best} ({k} of {n} rows/columns)"
    return f"no majority ({', '.join(f'{v} {c}' for v, c in ranked)} of {n} rows/columns)"


def main(out_dir: Path, results=None) -> dict:
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    bench = grid(results)
    duty = required_duty(results)
    feasible = followed(bench, duty) or bench
    figures, csvs, lines = [], [], []
    for stem, key, stage, title, paper_says, table1 in FIGURES:
        fig, ax = plt.subplots(figsize=(7.2, 5.8))
        vals = [100 * r.loss_fraction[key] for r in bench]
        # colour range at least 10 percentage points wide, so round-off and small trends do not look dramatic
        mid, half = 0.5 * (max(vals) + min(vals)), max(5.0, 0.5 * (max(vals) - min(vals)))
        vmin, vmax = max(0.0, mid - half), max(0.0, mid - half) + 2 * half
        heatmap(ax, bench, lambda r: 100 * r.loss_fraction[key], "loss relative to the previous point [%]",
                cmap="magma_r", vmin=vmin, vmax=vmax, duty=duty,
                mark=(0.008, 2.0, f"Table 1 condition (paper: {100 * table1:.1f} %)"))
        ax.set_title(title + "\n" + "\n".join(textwrap.wrap(f"({paper_says})", 80)), fontsize=9.5)
        png = save_figure(fig, out_dir / f"{stem}.png",
                          shows=f"simulation of the bench: AnkleActuator ({BENCH}), preset {HEADLINE}")
        figures.append(png)
        csvs.append(write_csv(out_dir / f"{stem}.csv",
                              grid_rows(bench, {"loss_pct_of_previous_point": lambda r, k=key: 100 * r.loss_fraction[k],
                                                "loss_J": lambda r, k=key: r.energy[_prev(k)] - r.energy[k]},
                                        duty)))
        f = [r.loss_fraction[key] for r in feasible]
        lines.append([title.split(":")[0], stage, pct(min(f)), pct(max(f)),
                      _trend(bench, key, "T", duty), _trend(bench, key, "P", duty), paper_says.replace("paper: ", "")])

    md = md_table(["figure", "stage", "min (motor can follow)", "max (motor can follow)", "along stride time",
                   "along precompression", "paper"], lines)
    md += ("\n\nMinimum and maximum over the conditions where the motor can follow (required duty <= 0.9); "
           "trends are counted over those conditions too (per precompression along stride time, per stride "
           "time along precompression).")

    drv = [r.loss_fraction["driver"] for r in feasible]
    gear = [r.loss_fraction["link"] for r in feasible]
    out = [r.loss_fraction["output"] for r in feasible]
    lo, hi = PAPER["fig9_driver_loss_range"]
    comps = [comparison("Fig. 9 smallest driver loss", min(drv), lo, "%", "driver"),
             comparison("Fig. 9 largest driver loss", max(drv), hi, "%", "driver"),
             comparison("Fig. 11 smallest gearing loss", min(gear), PAPER["fig11_gearing_loss_min"], "%", "gears"),
             comparison("Fig. 11 largest gearing loss", max(gear), PAPER["fig11_gearing_loss_worst"], "%", "gears",
                        note="Where the motor follows, the gearing loss is nearly flat (one mesh efficiency, a "
                             "constant drag); it grows where the arm lags."),
             comparison("Fig. 12 typical output loss (mean)", float(np.mean(out)), PAPER["fig12_output_loss_typical"],
                        "%", "maccepa"),
             comparison("Fig. 12 largest output loss", max(out), PAPER["fig12_output_loss_worst"], "%", "maccepa")]
    return dict(title="Figs. 9-12: stage losses over precompression x stride time", figures=figures, csv=csvs,
                markdown=md, comparisons=comps)


def _prev(key):
    order = ["source", "driver", "motor", "link", "output"]
    return order[order.index(key) - 1]


if __name__ == "__main__":
    print(main(Path("results"))["markdown"])
