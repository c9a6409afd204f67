"""Many runs of one compiled model in one call: a parameter sweep without a Python loop around the integrator.

On the compiled path every set is run by :func:`~acausal.simulation.simulate.simulate` itself on the native loop (where
it is built: the first set alone, the others on several threads of this process, the loop letting go of the
interpreter while it integrates), or else integrated by one CasADi call that maps CVODES over them (on several
threads, nothing pickled, nothing compiled again); either way every run is the same computation as its own
:func:`~acausal.simulation.simulate.simulate`, so the results are identical. A model or run the compiled path does not
take is simulated set by set on the scipy path, with the reason in each result's ``solver``.
"""
from __future__ import annotations

import os

import numpy as np

from ..errors import ModelError, SimulationError

MAX_EVENTS = 10_000  # events per member at most (simulate's default)


def simulate_many(cm, t_end: float, params, *, threads: int | None = None, t_start: float = 0.0,
                  inputs: dict | None = None, starts: dict | None = None, method: str = "auto", rtol: float = 1e-6,
                  atol: float = 1e-9, t_eval=None, n_points: int = 501, max_step: float = np.inf,
                  first_step: float | None = None, dense_output: bool = True, trust: str = "raise") -> list:
    """One :class:`~acausal.results.result.Result` per parameter set in ``params`` (a list of dicts of overrides by
    name), all with the same inputs, starts and output times; the other arguments are
    :func:`acausal.simulation.simulate.simulate`'s (``trust``: every member is checked as its own run would be).
    ``threads``: threads for the compiled path (default: the number of cores)."""
    from .compiled import available
    from ..results.result import DenseOutput, Result
    from .simulate import simulate_run
    from . import COMPILED, choose_path, prepare
    from ..results.trust import check, check_mode

    if isinstance(params, dict) or not hasattr(params, "__iter__"):
        raise ModelError("simulate_many: params must be a list of parameter dicts (one per run)")
    for k, s in enumerate(params):
        if s is not None and not isinstance(s, dict):
            raise ModelError(f"simulate_many: params[{k}] is {s!r}, not a dict of parameter overrides by name "
                             "(e.g. [{'R.R': 1.0}, {'R.R': 2.0}])")
    sets = [dict(s or {}) for s in params]
    if not sets:
        return []
    check_mode(trust)
    runs = [prepare(cm, t_end, t_start=t_start, params=s, inputs=inputs, starts=starts, method=method, rtol=rtol,
                    atol=atol, t_eval=t_eval, n_points=n_points, max_step=max_step, first_step=first_step,
                    max_events=MAX_EVENTS, dense_output=dense_output, max_steps=None) for s in sets]
    batched = False
    if method in ("auto", COMPILED) and cm.state_names and not cm.event_zeros and available():
        from ..backends.casadi import Signals, Unsupported
        try:
            same_inputs = len({Signals.layout(cm, run.u) for run in runs}) == 1
        except Unsupported:
            same_inputs = True  # choose_path below names the input
        if not same_inputs and method == COMPILED:
            raise ModelError("simulate_many(method='CVODES'): the parameter sets give inputs of different shapes "
                             "(parametric signals); run them one by one")
        batched = same_inputs and choose_path(cm, method, runs[0].u, rtol, atol)[0] == COMPILED
    if not batched:  # one run per set (a model with events restarts each run at its own crossings)
        return [simulate_run(run, trust) for run in runs]
    t_out = runs[0].t_out
    names = []
    if dense_output and t_out.size > 1 and cm.accounts is not None:
        from ..compile.accounts import account_integrals
        names = account_integrals(cm.accounts)
    n_threads = max(1, min(len(sets), threads or os.cpu_count() or 1))
    from .compiled import native_loop  # here: it needs CasADi, which batched runs have
    if native_loop.runner_for(cm, runs[0].u, names)[0] is not None:  # built here, once, if it was not
        return _threaded(lambda run: simulate_run(run, trust), runs, n_threads)
    path, u = cm.compiled_path, runs[0].u  # the first set's inputs: one integrator for all
    try:
        out = path.integrate_many(runs[0].t_start, [run.x0 for run in runs], t_out, [run.segment(u=u) for run in runs],
                                  integrals=names, threads=n_threads)
    except SimulationError:  # one member failed: each on its own, so the failing one is reported as simulate does
        return [simulate_run(run, trust) for run in runs]
    results = []
    for (X, Q), run in zip(out, runs):
        if not np.all(np.isfinite(X)):
            raise SimulationError("compiled path: non-finite states in a batch member")
        seg = run.segment()
        nodes = path.gauss_states(run.t_start, run.x0, t_out, seg) if dense_output and t_out.size > 1 else None
        later = path.quadratures_later(run.t_start, run.x0, t_out, seg) if nodes is not None else None
        results.append(Result(cm, t_out, X, run.p, run.u, run.d, events=[],
                              dense=DenseOutput(nodes=nodes, integrals=Q, more=later),
                              solver=f"{path.integrator_name(u)} (compiled path, CasADi; batch of {len(sets)} on "
                                     f"{n_threads} threads)"))
        check(results[-1], rtol, atol, trust, dense_output)
    return results


def _threaded(simulate, runs, n_threads: int) -> list:
    """``simulate(run)`` for every run: the first alone (what a run builds and keeps for the next is built once),
    the others on ``n_threads`` threads (the native loop lets go of the interpreter while it integrates). Each
    result is its own :func:`~acausal.simulation.simulate.simulate`'s; its ``solver`` says it ran in a batch."""
    from concurrent.futures import ThreadPoolExecutor

    out = [simulate(runs[0])]
    if len(runs) > 1:
        with ThreadPoolExecutor(max_workers=n_threads) as pool:
            out += list(pool.map(simulate, runs[1:]))
    for res in out:
        res.solver = (res.solver[:-1] if res.solver.endswith(")") else res.solver + " (") + \
            f"; batch of {len(runs)} on {n_threads} threads)"
    return out
