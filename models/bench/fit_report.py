"""What a calibration writes: fitted values with uncertainty, the paper's Table 2 with a calibrated column, RMSE per
signal and recording (training and held-out strides), and Fig. 14 (measured vs simulated motor current before and
after calibration). Used by ``acausal fit``, ``acausal paper`` and ``examples/fig14_calibration.py``."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .calibration import START, rmse_before_after, table2  # noqa: E402
from ..reporting.tables import md_table, write_csv  # noqa: E402
from ..reporting.figures import save_figure  # noqa: E402


def _rows(cal, tag: dict) -> tuple:
    """The rows of ``calibration.csv``, ``calibration_rmse.csv`` and ``table2_calibrated.csv`` of one calibration,
    each led by ``tag``."""
    values = [dict(tag, parameter=n, start=cal.start[n], value=cal.values[n], std_error=cal.std[n],
                   relative_std=cal.std[n] / abs(cal.values[n]) if cal.values[n] else np.inf) for n in cal.names]
    rmse = [dict(tag, recording=e, signal=s, rmse_train=cal.rmse_train[(e, s)],
                 rmse_heldout=cal.rmse_test.get((e, s), np.nan)) for (e, s) in cal.rmse_train]
    t2 = [dict(tag, parameter=a, unit=b, motor_datasheet=c, estimated_total=d, calibrated=e, std_error=f)
          for a, b, c, d, e, f in table2(cal)]
    return values, rmse, t2


def fit_outputs(out_dir, cal, exps, data_label: str, figure_recording: str | None = None,
                preset: str | None = None, others: dict | None = None, draw: bool = True) -> dict:
    """Write ``calibration.csv``, ``calibration_rmse.csv``, ``table2_calibrated.csv`` and ``fig14_calibration.png``
    (+ its CSV) into ``out_dir``; returns the example-output dictionary (title, figures, csv, markdown).
    ``draw=False``: the figure's CSV only (a caller that draws its own Fig. 14).
    ``preset``: the preset of the recordings' truth (a virtual bench of the component chain), written as a first
    column of every row. ``others``: further calibrations by the preset of their recordings' truth, whose rows
    follow in the three tables (the figure and the report's tables show the first)."""
    if others and preset is None:
        raise ValueError("fit_outputs: calibrations beside the first (others) need the first's preset, so that every "
                         "row says which recordings it comes from")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    tag = {} if preset is None else {"preset": preset}
    rows, rm, t2_rows = _rows(cal, tag)
    for name, other in (others or {}).items():
        for table, more in zip((rows, rm, t2_rows), _rows(other, {"preset": name})):
            table.extend(more)
    values_csv = write_csv(out / "calibration.csv", rows)
    rmse_csv = write_csv(out / "calibration_rmse.csv", rm)
    t2 = table2(cal)
    t2_csv = write_csv(out / "table2_calibrated.csv", t2_rows)
    ba = rmse_before_after(exps, cal, cal.signals)
    fig_png, fig_csv = _fig14(out, cal, exps, figure_recording, tag, draw)

    md = [f"Data: {data_label}. {len(exps)} recordings; every third stride held out; fitted on "
          f"{', '.join(cal.signals)} (noise-scaled, robust soft-L1 loss); {cal.nfev} model evaluations; "
          f"{'converged' if cal.success else 'NOT converged: ' + cal.message}.", "",
          md_table(["parameter", "start (datasheet)", "calibrated", "std. error", "rel."],
                   [[f"`{r['parameter']}`", f"{r['start']:.4g}", f"{r['value']:.4g}", f"{r['std_error']:.2g}",
                     f"{100 * r['relative_std']:.2g} %"] for r in rows[:len(cal.names)]]),
          "", "Table 2 of the paper with the calibrated column (Eq. 4, motor-side coefficients):", "",
          md_table(["parameter", "unit", "motor datasheet", "estimated total", "calibrated", "std. error"],
                   [[a, b, f"{c:.3g}", f"{d:.3g}", "-" if not np.isfinite(e) else f"{e:.3g}",
                     "-" if not np.isfinite(f) else f"{f:.2g}"] for a, b, c, d, e, f in t2]),
          "", "Held-out RMSE (all recordings pooled):", "",
          md_table(["signal", "datasheet values", "calibrated"],
                   [[s, f"{ba['datasheet'][s]:.4g}", f"{ba['calibrated'][s]:.4g}"] for s in cal.signals]),
          "", f"Standard errors: {cal.std_method} ({cal.clusters} clusters). They say how well the data pins "
          "each parameter within this model, not what the model misses (see `acausal diagnose`)."]
    for name, other in (others or {}).items():
        md += ["", f"The same calibration on recordings of the `{name}` chain (rows `preset` = {name} in the "
               "tables): " + ", ".join(f"`{n}` = {other.values[n]:.4g}" for n in other.names) + "."]
    return dict(title="Calibration (paper section 4.3, Table 2, Fig. 14)", figures=[fig_png] if fig_png else [],
                csv=[values_csv, rmse_csv, t2_csv, fig_csv], markdown="\n".join(md), comparisons=[],
                before_after=ba)


def figure_recording_of(exps, name: str | None = None):
    """The experiment Fig. 14 shows: the one called ``name``, else the longest stride time's."""
    return next((x for x in exps if x.name == name), None) or max(exps, key=lambda x: x.info["meta"]["stride_time_s"])


def _fig14(out: Path, cal, exps, name, tag: dict, draw: bool = True):
    e = figure_recording_of(exps, name)
    before = e.predict({n: START[n] for n in cal.names if n in START})["motor_current_A"]
    after = e.predict(cal.values)["motor_current_A"]
    meas = e.measured["motor_current_A"]
    T = e.info["meta"]["stride_time_s"]
    show = e.t <= e.t[0] + 2 * T
    csv = write_csv(out / "fig14_calibration.csv", [dict(tag, time_s=a, measured_A=b, before_A=c, after_A=d)
                                                    for a, b, c, d in zip(e.t[show], meas[show], before[show],
                                                                          after[show])])
    if not draw:
        return None, csv
    fig, axes = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    for ax, sim, label in ((axes[0], before, "before calibration (motor datasheet)"),
                           (axes[1], after, "after calibration")):
        ax.plot(e.t[show], meas[show], color="0.6", lw=0.6, label="measured")
        ax.plot(e.t[show], sim[show], color="C3" if ax is axes[0] else "C0", lw=1.2, label="simulated")
        rm = float(np.sqrt(np.mean((sim - meas)[e.test] ** 2)))
        ax.set_title(f"{label}: held-out RMSE {rm:.3g} A", fontsize=10)
        ax.set_ylabel("motor current [A]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="upper right")
    axes[1].set_xlabel(f"time [s] (recording {e.name}, first two strides)")
    png = save_figure(fig, out / "fig14_calibration.png",
                      shows="model: AnkleActuator.eq4 (replay of the recordings"
                            + (f" of the {tag['preset']} chain" if tag else "") + "), datasheet start vs calibrated")
    return png, csv
