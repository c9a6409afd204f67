"""Calibration of the Eq. (4) model against bench recordings: Table 2 with a calibrated column and Fig. 14
(measured vs simulated motor current before and after calibration).

The paper's bench recordings are not public, so by default this records a small virtual-bench set first
(``acausal.models.bench``: the paper's protocol in closed loop on the Eq. (4) truth with realistic sensors) into
``OUT/bench_data/`` and calibrates R, J, b on it; the report labels the data as simulated. With ``data=FOLDER`` it
calibrates on recordings in that folder instead (the format of ``acausal.models.bench.recording_format``).

Writes ``calibration.csv``, ``calibration_rmse.csv``, ``table2_calibrated.csv``, ``fig14_calibration.png`` (+ CSV).
Run: ``python examples/fig14_calibration.py`` (into ``results/``).
"""
from __future__ import annotations

from pathlib import Path

from acausal.models.bench import calibration
from acausal.models.bench.virtual import BenchCondition, run_bench
from acausal.models.bench.fit_report import fit_outputs

#: the on-the-fly bench set: 2 precompressions x 4 stride times, 3 recorded strides each
CONDITIONS = [BenchCondition(P, T, strides=3) for P in (0.005, 0.015) for T in (1.2, 1.5, 2.0, 3.0)]


def main(out_dir: Path, results=None, data=None, seed: int = 2014, executor=None) -> dict:
    out_dir = Path(out_dir)
    if data is None:
        data = out_dir / "bench_data"
        run_bench(data, CONDITIONS, seed=seed, executor=executor)
        label = (f"**virtual-bench recordings (simulated, not measured)**, generated on the fly into `{data.name}/` "
                 f"(seed {seed}; truth: Eq. 4 with R = 0.7 ohm, J = 4.07e-6 kg m2, b = 7e-6 N m s/rad; see its "
                 "README.md)")
    else:
        label = f"recordings in `{data}`"
    cal, exps = calibration.fit(data, "R,J,b")
    out = fit_outputs(out_dir, cal, exps, label)
    out["calibrated"] = dict(cal.values)
    return out


if __name__ == "__main__":
    print(main(Path("results"))["markdown"])
