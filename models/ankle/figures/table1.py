"""Table 1 of the paper: energy per stride at the five measurement points, 8 mm precompression, 2 s/stride,
simulation next to the paper, and a Sankey diagram of the loss chain.

Writes ``table1.csv``, ``table1_sankey.png`` (and ``table1_sankey.csv``, the flows drawn).
Run: ``python -m acausal.models.ankle.figures.table1`` (into ``results/``).
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from acausal.models.ankle.protocol import POINTS  # noqa: E402
from acausal.models.ankle.paper import BENCH, BESIDE, HEADLINE, comparison, pick  # noqa: E402
from acausal.models.ankle.published import PAPER  # noqa: E402
from acausal.models.reporting.tables import md_table, pct, write_csv  # noqa: E402
from acausal.models.reporting.sankey import LABELS, LOSSLESS_LINKAGE, loss_names_from_groups  # noqa: E402
from acausal.results.sankey import sankey  # noqa: E402
from acausal.models.reporting.figures import save_figure  # noqa: E402

P, T = 0.008, 2.0
# what drives a difference at each point (see acausal.models.ankle.paper.ASSUMPTIONS)
WHY_ENERGY = {"source": "driver", "driver": ["gears", "motor"], "motor": "gears", "link": "geometry",
              "output": "geometry"}
WHY_LOSS = {"driver": "driver", "motor": ["gears", "motor"], "link": "gears", "output": "maccepa"}


def main(out_dir: Path, results=None) -> dict:
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    r = pick(results, P, T, model=BENCH)
    lib = pick(results, P, T, model=BENCH, preset=BESIDE)
    paper_e, paper_eff, paper_loss = PAPER["table1_energy"], PAPER["table1_efficiency"], PAPER["table1_loss"]
    eff, loss = r.efficiency, r.loss_fraction

    rows = []
    for k in POINTS:
        rows.append(dict(point=k, sim_energy_J=r.energy[k], paper_energy_J=paper_e[k],
                         ratio_energy=r.energy[k] / paper_e[k], sim_efficiency=eff[k], paper_efficiency=paper_eff[k],
                         sim_loss_vs_previous=loss[k], paper_loss_vs_previous=paper_loss[k], preset=HEADLINE,
                         **{f"{BESIDE}_energy_J": lib.energy[k], f"{BESIDE}_loss_vs_previous": lib.loss_fraction[k]}))
    csv_path = write_csv(out_dir / "table1.csv", rows)

    md = md_table(["measurement point", f"energy `{HEADLINE}` [J]", "energy paper [J]", "ratio",
                   f"efficiency `{HEADLINE}`", "efficiency paper", f"loss vs previous `{HEADLINE}`",
                   "loss vs previous paper", f"energy `{BESIDE}` [J]", f"loss vs previous `{BESIDE}`"],
                  [[LABELS[k], f"{r.energy[k]:.1f}", f"{paper_e[k]:.1f}", f"{r.energy[k] / paper_e[k]:.2f}",
                    pct(eff[k]), pct(paper_eff[k]), pct(loss[k]), pct(paper_loss[k]), f"{lib.energy[k]:.1f}",
                    pct(lib.loss_fraction[k])] for k in POINTS])
    motor_abs = r.stage_loss["motor"]
    paper_motor_abs = paper_e["driver"] - paper_e["motor"]
    md += (f"\n\nEnergy per stride integrated over the last simulated stride (the bench: {BENCH}, `{HEADLINE}` "
           "preset; the "
           f"a-priori `{BESIDE}` preset beside it). "
           f"Losses in joules: driver {r.stage_loss['driver']:.1f} "
           f"(paper {paper_e['source'] - paper_e['driver']:.1f}), "
           f"motor {motor_abs:.1f} (paper {paper_motor_abs:.1f}), gearing {r.stage_loss['gearing']:.1f} "
           f"(paper {paper_e['motor'] - paper_e['link']:.1f}), output {round(r.stage_loss['output'], 6) + 0.0:.1f} "
           f"(paper {paper_e['link'] - paper_e['output']:.1f}). With `{BESIDE}` the MACCEPA is conservative "
           "(the paper's Eq. 1-3), so its link and output energies coincide over a stride.")

    # Sankey: simulation and paper side by side, on the same scale (J per stride)
    fig, axes = plt.subplots(1, 2, figsize=(14, 5.2))
    scale = 1.0 / max(r.energy["source"], paper_e["source"])
    loss_names = loss_names_from_groups(r.stages, link="MACCEPA linkage")
    sankey(axes[0], r.energy, scale=scale, loss_names=loss_names, labels=LABELS, lossless_note=LOSSLESS_LINKAGE,
           title=f"Simulation: {r.energy['source']:.1f} J/stride from the source, "
                 f"{r.energy['output']:.1f} J to the joint ({100 * eff['output']:.1f} %)")
    sankey(axes[1], paper_e, scale=scale, loss_names=loss_names, labels=LABELS, lossless_note=LOSSLESS_LINKAGE,
           title=f"Paper (Table 1, measured): {paper_e['source']:.1f} J/stride from the source, "
                 f"{paper_e['output']:.1f} J to the joint ({100 * paper_eff['output']:.1f} %)")
    fig.suptitle("Table 1: where the energy of one stride goes (8 mm precompression, 2 s/stride; "
                 "arrow widths proportional to J per stride)", fontsize=11)
    png = save_figure(fig, out_dir / "table1_sankey.png",
                      shows=f"simulation of the bench: AnkleActuator ({BENCH}), preset {HEADLINE}")
    flows = []
    for name, e in (("simulation", r.energy), ("paper", paper_e)):
        for (a, b), (_, lname) in zip(zip(POINTS, POINTS[1:]), loss_names):
            flows.append(dict(source=name, preset=HEADLINE if name == "simulation" else "published", from_point=a,
                              to_point=b, passed_on_J=e[b], loss_name=lname.split("\n")[0],
                              loss_J=e[a] - e[b]))
    sankey_csv = write_csv(out_dir / "table1_sankey.csv", flows)

    comps = [comparison(f"Table 1 energy at {LABELS[k]}", r.energy[k], paper_e[k], "J", WHY_ENERGY[k])
             for k in POINTS]
    comps += [comparison(f"Table 1 efficiency up to {LABELS[k]}", eff[k], paper_eff[k], "%", WHY_ENERGY[k])
              for k in POINTS[1:]]
    notes = {"motor": f"The motor's own loss in joules matches ({motor_abs:.1f} vs {paper_motor_abs:.1f} J); the "
                      "fraction is higher because less energy flows on through the gears than measured.",
             "driver": "The absolute driver loss is "
                       f"{r.stage_loss['driver']:.1f} vs {paper_e['source'] - paper_e['driver']:.1f} J, "
                       "on a smaller driver output."}
    comps += [comparison(f"Table 1 {n.splitlines()[0]} (vs previous point)", loss[k], paper_loss[k], "%",
                         WHY_LOSS[k], note=notes.get(k, "")) for k, n in loss_names]
    return dict(title="Table 1: energy chain at 8 mm, 2 s/stride", figures=[png], csv=[csv_path, sankey_csv],
                markdown=md, comparisons=comps, result=r)


if __name__ == "__main__":
    out = main(Path("results"))
    print(out["markdown"])
