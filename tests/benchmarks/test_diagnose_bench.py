"""Benchmark of ``acausal diagnose`` on the paper's 36 conditions (6 precompressions x 6 stride times, 3 recorded
strides each) with a gear mesh loss hidden (goal: under 3 minutes on 2 cores).

The recordings are made first (not timed); the command then runs in a fresh Python process as a user would start
it (imports, compilation, calibration, fingerprints, refits, report and figures). One round; the wall time is in
the benchmark table and ``extra_info``, beside the goal; it is not asserted (a wall time depends on the
machine's load). The verdict is the functional check.
"""
import json
import subprocess
import sys

import pytest

from acausal.models.bench.virtual import default_conditions, run_bench

#: minute-scale: run with --whole-jobs (tests/conftest.py)
pytestmark = pytest.mark.whole_job


def test_acausal_diagnose_36_recordings(benchmark, tmp_path):
    data = tmp_path / "data"
    run_bench(data, default_conditions(strides=3), {"gear_load_dependent_loss": 0.85}, seed=21)
    out, js = tmp_path / "out", tmp_path / "verdict.json"
    cmd = [sys.executable, "-m", "acausal.cli", "diagnose", str(data), "--out", str(out), "--json", str(js),
           "--no-progress"]
    proc = benchmark.pedantic(lambda: subprocess.run(cmd, capture_output=True, text=True), rounds=1, iterations=1)
    assert proc.returncode == 0, proc.stderr
    verdict = json.loads(js.read_text())
    assert verdict["cause"] == "gear_load_dependent_loss", verdict["candidates"]
    assert abs(verdict["extended"]["params"]["gear.eta"] - 0.85) < 0.03
    benchmark.extra_info["goal_s"] = 180.0
    if not benchmark.disabled and benchmark.stats is not None:
        wall = benchmark.stats.stats.min
        benchmark.extra_info["wall_s"] = wall
