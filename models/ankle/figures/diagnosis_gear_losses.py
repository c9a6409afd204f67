"""The paper's own story, diagnosed: gear mesh losses the Eq. (4) model leaves out, and what calibration does with them.

The paper calibrated Eq. (4) (DC motor R, L, k, J, b behind an ideal gear) on its bench and found R inflated from
0.7 to 2 ohm and J from 1.6e-5 to 3.5e-3 kg m2 (Table 2): lumped parameters soaking up what the model lacks. Here
the virtual bench records the paper's protocol on a truth that has a load-dependent gear mesh efficiency (the
gearhead catalogue's 70 %, :mod:`acausal.models.ankle.effects`), with realistic sensors. ``acausal diagnose``'s engine
then

1. calibrates the baseline (R, J, b) and shows how they compensate for the missing loss;
2. names the cause (``gear_load_dependent_loss``) among all candidates, with its fitted efficiency;
3. extends the model with the library's LossyGear and shows where R, J, b land.

Writes ``diagnosis_gear_losses.csv`` (parameters: truth, baseline, extended, paper), and in
``diagnosis_gear_losses/`` the full diagnosis report with its figures. Run:
``python -m acausal.models.ankle.figures.diagnosis_gear_losses`` (into ``results/``).
"""
from __future__ import annotations

from pathlib import Path

from acausal.models.bench import diagnosis
from acausal.models.bench.virtual import TRUTH, BenchCondition, run_bench
from acausal.models.bench.diagnosis_report import write_json, write_report
from acausal.models.ankle.presets import PRESETS
from acausal.models.reporting.tables import md_table, write_csv

#: the hidden loss: the catalogue's mesh efficiency of the two-stage gearhead
ETA = 0.7
CONDITIONS = [BenchCondition(P, T, strides=3) for P in (0.005, 0.011) for T in (1.2, 2.0)]


def main(out_dir: Path, results=None, seed: int = 7, executor=None) -> dict:
    out_dir = Path(out_dir)
    data = out_dir / "diagnosis_gear_losses" / "bench_data"
    run_bench(data, CONDITIONS, {"gear_load_dependent_loss": ETA}, seed=seed, executor=executor)
    d, problem = diagnosis.run(data)
    sub = write_report(out_dir / "diagnosis_gear_losses", d, problem,
                       f"**virtual-bench recordings (simulated)** with a hidden mesh efficiency of {ETA:.0%}")
    write_json(out_dir / "diagnosis_gear_losses" / "diagnosis.json", d)
    truth = {**TRUTH, "gear.eta": ETA}
    paper_opt = PRESETS["paper_optimized_total_as_printed"]
    rows = []
    for name in ("motor.R", "motor.J", "motor.b", "gear.eta"):
        rows.append(dict(parameter=name, truth=truth[name], baseline=d.baseline.values.get(name, float("nan")),
                         extended=d.final.values.get(name, float("nan")),
                         extended_std=d.final.cal.std.get(name, float("nan")),
                         paper_table2_optimized=paper_opt.get(name, float("nan"))))
    csv = write_csv(out_dir / "diagnosis_gear_losses.csv", rows)
    gain = {s: 1 - d.final.test_rmse[s] / d.baseline.test_rmse[s] for s in d.baseline.test_rmse}

    def ratio(name):
        return f"{d.baseline.values[name] / TRUTH[name]:.2f} times"

    md = [f"Virtual-bench recordings (simulated; {len(CONDITIONS)} conditions, 3 strides each, seed {seed}) of a truth "
          f"whose gear has a mesh efficiency of {ETA:.0%}; the Eq. (4) baseline has an ideal gear.", "",
          md_table(["parameter", "truth", "baseline calibrated (Eq. 4)", "extended model", "paper Table 2 (optimized)"],
                   [[f"`{r['parameter']}`", f"{r['truth']:.4g}", f"{r['baseline']:.4g}",
                     f"{r['extended']:.4g} ± {r['extended_std']:.2g}", f"{r['paper_table2_optimized']:.4g}"]
                    for r in rows]), "",
          f"Verdict: **`{d.cause}`**" + (f" (then {', '.join(d.causes[1:])})" if len(d.causes) > 1 else "")
          + ". Held-out RMSE after extending: "
          + ", ".join(f"{s} {100 * g:+.0f} %" for s, g in gain.items()) + ".", "",
          f"The baseline's R comes out {ratio('motor.R')} the truth: with an ideal gear the only way to draw the "
          "extra supply power the mesh burns is a larger winding resistance, as in the paper's 0.7 -> 2 ohm. "
          f"b comes out {ratio('motor.b')} and J {ratio('motor.J')} the truth: the part of the loss that shows "
          "in the motor current grows with the transmitted torque, which a viscous term only partly mimics. A "
          "mesh loss does not inflate J by orders of magnitude, so the paper's J of 3.5e-3 kg m2 needs another "
          "explanation (see the two readings of Table 2 in `acausal.models.ankle.presets`). Once the LossyGear is in "
          "the model, R, J and b return to the truth and the efficiency is recovered. Full report: "
          "`diagnosis_gear_losses/report.md`."]
    return {"title": "Diagnosis: the gear losses Eq. (4) leaves out (the paper's Table 2 story)",
            "figures": sub["figures"], "csv": [csv] + sub["csv"], "markdown": "\n".join(md),
            "diagnosis": d}


if __name__ == "__main__":
    print(main(Path("results"))["markdown"])
