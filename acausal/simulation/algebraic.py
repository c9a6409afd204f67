"""A model without states after index reduction: no integrator, its equations evaluated at the output times (the
modes of its state events found at each)."""
from __future__ import annotations

import numpy as np

from .events import algebraic_modes

SOLVER = "algebraic (no states: evaluated at the output times)"  # what res.solver and simulation_path() say


def integrate(run):
    """The :class:`~acausal.results.result.Result` of ``run`` (:class:`~.run.Run`) whose model has no states."""
    from ..results.result import DenseOutput, Result

    cm, t_out, p, d, u = run.cm, run.t_out, run.p, run.d, run.u
    modes = algebraic_modes(cm, t_out, p, d, u) if cm.event_zeros else d
    return Result(cm, t_out, np.zeros((0, t_out.size)), p, u, modes, events=[], dense=DenseOutput(exact_time=True),
                  solver=SOLVER)
