"""Real data: a Dynamixel XL330 servo swinging a pendulum, calibrated, diagnosed and scored against BAM.

The 16 recordings (Rhoban/bam, Apache-2.0, shipped with the package: ``acausal.models.servo`` ``data/xl330``) are
replayed in closed loop by :class:`~acausal.models.servo.model.ServoPendulum`. The diagnosis

1. calibrates the baseline (Coulomb + viscous friction, BAM's M1 law: kt, R, armature, offset, Kc, Kv) on the
   recordings at three of the four gains and shows what it gets wrong (over time, per recording, per phase);
2. adds each candidate of :mod:`acausal.models.servo.effects` (friction laws, firmware, electrics, sensing) in turn,
   refits, and names the one that improves the held-out recordings (every recording at the fourth gain)
   significantly, then the next on top of it while one does;
3. reports the extended model's parameters with uncertainty and its held-out MAE next to BAM's published scores
   and BAM's published parameter sets replayed on the same logs.

Writes ``servo_friction/report.md`` (+ figures, CSV, ``diagnosis.json``). Run:
``python examples/servo_friction.py`` (into ``results/``; under a minute on two cores).
``acausal diagnose DATA --model servo_pendulum`` does the same on any folder of recordings in this format.
"""
from __future__ import annotations

import os
import time
from pathlib import Path

from acausal.identify import load_recordings
from acausal.models.servo import bam, problem as servo
from acausal.models.servo.recording_format import SERVO_FORMAT, shipped_recordings
from acausal.models.servo.report import write_json, write_report
from acausal.simulation.sweep import process_pool


def main(out_dir: Path, results=None, executor=None, recordings=None, candidates=None, max_effects=None,
         jobs: int | None = None) -> dict:
    """``recordings``: a list of recordings (default: the shipped XL330 set); ``candidates``: the friction laws to
    try (default: all); ``executor``: a process pool for the replays (default: one of ``jobs`` processes, all
    cores; ``"serial"``: this process only)."""
    out_dir = Path(out_dir) / "servo_friction"
    recs = recordings if recordings is not None else load_recordings(shipped_recordings(), SERVO_FORMAT)
    t0 = time.perf_counter()
    own = None
    if executor == "serial":
        executor = None
    elif executor is None:
        own = executor = process_pool(jobs or os.cpu_count() or 1)
    try:
        d, problem = servo.run(recs, candidates=candidates, max_effects=max_effects, executor=executor)
        bam_rows = bam.replay_all(recs, executor)
        sub = write_report(out_dir, d, problem, "Dynamixel XL330 on a 0.49 kg, 0.1 m pendulum (Rhoban/bam, "
                           "Apache-2.0)" if recordings is None else f"{len(recs)} servo recordings", bam_rows,
                           elapsed=time.perf_counter() - t0)
    finally:
        if own is not None:
            own.shutdown()
    write_json(out_dir / "diagnosis.json", d)
    return {**sub, "diagnosis": d, "problem": problem, "bam": bam_rows}


if __name__ == "__main__":
    res = main(Path("results"))
    print(res["markdown"].split("## 1.")[0])
