"""`acausal paper` writes the same bytes under any PYTHONHASHSEED: no iteration order of a set or
a dict of symbols leaks into the generated code, the order of floating-point operations or the tables.

Two fresh processes with different hash seeds run ``acausal paper --quick`` (its smallest option) side by side, one
worker each, so the pair takes about as long as one run on two cores: about 55 s of wall time on an idle two-core
machine (each run needs about 53 s of CPU). Every CSV they write, the bench recordings and the diagnosis folder's
included, must be byte-identical. The quick grid runs the same code as the full one (fewer conditions, coarser output
grid); two full runs (seeds 0 and 12345) were also compared when this test was written: identical CSVs, only the wall
time in report.md differs. The first run's folder is also the one ``tests/cli/test_examples_cli.py`` reads its report
from, and there the second run is the installed wheel's (``tests/cli/wheel_support.py``): one pair of runs shows that
neither the hash seed nor installing from a wheel changes a byte, so the suite pays for two quick runs, not four.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

SEEDS = ("3", "31337")


def quick_runs_under_hash_seeds(root: Path, commands: dict | None = None) -> dict[str, Path]:
    """Run ``acausal paper --quick`` once per seed of :data:`SEEDS`, side by side; return each run's folder.
    ``commands``: seed -> (the ``acausal`` command as a list, the folder to run it from), for a seed that runs
    another installation (default: this interpreter's ``-m acausal.cli`` from here)."""
    procs = {}
    for seed in SEEDS:
        env = {**os.environ, "PYTHONHASHSEED": seed}
        out = root / f"seed{seed}"
        command, cwd = (commands or {}).get(seed, ([sys.executable, "-m", "acausal.cli"], None))
        procs[seed] = (out, subprocess.Popen([*command, "paper", "--quick", "--jobs", "1", "--no-progress", "--out",
                                              str(out)], env=env, cwd=cwd, stdout=subprocess.PIPE,
                                             stderr=subprocess.PIPE, text=True))
    for seed, (out, proc) in procs.items():
        _, stderr = proc.communicate(timeout=900)
        assert proc.returncode == 0, f"PYTHONHASHSEED={seed}: exit {proc.returncode}\n{stderr[-3000:]}"
    return {seed: out for seed, (out, _) in procs.items()}


def _first_difference(a: bytes, b: bytes) -> str:
    la, lb = a.decode(errors="replace").splitlines(), b.decode(errors="replace").splitlines()
    for n, (x, y) in enumerate(zip(la, lb), start=1):
        if x != y:
            return f"line {n}:\n  {x}\n  {y}"
    return f"{len(la)} lines against {len(lb)}"


def compare_csvs(runs: dict[str, Path]) -> None:
    """Assert that every CSV of the runs' folders is byte-identical between the seeds."""
    csvs = {seed: {p.relative_to(out).as_posix(): p.read_bytes() for p in sorted(out.rglob("*.csv"))}
            for seed, out in runs.items()}
    a, b = (csvs[s] for s in SEEDS)
    assert len(a) >= 20 and "protocol.csv" in a and any(name.startswith("bench_data/") for name in a), sorted(a)
    assert sorted(a) == sorted(b)
    differ = [name for name in a if a[name] != b[name]]
    assert not differ, (f"{len(differ)} of {len(a)} CSVs differ between PYTHONHASHSEED={SEEDS[0]} and {SEEDS[1]}: "
                        f"{', '.join(differ)}; {differ[0]}, {_first_difference(a[differ[0]], b[differ[0]])}")
