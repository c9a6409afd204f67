"""The paper's claims, each checked against what ``acausal paper`` computed (``claims.csv``, the report's "Claims").

Every check reads the CSV files the run wrote into its output folder (``protocol.csv``, ``design_optima.csv``,
``design_maps.csv``, ``fig07_summary.csv``, ``table2_calibrated.csv``): nothing here is typed in but the
paper's own statements and numbers (:data:`acausal.models.ankle.published.PAPER` and the paper's sections named in
each claim), and the tolerance each statement is read with (in the claim's ``reading``). A claim that a file does
not support (a reduced ``--quick`` grid) is reported as not checked, never as holding.

Loss fractions are per stage, relative to the energy entering the stage (the paper's Table 1 last column and
Figs. 9-12): driver ``1 - E_driver / E_source``, motor ``1 - E_motor / E_driver``, gearing ``1 - E_link / E_motor``,
output ``1 - E_output / E_link``. What the paper measured on its bench (Table 1, Figs. 8-12) is read from the bench
model's runs (:data:`~acausal.models.ankle.protocol.BENCH`: the closed loop), where the motor can follow from the
duty the replay of the plan requires (C8).
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from .protocol import (BENCH, BOWL_FROM, CORNER, D_MAX, FOLLOWS_AT_LEAST, POINTS, TUNED_P_MM, driver_bowl,
                       follows_as_in_the_paper, in_corner)
from .presets import PAPER_EQ4
from .published import PAPER
STAGE_OF = {"driver": ("source", "driver"), "motor": ("driver", "motor"), "gearing": ("motor", "link"),
            "output": ("link", "output")}


def read_csv(path: Path) -> list[dict]:
    """Rows of a CSV written by the run; numbers as floats, the rest as text."""
    def value(v):
        try:
            return float(v)
        except ValueError:
            return v
    with Path(path).open(newline="") as f:
        return [{k: value(v) for k, v in row.items()} for row in csv.DictReader(f)]


class Tables:
    """The run's CSV files, read on first use (``preset``: the parameter set the claims are checked on)."""

    def __init__(self, out_dir, preset: str = "library"):
        self.dir, self.preset, self._cache = Path(out_dir), preset, {}

    def __getitem__(self, name: str) -> list[dict]:
        if name not in self._cache:
            path = self.dir / f"{name}.csv"
            self._cache[name] = read_csv(path) if path.exists() else []
        return self._cache[name]

    def grid(self, model: str = BENCH) -> dict:
        """The conditions of ``model`` (default the bench) and the preset: {(P_mm, stride_time_s): row}."""
        return {(r["P_mm"], r["stride_time_s"]): r for r in self["protocol"]
                if r["model"] == model and r["preset"] == self.preset}

    def run(self, model: str, P_mm: float | None, T: float) -> dict | None:
        for r in self["protocol"]:
            if r["model"] == model and r["preset"] == self.preset and math.isclose(r["stride_time_s"], T) and (
                    P_mm is None or math.isclose(r["P_mm"], P_mm)):
                return r
        return None


def loss(row: dict, stage: str) -> float:
    a, b = STAGE_OF[stage]
    return 1.0 - row[f"E_{b}_J"] / row[f"E_{a}_J"]


def _axes(grid: dict):
    return sorted({p for p, _ in grid}), sorted({t for _, t in grid})


#: a fall smaller than this (a fraction) is a tie in a claim that a loss grows
MONOTONE_SLACK = 1e-3


def _monotone(values: list, slack: float = MONOTONE_SLACK) -> bool:
    return all(b >= a - slack for a, b in zip(values, values[1:]))


@dataclass(frozen=True)
class Limit:
    """One inequality of a claim's reading: ``lo <= value <= hi`` (``<`` where ``strict``; a side left None is
    open). ``slack`` is the distance to the nearer side (negative: the side crossed), ``spare`` that distance as a
    fraction of ``scale``, the tolerance it is read against: a band's half width unless given; a one-sided bound
    has the scale its claim gives it (its own size where the paper states a bound and no tolerance), or none."""

    what: str
    value: float
    lo: float | None = None
    hi: float | None = None
    strict: bool = False
    scale: float | None = None
    unit: str = ""

    @property
    def slack(self) -> float:
        sides = [self.value - self.lo] if self.lo is not None else []
        sides += [self.hi - self.value] if self.hi is not None else []
        return min(sides) if not any(map(math.isnan, sides)) else math.nan

    @property
    def ok(self) -> bool:
        return self.slack > 0 if self.strict else self.slack >= 0  # NaN: False

    @property
    def tolerance(self) -> float | None:
        if self.scale is not None:
            return self.scale
        return (self.hi - self.lo) / 2 if self.lo is not None and self.hi is not None else None

    @property
    def spare(self) -> float | None:
        """The slack as a fraction of the tolerance (None without one)."""
        tol = self.tolerance
        return self.slack / tol if tol else None

    def said(self) -> str:
        """``"driver output minimum -35.45 W: 0.455 W inside -65 to -35 W (3.0 % of 15 W)"``."""
        u = f" {self.unit}" if self.unit else ""
        su = " points" if self.unit == "%" else u  # a difference of percentages
        rel = {True: "<", False: "<="}[self.strict]
        bound = (f"{self.lo:.4g} to {self.hi:.4g}{u}" if self.lo is not None and self.hi is not None else
                 f"{rel} {self.hi:.4g}{u}" if self.hi is not None else
                 f"{'>' if self.strict else '>='} {self.lo:.4g}{u}")
        place = "inside" if self.ok else "outside"
        spare = "" if self.spare is None else f" ({100 * self.spare:.1f} % of {self.tolerance:.3g}{u})"
        return f"{self.what} {self.value:.4g}{u}: {abs(self.slack):.3g}{su} {place} {bound}{spare}"


