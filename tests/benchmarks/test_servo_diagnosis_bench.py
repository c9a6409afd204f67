"""Benchmarks of the servo diagnosis as a user starts it (its speed goals, 2 cores): the shipped XL330
example (goal 60 s) and ``acausal diagnose`` on 48 simulated recordings of another servo (goal 3 minutes).

Each runs in a fresh Python process with an empty library cache (``ACAUSAL_CACHE_DIR`` in the test's folder), so
the time includes building the C libraries of the native fixed step, as on a user's first run. One round; the
wall time is in the benchmark table and ``extra_info`` beside the goal, not asserted (a wall time depends on the
machine's load). The verdicts are the functional check.
"""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

#: minute-scale: run with --whole-jobs (tests/conftest.py)
pytestmark = pytest.mark.whole_job

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _fresh_env(tmp_path):
    return {**os.environ, "ACAUSAL_CACHE_DIR": str(tmp_path / "cache")}


def test_xl330_example_first_run(benchmark, tmp_path):
    cmd = [sys.executable, str(EXAMPLES / "servo_friction.py")]
    proc = benchmark.pedantic(lambda: subprocess.run(cmd, cwd=tmp_path, env=_fresh_env(tmp_path), capture_output=True,
                                                     text=True), rounds=1, iterations=1)
    assert proc.returncode == 0, proc.stderr
    d = json.loads((tmp_path / "results" / "servo_friction" / "diagnosis.json").read_text())
    assert d["causes"] == ["load"]
    assert d["heldout"]["extended"] <= 0.035 < d["heldout"]["baseline"]
    assert any((tmp_path / "cache" / "native").iterdir())  # the steps ran in C
    benchmark.extra_info["goal_s"] = 60.0
    if not benchmark.disabled and benchmark.stats is not None:
        benchmark.extra_info["wall_s"] = benchmark.stats.stats.min


def test_another_servo_48_recordings_first_run(benchmark, tmp_path):
    from acausal.models.servo import virtual
    data = tmp_path / "data"
    gains = tuple(int(g) for g in np.round(np.linspace(100, 1500, 16)))
    virtual.record(data, {"loop_delay": 0.003}, seed=3, gains=gains, trajectories=virtual.TRAJECTORIES, duration=6.0)
    js = tmp_path / "verdict.json"
    cmd = [sys.executable, "-m", "acausal.cli", "diagnose", str(data), "--model", "servo_pendulum", "--out",
           str(tmp_path / "out"), "--json", str(js), "--no-progress"]
    proc = benchmark.pedantic(lambda: subprocess.run(cmd, env=_fresh_env(tmp_path), capture_output=True, text=True),
                              rounds=1, iterations=1)
    assert proc.returncode == 0, proc.stderr
    v = json.loads(js.read_text())
    assert v["causes"] == ["loop_delay"]
    value, se = v["extended"]["params"]["servo.loop_delay.T"], v["extended"]["std"]["servo.loop_delay.T"]
    assert abs(value - 0.003) <= 3 * se
    benchmark.extra_info["goal_s"] = 180.0
    if not benchmark.disabled and benchmark.stats is not None:
        benchmark.extra_info["wall_s"] = benchmark.stats.stats.min
