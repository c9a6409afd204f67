"""Sweeps: a function over many argument sets through any ``concurrent.futures.Executor``.

The default executor is a process pool on all cores. Anything with ``submit`` that returns futures works: a
``ThreadPoolExecutor``, a dask cluster (``distributed.Client(...).get_executor()``), ray's executor. The function
and its arguments must be picklable for process and cluster executors (a module-level function, plain data).
Results come back in the order of the arguments, so a sweep through a cluster gives exactly what the in-process
run gives.
"""
from __future__ import annotations

import os
import sys
from concurrent.futures import Executor, ProcessPoolExecutor

from .errors import ModelError


def sweep(fn, args, executor: Executor | None = None, progress: bool = False, label: str = "tasks") -> list:
    """``[fn(a) for a in args]``, run through ``executor`` (default: a process pool on all cores; ``"serial"``
    runs in this process)."""
    if not callable(fn):
        raise ModelError(f"sweep: fn must be a function of one argument, got {fn!r}")
    if isinstance(args, (str, bytes)) or not hasattr(args, "__iter__"):
        raise ModelError(f"sweep: args must be a list (or another iterable) of arguments, one per call of fn, got "
                         f"{args!r}")
    args = list(args)
    if not (executor is None or executor == "serial" or callable(getattr(executor, "submit", None))):
        raise ModelError(f"sweep: executor must be None, 'serial' or an Executor (something with submit), got "
                         f"{executor!r}")
    if executor == "serial" or (executor is None and (len(args) <= 1 or (os.cpu_count() or 1) == 1)):
        out = []
        for i, a in enumerate(args, 1):
            out.append(fn(a))
            if progress:
                progress_bar(i, len(args), label)
        return out
    own = executor is None
    if own:
        executor = ProcessPoolExecutor(max_workers=min(os.cpu_count() or 1, len(args)))
    try:
        futures = [executor.submit(fn, a) for a in args]
        out = []
        for i, f in enumerate(futures, 1):
            out.append(f.result())
            if progress:
                progress_bar(i, len(futures), label)
        return out
    finally:
        if own:
            executor.shutdown()


def chunks(items, n: int) -> list:
    """``items`` split into ``n`` contiguous chunks of nearly equal size (no empty chunk)."""
    items = list(items)
    n = max(1, min(n, len(items)))
    q, r = divmod(len(items), n)
    out, i = [], 0
    for k in range(n):
        j = i + q + (k < r)
        out.append(items[i:j])
        i = j
    return out


def progress_bar(i: int, n: int, label: str = "tasks", width: int = 36):
    filled = int(width * i / n)
    sys.stderr.write(f"\r  [{'#' * filled}{'.' * (width - filled)}] {i}/{n} {label}")
    if i == n:
        sys.stderr.write("\n")
    sys.stderr.flush()
