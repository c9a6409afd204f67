"""The energy balance of a whole run, as the trust check judges it (:func:`acausal.results.trust.energy_balance`): the
unaccounted energy (sources + boundary work - losses - change in stored energy) against the largest energy that
moved.

The run's totals come from where the run integrated them: on the scipy path the 5-point Gauss rule on the solver's
own steps (their interpolants at the nodes), on the compiled path CVODES's quadratures. Everything the balance
reads at those samples, every account's integrand (a port's power into its component ``v*i``, ``tau*der(phi)``,
``Q_flow``; a loss; a source), every stored energy and every additive term of one (what moves between the forms
inside it), is one generated function of the model
(:meth:`~acausal.backends.numpy.ondemand.OnDemand.expressions_function`, generated once per model), called once at the
nodes; the stored energies and their terms alone are another, called at the run's two ends (on the compiled path at
every output). A model for which one of them has no closed form (a rate the model does not compute) takes each account
through :meth:`Result.energy <acausal.results.result.Result.energy>` instead, with the same totals.
"""
from __future__ import annotations

import numpy as np

from ..errors import AcausalError, ModelError
from ..backends.numpy.runtime import rows


def residual(res, floor: float):
    """``(unaccounted energy [J], the largest energy that moved [J], their ratio)``, or None: no balance to check
    (no accounts, or less than ``floor`` joules moved)."""
    acc = res.model.accounts
    if acc is None or not (acc.losses or acc.stored):
        return None
    from .energy import balance
    found = _from_plan(res, acc)
    if found is None:
        found = _by_account(res, acc)
    energy, change, swing, sources, exchanged = found
    b = balance(res, acc, 0, -1, energy=energy, change=change)
    terms = list(b.sources.values()) + list(b.boundary.values()) + list(b.losses.values())
    scale = max([abs(v) for v in terms] + swing + sources + exchanged + [0.0])
    if scale < floor or not np.isfinite(scale):
        return None
    total = sum(b.sources.values()) + sum(b.boundary.values()) - sum(b.losses.values()) - sum(b.stored.values())
    return total, scale, abs(total) / scale


def plan(cm):
    """``(flow names, the generated function of [integrands, stored energies, their terms], that of the stored
    energies and their terms alone, number of terms)`` of compiled model ``cm``, found once per model; None where
    an integrand has no closed form."""
    key = "trust: balance plan"
    if key in cm.derived:
        return cm.derived[key]
    from ..compile.accounts import balance_integrals, integrand_expr
    from ..model.symbols import var_symbol

    acc = cm.accounts
    names = balance_integrals(acc)
    exprs = [integrand_expr(cm, n) for n in names]
    known = set(cm.state_names) | set(cm.unknown_names)
    stored = [var_symbol(n) if n in known else cm.flat.aliases.get(n) for n in acc.stored]
    terms = energy_terms(cm, acc.stored)
    found = None
    if all(e is not None for e in exprs + stored):
        try:
            gen = cm.generator
            found = (names, gen.expressions_function(exprs + stored + terms), gen.expressions_function(stored + terms),
                     len(terms))
        except ModelError:  # a symbol the generated code has no value for: account by account
            found = None
    cm.derived[key] = found
    return found


def energy_terms(cm, stored) -> list:
    """The additive terms of each stored account's solved equation (a pendulum's kinetic and potential energy),
    found once per model."""
    import sympy as sp

    terms = cm.derived.get("trust: energy terms")
    if terms is None:
        terms = [term for name in stored for expr in [cm.program.assignment(name)] if isinstance(expr, sp.Add)
                 for term in expr.args if term.free_symbols]
        cm.derived["trust: energy terms"] = terms
    return terms


