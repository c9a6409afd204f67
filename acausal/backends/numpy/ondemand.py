"""Functions generated from a model's solved steps on demand, never at compile time (a mixin of
:class:`~acausal.backends.numpy.printer.CodeGenerator`, sharing its namespace of helpers): the values of chosen unknowns
only (:meth:`OnDemand.values_function`, a backward slice of the steps) and chosen outputs with their exact partial
derivatives (:meth:`OnDemand.sensitivity_function`)."""
from __future__ import annotations

import numpy as np
import sympy as sp

from . import runtime
from ...errors import ModelError
from ...compile.parameters import binding_totals
from ...model.signals import SignalCall
from ...compile.solve import step_exprs
from ...model.symbols import var_symbol


class OnDemand:
    """The functions a :class:`~acausal.backends.numpy.printer.CodeGenerator` generates when first asked for, cached by
    their arguments."""

    def values_function(self, names):
        """Generate (once per tuple of names, then cached) ``f(t, x, p, d, u) -> list`` of the named unknowns only:
        the backward slice of the steps they need (what the trust checks evaluate at many points)."""
        names = tuple(names)
        key = ("values", names)
        if key not in self._on_demand:
            syms = [var_symbol(v) for v in names]
            items, _ = self._body(self._slice(syms))
            fname = f"values{len(self._on_demand)}"
            outs = ", ".join(self.names[s] for s in syms)
            src = self._render(fname, items, [f"    return [{outs}{',' if len(syms) == 1 else ''}]"])
            self._on_demand[key] = self._define(fname, src)
        return self._on_demand[key]

    def expressions_function(self, exprs):
        """Generate (once per tuple of expressions, then cached) ``f(t, x, p, d, u) -> list``: the values of sympy
        expressions of states, unknowns, parameters, modes, time and input signal calls (alias definitions, a
        port's power), through the backward slice of the steps they need; what the trust check's energy balance
        evaluates at the solver's Gauss nodes in one call."""
        exprs = tuple(sp.sympify(e) for e in exprs)
        key = ("expressions", exprs)
        if key not in self._on_demand:
            items, _ = self._body(self._slice({s for e in exprs for s in e.free_symbols}))
            outs = []
            for k, e in enumerate(exprs):
                e = self._signal_symbols(e)
                if isinstance(e, sp.Symbol) and e in self.names:
                    outs.append(self.names[e])
                else:
                    items.append(("assign", f"_e{k}", e))
                    outs.append(f"_e{k}")
            fname = f"expressions{len(self._on_demand)}"
            src = self._render(fname, items, [f"    return [{', '.join(outs)}{',' if len(outs) == 1 else ''}]"])
            self._on_demand[key] = self._define(fname, src)
        return self._on_demand[key]

    def sensitivity_function(self, wrt, bindings=None, outputs=None):
        """Generate (once per argument set, then cached) ``sens(t, x, p, d, u) -> (values, dx, dp)``.

        ``values`` (shape ``(m,) + b``) are the outputs, ``dx`` (``(m, n_states) + b``) their partial derivatives
        with respect to the states and ``dp`` (``(m, q) + b``) those with respect to the parameters named in
        ``wrt`` (at fixed states), ``b`` the broadcast shape of ``t``/``p``. Outputs are the unknowns in
        :attr:`unknowns` order by default, else ``outputs``: sympy expressions of states, unknowns, parameters,
        modes, time and signal calls (e.g. alias definitions).

        ``bindings`` maps a parameter to the expression of other parameters that defines its value (its default
        binding, e.g. ``winding.C = 1/winding_heating``): such a parameter is seeded with its total derivative
        through the chain of bindings (symbolic). A parameter named in ``wrt`` is independent (its own binding
        is ignored). Discrete modes are piecewise constant (derivative zero). A requested parameter in the
        argument of an input signal call is not supported (the signal is numeric): :class:`ModelError`.
        """
        from ...model.symbols import par_symbol

        wrt = tuple(wrt)
        bindings = {k: sp.sympify(v) for k, v in (bindings or {}).items() if k not in wrt}
        outs = [var_symbol(v) for v in self.unknowns] if outputs is None else [sp.sympify(o) for o in outputs]
        key = (wrt, frozenset(bindings.items()), None if outputs is None else tuple(outs))
        cache = self._on_demand
        if key in cache:
            return cache[key]
        for w in wrt:
            if w not in self.params:
                raise ModelError(f"sensitivity: {w!r} is no parameter of the model")
        n, q, m = len(self.states), len(wrt), len(outs)
        seeds = {var_symbol(s): {i: sp.Integer(1)} for i, s in enumerate(self.states)}
        for name, col in binding_totals(self.params, wrt, bindings).items():
            seeds[par_symbol(name)] = {n + j: e for j, e in col.items()}
        step_ids = list(range(len(self.steps))) if outputs is None else \
            self._slice({s for o in outs for s in o.free_symbols})
        for e in [e for k in step_ids for e in step_exprs(self.steps[k])] + outs:
            for call in (e.atoms(SignalCall) if e.has(SignalCall) else ()):
                hit = sorted({wrt[c - n] for s in call.args[2].free_symbols for c in seeds.get(s, {}) if c >= n})
                if hit:
                    raise ModelError(f"sensitivity with respect to {', '.join(map(repr, hit))}: it enters the "
                                     f"argument of the input signal {call.args[0].name!r} ({call.args[2]}), "
                                     "which is not differentiated; not supported")
        items, D = self._body(step_ids, seeds=seeds)
        vals, dxs, dps = [], [], []
        for k, o in enumerate(outs):
            o = self._signal_symbols(o)
            if isinstance(o, sp.Symbol) and o in self.names:
                sym = o
            else:  # an expression (alias definition): a value and its derivatives like any assignment
                sym = sp.Dummy(f"o{k}", real=True)
                self.names[sym] = f"_o{k}"
                items.append(("assign", f"_o{k}", o))
                self._jac_assign(sym, o, D, items)
            vals.append(self.names[sym])
            row = D.get(sym, {})
            for c in range(n + q):
                e = row.get(c, sp.Integer(0))
                if isinstance(e, sp.Symbol) and e in self.names:
                    ident = self.names[e]
                elif e == 0:
                    ident = "0.0"
                else:
                    ident = f"_o{k}_S{c}"
                    items.append(("assign", ident, e))
                (dxs if c < n else dps).append(ident)
        fname = f"sens{len(cache)}"
        body = [f"    _A = _stack([{', '.join(vals + dxs + dps)}])",
                f"    return (_A[:{m}], _A[{m}:{m * (1 + n)}].reshape(({m}, {n}) + _A.shape[1:]), "
                f"_A[{m * (1 + n)}:].reshape(({m}, {q}) + _A.shape[1:]))"]
        src = self._render(fname, items, body)
        for o in [s for s in self.names if isinstance(s, sp.Dummy)]:
            del self.names[o]  # output placeholders are local to this function
        cache[key] = self._define(fname, src, _stack=_stack)
        return cache[key]

    def _define(self, fname: str, src: str, **helpers):
        """The function ``fname`` of the generated source ``src``, defined beside the model's helper blocks in a
        copy of the generated functions' namespace (with ``helpers`` added); its source as ``.source``."""
        ns = dict(self._namespace, **helpers)
        exec(compile("\n\n".join(self._blocks + [src]) + "\n", f"<acausal generated {fname}>", "exec"), ns)
        fn = ns[fname]
        fn.source = src
        return fn


def _stack(values) -> np.ndarray:
    """:func:`runtime.bstack`, with a fast path for plain floats (the integrator's scalar calls)."""
    try:
        return np.array(values, dtype=float)  # all scalars, or arrays of one shape
    except ValueError:  # mixed shapes: broadcast
        return runtime.bstack(values)
