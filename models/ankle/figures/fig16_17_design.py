"""Efficiency-optimal spring design (paper section 4.4): overall efficiency per stride (joint energy / source
energy) over spring stiffness x precompression at 1.2 s (Fig. 16) and 2.0 s (Fig. 17) per stride, with the
original design criterion (minimum peak moment-arm power at 1.2 s; paper: 130 N/mm, 7 mm) next to the
efficiency optimum and a continuous refinement of it.

Two models: the one of every other figure, the paper's actuator with the ``paper_fit`` preset (gear, driver and
linkage losses included; :func:`acausal.models.bench.design.chain_model`), and the paper's own model for these
figures, Eq. 4 as it calibrated it (Table 2's optimized total, arm side: ``presets.PAPER_EQ4``, the same chain with
ideal gears and driver). Every design is planned with the preset's body mass and torque tolerance, all designs of a
map in one vectorised evaluation. The fitted chain's 1.2 s optimum is also computed at 60 kg (the body mass is not
published). The copper loss per stride at three designs is reported (claim C11's reason), and the fitted chain's
best precompression per stiffness at both stride times with and without the linkage's friction (Fig. 17's reason).

Writes ``fig16_efficiency_1.2s.png``, ``fig17_efficiency_2.0s.png``, ``design_maps.csv``, ``design_optima.csv``,
``fig17_linkage_friction.csv``.
Run: ``python -m acausal.models.ankle.figures.fig16_17_design`` (into ``results/``).
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from acausal.models.ankle.protocol import D_MAX  # noqa: E402
from acausal.models.bench import design  # noqa: E402
from acausal.models.ankle.paper import HEADLINE  # noqa: E402
from acausal.models.ankle.presets import PAPER_EQ4  # noqa: E402
from acausal.models.reporting.tables import md_table, write_csv  # noqa: E402
from acausal.models.reporting.figures import save_figure  # noqa: E402
from acausal.models.ankle.figures.trends import verdict  # noqa: E402

PAPER_DESIGN = (130e3, 0.007)  # N/m, m (paper section 4.4)
#: the design of the actuator is copper loss at these (k [N/m], P [m]) at 1.2 s/stride (claim C11's reason)
COPPER_DESIGNS = ((130e3, 0.007), (60e3, 0.007), (60e3, 0.004))
#: the body mass the paper's design was chosen for is not published: the headline's optimum is also computed at the
#: library's default (60 kg, docs/parameters.md) to show how far it moves with the mass
OTHER_MASS = 60.0
#: the parameters the planned arm trajectory reads besides the spring (models/ankle/planning.py)
PLANNING = ("body_mass", "torque_tolerance", "arm_limit")
#: the linkage without its friction (Fig. 17's reason: what keeps the chain's best precompression in place)
FRICTIONLESS = {"link.r_f": 0.0}
#: the designs (k [N/m], P [m]) the linkage's friction loss per stride is read at (Fig. 17's reason)
FRICTION_DESIGNS = ((130e3, 0.007), (130e3, 0.013))


def best_precompression(m) -> np.ndarray:
    """The precompression [m] of the best efficiency per stiffness of map ``m`` among its finite designs (NaN where
    a stiffness has none)."""
    e = m.values["efficiency"]
    ok = np.isfinite(e).any(axis=1)
    return np.where(ok, m.P[np.argmax(np.where(np.isfinite(e), e, -np.inf), axis=1)], np.nan)


def moved_up(ba, bb) -> tuple[int, int]:
    """How many stiffnesses have their best precompression higher in ``bb`` (2 s) than in ``ba`` (1.2 s), of how
    many have one in both (:func:`best_precompression` of each map)."""
    both = np.isfinite(ba) & np.isfinite(bb)
    return int(np.sum(bb[both] > ba[both])), int(both.sum())


def friction_rows(runs: dict, frictionless: dict) -> list[dict]:
    """Per stiffness, the fitted chain's best precompression at 1.2 and 2 s/stride with the linkage's friction
    (``runs``) and without (``frictionless``: stride time -> map)."""
    best = {(T, f): best_precompression(runs[(HEADLINE, T)] if not f else frictionless[T])
            for f in (False, True) for T in (1.2, 2.0)}
    column = {(T, f): f"best_P_mm_{T:g}s" + ("_frictionless" if f else "") for T, f in best}
    return [dict(preset=HEADLINE, k_kNpm=k / 1e3, **{column[c]: 1e3 * float(b[i]) for c, b in best.items()})
            for i, k in enumerate(runs[(HEADLINE, 1.2)].k)]


def _optimum_row(m, peak, label_mass, variant: str = "") -> dict:
    k_e, P_e, eff = m.optimum()
    k_r, P_r, eff_r = design.refine(m)
    return dict(preset=m.preset, body_mass_kg=label_mass, variant=variant,
                stride_time_s=m.stride_time, paper_design_kNpm=PAPER_DESIGN[0] / 1e3,
                paper_design_P_mm=PAPER_DESIGN[1] * 1e3, efficiency_at_paper_design=m.at(*PAPER_DESIGN),
                peak_power_optimum_kNpm=peak[0] / 1e3, peak_power_optimum_P_mm=peak[1] * 1e3,
                efficiency_at_peak_power_optimum=m.at(peak[0], peak[1]), grid_optimum_kNpm=k_e / 1e3,
                grid_optimum_P_mm=P_e * 1e3, grid_optimum_efficiency=eff, refined_kNpm=k_r / 1e3,
                refined_P_mm=P_r * 1e3, refined_efficiency=eff_r, designs=m.values["efficiency"].size,
                designs_over_duty_limit=int(np.nansum(m.values["max_duty"] > D_MAX)),
                **{f"E_copper_J_{k / 1e3:g}Npmm_{P * 1e3:g}mm": m.at(k, P, "E_copper_J") for k, P in COPPER_DESIGNS})


def main(out_dir: Path, results=None, executor=None) -> dict:
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    # both models are planned alike (the headline's body mass, planner tolerance and arm range): only the model
    # differs; the paper's Eq. 4 drives its motor from an ideal voltage, so its optima ignore the duty limit
    plan = {k: v for k, v in design.design_params(HEADLINE)[1].items() if k in PLANNING}
    runs = {(preset, T): design.efficiency_map(T, preset, overrides=None if preset == HEADLINE else plan,
                                               executor=executor, duty_limited=preset == HEADLINE)
            for preset in (HEADLINE, PAPER_EQ4) for T in (1.2, 2.0)}
    other = design.efficiency_map(1.2, HEADLINE, overrides={"body_mass": OTHER_MASS}, executor=executor)
    # the paper's design criterion: minimum peak moment-arm power at 1.2 s of the exact plan (no torque tolerance:
    # the mechanics the design was optimised on, 4.4), over every feasible design, at each body mass
    peak_of = {m: design.efficiency_map(1.2, HEADLINE, overrides={"body_mass": m, "torque_tolerance": 0.0},
                                        executor=executor).optimum("peak_link_W", maximise=False, duty_limited=False)
               for m in (plan["body_mass"], OTHER_MASS)}
    frictionless = {T: design.efficiency_map(T, HEADLINE, overrides=FRICTIONLESS, executor=executor) for T in (1.2, 2.0)}
    rows, opt_rows = [], []
    for preset in (HEADLINE, PAPER_EQ4):
        for T in (1.2, 2.0):
            m = runs[(preset, T)]
            opt_rows.append(_optimum_row(m, peak_of[plan["body_mass"]], plan["body_mass"]))
            for a, k in enumerate(m.k):
                for b, P in enumerate(m.P):
                    rows.append(dict(preset=preset, body_mass_kg=plan["body_mass"], stride_time_s=T, k_Npm=k, P_m=P,
                                     **{key: float(v[a, b]) for key, v in m.values.items()}))
    opt_rows.append(_optimum_row(other, peak_of[OTHER_MASS], OTHER_MASS,
                                 f"body mass {OTHER_MASS:g} kg"))
    figures = [_plot(out_dir, [runs[(HEADLINE, T)], runs[(PAPER_EQ4, T)]], opt_rows, T) for T in (1.2, 2.0)]
    maps_csv = write_csv(out_dir / "design_maps.csv", rows)
    opt_csv = write_csv(out_dir / "design_optima.csv", opt_rows)
    friction = friction_rows(runs, frictionless)
    friction_csv = write_csv(out_dir / "fig17_linkage_friction.csv", friction)
    name = {HEADLINE: f"`{HEADLINE}` chain", PAPER_EQ4: "paper's Eq. 4"}
    m12 = runs[(HEADLINE, 1.2)]
    md = [f"Models: the paper's actuator with the `{HEADLINE}` preset (the chain of every other figure: gear, driver "
          "and linkage losses; on a stiff 48 V supply, which makes the replay algebraic), and the paper's own model "
          f"for these figures (Eq. 4 with Table 2's optimized total, arm side: preset `{PAPER_EQ4}`, ideal gear "
          "and driver, planned as the chain: its body mass and planner tolerance; no duty limit, the paper's Eq. 4 has "
          "an ideal voltage). "
          f"Grid: k {design.K_GRID[0] / 1e3:g}-{design.K_GRID[-1] / 1e3:g} "
          f"N/mm x P {design.P_GRID[0] * 1e3:g}-{design.P_GRID[-1] * 1e3:g} mm "
          f"({m12.values['efficiency'].size} designs per map); infeasible designs (gait torque above the "
          "linkage's reach) are blank; designs that need more than 0.9 duty are hatched in the figures (their "
          "energy is a lower bound: the motor could not follow) and are no candidates for an optimum.", "",
          md_table(["model", "body mass", "stride time", "paper design 130 N/mm, 7 mm", "peak-power optimum (1.2 s, exact plan)",
                    "efficiency optimum (grid)", "refined optimum", "gain over the paper's design"],
                   [[name[r["preset"]], f"{r['body_mass_kg']:.1f} kg", f"{r['stride_time_s']} s",
                     f"{100 * r['efficiency_at_paper_design']:.1f} %",
                     f"{r['peak_power_optimum_kNpm']:.0f} N/mm, {r['peak_power_optimum_P_mm']:.1f} mm: "
                     f"{100 * r['efficiency_at_peak_power_optimum']:.1f} %",
                     f"{r['grid_optimum_kNpm']:.0f} N/mm, {r['grid_optimum_P_mm']:.1f} mm: "
                     f"{100 * r['grid_optimum_efficiency']:.1f} %",
                     f"{r['refined_kNpm']:.1f} N/mm, {r['refined_P_mm']:.2f} mm: {100 * r['refined_efficiency']:.1f} %",
                     f"{100 * (r['refined_efficiency'] - r['efficiency_at_paper_design']):+.1f} points"]
                    for r in opt_rows]),
          "", "Copper loss per stride at 1.2 s/stride (the winding's R i^2; C11's reason):", "",
          md_table(["model", *[f"{k / 1e3:g} N/mm, {P * 1e3:g} mm" for k, P in COPPER_DESIGNS]],
                   [[name[r["preset"]], *[f"{r[f'E_copper_J_{k / 1e3:g}Npmm_{P * 1e3:g}mm']:.1f} J"
                                          for k, P in COPPER_DESIGNS]]
                    for r in opt_rows if r["stride_time_s"] == 1.2 and not r["variant"]]),
          "", caption(runs, opt_rows, name, friction)]
    return dict(title="Efficiency-optimal design (paper section 4.4, Figs. 16-17)", figures=figures,
                csv=[maps_csv, opt_csv, friction_csv], markdown="\n".join(md), comparisons=[], optima=opt_rows)


#: the stiffnesses [N/m] the caption reads the efficiency at, along the paper design's precompression
ALONG_K = (60e3, 130e3, 200e3)


def _mean_and_best(a, b) -> tuple:
    """Mean efficiency of maps ``a`` (1.2 s) and ``b`` (2 s) over the designs feasible (and finite) in both, the
    number of such designs, and how many stiffnesses have their best precompression higher in ``b`` (of how many
    have one in both)."""
    ea, eb = a.values["efficiency"], b.values["efficiency"]
    both = np.isfinite(ea) & np.isfinite(eb)
    return (float(np.mean(ea[both])), float(np.mean(eb[both])), int(both.sum()),
            *moved_up(best_precompression(a), best_precompression(b)))


def _friction_reason(runs: dict, friction: list) -> str:
    """Why the fitted chain's best precompression stays in place at 2 s/stride, read on ``friction``
    (:func:`friction_rows`) and the maps' linkage loss (E_link - E_output) at :data:`FRICTION_DESIGNS`."""
    later, nk = moved_up(*(np.array([r[f"best_P_mm_{T:g}s_frictionless"] for r in friction]) for T in (1.2, 2.0)))
    if not later:
        return ("what keeps this model's best precompression in place at 2 s is not isolated here (not the linkage's "
                "friction: without it, too, no stiffness has its best precompression higher at 2 s)")
    loss = "; ".join(f"{T:g} s: " + ", ".join(
        f"{runs[(HEADLINE, T)].at(k, P, 'E_link_J') - runs[(HEADLINE, T)].at(k, P, 'E_output_J'):.2f} J at "
        f"{P * 1e3:g} mm" for k, P in FRICTION_DESIGNS) for T in (1.2, 2.0))
    return (f"the linkage's friction (its torque r_f times the spring's force, Coulomb) costs about the same per "
            f"stride at either stride time and more at a higher precompression (link to output at "
            f"{FRICTION_DESIGNS[0][0] / 1e3:g} N/mm, {loss}): without it (link.r_f = 0) {later} of {nk} stiffnesses "
            "have their best precompression higher at 2 s, as on the paper's Eq. 4, which has no linkage friction "
            "(fig17_linkage_friction.csv)")