#: a claim that holds with less than this fraction of a tolerance to spare is fragile
FRAGILE = 0.10

#: the claim's class in the calibration set of ``paper_fit`` (declared here, read by the report and ``claims.csv``)
TARGET, TESTABLE, IN_NAME_ONLY, NOT_TESTABLE = ("target", "testable prediction", "prediction in name only",
                                                "not testable from the published text")


@dataclass(frozen=True)
class Claim:
    id: str
    section: str
    statement: str  # the paper's claim, in its words (shortened)
    paper: str  # the paper's numbers
    reading: str  # how it is checked: quantity and tolerance
    check: Callable  # Tables -> (simulated: str, limits: list[Limit] | None, note: str); None: not checked
    opposes: str = ""  # the mechanism in the model that works against the claim (reported when it does not hold)
    role: str = ""  # TARGET, TESTABLE, IN_NAME_ONLY or NOT_TESTABLE
    quote: str = ""  # the paper's sentence that decides the role, verbatim
    why: str = ""  # why the claim has that role


NOT_CHECKED = ("-", None)


def _c1(t: Tables):
    r = t.run(BENCH, 8, 2.0)
    if r is None:
        return (*NOT_CHECKED, "the 8 mm, 2 s/stride condition was not run")
    ratios = {k: r[f"E_{k}_J"] / PAPER["table1_energy"][k] for k in POINTS}
    worst = max(ratios, key=lambda k: abs(ratios[k] - 1))
    return (" / ".join(f"{r[f'E_{k}_J']:.1f}" for k in POINTS) + " J",
            [Limit(f"{k} simulated / paper", v, 1 - 0.15, 1 + 0.15) for k, v in ratios.items()],
            f"largest deviation at {worst}: simulated / paper = {ratios[worst]:.2f} "
            f"({100 * (ratios[worst] - 1):+.0f} % of the paper's value)")


def _c2(t: Tables):
    g = t.grid()
    if len(g) < 36:
        return (*NOT_CHECKED, f"{len(g)} of 36 grid conditions")
    vals = [loss(r, "driver") for r in g.values()]
    lo, hi = PAPER["fig9_driver_loss_range"]
    limits = [Limit("smallest driver loss", 100 * min(vals), 100 * (lo - DRIVER_TOL), 100 * (lo + DRIVER_TOL),
                    unit="%"),
              Limit("largest driver loss", 100 * max(vals), 100 * (hi - DRIVER_TOL), 100 * (hi + DRIVER_TOL),
                    unit="%")]
    return f"{100 * min(vals):.1f}-{100 * max(vals):.1f} %", limits, f"paper {100 * lo:.1f}-{100 * hi:.1f} %"


#: C2's tolerance on the driver loss (a fraction of the source energy); C3's bowl is measured against it
DRIVER_TOL = 0.06

#: the slack of C3's long-stride branch [J]: a fall of the loss per stride smaller than this is a tie
LONG_SLACK = 1e-2