def _from_plan(res, acc):
    """The balance's inputs from the model's generated functions (see the module's docstring), or None where
    the run's totals are not on the steps' nodes or in the quadratures. A total is passed as ``(0, total)``, a
    source's energy over the whole run (its largest excursion scales the balance)."""
    found = plan(res.model)
    if found is None:
        return None
    names, fn, stores, n_terms = found
    k, m = len(names), len(acc.stored)
    whole = set(acc.sources)  # the whole run for a source (its largest excursion), else the total
    if res._totals_on_steps():
        _, tn, half, wg, Xn, Dn = res._node_samples()
        with np.errstate(all="ignore"):
            at_nodes = rows(fn(tn.ravel(), Xn, res.params, Dn, res.inputs), tn.size)
        pieces = (at_nodes[:k].reshape((k,) + tn.shape) @ wg) * half  # each interval's integral
        totals = pieces.sum(axis=1).tolist()
        energy = {n: np.concatenate([[0.0], np.cumsum(pieces[i])]) if n in whole else (0.0, totals[i])
                  for i, n in enumerate(names)}
        samples = at_nodes[k:]
    elif res.dense.integrals and all(n in res.dense.integrals for n in names):
        energy = {n: q - q[0] if n in whole else (0.0, float(q[-1] - q[0]))
                  for n in names for q in [res.dense.integrals[n]]}
        samples = None
    else:
        return None
    pick = [0, res.t.size - 1]
    X = np.asarray(res.states, dtype=float)
    with np.errstate(all="ignore"):
        if samples is None:  # the compiled path: the stores at every output (their ends among them)
            samples = rows(stores(res.t, X, res.params, res.modes, res.inputs), res.t.size)
            ends = samples[:m][:, pick]
        else:
            D = res.modes if np.ndim(res.modes) == 1 else np.asarray(res.modes)[:, pick]
            ends = rows(stores(res.t[pick], X[:, pick], res.params, D, res.inputs), 2)[:m]
    change = dict(zip(acc.stored, (ends[:, 1] - ends[:, 0]).tolist()))
    with np.errstate(all="ignore"):
        top, low = samples.max(axis=1), samples.min(axis=1)  # NaN where a row has one
        swing = [t - b if t == t else float(np.nanmax(v) - np.nanmin(v))
                 for t, b, v in zip(top[:m].tolist(), low[:m].tolist(), samples[:m])]
        exchanged = [t - b for t, b in zip(top[m:].tolist(), low[m:].tolist()) if np.isfinite(t - b)]
        sources = [float(np.nanmax(np.abs(energy[n]))) for n in acc.sources]
    return energy.__getitem__, change.__getitem__, swing, sources, exchanged


def _by_account(res, acc):
    """The balance's inputs account by account (:meth:`Result.energy <acausal.results.result.Result.energy>` and the
    stores' values), where the model's integrands have no closed form."""
    ends = res.ends(acc.stored)
    run = res._run_samples()
    swing = [float(np.nanmax(run[n]) - np.nanmin(run[n])) for n in acc.stored]
    sources = [float(np.nanmax(np.abs(res._run_energy(n)))) for n in acc.sources]
    return (res._run_energy, lambda n: float(ends[n][1] - ends[n][0]), swing, sources,
            _exchanged(run, acc.stored))


def _exchanged(res, stored) -> list:
    """The energy moved between the forms inside each stored account: the largest swing of one additive term of
    its solved equation (a pendulum's kinetic and potential energy trade 0.86 J while their sum, the account,
    moves by what the integrator's error adds to it), evaluated by
    :meth:`~acausal.compiled_model.CompiledModel.eval_expr`."""
    cm = res.model
    out = []
    for term in energy_terms(cm, stored):
        try:
            values = {str(x): res[str(x)] for x in term.free_symbols
                      if not cm.has_parameter(str(x)) and str(x) != "time"}
            v = np.asarray(cm.eval_expr(term, values, res.params, None, res.t), dtype=float)
        except (KeyError, AcausalError, ValueError, TypeError):  # a symbol the result does not carry: no scale
            continue
        if v.size and np.all(np.isfinite(v)):
            out.append(float(np.max(v) - np.min(v)))
    return out
