"""Sweeps: a function over many argument sets through any ``concurrent.futures.Executor``.

The default executor is a process pool on all cores, each worker's BLAS on one thread (:func:`process_pool`).
Anything with ``submit`` that returns futures works: a ``ThreadPoolExecutor``, a dask cluster
(``distributed.Client(...).get_executor()``), ray's executor. The function and its arguments must be picklable for
process and cluster executors (a module-level function, plain data). Results come back in the order of the
arguments, so a sweep through a cluster gives exactly what the in-process run gives.
"""
from __future__ import annotations

import os
import sys
from concurrent.futures import Executor, ProcessPoolExecutor

from ..errors import ModelError


#: the names an OpenBLAS build exports its thread-count setter under (plain, 64-bit interface, scipy's and numpy's
#: wheels' prefixed builds)
_BLAS_THREADS = ("openblas_set_num_threads", "openblas_set_num_threads64_", "scipy_openblas_set_num_threads",
                 "scipy_openblas_set_num_threads64_")


def one_blas_thread() -> int:
    """Run every OpenBLAS loaded in this process on one thread; returns how many were set. A pool's workers share
    the cores: two workers each with a BLAS thread per core made ``acausal paper`` 12 % slower on 2 cores (paired
    runs; the threads contend, nothing is computed in parallel that the pool does not already run). Where the
    libraries cannot be listed (no ``/proc``) or the BLAS is another, nothing changes."""
    import ctypes
    import importlib

    importlib.import_module("scipy.linalg")  # loads scipy's own OpenBLAS (where it has one), to be set too
    try:
        with open("/proc/self/maps") as fh:
            paths = {line.split()[-1] for line in fh if "openblas" in line.lower() and line.split()[-1][:1] == "/"}
    except OSError:
        return 0
    done = 0
    for path in sorted(paths):
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        setter = next((getattr(lib, name) for name in _BLAS_THREADS if hasattr(lib, name)), None)
        if setter is not None:
            setter(1)
            done += 1
    return done


def process_pool(workers: int) -> ProcessPoolExecutor:
    """A process pool of ``workers`` processes, each running its BLAS on one thread (:func:`one_blas_thread`):
    the default of :func:`sweep` and of the command line's verbs."""
    return ProcessPoolExecutor(max_workers=max(1, int(workers)), initializer=one_blas_thread)


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
        executor = process_pool(min(os.cpu_count() or 1, len(args)))
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