def _c3(t: Tables):
    g = t.grid()
    Ps, Ts = _axes(g)
    if len(Ts) < 3 or not any(math.isclose(P, TUNED_P_MM) for P in Ps):
        return (*NOT_CHECKED, "needs three stride times and the tuned precompression")
    b = driver_bowl({k: r["E_source_J"] - r["E_driver_J"] for k, r in g.items()},
                    {k: loss(r, "driver") for k, r in g.items()})
    P8 = next(P for P in Ps if math.isclose(P, TUNED_P_MM))
    T_min, row0 = b["T_min"], loss(g[(P8, Ts[0])], "driver")
    limits = [Limit(f"bowl depth at {TUNED_P_MM:g} mm (the shortest stride's loss above the lowest)", 100 * b["short"],
                    lo=0.0, strict=True, scale=100 * DRIVER_TOL, unit="points"),
              Limit(f"stride time of the lowest loss at {TUNED_P_MM:g} mm", T_min, BOWL_FROM - 0.5, BOWL_FROM + 0.5,
                    unit="s"),
              Limit(f"smallest rise of the loss per stride from {BOWL_FROM:g} s on", b["long"], lo=-LONG_SLACK,
                    scale=LONG_SLACK, unit="J")]
    bowl = limits[0].ok and T_min < Ts[-1] and limits[1].ok
    long_bad = [P for P, rise in b["long_by_P"].items() if rise < -LONG_SLACK]
    frac_bad = [P for P in Ps
                if not _monotone([loss(g[(P, T)], "driver") for T in Ts if T >= BOWL_FROM and (P, T) in g])]
    low = loss(g[(P8, T_min)], "driver")
    sim = (f"at {TUNED_P_MM:g} mm lowest at {T_min:g} s ({100 * low:.1f} %; {Ts[0]:g} s: {100 * row0:.1f} %); "
           f"loss per stride rises from {BOWL_FROM:g} s on at {len(Ps) - len(long_bad)} of {len(Ps)} precompressions")
    note = "; ".join(filter(None, ["" if bowl else f"no bowl at {TUNED_P_MM:g} mm: the minimum is at {T_min:g} s",
                                   f"long-stride branch not at {', '.join(f'{P:g} mm' for P in long_bad)}"
                                   if long_bad else f"smallest rise of the loss per stride from {BOWL_FROM:g} s on "
                                   f"{b['long']:+.2f} J",
                                   f"the loss fraction also rises from {BOWL_FROM:g} s on" + (
                                       f" except at {', '.join(f'{P:g} mm' for P in frac_bad)}" if frac_bad else "")]))
    if not T_min < Ts[-1]:
        limits.append(Limit("lowest loss before the longest stride", T_min, hi=Ts[-1], strict=True, unit="s"))
    return sim, limits, note


def _c4(t: Tables):
    g = t.grid()
    if len(g) < 36:
        return (*NOT_CHECKED, f"{len(g)} of 36 grid conditions")
    (P, T), _ = min(g.items(), key=lambda kv: loss(kv[1], "driver"))
    return (f"minimum at {P:g} mm, {T:g} s/stride",
            [Limit("precompression of the minimum", P, 11 - 3.0, 11 + 3.0, unit="mm"),
             Limit("stride time of the minimum", T, 1.5 - 0.5, 1.5 + 0.5, unit="s")],
            "near: within 3 mm and 0.5 s of 11 mm, 1.5 s")


def _c5(t: Tables):
    g = t.grid()
    Ps, Ts = _axes(g)
    if len(Ps) < 2 or len(Ts) < 2:
        return (*NOT_CHECKED, "grid too small")
    by_T = [P for P in Ps if not _monotone([loss(g[(P, T)], "motor") for T in Ts if (P, T) in g])]
    by_P = [T for T in Ts if not _monotone([loss(g[(P, T)], "motor") for P in Ps if (P, T) in g])]
    note = "; ".join(filter(None, [
        f"not with stride time at {', '.join(f'{P:g} mm' for P in by_T)}" if by_T else "",
        f"not with precompression at {', '.join(f'{T:g} s' for T in by_P)}" if by_P else ""]))
    grown = f"{len(Ps) - len(by_T)}/{len(Ps)} rows, {len(Ts) - len(by_P)}/{len(Ts)} columns grow"
    lines = [[loss(g[(P, T)], "motor") for T in Ts if (P, T) in g] for P in Ps]
    lines += [[loss(g[(P, T)], "motor") for P in Ps if (P, T) in g] for T in Ts]
    step = min((b - a for v in lines for a, b in zip(v, v[1:])), default=math.inf)
    # no tolerance: the paper states a direction only (a fall within the tie slack counts as growing)
    return grown, [Limit("smallest step of the motor loss along a row or column", 100 * step, lo=-100 * MONOTONE_SLACK,
                         unit="points")], note


def _c6(t: Tables):
    g = t.grid()
    if not g:
        return (*NOT_CHECKED, "no grid")
    vals = {k: loss(r, "gearing") for k, r in g.items()}
    corner = [v for (P, T), v in vals.items() if in_corner(P, T)]
    worst = max(corner) if corner else float("nan")
    floor, corner_floor = PAPER["fig11_gearing_loss_min"], PAPER["fig11_gearing_loss_worst"]
    # the paper states bounds and no tolerance: each measured against its own size
    return (f"{100 * min(vals.values()):.1f}-{100 * max(vals.values()):.1f} %, high P / short strides up to "
            f"{100 * worst:.1f} %",
            [Limit("smallest gearing loss", 100 * min(vals.values()), lo=100 * floor, scale=100 * floor, unit="%"),
             Limit("worst gearing loss in the corner", 100 * worst, lo=100 * corner_floor, strict=True,
                   scale=100 * corner_floor, unit="%")], "")


