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

import math
import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from acausal.models.ankle.paper import (BENCH, HEADLINE, comparison, followed, grid, grid_rows,  # noqa: E402
                                        heatmap, required_duty)
from acausal.models.ankle.figures.trends import verdict  # noqa: E402
from acausal.models.ankle.protocol import CORNER, D_MAX, in_corner, negative_energy  # noqa: E402
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


def _trend(results, key, along: str) -> str:
    """Does the loss grow along stride time / precompression at every fixed other coordinate (every cell)?"""
    groups = {}
    for r in results:
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
                                                "loss_J": lambda r, k=key: r.energy[_prev(k)] - r.energy[k],
                                                **({"mean_motor_speed_radps": lambda r: r.mean_motor_speed}
                                                   if key == "motor" else {})},
                                        duty)))
        a = [r.loss_fraction[key] for r in bench]
        f = [r.loss_fraction[key] for r in feasible]
        lines.append([title.split(":")[0], stage, f"{pct(min(a))} - {pct(max(a))}", f"{pct(min(f))} - {pct(max(f))}",
                      _trend(bench, key, "T"), _trend(bench, key, "P"), paper_says.replace("paper: ", "")])

    md = md_table(["figure", "stage", f"min - max, all {len(bench)} cells (as claims.csv)",
                   f"min - max, the {len(feasible)} cells where the motor can follow", "along stride time",
                   "along precompression", "paper"], lines)
    md += (f"\n\nThe claims (claims.csv: C2, C5, C6, C7) and the comparisons below read every cell of the grid, the "
           "hatched ones included: the paper measured them all, and its worst cases (high precompression, short "
           "strides) are where the motor cannot follow. The column of the cells where the motor can follow (the "
           f"replay's required duty <= {D_MAX:g}) is beside it. Trends are counted over every cell too (per "
           "precompression along stride time, per stride time along precompression).")
    md += "\n\n" + caption(bench, duty)

    drv = [r.loss_fraction["driver"] for r in bench]
    gear = [r.loss_fraction["link"] for r in bench]
    out = [r.loss_fraction["output"] for r in bench]
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


def _cells(results, value) -> dict:
    """{(P [mm], T [s]): value(result)} over the grid."""
    return {(round(1e3 * r.condition.P, 6), r.condition.stride_time): value(r) for r in results}


def _along(cells: dict, fixed: float, axis: str) -> list:
    """The (coordinate, value) pairs of one row (``axis="T"``: along stride time at precompression ``fixed``) or
    column (``axis="P"``: along precompression at stride time ``fixed``), sorted."""
    if axis == "T":
        return sorted((T, v) for (P, T), v in cells.items() if math.isclose(P, fixed))
    return sorted((P, v) for (P, T), v in cells.items() if math.isclose(T, fixed))


def _argmin(pairs: list):
    return min(pairs, key=lambda xv: xv[1])[0]


def _mm(values) -> str:
    return ", ".join(f"{v:g}" for v in values) + " mm"


def _s(values) -> str:
    return ", ".join(f"{v:g}" for v in values) + " s"


def _rms(r, name: str = "motor.i") -> float:
    """rms of a trace of a bench result over its evaluated stride (the last ``stride_time``)."""
    t, x = np.asarray(r.traces["time"]), np.asarray(r.traces[name])
    sel = t >= t[-1] - r.condition.stride_time - 1e-9
    return float(np.sqrt(np.mean(x[sel] ** 2)))


def _arm_path(r) -> tuple:
    """The planned moment-arm angle of a bench result over its evaluated stride: (smallest, largest, travel) in
    degrees, the travel being the path's total variation (how far the arm moves per stride)."""
    a = np.degrees(np.asarray(r.traces["arm_ref.y.value"]))
    return float(a.min()), float(a.max()), float(np.sum(np.abs(np.diff(a))))


