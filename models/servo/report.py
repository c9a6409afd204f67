"""What the servo diagnosis writes: ``report.md`` (verdict, held-out score beside BAM's, what the baseline gets
wrong over time, per recording and per phase, the candidates, the extended model's parameters with uncertainty,
BAM's published parameters replayed, what the data cannot show), CSV tables and figures."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from acausal.identify.diagnose import residual_analysis  # noqa: E402

from ..reporting.evidence import (confusable_lines, detection_lines, drift_lines, screening_lines,  # noqa: E402
                                  warning_lines)
from ..reporting.tables import md_table, write_csv, write_verdict as write_json  # noqa: E402
from .bam import MAPPING, published  # noqa: E402
from .recording_format import POSITION  # noqa: E402

#: speed of the goal [rad/s] below which a sample counts as "holding" (the goal still)
HOLD_SPEED = 0.05

#: the model's parameter -> BAM's name (:data:`.bam.MAPPING` turned round)
BAM_NAMES = {ours: theirs for theirs, ours in MAPPING.items()}


def phases(exp) -> dict:
    """Masks of the phases of a recording: torque off, holding (goal still), moving."""
    rec_t = exp.t
    enable = np.asarray(exp.info["inputs"]["enable.signal"](rec_t)) > 0.5
    goal_speed = np.abs(np.asarray(exp.info["inputs"]["goal.signal"](rec_t, 1)))
    return {"moving": enable & (goal_speed >= HOLD_SPEED), "holding": enable & (goal_speed < HOLD_SPEED),
            "torque off": ~enable}


def per_recording(d) -> list:
    """One row per recording: trajectory, kp, role, baseline and extended MAE (all samples and per phase)."""
    base = {e.name: e.predict(d.baseline.values)[POSITION] for e in d.baseline.exps}
    ext = {e.name: e.predict(d.final.values)[POSITION] for e in d.final.exps}
    rows = []
    for e in d.baseline.exps:
        m = e.measured[POSITION]
        row = {"recording": e.name, "trajectory": e.info["meta"].get("trajectory_name", ""),
               "kp": e.info["meta"]["kp"], "role": "held out" if e.test.any() else "fitted",
               "mae_baseline": float(np.mean(np.abs(base[e.name] - m))),
               "mae_extended": float(np.mean(np.abs(ext[e.name] - m)))}
        for ph, mask in phases(e).items():
            key = ph.replace(" ", "_")
            row[f"mae_baseline_{key}"] = float(np.mean(np.abs(base[e.name] - m)[mask])) if mask.any() else np.nan
            row[f"mae_extended_{key}"] = float(np.mean(np.abs(ext[e.name] - m)[mask])) if mask.any() else np.nan
        rows.append(row)
    return rows


def _phase_rows(rows) -> list:
    out = []
    for ph in ("moving", "holding", "torque off"):
        key = ph.replace(" ", "_")
        b, e = _mean(rows, f"mae_baseline_{key}"), _mean(rows, f"mae_extended_{key}")
        out.append([ph, f"{b:.4f}", f"{e:.4f}", f"{100 * (e / b - 1):+.0f} %"])
    return out


def _mean(rows, key, where=lambda r: True):
    vals = [r[key] for r in rows if where(r) and np.isfinite(r[key])]
    return float(np.mean(vals)) if vals else float("nan")


def write_report(out_dir, d, problem, data_label: str, bam_rows=None, elapsed: float | None = None) -> dict:
    """Write ``report.md``, ``servo_recordings.csv``, ``servo_candidates.csv`` (and ``servo_bam_replay.csv``)
    and the figures into ``out_dir``; returns the example-output dictionary."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ho = d.heldout()
    rows = per_recording(d)
    pub = published()
    fin = d.final
    ext_label = " + ".join(["Coulomb + viscous"] + list(d.causes))
    gain = 1 - ho["extended"] / ho["baseline"] if ho["baseline"] else float("nan")
    md = [f"Data: {data_label}: {len(rows)} recordings; {ho['split']}. The model replays each recording in closed "
          "loop (the firmware's P law on the simulated position, the logged goal, supply voltage and torque "
          "enable) from the first measured position; the score is the mean absolute error of the simulated "
          "position (rad) on the held-out recordings, BAM's metric. Residuals are fitted in units of the position "
          f"reading's quantisation noise ({d.scales[POSITION]:.3g} rad: one step of {problem.step:.4g} rad over "
          "sqrt(12), measured from the data)." + (f" Run time {elapsed:.0f} s." if elapsed else ""), "",
          f"**Verdict: `{d.cause}`**" + (f" (in order: {', '.join(f'`{c}`' for c in d.causes)})"
                                          if len(d.causes) > 1 else ""), "", *warning_lines(d),
          *screening_lines(d),
          md_table(["model", "held-out MAE [rad]", "vs baseline"],
                   [["baseline: Coulomb + viscous (BAM M1's law), calibrated here", f"{ho['baseline']:.4f}", ""],
                    [f"extended: {ext_label}, calibrated here", f"{ho['extended']:.4f}", f"{-100 * gain:+.1f} %"]]),
          ""]
    # ---------------------------------------------------------------- what the baseline gets wrong
    by_traj = sorted({r["trajectory"] for r in rows})
    md += ["## 1. What the calibrated baseline gets wrong", "",
           "Per trajectory and gain (MAE over each recording, rad; held-out recordings marked *):", "",
           md_table(["trajectory"] + [f"kp {kp:g}" for kp in sorted({r['kp'] for r in rows})],
                    [[t] + [" / ".join(f"{r['mae_baseline']:.3f} -> {r['mae_extended']:.3f}"
                                       + ("*" if r["role"] == "held out" else "")
                                       for r in rows if r["trajectory"] == t and r["kp"] == kp)
                            for kp in sorted({r['kp'] for r in rows})] for t in by_traj]), "",
           "Per phase (mean over recordings of the MAE within the phase; holding: goal speed below "
           f"{HOLD_SPEED} rad/s; torque off: the servo let go):", "",
           md_table(["phase", "baseline", "extended", "change"], _phase_rows(rows)), ""]
    before = residual_analysis(problem, d.baseline)
    corr = before[POSITION]["correlations"][:4]
    if corr:
        md += ["Residual of the baseline against the replay's physical quantities (strongest first; * = "
               "significant): " + "; ".join(f"{c.name} {c.r:+.2f}{'*' if c.significant else ''}" for c in corr)
               + ".", ""]
    fig_time = _time_figure(out / "servo_residual_time.png", d)
    fig_traj = _trajectory_figure(out / "servo_heldout.png", d)
    md += [f"![residual over time]({fig_time.name})", "", f"![held-out recordings]({fig_traj.name})", ""]
    # ---------------------------------------------------------------- candidates
    th = d.thresholds
    md += ["## 2. Candidates across the chain (friction, firmware, electrics, sensing) added to the calibrated "
           "baseline, everything refitted", "",
           "The library: " + "; ".join(f"`{e.id}` ({e.slot}: {e.doc.split(' (')[0]})"
                                       for e in problem.effects.values()) + ".", "",
           f"A candidate counts when its held-out RMSE gain and its leave-one-segment-out RMSE gain (segments of "
           f"{problem.split.segment:g} s of the fitted recordings) are at least {100 * th.min_gain:.0f} %, its "
           f"per-segment improvements are consistent (paired t at least {th.min_t:g}, or a sign test with p at most "
           f"{th.max_sign_p:g}) and its BIC falls by at least {-th.max_delta_bic:g}.", ""]
    for k, st in enumerate(d.steps):
        if k:
            md += [f"Step {k + 1}: on top of {', '.join(f'`{e}`' for e in st.before.effects)}", ""]
        md += [md_table(["candidate", "parameter", "fitted", "held-out RMSE gain", "leave-one-out gain", "paired t",
                         "sign test p", "delta BIC", "significant"],
                        [[f"`{s.id}`", f"`{s.parameter}`",
                          s.refit_note(problem.max_refits) if s.screened else f"{s.value:.4g} ± {s.std:.2g}",
                          f"{100 * s.heldout_rmse_gain:+.1f} %" + (" (lin.)" if s.screened else ""),
                          "" if s.screened else f"{100 * s.loso_rmse_gain:+.1f} %",
                          "" if s.screened or not np.isfinite(s.t_stat) else f"{s.t_stat:.1f}",
                          "" if s.screened or not np.isfinite(s.sign_p) else f"{s.sign_p:.2g}",
                          f"{s.delta_bic:.4g}" + (" (lin.)" if s.screened else ""),
                          "**yes**" if s.significant else "no"] for s in st.scores]), "",
               "(lin.): not refitted; the gain and BIC the linearised (Gauss-Newton) step predicts on the fitted "
               "recordings, not a held-out score.", "",
               f"Chosen: `{st.chosen}`." if st.chosen else "Nothing significant: the selection stops here.", ""]
    if d.left_out:
        md += [f"The limit on the number of effects stopped the search: {', '.join(f'`{c}`' for c in d.left_out)} "
               "scored significant in the last step and was not named.", ""]
    md += confusable_lines(d)
    md += detection_lines(d)
    md += drift_lines(d)
    # ---------------------------------------------------------------- parameters
    bam_sets = {lab: pub["sets"][lab] for lab in ("main m1", "main m3") if lab in pub["sets"]}
    md += ["## 3. Parameters (output side) with standard errors", "",
           md_table(["parameter", "baseline", "extended", "std. error", *[f"BAM {lab} (published)" for lab in bam_sets]],
                    [[f"`{n}`", f"{d.baseline.values[n]:.4g}" if n in d.baseline.values else "-",
                      f"{fin.values[n]:.4g}", f"{fin.cal.std[n]:.2g}",
                      *[f"{s[BAM_NAMES[n]]:.4g}" if BAM_NAMES.get(n) in s else "-" for s in bam_sets.values()]]
                     for n in fin.cal.names]), "",
           f"Standard errors: {fin.cal.std_method} ({fin.cal.clusters} recordings): a closed-loop replay's "
           "residuals are correlated over a whole recording, so each recording counts once (the held-out scores "
           "say what transfers). BAM's M3 "
           "multiplies |tau_external - tau_motor|, this model |tau_motor| (see `acausal.models.servo.bam`).", ""]
    # ---------------------------------------------------------------- BAM
    csvs = []
    if bam_rows:
        trajs = [k for k in bam_rows[0] if k not in ("set", "mae", "mae_bam_simulator")]
        ours = [[f"this model, {lab}", f"{_mean(rows, key):.4f}", "-",
                 *[f"{_mean(rows, key, lambda r, t=t: r['trajectory'] == t):.4f}" for t in trajs]]
                for lab, key in (("baseline (calibrated)", "mae_baseline"), (f"extended: {ext_label}", "mae_extended"))]
        md += ["## 4. Next to BAM's published models", "",
               "MAE [rad] over all recordings (fitted and held out alike, as the data set's README scores BAM's "
               "sets); BAM's published parameter sets replayed on this model, beside what BAM's own simulator gives "
               "with them (the data set's README):", "",
               md_table(["parameters", "all (this model)", "all (BAM's simulator)", *trajs],
                        [[r["set"], f"{r['mae']:.4f}",
                          f"{r['mae_bam_simulator']:.4f}" if r["mae_bam_simulator"] is not None else "-",
                          *[f"{r[t]:.4f}" for t in trajs]] for r in bam_rows] + ours), "",
               "BAM's scores on its own full XL330 data set (branch 4traj_xl330, not these logs): "
               + ", ".join(f"{k} {v:.4f}" for k, v in pub["bam_branch_base_mae_rad"].items() if k != "source")
               + " rad. Those logs cannot be reached here.", ""]
        csvs.append(write_csv(out / "servo_bam_replay.csv", bam_rows))
    # ---------------------------------------------------------------- limits
    worse = [r for r in rows if r["mae_extended"] > 1.05 * r["mae_baseline"]]
    if worse:
        md.insert(md.index("## 1. What the calibrated baseline gets wrong") + 2,
                  "Recordings the extended model fits worse than the baseline (by more than 5 %): " + "; ".join(
                      f"{r['trajectory']} kp {r['kp']:g} ({r['mae_baseline']:.3f} -> {r['mae_extended']:.3f} rad)"
                      for r in worse) + ".\n")
    md += ["## 5. What these data cannot show", "",
           *[f"- {line}" for line in _correlated(fin)],
           *[f"- {line}" for line in _loader_notes(problem)],
           "- There is no current or torque measurement: kt and R are seen only through the motion, and the "
           "friction law only through the position error it causes. A firmware gain off its declared value "
           "(`gain_error`) is the same motion as other kt and R until the duty saturates.",
           "- One mass at one arm length: load-dependent friction and inertia or gravity scale together, so a "
           "load law cannot be told from a wrong inertia by varying the load.",
           "- The winding warms during the session (the logged temperature rises from "
           f"{_temperature_range(problem)}); resistance is fitted as one constant.",
           "- Positions are quantised to one encoder step; errors below it are not resolved.", ""]
    csvs.append(write_csv(out / "servo_recordings.csv", rows))
    csvs.append(write_csv(out / "servo_candidates.csv", [
        dict(step=k + 1, candidate=s.id, parameter=s.parameter, value=s.value, std=s.std,
             heldout_rmse_gain=s.heldout_rmse_gain, loso_rmse_gain=s.loso_rmse_gain, t_stat=s.t_stat,
             delta_bic=s.delta_bic, significant=s.significant) for k, st in enumerate(d.steps) for s in st.scores]))
    title = "Real data: a servo on a pendulum, calibrated and diagnosed"
    (out / "report.md").write_text(f"# {title}\n\n" + "\n".join(md) + "\n")
    return {"title": title, "markdown": "\n".join(md), "figures": [fig_time, fig_traj], "csv": csvs,
            "heldout": ho, "causes": list(d.causes), "rows": rows}