def _c7(t: Tables):
    g = t.grid()
    if not g:
        return (*NOT_CHECKED, "no grid")
    vals = [loss(r, "output") for r in g.values()]
    mean = sum(vals) / len(vals)
    typical, worst = PAPER["fig12_output_loss_typical"], PAPER["fig12_output_loss_worst"]
    limits = [Limit("mean output loss", 100 * mean, 100 * (typical - 0.05), 100 * (typical + 0.05), unit="%"),
              Limit("worst output loss", 100 * max(vals), lo=100 * worst, strict=True, scale=100 * worst, unit="%")]
    return (f"mean {100 * mean:.1f} %, worst {100 * max(vals):.1f} %", limits, "around 20 %: within 5 points")


def _c8(t: Tables):
    g = t.grid("replay")
    if (18, 1.2) not in g or (18, 3.0) not in g or len(g) < 36:
        return (*NOT_CHECKED, "needs the 36-condition grid")
    c8 = follows_as_in_the_paper({k: r["max_duty"] for k, r in g.items()})
    limits = [Limit("required duty at 18 mm, 1.2 s/stride", c8["duty_18mm_1p2s"], lo=D_MAX, strict=True, scale=D_MAX),
              Limit("required duty at 18 mm, 3 s/stride", c8["duty_18mm_3s"], hi=D_MAX, scale=D_MAX),
              Limit("conditions the motor follows", c8["follows"], lo=FOLLOWS_AT_LEAST, scale=FOLLOWS_AT_LEAST)]
    return (f"duty at 18 mm: {c8['duty_18mm_1p2s']:.3f} (1.2 s), {c8['duty_18mm_3s']:.2f} (3 s); follows in "
            f"{c8['follows']}/36", limits, f"follows: required duty <= {D_MAX:g}")


def _c9(t: Tables):
    rows = {r["drive"]: r for r in t["fig07_summary"] if r.get("preset", t.preset) == t.preset}
    if len(rows) < 2:
        return (*NOT_CHECKED, "fig07_summary.csv missing")
    if "bench output motor" not in rows:
        return (*NOT_CHECKED, "no bench output motor in fig07_summary.csv")
    act, dd = rows["MACCEPA actuator"], rows["bench output motor"]
    peak = dd["peak_source_power_W"] / act["peak_source_power_W"]
    energy = dd["energy_per_stride_J"] / act["energy_per_stride_J"]
    return (f"peak ratio {peak:.2f}, energy ratio {energy:.2f}",
            [Limit("peak source power, output motor / actuator", peak, 1.3, 1.6),
             Limit("energy per stride, output motor / actuator", energy, 0.9, 1.1)], "")


def _c10(t: Tables):
    r = t.run(BENCH, 8, 2.0)
    if r is None or "min_driver_W" not in r:
        return (*NOT_CHECKED, "the 8 mm, 2 s/stride condition was not run")
    return (f"driver output down to {r['min_driver_W']:.1f} W, source down to {r['min_source_W']:.2f} W",
            [Limit("driver output minimum", r["min_driver_W"], -65.0, -35.0, unit="W"),
             Limit("source minimum", r["min_source_W"], lo=-1.0, strict=True, scale=1.0, unit="W")],
            "source near 0 W: above -1 W")


def _optimum(t: Tables, T: float, preset: str | None = None):
    return next((r for r in t["design_optima"] if math.isclose(r["stride_time_s"], T)
                 and r.get("preset", t.preset) == (preset or t.preset) and not r.get("variant")), None)


#: C11's gain: the optimum at least this far (a fraction) above the design's efficiency ("15 % to 25 %", read as 8
#: points or more)
C11_GAIN = 0.08


def _c11(t: Tables):
    o = _optimum(t, 1.2)
    if o is None:
        return (*NOT_CHECKED, f"no design optimum of preset {t.preset} in design_optima.csv")
    gain = o["refined_efficiency"] - o["efficiency_at_paper_design"]
    limits = [Limit("optimum stiffness", o["refined_kNpm"], hi=o["paper_design_kNpm"], strict=True,
                    scale=o["paper_design_kNpm"], unit="N/mm"),
              Limit("efficiency at the design", 100 * o["efficiency_at_paper_design"], 10.0, 20.0, unit="%"),
              Limit("gain of the optimum", 100 * gain, lo=100 * C11_GAIN, scale=100 * C11_GAIN, unit="points")]
    eq4 = _optimum(t, 1.2, PAPER_EQ4)
    other = (f"the paper's Eq. 4 (its own model for Fig. 16): optimum {eq4['refined_kNpm']:.0f} N/mm, "
             f"{eq4['refined_P_mm']:.1f} mm ({100 * eq4['refined_efficiency']:.1f} %), design point "
             f"{100 * eq4['efficiency_at_paper_design']:.1f} %" if eq4 and t.preset != PAPER_EQ4 else "")
    return (f"optimum {o['refined_kNpm']:.0f} N/mm, {o['refined_P_mm']:.1f} mm ({100 * o['refined_efficiency']:.1f} %);"
            f" design point {100 * o['efficiency_at_paper_design']:.1f} %", limits, other)


