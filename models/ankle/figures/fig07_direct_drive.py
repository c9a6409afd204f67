"""Fig. 7 of the paper: power at the driver input (source power) over one stride, 8 mm precompression,
3 s/stride, the MACCEPA actuator against the paper's "direct drive": the bench's output motor, which imposes the
gait angle on the joint while the actuator pushes it (``bench_output_motor``: its drive train is not published, so
it is guessed as the actuator's own motor, driver and 860:1 gears; claim C9 reads it). Beside them the forward
direct drive (``direct_drive``: the same drive train delivering the gait's torque and power to the joint without
the spring), the design alternative. Peak power and energy per stride of each.

Writes ``fig07_direct_drive.png``, ``fig07_direct_drive.csv`` (the curves) and ``fig07_summary.csv``.
Run: ``python -m acausal.models.ankle.figures.fig07_direct_drive`` (into ``results/``).
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
from acausal.models.ankle.figures.trends import phase_of, push_off_span, verdict  # noqa: E402

P, T = 0.008, 3.0
#: (label, registered model, the paper's energy per stride in PAPER) of each drive; C9 reads the first two
DRIVES = (("MACCEPA actuator", "replay", "fig7_energy_actuator"),
          ("bench output motor", "bench_output_motor", "fig7_energy_direct"),
          ("forward direct drive", "direct_drive", None))


def _paper(row: dict, unit: str = "") -> str:
    """The paper's energy per stride of a drive, "-" for a drive the paper did not run."""
    e = row["paper_energy_per_stride_J"]
    return "-" if np.isnan(e) else f"{e:.0f}{unit}"


def main(out_dir: Path, results=None) -> dict:
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = []
    for preset in (HEADLINE, BESIDE):
        for drive, model, paper in DRIVES:
            r = pick(results, P, T, model=model, preset=preset)
            rows.append(dict(preset=preset, drive=drive, peak_source_power_W=r.peak_power["source"],
                             energy_per_stride_J=r.energy["source"], output_energy_J=r.energy["output"],
                             paper_energy_per_stride_J=PAPER[paper] if paper else float("nan")))
    summary_csv = write_csv(out_dir / "fig07_summary.csv", rows)
    act, dd = pick(results, P, T), pick(results, P, T, model="bench_output_motor")
    fwd = pick(results, P, T, model="direct_drive")
    rows = rows[:len(DRIVES)]  # the headline preset's, in the figure and the report
    t_a, p_a = act.time, act.power["source"]
    t_d, p_d = dd.time, dd.power["source"]
    curves_csv = write_columns(out_dir / "fig07_direct_drive.csv",
                               {"time_ms": 1e3 * t_a, "P_source_actuator_W": p_a,
                                "P_source_bench_output_motor_W": np.interp(t_a, t_d, p_d),
                                "P_source_forward_direct_drive_W": np.interp(t_a, fwd.time, fwd.power["source"])},
                               {"preset": HEADLINE})
    peak_ratio = dd.peak_power["source"] / act.peak_power["source"]

    fig, (ax, axt) = plt.subplots(2, 1, figsize=(8.5, 6.2), gridspec_kw=dict(height_ratios=[3.2, 1]))
    ax.plot(1e3 * fwd.time, fwd.power["source"], color="0.55", lw=1.2, ls="--",
            label=f"forward direct drive (peak {fwd.peak_power['source']:.0f} W)")
    ax.plot(1e3 * t_d, p_d, color="C3", lw=1.6, label=f"bench output motor (peak {dd.peak_power['source']:.0f} W)")
    ax.plot(1e3 * t_a, p_a, color="C0", lw=1.6, label=f"MACCEPA actuator (peak {act.peak_power['source']:.0f} W)")
    ax.axhline(0, color="0.6", lw=0.6)
    ax.set_xlabel("time in the stride [ms]")
    ax.set_ylabel("power at the driver input (source) [W]")
    ax.set_xlim(0, 1e3 * T)
    ax.set_title(f"Fig. 7: source power over one stride, {1e3 * P:g} mm precompression, {T:g} s/stride\n"
                 f"simulated output-motor peak = {peak_ratio:.2f} x actuator peak "
                 f"(paper: about {PAPER['fig7_peak_ratio']:.1f} x"
                 + ("" if (peak_ratio > 1) == (PAPER["fig7_peak_ratio"] > 1) else ": the order is reversed")
                 + ")", fontsize=10)
    ax.legend(loc="upper left", fontsize=9)
    ax.grid(alpha=0.3)
    axt.axis("off")
    cells = [[r["drive"], f"{r['peak_source_power_W']:.0f} W", f"{r['energy_per_stride_J']:.1f} J",
              _paper(r, " J")] for r in rows]
    tab = axt.table(cellText=cells, colLabels=["", "peak source power", "energy per stride (sim)",
                                                "energy per stride (paper)"], loc="center", cellLoc="center")
    tab.auto_set_font_size(False)
    tab.set_fontsize(9)
    tab.scale(1, 1.4)
    png = save_figure(fig, out_dir / "fig07_direct_drive.png",
                      shows=f"simulation: AnkleActuator, BenchOutputMotor and DirectDrive (replay), preset {HEADLINE}")

    md = md_table(["drive", "peak source power [W]", "energy per stride sim [J]", "energy per stride paper [J]",
                   "joint work [J]"],
                  [[r["drive"], f"{r['peak_source_power_W']:.0f}", f"{r['energy_per_stride_J']:.1f}",
                    _paper(r), f"{r['output_energy_J']:.1f}"] for r in rows])
    md += "\n\n" + caption(act, dd, fwd)
    comps = [comparison("Fig. 7 peak source power, bench output motor / actuator", peak_ratio,
                        PAPER["fig7_peak_ratio"], "", "direct_drive", fmt=".2f",
                        note="The output motor's drive train is guessed as the actuator's: with it the motor that "
                             "holds the joint needs less than the actuator."),
             comparison("Fig. 7 energy per stride, actuator", act.energy["source"], PAPER["fig7_energy_actuator"],
                        "J", "first_experiment"),
             comparison("Fig. 7 energy per stride, bench output motor", dd.energy["source"],
                        PAPER["fig7_energy_direct"], "J", ["first_experiment", "direct_drive"]),
             comparison("Fig. 7 energy ratio, bench output motor / actuator", dd.energy["source"] / act.energy["source"],
                        PAPER["fig7_energy_direct"] / PAPER["fig7_energy_actuator"], "", "direct_drive", fmt=".2f")]
    return dict(title="Fig. 7: actuator against the bench's output motor and a direct drive (8 mm, 3 s/stride)", figures=[png],
                csv=[curves_csv, summary_csv], markdown=md, comparisons=comps)