def caption(runs: dict, opt_rows: list, name: dict, friction: list | None = None) -> str:
    """The verdicts of Figs. 16-17 for each model (4.4: at 1.2 s/stride a much higher efficiency at lower
    stiffness than the design, about 15 % -> 25 %; at 2 s/stride a higher average efficiency over the same range,
    and for some stiffnesses a higher best precompression), from the maps and their optima; ``friction``
    (:func:`friction_rows`) gives the fitted chain's reason where its best precompression stays in place."""
    K0, P0 = PAPER_DESIGN
    L = []
    for preset in (HEADLINE, PAPER_EQ4):
        r = next(o for o in opt_rows if o["preset"] == preset and o["stride_time_s"] == 1.2 and not o["variant"])
        m = runs[(preset, 1.2)]
        along = ", ".join(f"{100 * m.at(k, P0):.1f} % at {k / 1e3:g}" for k in ALONG_K)
        copper = [r[f"E_copper_J_{k / 1e3:g}Npmm_{P * 1e3:g}mm"] for k, P in COPPER_DESIGNS]
        lower = r["refined_kNpm"] < K0 / 1e3
        L.append(verdict(
            "Fig. 16", f"where the efficiency optimum lies in stiffness, {name[preset]}", lower,
            f"a much higher efficiency mainly at lower stiffness than the design's {K0 / 1e3:g} N/mm",
            f"the optimum is at {r['refined_kNpm']:.0f} N/mm, {r['refined_P_mm']:.1f} mm "
            f"({100 * r['refined_efficiency']:.1f} %), " + ("below" if lower else "above") + " the design; along "
            f"{P0 * 1e3:g} mm the efficiency is {along} N/mm",
            "" if lower else "the copper loss is not the same for every spring: a softer one needs more arm travel "
            "and arm acceleration, and the rotor's inertia reflected to the arm (J n^2, 2.5-12 kg m2) turns that "
            "acceleration into winding current (copper loss per stride " + ", ".join(
                f"{c:.1f} J at {k / 1e3:g} N/mm, {P * 1e3:g} mm" for c, (k, P) in zip(copper, COPPER_DESIGNS)) + ")"))
        gain = r["refined_efficiency"] - r["efficiency_at_paper_design"]
        L.append(verdict(
            "Fig. 16", f"the gain over the design, {name[preset]}", gain >= 0.08,
            "from about 15 % at the design to about 25 % (conclusion), a gain of about 10 points",
            f"{100 * r['efficiency_at_paper_design']:.1f} % at the design, {100 * r['refined_efficiency']:.1f} % at "
            f"the optimum ({100 * gain:+.1f} points)",
            "" if gain >= 0.08 else "the design already sits near the model's optimum (above)"))
        a12, a20, n, later, nk = _mean_and_best(runs[(preset, 1.2)], runs[(preset, 2.0)])
        r2 = next(o for o in opt_rows if o["preset"] == preset and o["stride_time_s"] == 2.0 and not o["variant"])
        L.append(verdict(
            "Fig. 17", f"the average efficiency at 2 s against 1.2 s/stride, {name[preset]}", a20 > a12,
            "the average efficiency is higher at 2 s/stride for the same parameter range",
            f"mean {100 * a12:.1f} % at 1.2 s, {100 * a20:.1f} % at 2 s over the {n} designs feasible at both",
            "" if a20 > a12 else "the driver's constant draw costs more per stride at 2 s"))
        L.append(verdict(
            "Fig. 17", f"the best precompression at 2 s, {name[preset]}", later > 0,
            "for some stiffnesses a higher precompression is worthwhile at 2 s/stride",
            f"{later} of {nk} stiffnesses have their best precompression higher at 2 s; the 2 s optimum is at "
            f"{r2['refined_kNpm']:.0f} N/mm, {r2['refined_P_mm']:.1f} mm ({100 * r2['refined_efficiency']:.1f} %)",
            "" if later > 0 else _friction_reason(runs, friction) if preset == HEADLINE and friction
            else "what keeps this model's best precompression in place at 2 s is not isolated here"))
    return "\n\n".join(L)