def _cells(t: Tables, preset: str) -> dict:
    """{(k, P): {stride_time: efficiency}} of the feasible designs of a preset's maps."""
    cells = {}
    for r in t["design_maps"]:
        if r.get("preset") == preset and r["feasible"] and not math.isnan(r["efficiency"]):
            cells.setdefault((r["k_Npm"], r["P_m"]), {})[r["stride_time_s"]] = r["efficiency"]
    return cells


def _average_and_best_p(cells: dict) -> tuple:
    """Mean efficiency at 1.2 s and 2 s over the designs feasible at both, and how many stiffnesses have their
    best precompression higher at 2 s (of how many)."""
    both = [v for v in cells.values() if 1.2 in v and 2.0 in v]
    best = {}
    for (k, P), v in cells.items():
        for T, e in v.items():
            if e > best.get((k, T), (-1, None))[0]:
                best[(k, T)] = (e, P)
    ks = sorted({k for k, _ in best})
    later = [k for k in ks if (k, 1.2) in best and (k, 2.0) in best and best[(k, 2.0)][1] > best[(k, 1.2)][1]]
    mean = (lambda T: sum(v[T] for v in both) / len(both)) if both else (lambda T: math.nan)
    return mean(1.2), mean(2.0), len(both), len(later), len(ks)


def _c12(t: Tables):
    # the paper's Figs. 16-17 are maps of its own calibrated Eq. 4 model (4.4: "incorporating the model obtained
    # in this paper"), so the claim is read on that model's maps; the fitted chain's are reported beside them
    eq4 = _cells(t, PAPER_EQ4)
    if not eq4:
        return (*NOT_CHECKED, "no map of the paper's Eq. 4 model in design_maps.csv")
    a12, a20, n, later, nk = _average_and_best_p(eq4)
    chain = _cells(t, t.preset) if t.preset != PAPER_EQ4 else {}
    c12, c20, cn, clater, cnk = _average_and_best_p(chain) if chain else (math.nan,) * 5
    sim = f"Eq. 4: mean {100 * a12:.1f} % (1.2 s) -> {100 * a20:.1f} % (2 s) over {n} designs"
    note = [f"second half (for some stiffness the best precompression is higher at 2 s), read apart: "
            f"{later} of {nk} stiffnesses on Eq. 4" + (f", {clater} of {cnk} on the {t.preset} chain" if chain else "")]
    if chain:
        note.append(f"the {t.preset} chain: mean {100 * c12:.1f} % -> {100 * c20:.1f} %")
    # a direction only: the rise measured against the mean at 1.2 s
    return sim, [Limit("mean efficiency, 2 s less 1.2 s", 100 * (a20 - a12), lo=0.0, strict=True, scale=100 * a12,
                       unit="points")], "; ".join(note)


#: the row of Table 2 (``table2_calibrated.csv``) C13 reads
RESISTANCE = "actuator resistance"


def _c13(t: Tables):
    # Eq. (4) calibrated on virtual-bench recordings of this preset's component chain (fig14_calibration): its R
    # against Table 2's estimated total, the a-priori value the paper's calibration moved from 0.7 to 2 ohm
    row = next((r for r in t["table2_calibrated"] if r.get("preset") == t.preset and r["parameter"] == RESISTANCE),
               None)
    if row is None:
        return (*NOT_CHECKED, f"no calibration on recordings of the {t.preset} chain in table2_calibrated.csv")
    ratio = row["calibrated"] / row["estimated_total"]
    R0, R1 = PAPER["table2_R"]
    paper = R1 / R0
    return (f"R {row['estimated_total']:.2g} -> {row['calibrated']:.2g} ohm ({ratio:.2f}x)",
            [Limit("inflation / the paper's", ratio / paper, 1 - 0.25, 1 + 0.25)],
            f"about: within 25 % of the paper's {paper:.2f}x; calibrated on virtual-bench recordings of the "
            f"{t.preset} chain")