def _peak(r) -> tuple:
    """(peak source power [W], its time as a fraction of the stride) of one drive's result."""
    p = np.asarray(r.power["source"])
    k = int(np.argmax(p))
    return float(p[k]), float((r.time[k] - r.time[0]) / (r.time[-1] - r.time[0]))


def caption(act, dd, fwd) -> str:
    """The figure's text: the order of the peaks against the paper's (4.1: the output motor's peak about 1.4 x
    the actuator's, for about the same energy), for the bench's output motor and for the forward direct drive,
    each computed from the three results (``act``: the actuator, ``dd``: the bench's output motor, ``fwd``: the
    forward direct drive)."""
    span = push_off_span(act.time, act.power["output"])
    (pa, ta), (pd, td), (pf, tf) = _peak(act), _peak(dd), _peak(fwd)
    ratio, ratio_f = pd / pa, pf / pa
    t_peak = act.time[int(np.argmax(act.power["source"]))]
    at_push = {k: float(np.interp(t_peak, dd.time, dd.power[k])) for k in ("source", "driver")}
    where = lambda tt: f"{100 * tt:.0f} % of the stride, {phase_of(tt, span)}"  # noqa: E731
    paper = f"the output motor's peak source power about {PAPER['fig7_peak_ratio']:.1f} x the actuator's"
    lines = [verdict(
        "Fig. 7", "order of the peaks, bench output motor against actuator", ratio > 1.0, paper,
        f"the bench output motor peaks at {pd:.0f} W ({where(td)}), {ratio:.2f} x the actuator's {pa:.0f} W "
        f"({where(ta)})" + ("" if ratio > 1.0 else ": the order is reversed"),
        "" if ratio > 1.0 else
        "the output motor holds the joint on the gait angle while the actuator pushes it, so at push-off, where "
        "the actuator's peak is, it is back-driven and absorbs the joint's work; with the actuator's own drive "
        "train as the guess for it (860:1 gears, the same motor and driver) its winding loses less there than it "
        f"generates (driver output {at_push['driver']:.0f} W at the actuator's peak), and its supply, which takes "
        f"nothing back, draws {at_push['source']:.0f} W (the driver's own consumption). Its own peak comes where it "
        "drives the joint itself. The paper's output drive train is not published; one with a higher winding "
        "resistance or a less efficient gear would draw more at push-off")]
    lines.append(verdict(
        "Fig. 7", "order of the peaks, forward direct drive against actuator", ratio_f > 1.0,
        "a drive without the series spring needs the higher power peak (section 1: the spring amplifies power)",
        f"the forward direct drive (the same drive train delivering the gait's torque and power to the joint "
        f"without the spring) peaks at {pf:.0f} W ({where(tf)}), {ratio_f:.2f} x the actuator's",
        "" if ratio_f > 1.0 else "the forward direct drive's peak is below the actuator's"))
    lines.append(f"Energy per stride: actuator {act.energy['source']:.1f} J, bench output motor "
                 f"{dd.energy['source']:.1f} J, forward direct drive {fwd.energy['source']:.1f} J (paper: "
                 f"{PAPER['fig7_energy_actuator']:.0f} and {PAPER['fig7_energy_direct']:.0f} J, about the same). "
                 "The bench output motor's joint work is the actuator's with the sign turned: its "
                 "non-regenerative supply keeps none of what it absorbs.")
    return "\n\n".join(lines)


if __name__ == "__main__":
    print(main(Path("results"))["markdown"])
