"""Timing helpers shared by the benchmarks: the fastest of several rounds of a reference measured in the same run,
and the fastest round pytest-benchmark measured."""
import time

import numpy as np


def best_of(fn, rounds: int) -> float:
    """The fastest of ``rounds`` calls of ``fn`` [s]."""
    best = np.inf
    for _ in range(rounds):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def min_time(benchmark):
    """Fastest round, or None when benchmarks are disabled (--benchmark-disable runs each once)."""
    return None if benchmark.disabled or benchmark.stats is None else benchmark.stats.stats.min
