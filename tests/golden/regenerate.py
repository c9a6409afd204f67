"""Regenerate the golden values of our own paper-model outputs (NOT the paper's numbers).

Run after an *intended* change of the models or the integrator, inspect the diff, and commit it:

    python -m tests.golden.regenerate

The golden file pins energies per stride at the five measurement points, peak powers and tracking errors for a
few conditions, so that unintended changes show up in tests/models/ankle/test_paper_findings.py.
"""
import json
from pathlib import Path

from acausal.models.ankle.protocol import Condition, run_condition

GOLDEN = Path(__file__).with_name("paper_golden.json")
CASES = {
    "replay_8mm_2s": Condition(0.008, 2.0),
    "replay_18mm_1.2s": Condition(0.018, 1.2),
    "replay_5mm_3s": Condition(0.005, 3.0),
    "direct_drive_3s": Condition(0.008, 3.0, model="direct_drive"),
    "closed_loop_18mm_3s": Condition(0.018, 3.0, model="closed_loop", strides=3),
    "paper_fit_replay_8mm_2s": Condition(0.008, 2.0, preset="paper_fit"),
    "paper_fit_bench_8mm_2s": Condition(0.008, 2.0, model="closed_loop", preset="paper_fit"),
    "paper_fit_direct_drive_3s": Condition(0.008, 3.0, model="direct_drive", preset="paper_fit"),
    "paper_fit_bench_output_motor_3s": Condition(0.008, 3.0, model="bench_output_motor", preset="paper_fit"),
}


def compute() -> dict:
    out = {}
    for name, cond in CASES.items():
        r = run_condition(cond)
        out[name] = {"energy": r.energy, "peak_power": r.peak_power, "tracking_rms": r.tracking_rms,
                     "max_duty": r.max_duty}
    return out


if __name__ == "__main__":
    GOLDEN.write_text(json.dumps(compute(), indent=2, sort_keys=True) + "\n")
    print(f"wrote {GOLDEN}")
