"""A process pool's workers run their BLAS on one thread (acausal.simulation.sweep.process_pool): two workers each with
a BLAS thread per core only contend on a machine with as many cores as workers."""
import ctypes
import importlib

import pytest

from acausal.simulation.sweep import one_blas_thread, process_pool

GETTERS = ("openblas_get_num_threads", "openblas_get_num_threads64_", "scipy_openblas_get_num_threads",
           "scipy_openblas_get_num_threads64_")


def blas_threads() -> dict:
    """Library file -> its thread count, for every OpenBLAS loaded in this process."""
    importlib.import_module("scipy.linalg")  # its own OpenBLAS, where it has one

    with open("/proc/self/maps") as fh:
        paths = {line.split()[-1] for line in fh if "openblas" in line.lower() and line.split()[-1][:1] == "/"}
    out = {}
    for path in sorted(paths):
        lib = ctypes.CDLL(path)
        getter = next((getattr(lib, n) for n in GETTERS if hasattr(lib, n)), None)
        if getter is not None:
            out[path.rsplit("/", 1)[-1]] = int(getter())
    return out


def test_a_pool_worker_runs_its_blas_on_one_thread():
    try:
        here = blas_threads()
    except OSError:
        pytest.skip("no /proc/self/maps: the libraries cannot be listed (one_blas_thread changes nothing there)")
    if not here:
        pytest.skip("no OpenBLAS in this process")
    with process_pool(1) as pool:
        there = pool.submit(blas_threads).result()
        assert pool.submit(one_blas_thread).result() == len(there)
    assert there and set(there) == set(here) and all(n == 1 for n in there.values()), there
    assert blas_threads() == here  # the parent keeps its own
