"""Fig. 7 of the paper: power at the driver input (source power) over one stride, 8 mm precompression,
3 s/stride, the MACCEPA actuator against a direct drive (the same motor, driver and 860:1 gears moving the joint
without the series spring), with peak power and energy per stride.

Writes ``fig07_direct_drive.png``, ``fig07_direct_drive.csv`` (the curves) and ``fig07_summary.csv``.
Run: ``python examples/fig07_direct_drive.py`` (into ``results/``).
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from acausal.models.ankle.paper import BESIDE, HEADLINE, comparison, pick  # noqa: E402
from acausal.models.ankle.published import PAPER  # noqa: E402
from acausal.models.reporting.tables import md_table, write_columns, write_csv  # noqa: E402
from acausal.models.reporting.figures import save_figure  # noqa: E402

P, T = 0.008, 3.0


def main(out_dir: Path, results=None) -> dict:
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = []
    for preset in (HEADLINE, BESIDE):
        for drive, model, paper in (("MACCEPA actuator", "replay", "fig7_energy_actuator"),
                                    ("direct drive", "direct_drive", "fig7_energy_direct")):
            r = pick(results, P, T, model=model, preset=preset)
            rows.append(dict(preset=preset, drive=drive, peak_source_power_W=r.peak_power["source"],
                             energy_per_stride_J=r.energy["source"], output_energy_J=r.energy["output"],
                             paper_energy_per_stride_J=PAPER[paper]))
    summary_csv = write_csv(out_dir / "fig07_summary.csv", rows)
    act, dd = pick(results, P, T), pick(results, P, T, model="direct_drive")
    rows = rows[:2]  # the headline preset's, in the figure and the report
    t_a, p_a = act.time, act.power["source"]
    t_d, p_d = dd.time, dd.power["source"]
    p_d_on_a = np.interp(t_a, t_d, p_d)
    curves_csv = write_columns(out_dir / "fig07_direct_drive.csv",
                               {"time_ms": 1e3 * t_a, "P_source_actuator_W": p_a, "P_source_direct_drive_W": p_d_on_a},
                               {"preset": HEADLINE})
    peak_ratio = dd.peak_power["source"] / act.peak_power["source"]

    fig, (ax, axt) = plt.subplots(2, 1, figsize=(8.5, 6.2), gridspec_kw=dict(height_ratios=[3.2, 1]))
    ax.plot(1e3 * t_d, p_d, color="C3", lw=1.6, label=f"direct drive (peak {dd.peak_power['source']:.0f} W)")
    ax.plot(1e3 * t_a, p_a, color="C0", lw=1.6, label=f"MACCEPA actuator (peak {act.peak_power['source']:.0f} W)")
    ax.axhline(0, color="0.6", lw=0.6)
    ax.set_xlabel("time in the stride [ms]")
    ax.set_ylabel("power at the driver input (source) [W]")
    ax.set_xlim(0, 1e3 * T)
    ax.set_title(f"Fig. 7: source power over one stride, {1e3 * P:g} mm precompression, {T:g} s/stride\n"
                 f"simulated direct-drive peak = {peak_ratio:.2f} x actuator peak "
                 f"(paper: about {PAPER['fig7_peak_ratio']:.1f} x)", fontsize=10)
    ax.legend(loc="upper left", fontsize=9)
    ax.grid(alpha=0.3)
    axt.axis("off")
    cells = [[r["drive"], f"{r['peak_source_power_W']:.0f} W", f"{r['energy_per_stride_J']:.1f} J",
              f"{r['paper_energy_per_stride_J']:.0f} J"] for r in rows]
    tab = axt.table(cellText=cells, colLabels=["", "peak source power", "energy per stride (sim)",
                                                "energy per stride (paper)"], loc="center", cellLoc="center")
    tab.auto_set_font_size(False)
    tab.set_fontsize(9)
    tab.scale(1, 1.4)
    png = save_figure(fig, out_dir / "fig07_direct_drive.png",
                      shows=f"simulation: AnkleActuator and DirectDrive (replay), preset {HEADLINE}")

    md = md_table(["drive", "peak source power [W]", "energy per stride sim [J]", "energy per stride paper [J]",
                   "joint work [J]"],
                  [[r["drive"], f"{r['peak_source_power_W']:.0f}", f"{r['energy_per_stride_J']:.1f}",
                    f"{r['paper_energy_per_stride_J']:.0f}", f"{r['output_energy_J']:.1f}"] for r in rows])
    md += ("\n\nBoth drives do the same joint work; the series spring stores and returns energy, so the motor's "
           f"peak demand at the driver input falls from {dd.peak_power['source']:.0f} W to "
           f"{act.peak_power['source']:.0f} W while the energy per stride changes by "
           f"{100 * (dd.energy['source'] / act.energy['source'] - 1):+.0f} % (paper: peak 40 % higher, "
           "energy about the same).")
    comps = [comparison("Fig. 7 peak source power, direct drive / actuator", peak_ratio, PAPER["fig7_peak_ratio"],
                        "", "direct_drive", fmt=".2f",
                        note="Our direct drive must deliver the full gait torque through the lossy 860:1 gears at "
                             "every instant, so its push-off peak is not cut by a torque limit."),
             comparison("Fig. 7 energy per stride, actuator", act.energy["source"], PAPER["fig7_energy_actuator"],
                        "J", "first_experiment"),
             comparison("Fig. 7 energy per stride, direct drive", dd.energy["source"], PAPER["fig7_energy_direct"],
                        "J", ["first_experiment", "direct_drive"]),
             comparison("Fig. 7 energy ratio, direct drive / actuator", dd.energy["source"] / act.energy["source"],
                        PAPER["fig7_energy_direct"] / PAPER["fig7_energy_actuator"], "", "direct_drive", fmt=".2f")]
    return dict(title="Fig. 7: actuator against direct drive (8 mm, 3 s/stride)", figures=[png],
                csv=[curves_csv, summary_csv], markdown=md, comparisons=comps)


if __name__ == "__main__":
    print(main(Path("results"))["markdown"])
