"""Benchmark of ``acausal compare`` on three models at two stride times, 2 worker processes (goal: under 20 s
on 2 cores).

The command runs in a fresh Python process, as a user would start it (imports, compilation in the workers,
simulation, CSV, markdown and Sankey PNGs all included): through ``acausal.cli`` once the verb is wired there,
else through :func:`acausal.models.drivetrains.compare.configure`/``run`` (the functions the CLI wires). One round; the
wall time is in the benchmark table and in ``extra_info``, beside the goal; it is not asserted (a wall time depends on
the machine's load, not on the code alone); the written table is the functional check.
"""
import csv
import subprocess
import sys

from acausal.cli import main as cli

ARGS = ["replay", "direct_drive", "sea", "--stride-time", "1.5", "2.0", "--jobs", "2", "--no-progress"]
_VIA_MODELS = ("import argparse, sys; from acausal.models.drivetrains import compare; p = argparse.ArgumentParser(); "
               "compare.configure(p); a = p.parse_args(sys.argv[1:]); sys.exit(a.run(a))")


def command(out) -> list:
    if "compare" not in getattr(cli, "PLANNED", {}):
        return [sys.executable, "-m", "acausal.cli", "compare", *ARGS, "--out", str(out)]
    return [sys.executable, "-c", _VIA_MODELS, *ARGS, "--out", str(out)]


def test_acausal_compare_three_models_two_stride_times(benchmark, tmp_path):
    out = tmp_path / "compare"
    proc = benchmark.pedantic(lambda: subprocess.run(command(out), capture_output=True, text=True), rounds=1,
                              iterations=1)
    assert proc.returncode == 0, proc.stderr
    with open(out / "compare.csv") as f:
        rows = list(csv.DictReader(f))
    assert [(r["model"], float(r["stride_time_s"])) for r in rows] == [
        ("replay", 1.5), ("replay", 2.0), ("direct_drive", 1.5), ("direct_drive", 2.0), ("sea", 1.5), ("sea", 2.0)]
    assert all(abs(float(r["balance_residual"])) < 1e-6 for r in rows)
    assert len(list(out.glob("sankey_*.png"))) == 3
    benchmark.extra_info["goal_s"] = 20.0
    if not benchmark.disabled and benchmark.stats is not None:
        benchmark.extra_info["wall_s"] = benchmark.stats.stats.min