def _correlated(fit, limit: float = 0.9) -> list:
    """Sentences naming the parameter pairs whose estimates are correlated beyond ``limit`` (from the fit's
    covariance): directions the data barely constrain."""
    names, cov = fit.cal.names, fit.cal.cov
    sd = np.sqrt(np.clip(np.diag(cov), 1e-300, None))
    out = []
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            with np.errstate(over="ignore", invalid="ignore"):  # a parameter the data leave undetermined
                r = cov[i, j] / (sd[i] * sd[j])
            if np.isfinite(r) and abs(r) >= limit:
                out.append(f"`{names[i]}` and `{names[j]}` are estimated together (correlation {r:+.2f}): the data "
                           "constrain a combination of them better than either.")
    return out


def _loader_notes(problem) -> list:
    """What the loader ignored or assumed, once per key over all recordings."""
    ignored, null = set(), set()
    for r in problem.recordings:
        for n in r.notes:
            key = n.split("key '", 1)[1].split("'", 1)[0] if "key '" in n else n
            (null if "is null" in n else ignored).add(key)
    out = []
    if null:
        out.append("Not recorded (null in the JSON, taken as 0 as BAM does): " + ", ".join(f"`{k}`" for k in sorted(null))
                   + ".")
    if ignored:
        out.append("JSON keys the model does not use (provenance and notes; ignored): "
                   + ", ".join(f"`{k}`" for k in sorted(ignored)) + ".")
    return out