def _plot(out_dir, maps, opt_rows, T):
    fig, axes = plt.subplots(1, len(maps), figsize=(7.0 * len(maps), 5.2))
    for ax, m in zip(np.atleast_1d(axes), maps):
        r = next(r for r in opt_rows if r["preset"] == m.preset and r["stride_time_s"] == T and not r["variant"])
        K, P = np.meshgrid(m.k / 1e3, m.P * 1e3, indexing="ij")
        cs = ax.contourf(K, P, 100 * m.values["efficiency"], levels=16, cmap="viridis")
        fig.colorbar(cs, ax=ax, label="overall efficiency per stride [%]")
        over = m.values["max_duty"] > D_MAX
        if over.any():
            ax.contourf(K, P, over.astype(float), levels=[0.5, 1.5], colors="none", hatches=["///"])
        marks = dict(mec="k", mew=1.0, clip_on=False, zorder=5, ls="none")  # visible on any colour, on an edge
        ax.plot(PAPER_DESIGN[0] / 1e3, PAPER_DESIGN[1] * 1e3, "s", mfc="red", ms=9,
                label="paper's design (130 N/mm, 7 mm)", **marks)
        ax.plot(r["peak_power_optimum_kNpm"], r["peak_power_optimum_P_mm"], "^", mfc="white", ms=10,
                label="min. peak moment-arm power (1.2 s)", **marks)
        ax.plot(r["refined_kNpm"], r["refined_P_mm"], "*", mfc="magenta", ms=16, label="efficiency optimum (refined)",
                **marks)
        ax.set_xlabel("spring stiffness k [N/mm]")
        ax.set_ylabel("precompression P [mm]")
        ax.set_title(f"preset {m.preset} ({r['body_mass_kg']:.1f} kg)"
                     + ("" if m.duty_limited else "; ideal voltage: optimum over every design"), fontsize=9)
        ax.legend(fontsize=7.5, loc="lower right")
    fig_no = 16 if T < 1.5 else 17
    fig.suptitle(f"Fig. {fig_no}: efficiency at {T} s per stride (hatched: duty > {D_MAX:g}); left: the fitted "
                 "chain, right: the paper's Eq. 4 as it calibrated it", fontsize=10)
    return save_figure(fig, Path(out_dir) / f"fig{fig_no}_efficiency_{T}s.png")


if __name__ == "__main__":
    print(main(Path("results"))["markdown"])
