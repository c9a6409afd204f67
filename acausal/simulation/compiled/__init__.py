"""The compiled simulation path: a model's equations as CasADi expressions, integrated by SUNDIALS CVODES whose
step loop runs in compiled code (see :mod:`acausal.simulation.compiled.path`). Optional: without CasADi installed
(``pip install "acausal[fast]"``) every run takes the scipy path, with the same answers."""
from __future__ import annotations

import functools
import importlib.util


@functools.lru_cache(maxsize=1)
def available() -> bool:
    """Whether CasADi is installed (looked up once per process)."""
    return importlib.util.find_spec("casadi") is not None