#: (id, paper section, statement, the paper's numbers, how it is read, check)
_TABLE = [
    ("C1", "Table 1", "8 mm, 2 s/stride: energy per stride at source, driver, motor, link, output",
     " / ".join(f"{v:g}" for v in PAPER["table1_energy"].values()) + " J", "each energy within 15 %", _c1),
    ("C2", "4.2.1, Fig. 9", "the driver loss spans 28.6-49.3 % over the conditions", "28.6-49.3 %",
     "minimum and maximum each within 6 points", _c2),
    ("C3", "4.2.1", "the driver loss has an optimum near 1.5 s/stride and rises towards both shorter and longer "
     "strides; its constant 10-15 W draw makes the loss per stride higher at slow walking", "bowl, min. 1.5 s",
     f"at the tuned {TUNED_P_MM:g} mm the loss fraction's minimum over stride time is interior and within 0.5 s of "
     "1.5 s; at every precompression the energy lost per stride [J] non-decreasing from 1.5 s on", _c3),
    ("C4", "4.2.1", "the driver loss is lowest near 11 mm and 1.5 s/stride", "11 mm, 1.5 s",
     "grid minimum near there", _c4),
    ("C5", "4.2.2, Fig. 10", "the motor loss grows with stride time and with precompression", "grows",
     "non-decreasing along every row and column of the grid", _c5),
    ("C6", "4.2.3, Fig. 11", "the gearing loss is never below 50 %, above 65 % at high precompression and short "
     "strides", ">= 50 %, > 65 %", f"grid minimum >= 50 %, worst of P >= {CORNER[0]:g} mm and T <= {CORNER[1]:g} s "
     "above 65 %", _c6),
    ("C7", "4.2.3, Fig. 12", "the output (linkage) loss is around 20 %, above 50 % in the worst case",
     "~20 %, > 50 %", "grid mean within 5 points of 20 %, maximum above 50 %", _c7),
    ("C8", "4.2.3, Fig. 13", "at 18 mm the motor cannot follow at 1.2 s/stride but follows at 3 s",
     "fails only there", "required duty > 0.9 at 1.2 s, <= 0.9 at 3 s; follows in >= 30 of 36 conditions", _c8),
    ("C9", "4.1, Fig. 7", "8 mm, 3 s/stride: the output motor's (the direct drive's) peak source power is about 40 % "
     "higher for about the same energy", "1.4x, 126 vs 122 J",
     "the bench's output motor (imposing the gait angle while the actuator pushes) against the actuator: peak ratio "
     "1.3-1.6, energy within 10 %", _c9),
    ("C10", "4.2.1, Fig. 8", "the driver output power dips to about -50 W while the source stays near 0 W",
     "-50 W, 0 W", "minimum driver power -35 to -65 W, source above -1 W", _c10),
    ("C11", "4.4, Fig. 16", "at 1.2 s/stride lower stiffness is more efficient than the design (130 N/mm, 7 mm), "
     "15 % -> 25 % reachable", "lower k, 15 -> 25 %",
     "optimum below 130 N/mm, design point 10-20 %, optimum >= 8 points higher", _c11),
    ("C12", "4.4, Fig. 17", "at 2 s/stride the average efficiency is higher for the same parameter range (and for "
     "some stiffnesses the best precompression is higher)", "higher",
     "on the paper's Eq. 4 maps: mean efficiency over the designs feasible at both stride times higher at 2 s "
     "(the second half reported in the note)", _c12),
    ("C13", "4.3, Table 2", "calibrating Eq. 4 (ideal gears) inflates the resistance (0.7 -> 2 ohm)",
     "0.7 -> 2 ohm", "R calibrated on recordings of the chain over Table 2's estimated total (0.7 ohm) within 25 % "
     "of 2.86", _c13),
]
#: what in the model's physics opposes a claim that does not hold (the evidence: README, "The paper's actuator")
OPPOSES = {
    "C3": "the bowl comes from the non-regenerative front end burning the energy the motor sends back (the rotor's "
          "kinetic energy), which grows towards short strides, against the constant draw, which grows towards long "
          "ones; at 18 mm the burnt energy falls from 1.5 to 2 s/stride by about what the draw adds over the extra "
          "half second, so the long-stride branch holds there only with the draw and the inertia paper_fit infers "
          "(C3 is one of its targets): with less draw or more inertia the loss per stride is lowest at 2 s there",
    "C4": "the energy burnt in the non-regenerative front end grows with precompression at short strides and the "
          "joint work falls, so the grid's minimum sits at low precompression; the paper puts its optimum near 11 mm "
          "down to the driver's tuning near 8 mm (4.2.1), which the model's controller does not depend on",
    "C5": "the model follows the paper's own explanation (the lower the mean motor speed, the higher the motor loss; "
          "Fig. 10's caption ranks them over the grid), but its mean motor speed along precompression is highest at "
          "5 mm, not at 2 mm: at 2 mm the MACCEPA is soft (T ~ alpha^3) and the fitted planner band takes a higher, "
          "shorter arm path (a tight band moves the arm far and fast there and draws more current instead), so the "
          "motor loss falls from 2 to 5 mm before it grows; with the motor's inertia at the datasheet rotor's, "
          "instead of the inferred, it falls as well",
    "C6": "the gearing loss's corner (high precompression, short strides) comes from the arm lagging where the "
          "motor cannot follow; the feed-forward that brings the output loss's mean to 20 % (C7) also cuts that "
          "lag (inference record: feed_forward_trials)",
    "C7": "the mean and the worst case pull against each other through the controller: a feed-forward that keeps the "
          "arm on its path brings the mean near 20 % and the worst case under 50 %, a lagging PID the worst case "
          "over 50 % and the mean near 30 % (inference record: feed_forward_trials)",
    "C9": "the paper's direct drive was the bench's output motor, which holds the joint on the gait angle while the "
          "actuator pushes it; with the actuator's own drive train (the guess: the output motor's is not published) "
          "it needs less peak power and less energy than the actuator, so the paper's output drive train was "
          "another (about 10 % under the target torque, 4.1)",
    "C10": "at 8 mm and 2 s/stride the arm returns little power: the driver output dips no deeper than the moment "
           "arm's own negative peak; more inertia on the motor shaft deepens the dip but raises the regenerated "
           "energy the driver burns against Table 1 and Fig. 9 (inference record)",
    "C11": "not reproduced: the report's C11 table (c11_readings.csv) gives the optimum under each reading of the "
           "efficiency the paper leaves open and under which it is softer than the reference. A softer spring costs "
           "more copper per stride (design_optima.csv: E_copper_J at 130/7, 60/7 and 60/4 N/mm/mm) on the fitted "
           "chain and on the paper's Eq. 4 alike; the table, not this sentence, says whether that decides the optimum",
    "C12": "the driver's constant draw costs more per stride at 2 s; on the paper's own Eq. 4, which has no such "
           "draw, the average is higher at 2 s",
    "C13": "Eq. 4's driver is ideal, so the calibration explains the chain's driver losses in the supply current (its "
           "constant draw, conduction, switching) by R as well, on top of the gear and linkage losses the paper's "
           "inflation stands for; with the chain's driver made lossless the same calibration gives about 3x",
}
#: the calibration set of ``paper_fit``, one entry per claim: its class, the paper's sentence that decides it
#: (verbatim, the paper's spelling kept; " [...] " where the text breaks a sentence, as Table 2 does C12's) and
#: why. The targets are what ``targets.TARGETS`` fits and the planner's tolerance is chosen for (C8);
#: ``paper_fit.json``'s targets must name the same claims (tests). A prediction is testable where the published text
#: fixes what the claim depends on; not testable where it rests on something the paper does not publish
_E = PAPER["table1_energy"]
_GEARING_T1 = 1 - _E["link"] / _E["motor"]  # Table 1's gearing loss (its 53.3 %)
CALIBRATION = {
    "C1": (TARGET, "Table 1 Energy and efficiency of the actuator at different components.",
           "the five energies at 8 mm, 2 s/stride fix the chain stage by stage: the body mass scaling the torque, "
           "the driver's losses, the gearhead's drag and mesh efficiency, the linkage friction"),
    "C2": (TARGET, "The losses vary from 28.6% to 49.3% and show a clear relation with both the walking duration "
           "and the precompression.",
           "the driver loss's extremes over the grid fix the driver's constant draw against its current-dependent "
           "losses"),
    "C3": (TARGET, "There is a constant energy consumption in the driver of between 10 and 15 W, which explains why "
           "the energy loss per stride is higher at slower walking velocities.",
           "the bowl over stride time at the tuned 8 mm weighs the constant draw against the regenerated energy the "
           "driver burns (the inertia on the motor shaft); it cannot be a prediction: fitted without it from the "
           "a-priori values (the trial without_C3), the inertia ends on its upper bound and the loss per stride "
           "falls from 1.5 s/stride on at 18 mm"),
    "C4": (NOT_TESTABLE, "The change in efficiency for different precompressions can be explained by the fact that "
           "the driver was tuned when the precompression was set to around 8 mm.",
           "the paper puts the precompression of the driver's optimum down to the driver's tuning, which it does not "
           "publish; the model's driver has no tuning-dependent loss (the stride-time half is C3's)"),
    "C5": (TESTABLE, "Both of these effects can be explained by the fact that the average motor velocity is lower in "
           "these cases, resulting in a lower motor efficiency.",
           "the paper explains it by the motor's own efficiency over speed and torque, which the datasheet motor "
           "and the published trajectories fix"),
    "C6": (IN_NAME_ONLY, "From the graphs it can be seen that the overall losses in the gearing are very substantial "
           "as they are never below 50%.",
           "not a target of this record, but no independent test: the fit started from a record that had C6 as a "
           "target, so the values began where that fit put them (a fit from the a-priori values that never had it, "
           "the trial without_C3, ends next to them and C6 holds there as well); its floor sits next to C1's targets "
           "(Table 1's "
           f"gearing loss at 8 mm, 2 s/stride, 1 - {_E['link']:g}/{_E['motor']:g} = {100 * _GEARING_T1:.1f} %, is "
           f"{100 * (_GEARING_T1 - PAPER['fig11_gearing_loss_min']):.1f} points above it) and its corner rises with "
           "the arm's lag, which C7's worst case (> 50 %) sets through the feed-forward (the record's "
           "feed_forward_trials)"),
    "C7": (TARGET, "For the output, the average losses are a lot lower, around 20%, vet also at the output the losses "
           "increase greatly in the case of both high precompression and low walking duration to over 50% in the "
           "worst case.",
           "the output loss's mean fixes the linkage friction, its worst case the bench controller's feed-forward "
           "(how far the arm lags where the motor cannot follow)"),
    "C8": (TARGET, "It is clear that the motor cannot follow the setpoint anymore during the push-off phase at the "
           "low walking duration.",
           "the planner's torque tolerance, which the paper does not publish, is chosen as the smallest with which "
           "the motor follows where the paper says it does (the record's tolerance_trials)"),
    "C9": (NOT_TESTABLE, "The other side of the torque sensor is connected to a DC motor with high gearing, which will "
           "be referred to as the output motor.",
           "the paper's direct drive is the bench's output motor, of which it publishes no motor, gear or driver: "
           "the model's guesses the actuator's own drive train"),
    "C10": (TARGET, "When the driver power has a negative peak to -50 W, the source power only drops to around 0 W.",
            "the depth of the driver output's dip fixes the inertia on the motor shaft, which the paper estimates "
            "but does not measure"),
    "C11": (TESTABLE, "The simulation shows that a much higher efficiency can be achieved mainly at lower spring "
            "stiffnesses.",
            "the paper publishes the model its Fig. 16 was computed with (Eq. 4, Table 2) and the design it compares "
            "with (130 N/mm, 7 mm); which efficiency Fig. 16 maps it does not say (the report's C11 table reads it "
            "several ways)"),
    "C12": (TESTABLE, "The same simulation for a longer simulated walking duration, shown in Figure 17, shows that the "
            "average efficiency of the actuator is higher for the same parameter [...] range.",
            "read on the paper's own Eq. 4 with Table 2's optimized values, all published"),
    "C13": (NOT_TESTABLE, "Using the torque and angular measurements performed on the device, an optimization of the "
            "model was performed, changing the motor parameters to perform a least squares minimization between "
            "modeled and measured current over all of the performed measurements at different walking velocities "
            "and spring precompressions.",
            "the bench recorded two currents (section 3: \"the current to the actuator driver and the motor current "
            "of the actuator motor\") and the paper does not say which one the calibration fitted; the inflation "
            "differs with the one chosen"),
}
CLAIMS = [Claim(*row, opposes=OPPOSES.get(row[0], ""), role=CALIBRATION[row[0]][0], quote=CALIBRATION[row[0]][1],
                why=CALIBRATION[row[0]][2]) for row in _TABLE]


