"""Calibration of the Eq. (4) model against bench recordings: Table 2 with a calibrated column and Fig. 14
(measured vs simulated motor current before and after calibration).

The paper's bench recordings are not public, so by default this records a small virtual-bench set first
(``acausal.models.bench``: the paper's protocol in closed loop with realistic sensors) into ``OUT/bench_data/`` and
calibrates R, J, b on it; the report labels the data as simulated. The bench's truth is the whole component chain
with the ``paper_fit`` preset (``chain``: supply, rectifier, EPOS2 driver, motor, lossy gears, frictional MACCEPA),
the model's best stand-in for the paper's actuator, so that the calibration does what the paper's did: fit Eq. (4)'s
ideal gear and driver to an actuator that has their losses (claim C13, Table 2's R 0.7 -> 2 ohm); ``chain=None``
records the Eq. (4) truth itself instead (the calibration then recovers it). The same is done on recordings of the
chain with each preset of ``beside`` (default the a-priori ``library``), whose rows follow in the tables (C13 of
each preset). With ``data=FOLDER`` it calibrates on recordings in that folder instead (the format of
``acausal.models.bench.recording_format``).

Writes ``calibration.csv``, ``calibration_rmse.csv``, ``table2_calibrated.csv``, ``fig14_calibration.png`` (+ CSV),
each row with the preset of the recordings' truth (``preset``) when they come from a virtual bench of the chain.
On virtual-bench recordings the figure is drawn here (:func:`draw`; ``fit_outputs`` writes its CSV only), so that its
legend calls the recording what it is (a simulated recording, not a measurement) and marks the peaks the caption
compares; the CSV's column ``measured_A`` keeps ``fit_outputs``'s name (for virtual data: the recorded current).
Run: ``python -m acausal.models.ankle.figures.fig14_calibration`` (into ``results/``).
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from acausal.models.bench import calibration  # noqa: E402
from acausal.models.bench.virtual import BenchCondition, run_bench, truth_body_mass  # noqa: E402
from acausal.models.bench.fit_report import figure_recording_of, fit_outputs  # noqa: E402
from acausal.models.ankle.figures.trends import verdict  # noqa: E402
from acausal.models.reporting.figures import save_figure  # noqa: E402
from acausal.models.reporting.tables import write_columns  # noqa: E402

#: the legend's name of a virtual-bench recording
VIRTUAL = "virtual bench recording (simulated)"
#: the extension calibrated beside Eq. 4's R, J, b: a mesh efficiency below 1 (models/ankle/effects.py)
MESH_EFFECT, MESH_PARAMS = "gear_load_dependent_loss", "R,J,b,gear.eta"
#: how close the calibrated current's peak has to come to the recording's to fit it ("a good fit", 4.3-4.4)
PEAK_TOLERANCE = 0.15

#: the on-the-fly bench set: 2 precompressions x 4 stride times, 3 recorded strides each
PRECOMPRESSIONS, STRIDE_TIMES = (0.005, 0.015), (1.2, 1.5, 2.0, 3.0)
#: the truth of the on-the-fly recordings: the component chain with this preset (None: Eq. 4), and the presets whose
#: chains are calibrated beside it
CHAIN, BESIDE = "paper_fit", ("library",)


def conditions(chain: str | None = CHAIN) -> list:
    """The on-the-fly bench set, for the body mass of the truth (the chain's preset's, else the default)."""
    mass = truth_body_mass(chain)
    return [BenchCondition(P, T, strides=3, body_mass=mass) for P in PRECOMPRESSIONS for T in STRIDE_TIMES]


def main(out_dir: Path, results=None, data=None, seed: int = 2014, executor=None, chain: str | None = CHAIN,
         beside=BESIDE) -> dict:
    out_dir = Path(out_dir)
    others = {}
    if data is None:
        for name in beside if chain else ():
            folder = out_dir / f"bench_data_{name}"
            run_bench(folder, conditions(name), seed=seed, executor=executor, chain=name)
            others[name] = calibration.fit(folder, "R,J,b")[0]
        data = out_dir / "bench_data"
        run_bench(data, conditions(chain), seed=seed, executor=executor, chain=chain)
        truth = (f"the component chain with preset `{chain}` (driver, gear and linkage losses included)" if chain else
                 "Eq. 4 with R = 0.7 ohm, J = 4.07e-6 kg m2, b = 7e-6 N m s/rad")
        label = (f"**virtual-bench recordings (simulated, not measured)**, generated on the fly into `{data.name}/` "
                 f"(seed {seed}; truth: {truth}; see its README.md)")
    else:
        label, chain = f"recordings in `{data}`", None
    cal, exps = calibration.fit(data, "R,J,b")
    out = fit_outputs(out_dir, cal, exps, label, preset=chain, others=others, draw=not chain)
    out["calibrated"] = dict(cal.values)
    if chain:  # virtual-bench recordings: the figure says so, the caption compares the fit with the paper's
        mesh = calibration.fit(data, MESH_PARAMS, effects=(MESH_EFFECT,))
        fig = draw(out_dir, cal, exps, chain, mesh)
        fig["R_after"] = float(cal.values["motor.R"])
        out["figures"] = [fig["png"]]
        out["csv"] = [*out["csv"], fig["csv"]]
        out["fig14"] = fig
        out["markdown"] += "\n\n" + caption(fig, chain)
    return out


def draw(out_dir: Path, cal, exps, chain: str, mesh=None) -> dict:
    """Fig. 14 on virtual-bench recordings of the ``chain`` preset: the recorded motor current against Eq. 4's before
    (datasheet) and after calibration of R, J, b, and, with ``mesh`` (the ``(Calibration, experiments)`` of
    :data:`MESH_PARAMS`), after calibration with a mesh efficiency; first two strides of the recording
    ``figure_recording_of`` picks, each panel's peaks in its legend. Writes ``fig14_mesh_efficiency.csv`` (the curves of every panel) and returns the
    paths and the numbers the caption reads (peaks, held-out RMSE, the mesh calibration's values)."""
    e = figure_recording_of(exps)
    rec = e.measured["motor_current_A"]
    T = e.info["meta"]["stride_time_s"]
    show = e.t <= e.t[0] + 2 * T
    panels = [("before", "before calibration (motor datasheet)", "C3",
               e.predict({n: calibration.START[n] for n in cal.names if n in calibration.START})["motor_current_A"]),
              ("after", "after calibration of R, J, b (the paper's)", "C0", e.predict(cal.values)["motor_current_A"])]
    if mesh is not None:
        m_cal, m_exps = mesh
        m = next(x for x in m_exps if x.name == e.name)
        panels.append(("mesh", "after calibration of R, J, b and a mesh efficiency (gear.eta = "
                       f"{m_cal.values['gear.eta']:.2f})", "C2", m.predict(m_cal.values)["motor_current_A"]))
    fig, axes = plt.subplots(len(panels), 1, figsize=(9, 2.9 * len(panels) + 0.6), sharex=True)
    rm = {}
    for ax, (key, label, colour, sim) in zip(axes, panels):
        rm[key] = float(np.sqrt(np.mean((sim - rec)[e.test] ** 2)))
        ax.plot(e.t[show], rec[show], color="0.6", lw=0.6, label=f"{VIRTUAL}, peak {np.max(rec[show]):.1f} A")
        model = "Eq. 4 with a mesh efficiency" if key == "mesh" else "Eq. 4"
        ax.plot(e.t[show], sim[show], color=colour, lw=1.2, label=f"{model}, simulated, peak {np.max(sim[show]):.1f} A")
        ax.set_title(f"{label}: held-out RMSE {rm[key]:.3g} A", fontsize=10)
        ax.set_ylabel("motor current [A]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="upper right")
    axes[-1].set_xlabel(f"time [s] (virtual-bench recording {e.name}, first two strides)")
    fig.suptitle(f"Fig. 14: Eq. 4 against a virtual-bench recording of the {chain} chain (simulated, not measured)",
                 fontsize=10)
    png = save_figure(fig, Path(out_dir) / "fig14_calibration.png",
                      shows=f"model: AnkleActuator.eq4, replay of virtual-bench recordings of the {chain} chain; "
                            "datasheet start vs calibrated")
    consts = {"preset": chain, "recording": e.name}
    if mesh is not None:
        consts.update({f"mesh_fit_{n}": v for n, v in mesh[0].values.items()})
    path = write_columns(Path(out_dir) / "fig14_mesh_efficiency.csv",
                         {"time_s": e.t[show], "recorded_A": rec[show],
                          **{f"{key}_A": sim[show] for key, _, _, sim in panels}}, consts)
    peaks = {f"peak_{key}": float(np.max(sim[show])) for key, _, _, sim in panels}  # the peaks the legends give
    return dict(png=png, csv=path, recording=e.name, peak_recorded=float(np.max(rec[show])), **peaks,
                **{f"rmse_{k}": v for k, v in rm.items()},
                mesh_values=dict(mesh[0].values) if mesh is not None else None)


def caption(fig: dict, chain: str) -> str:
    """The verdict of Fig. 14 (4.3-4.4: after the optimization the model fits the measured current, "a good fit
    for the physical system"): the calibrated current's peak against the recording's, and why it falls short."""
    from acausal.models.bench.design import design_params

    values = design_params(chain)[1]
    eta = float(values.get("planetary.eta", 1.0)) * float(values.get("helical.eta", 1.0))
    short = fig["peak_after"] / fig["peak_recorded"]
    fits = abs(short - 1) <= PEAK_TOLERANCE
    return verdict(
        "Fig. 14", "the calibrated current at its peak", fits,
        "after the optimization the model's current follows the measured one (4.4: the model is a good fit)",
        f"on the {VIRTUAL} {fig['recording']} the calibrated Eq. 4 peaks at {fig['peak_after']:.1f} A against the "
        f"recording's {fig['peak_recorded']:.1f} A ({100 * (short - 1):+.0f} %; the datasheet's "
        f"{fig['peak_before']:.1f} A), held-out RMSE {fig['rmse_before']:.2f} -> {fig['rmse_after']:.2f} A "
        f"('fits' read as a peak within {100 * PEAK_TOLERANCE:.0f} %)",
        "" if fits else
        "with the motion prescribed, Eq. 4's motor current is (J a + b w + tau / n) / k: J acts only where the "
        "arm accelerates and b where the motor turns fast, while the peak comes at push-off, at high torque and "
        f"low speed. There the {chain} chain's gears pass on only eta = {eta:.2f} of the motor's torque "
        f"(planetary x helical), so its current is about 1 / eta = {1 / eta:.2f} times Eq. 4's ideal-gear "
        f"current (recording / calibrated peak: {1 / short:.2f}), and no R, J or b reproduce a loss that scales "
        "with the torque (the paper's own calibration moved J and b far beyond its estimate, Table 2: 3.5e-3 "
        "and 6e-3 against 1.6e-5 and 1.3e-4)") + ("" if fig.get("mesh_values") is None else _mesh_sentence(fig))


def _mesh_sentence(fig: dict) -> str:
    v = fig["mesh_values"]
    return ("\n\nWith a mesh efficiency calibrated beside R, J and b (Eq. 4 with the diagnosis's candidate "
            f"`{MESH_EFFECT}`, lowest panel) the peak is {fig['peak_mesh']:.1f} A against "
            f"{fig['peak_recorded']:.1f} A, held-out RMSE {fig['rmse_mesh']:.2f} A, with gear.eta = "
            f"{v['gear.eta']:.2f} and R = {v['motor.R']:.2f} ohm (against {fig['R_after']:.2f} ohm without it): "
            "the loss that scales with the torque is what R, J and b could not stand in for. Table 2 and claim "
            "C13 read the calibration of R, J, b alone, as the paper's.")



if __name__ == "__main__":
    print(main(Path("results"))["markdown"])
