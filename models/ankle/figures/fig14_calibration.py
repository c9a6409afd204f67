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
Run: ``python -m acausal.models.ankle.figures.fig14_calibration`` (into ``results/``).
"""
from __future__ import annotations

from pathlib import Path

from acausal.models.bench import calibration
from acausal.models.bench.virtual import BenchCondition, run_bench, truth_body_mass
from acausal.models.bench.fit_report import fit_outputs

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
    out = fit_outputs(out_dir, cal, exps, label, preset=chain, others=others)
    out["calibrated"] = dict(cal.values)
    return out


if __name__ == "__main__":
    print(main(Path("results"))["markdown"])