def declared_targets() -> frozenset:
    """The ids of the claims the calibration set declares targets."""
    return frozenset(c.id for c in CLAIMS if c.role == TARGET)


def tightest(limits: list) -> Limit | None:
    """The limit with the least to spare (as a fraction of its tolerance where it has one, else by its slack)."""
    if not limits:
        return None
    return min(limits, key=lambda x: (x.ok, x.spare if x.spare is not None else math.inf, x.slack))


def evaluate(out_dir, preset: str = "library", fitted: frozenset = frozenset()) -> list[dict]:
    """The claims checked on the CSV files in ``out_dir`` for one preset: one row per claim (``claims.csv``'s
    columns). ``fitted``: the ids of the claims the preset's parameters were inferred from (the inference record
    says which), marked ``used_in_fit``.
    The claim's ``role`` (its class in the calibration set of ``paper_fit``), the ``quote`` that decides it, the
    tightest of its limits (``margin``: said in words; ``spare``: the fraction of that limit's tolerance left) and
    ``fragile`` (it holds with less than :data:`FRAGILE` of a tolerance to spare) come with each row."""
    t = Tables(out_dir, preset)
    rows = []
    for c in CLAIMS:
        simulated, limits, note = c.check(t)
        holds = None if limits is None else all(x.ok for x in limits)
        why = f"against it: {c.opposes}" if holds is False and c.opposes else ""
        worst = tightest(limits or [])
        spare = "nan" if worst is None or worst.spare is None else f"{worst.spare:.4f}"  # a missing number
        fragile = ("" if holds is not True or worst is None or worst.spare is None
                   else "yes" if worst.spare < FRAGILE else "no")
        rows.append(dict(id=c.id, statement=f"[{c.section}] {c.statement}", paper=c.paper, simulated=simulated,
                         holds="not checked" if holds is None else ("yes" if holds else "no"),
                         used_in_fit="yes" if c.id in fitted else "no", preset=preset, role=c.role,
                         margin="" if worst is None else worst.said(), spare=spare, fragile=fragile,
                         quote=c.quote, why=c.why,
                         note="; ".join(filter(None, [f"read as: {c.reading}", note, why]))))
    return rows
