"""The compiled backend: the run integrated by SUNDIALS CVODES (IDAS for a Newton block), the step loop in compiled
code. Where a C compiler and SUNDIALS's library are there, the native loop
(:mod:`acausal.simulation.compiled.native_loop`: SUNDIALS in C on the model's functions printed as C, a state event's
crossing found in its steps) runs it; else, or for a run the native loop fails on, CasADi's integrators
(:mod:`acausal.simulation.compiled`) do: in one call for a model without state events, in windows between its crossings
for one with them (:mod:`acausal.simulation.compiled.events`)."""
from __future__ import annotations

import numpy as np

from ...compile.accounts import account_integrals
from ...errors import SimulationError
from ...results.result import DenseOutput, Result


def integrate(run):
    """Integrate ``run`` (:class:`~.run.Run`) on the compiled path. With ``dense_output`` the energy integrals of
    the model's accounts are integrated by the solver beside the states (under its error control); the integral of
    anything else takes the states at the Gauss nodes of the output intervals, integrated again when first asked
    for. A SimulationError says the run failed there (the caller runs it on the scipy path, which names where)."""
    from . import native_loop  # here: the module needs CasADi, which the scipy path does not

    cm, t_start, t_out, p, u = run.cm, run.t_start, run.t_out, run.p, run.u
    path = cm.compiled_path
    dense = run.dense_output and t_out.size > 1
    # the states at the Gauss nodes of the output intervals, integrated when first asked for (events: the steps')
    nodes = path.gauss_states(t_start, run.x0, t_out, run.segment()) if dense and not cm.event_zeros else None
    names = account_integrals(cm.accounts) if dense and cm.accounts is not None else []
    runner, sig = native_loop.runner_for(cm, u, names) if run.budget is None else (None, None)
    if runner is not None:  # (a run under a budget takes CasADi's calls, between which it can stop)
        try:
            return native_loop.simulate_native(run, runner, sig, nodes)
        except SimulationError:
            pass  # the CasADi path runs it from the start (and says where it fails)
    if cm.event_zeros:
        from .events import simulate_with_events
        return simulate_with_events(run)
    x0, d = run.x0, run.d.copy()
    seg = run.segment(d)
    if run.budget is None:
        X, integrals = path.integrate(t_start, x0, t_out, seg, integrals=names if dense else ())
    else:
        X, integrals = _in_chunks(path, t_start, x0, t_out, seg, names if dense else ())
    if not np.isfinite(X).all():
        raise SimulationError("compiled path: non-finite states")
    later = path.quadratures_later(t_start, x0, t_out, seg) if dense else None
    return Result(cm, t_out, X, p, u, d, events=[], dense=DenseOutput(nodes=nodes, integrals=integrals, more=later),
                  solver=f"{path.integrator_name(u)} (compiled path, CasADi)")


CHUNKS = 64  # a run under a budget: CVODES calls over this many parts of its output times at most


def _in_chunks(path, t_start, x0, t_out, seg, names) -> tuple:
    """``path.integrate`` over the output times ``t_out`` in up to :data:`CHUNKS` calls, each from where the one
    before ended (the integrals added up): a run under a budget (``seg.budget``) stops between two of them when
    its seconds are spent, and within one when its steps are."""
    size = max(1, -(-t_out.size // CHUNKS))
    X = np.empty((len(x0), t_out.size))
    Q = {name: np.zeros(t_out.size) for name in names}
    t, x, done = t_start, np.asarray(x0, dtype=float), dict.fromkeys(names, 0.0)
    for k in range(0, t_out.size, size):
        grid = t_out[k:k + size]
        Xs, Qs = path.integrate(t, x, grid, seg, integrals=names)
        X[:, k:k + size] = Xs
        for name in names:
            Q[name][k:k + size] = done[name] + Qs[name]
            done[name] += float(Qs[name][-1])
        t, x = float(grid[-1]), Xs[:, -1].copy()
    return X, Q
