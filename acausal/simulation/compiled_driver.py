"""The compiled backend: the run integrated by SUNDIALS CVODES (IDAS for a Newton block) through CasADi
(:mod:`acausal.compiled`), the step loop in compiled code. A model with state events runs in the native event loop
(:mod:`acausal.compiled.native_events`: IDAS in C, the crossings found in its steps) where it can be built, else
in windows between its crossings on CasADi's integrators (:mod:`acausal.compiled.events`), which also takes a run
the native loop fails on."""
from __future__ import annotations

import numpy as np

from ..energy import account_integrals
from ..errors import SimulationError
from ..result import Result


def integrate(run):
    """Integrate ``run`` (:class:`~.run.Run`) on the compiled path. With ``dense_output`` the energy integrals of
    the model's accounts are integrated by CVODES beside the states (under its error control); the integral of
    anything else takes the states at the Gauss nodes of the output intervals, integrated again when first asked
    for. A SimulationError says the run failed there (the caller runs it on the scipy path, which names where)."""
    cm, t_start, t_out, p, d, u = run.cm, run.t_start, run.t_out, run.p, run.d.copy(), run.u
    if cm.event_zeros:
        from ..compiled import native_events
        from ..compiled.events import simulate_with_events
        if native_events.enabled():
            names = account_integrals(cm.accounts) if run.dense_output and cm.accounts is not None else []
            runner, sig = native_events.segment_runner(cm, u, cm.compiled_path.integrable(names, u) if names else [])
            if runner is not None:
                try:
                    return native_events.simulate_native(cm, runner, sig, t_start, run.x0.copy(), t_out, p, d, u,
                                                         run.rtol, run.atol, run.max_step, run.first_step,
                                                         run.max_events, run.dense_output, run.starts)
                except SimulationError:
                    d = run.d.copy()  # the CasADi path runs it from the start (and says where it fails)
        return simulate_with_events(cm, t_start, run.x0.copy(), t_out, p, d, u, run.rtol, run.atol, run.max_step,
                                    run.first_step, run.max_events, run.dense_output, run.starts)
    path = cm.compiled_path
    x0 = run.x0
    args = (run.rtol, run.atol, run.max_step, run.first_step)
    nodes, integrals = None, {}
    if run.dense_output and t_out.size > 1:
        names = account_integrals(cm.accounts) if cm.accounts is not None else []
        X, integrals = path.integrate(t_start, x0, t_out, p, d, u, *args, integrals=names)
        nodes = path.gauss_states(t_start, x0, t_out, p, d, u, *args)
    else:
        X, _ = path.integrate(t_start, x0, t_out, p, d, u, *args)
    if not np.isfinite(X).all():
        raise SimulationError("compiled path: non-finite states")
    later = path.quadratures_later(t_start, x0, t_out, p, d, u, *args) if nodes is not None else None
    return Result(cm, t_out, X, p, u, d, events=[], nodes=nodes, integrals=integrals, more_integrals=later,
                  solver=f"{path.integrator_name(u)} (compiled path, CasADi)")