def _motor_speed_reason(bench, mot: dict, Ps: list, Ts: list) -> str:
    """Why Fig. 10's motor loss does not grow from the lowest precompression on: the paper's own mechanism (a lower
    average motor velocity, a lower motor efficiency) read on the model, the mean |w| of each cell against its
    loss, and where the mean speed is highest along precompression, with the planned arm path that sets it."""
    from scipy.stats import spearmanr
    spd = _cells(bench, lambda r: r.mean_motor_speed)
    rho = float(spearmanr([mot[c] for c in mot], [spd[c] for c in mot])[0])
    P0, P1 = Ps[0], Ps[1]
    both = [T for T in Ts if mot[(P1, T)] < mot[(P0, T)] and spd[(P1, T)] > spd[(P0, T)]]
    fastest = {T: max(_along(spd, T, "P"), key=lambda xv: xv[1])[0] for T in Ts}
    L = [f"the model's motor loss is the winding's R i^2 alone; over the {len(mot)} cells it ranks "
         + ("opposite to" if rho < 0 else "with") + f" the mean motor speed |w| (Spearman {rho:.2f}), "
         + ("as the paper's explanation has it (a lower average motor velocity, a lower efficiency)" if rho < 0 else
            "against the paper's explanation (a lower average motor velocity, a lower efficiency)")]
    if both:
        T = min(both, key=lambda T: abs(T - 2.0))
        L.append(f"but along precompression the mean motor speed is highest at "
                 + "; ".join(f"{P:g} mm ({_s([t for t in Ts if fastest[t] == P])})"
                             for P in sorted(set(fastest.values())))
                 + f", and from {P0:g} to {P1:g} mm it rises while the loss falls at {len(both)} of {len(Ts)} "
                 f"stride times ({spd[(P0, T)]:.0f} to {spd[(P1, T)]:.0f} rad/s, {pct(mot[(P0, T)])} to "
                 f"{pct(mot[(P1, T)])} at {T:g} s/stride)")
        r0, r1 = (next((r for r in bench if math.isclose(1e3 * r.condition.P, P) and
                        math.isclose(r.condition.stride_time, T) and "arm_ref.y.value" in r.traces), None)
                  for P in (P0, P1))
        if r0 is not None and r1 is not None:
            (lo0, hi0, tr0), (lo1, hi1, tr1) = _arm_path(r0), _arm_path(r1)
            L.append(f"the planned arm path spans {lo0:.1f}-{hi0:.1f} deg at {P0:g} mm against {lo1:.1f}-{hi1:.1f} "
                     f"deg at {P1:g} mm, {tr0:.1f} against {tr1:.1f} deg of travel per stride")
    return "; ".join(L)