def _temperature_range(problem) -> str:
    temps = [r.extra["temperature_C"] for r in problem.recordings if "temperature_C" in r.extra]
    if not temps:
        return "(not logged)"
    return f"{min(t.min() for t in temps):.0f} to {max(t.max() for t in temps):.0f} °C"


def _time_figure(path, d):
    exps = d.baseline.exps
    n = len(exps)
    cols = 4
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.0 * cols, 1.8 * rows), sharex=True, sharey=True, squeeze=False)
    for ax, e, ef in zip(axes.flat, exps, d.final.exps):
        m = e.measured[POSITION]
        ax.plot(e.t, m - e.predict(d.baseline.values)[POSITION], color="C3", lw=0.8, label="baseline")
        if d.causes:
            ax.plot(ef.t, m - ef.predict(d.final.values)[POSITION], color="C0", lw=0.8, label="extended")
        ax.axhline(0, color="k", lw=0.4)
        meta = e.info["meta"]
        ax.set_title(f"{meta.get('trajectory_name', e.name)} kp {meta['kp']:g}" + (" (held out)" if e.test.any() else ""),
                     fontsize=7)
    for ax in axes.flat[n:]:
        ax.axis("off")
    axes[0, 0].legend(fontsize=6)
    for ax in axes[:, 0]:
        ax.set_ylabel("measured - sim.\n[rad]", fontsize=7)
    for ax in axes[-1, :]:
        ax.set_xlabel("time [s]", fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return Path(path)


def _trajectory_figure(path, d):
    held = [(e, ef) for e, ef in zip(d.baseline.exps, d.final.exps) if e.test.any()]
    fig, axes = plt.subplots(len(held), 1, figsize=(7, 1.9 * len(held)), sharex=True, squeeze=False)
    for ax, (e, ef) in zip(axes[:, 0], held):
        ax.plot(e.t, e.info["inputs"]["goal.signal"](e.t), color="0.6", lw=0.8, label="goal")
        ax.plot(e.t, e.measured[POSITION], color="k", lw=1.0, label="measured")
        ax.plot(e.t, e.predict(d.baseline.values)[POSITION], color="C3", lw=0.9, label="baseline")
        if d.causes:
            ax.plot(ef.t, ef.predict(d.final.values)[POSITION], color="C0", lw=0.9, label="extended")
        meta = e.info["meta"]
        ax.set_title(f"held out: {meta.get('trajectory_name', e.name)}, kp {meta['kp']:g}", fontsize=8)
        ax.set_ylabel("position [rad]", fontsize=7)
    axes[0, 0].legend(fontsize=6, ncol=4)
    axes[-1, 0].set_xlabel("time [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return Path(path)


__all__ = ["write_report", "write_json", "per_recording", "phases"]