def caption(bench, duty: dict) -> str:
    """The verdicts of Figs. 9-12 (:func:`~acausal.models.ankle.figures.trends.verdict`): each trend the paper's
    text states about them (4.2.1-4.2.3) against the bench grid's, every cell read."""
    Ps = sorted({round(1e3 * r.condition.P, 6) for r in bench})
    Ts = sorted({r.condition.stride_time for r in bench})
    drv = _cells(bench, lambda r: r.loss_fraction["driver"])
    mot = _cells(bench, lambda r: r.loss_fraction["motor"])
    back = _cells(bench, lambda r: negative_energy(r.time, r.power["driver"]))
    L = []

    # Fig. 9: the minimum, the bowl along stride time, the minimum along precompression
    (P0, T0), v0 = min(drv.items(), key=lambda kv: kv[1])
    near = abs(P0 - 11) <= 3 and abs(T0 - 1.5) <= 0.5
    L.append(verdict("Fig. 9", "the smallest driver loss", near, "an optimum around 11 mm and 1.5 s/stride",
                     f"the grid's smallest driver loss is at {P0:g} mm, {T0:g} s/stride ({pct(v0)})",
                     "" if near else "the energy the motor sends back, which the non-regenerative front end burns, "
                     f"grows with precompression ({back[(Ps[1], Ts[0])]:.1f} J per stride at {Ps[1]:g} mm, "
                     f"{back[(Ps[-1], Ts[0])]:.1f} J at {Ps[-1]:g} mm, {Ts[0]:g} s/stride), so the loss is lowest "
                     "at a low precompression; the paper puts its optimum down to the driver's tuning near 8 mm "
                     "(4.2.1), and the model's driver has no tuning-dependent loss"))
    bowl = [P for P in Ps if Ts[0] < _argmin(_along(drv, P, "T")) < Ts[-1]]
    rising = [P for P in Ps if P not in bowl]
    L.append(verdict(
        "Fig. 9", "the driver loss along stride time", not rising,
        "the loss rises towards both shorter and longer strides from an optimum near 1.5 s/stride",
        (f"an interior minimum (a bowl) at {_mm(bowl)}" if bowl else "no interior minimum at any precompression")
        + (f"; at {_mm(rising)} the loss is lowest at the " + ("shortest" if all(
            _argmin(_along(drv, P, 'T')) == Ts[0] for P in rising) else "shortest or longest")
           + f" stride and grows from there (no bowl)" if rising else ""),
        "" if not rising else "the loss is the driver's constant draw, which costs more the longer the stride, plus "
        "the energy the motor sends back, burnt in the non-regenerative front end, which falls with the stride "
        f"time; at {_mm(rising)} little comes back ({back[(rising[0], Ts[0])]:.1f} J per stride at "
        f"{rising[0]:g} mm, {Ts[0]:g} s/stride, against {back[(Ps[-1], Ts[0])]:.1f} J at {Ps[-1]:g} mm), so "
        "the constant draw sets the trend from the shortest stride on"))
    best_P = {T: _argmin(_along(drv, T, "P")) for T in Ts}
    at11 = [T for T, P in best_P.items() if abs(P - 11) <= 3]
    L.append(verdict(
        "Fig. 9", "the driver loss along precompression", len(at11) > len(Ts) / 2,
        "the loss rises towards both higher and lower precompressions from an optimum around 11 mm",
        "the lowest loss along precompression is at " + "; ".join(
            f"{P:g} mm ({_s([T for T in Ts if best_P[T] == P])})" for P in sorted(set(best_P.values()))),
        "" if len(at11) > len(Ts) / 2 else "the energy the motor sends back grows with precompression (above), "
        "so past the lowest precompressions the loss grows with it"))

    # Fig. 10: grows with stride time and with precompression
    grows = lambda pairs: all(b >= a - 1e-4 for (_, a), (_, b) in zip(pairs, pairs[1:]))  # noqa: E731
    cur = _cells(bench, _rms) if all("motor.i" in r.traces for r in bench) else {}
    low_T = {P: _argmin(_along(mot, P, "T")) for P in Ps}
    falls_first = [P for P in Ps if low_T[P] != Ts[0]]
    other_T = [P for P in Ps if P not in falls_first and not grows(_along(mot, P, "T"))]
    ok_T = not falls_first and not other_T
    Pf = falls_first[-1] if falls_first else None
    L.append(verdict(
        "Fig. 10", "the motor loss along stride time", ok_T, "the motor loss grows with the stride time",
        f"it grows from the shortest stride at {_mm([P for P in Ps if P not in falls_first + other_T])}"
        + (f"; at {_mm(falls_first)} it falls first, lowest at " + ", ".join(
            f"{low_T[P]:g} s ({P:g} mm)" for P in falls_first) if falls_first else "")
        + (f"; at {_mm(other_T)} it is lowest at the shortest stride but not monotone" if other_T else ""),
        "" if ok_T else "the model's motor loss is the winding's R i^2 alone"
        + (f"; at {Pf:g} mm and {Ts[0]:g} s/stride, where the arm lags with the driver at its limit, the rms current "
           f"is {cur[(Pf, Ts[0])]:.2f} A against {cur[(Pf, low_T[Pf])]:.2f} A at {low_T[Pf]:g} s, the stride "
           "time of the lowest loss there: the extra current outweighs the shorter stride" if cur and Pf else "")))
    lowest = {T: _argmin(_along(mot, T, "P")) for T in Ts}
    u = [T for T in Ts if lowest[T] != Ps[0]]
    other_P = [T for T in Ts if T not in u and not grows(_along(mot, T, "P"))]
    ok_P = not u and not other_P
    L.append(verdict(
        "Fig. 10", "the motor loss along precompression", ok_P, "the motor loss grows with the precompression",
        ("U-shaped: it falls from " + f"{Ps[0]:g} mm to its lowest at " + "; ".join(
            f"{P:g} mm ({_s([T for T in Ts if lowest[T] == P])})" for P in sorted(set(lowest[T] for T in u)))
         + f", then grows ({len(u)} of {len(Ts)} stride times)" if u else "it is lowest at the lowest precompression")
        + (f"; not monotone at {_s(other_P)}" if other_P else ""),
        "" if ok_P else _motor_speed_reason(bench, mot, Ps, Ts)))

    # Figs. 11-12: the levels and the corner
    gear = _cells(bench, lambda r: r.loss_fraction["link"])
    out = _cells(bench, lambda r: r.loss_fraction["output"])
    corner = [v for (P, T), v in gear.items() if in_corner(P, T)]
    g_lo, g_hi = min(gear.values()), max(corner) if corner else float("nan")
    L.append(verdict("Fig. 11", "the gearing loss's level", g_lo >= PAPER["fig11_gearing_loss_min"],
                     "never below 50 %", f"{pct(g_lo)} at its lowest",
                     "" if g_lo >= PAPER["fig11_gearing_loss_min"] else "the inferred mesh efficiency and drag "
                     "leave less loss than the paper measured"))
    L.append(verdict("Fig. 11", "the gearing loss at high precompression and short strides",
                     g_hi > PAPER["fig11_gearing_loss_worst"], "over 65 %",
                     f"up to {pct(g_hi)} (P >= {CORNER[0]:g} mm, T <= {CORNER[1]:g} s)",
                     "" if g_hi > PAPER["fig11_gearing_loss_worst"] else "the arm lags too little there"))
    mean = float(np.mean(list(out.values())))
    (Pw, Tw), worst = max(out.items(), key=lambda kv: kv[1])
    hatched = any(d > D_MAX for (P, T), d in duty.items() if math.isclose(1e3 * P, Pw) and math.isclose(T, Tw))
    L.append(verdict("Fig. 12", "the output loss's level", abs(mean - PAPER["fig12_output_loss_typical"]) <= 0.05,
                     "around 20 % on average", f"mean {pct(mean)} over the {len(out)} cells",
                     "" if abs(mean - PAPER["fig12_output_loss_typical"]) <= 0.05 else
                     "the inferred linkage friction gives another mean"))
    L.append(verdict("Fig. 12", "the worst output loss", worst > PAPER["fig12_output_loss_worst"],
                     "over 50 % in the worst case (high precompression, short strides)",
                     f"{pct(worst)} at {Pw:g} mm, {Tw:g} s/stride"
                     + (" (a hatched cell: the motor cannot follow there)" if hatched else ""),
                     "" if worst > PAPER["fig12_output_loss_worst"] else "the arm lags too little there"))
    return "\n\n".join(L)


def _prev(key):
    order = ["source", "driver", "motor", "link", "output"]
    return order[order.index(key) - 1]


if __name__ == "__main__":
    print(main(Path("results"))["markdown"])
