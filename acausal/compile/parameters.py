"""Parameter values of a compiled model: the order in which the parameter vector is computed (bound parameters after
those their expressions use) and the check of every value (a number, or an array for a batch of runs) against its
parameter's bounds, with errors naming the parameter and its owner; and the derivatives of bound parameters through
their chain of bindings (:func:`binding_totals`, for sensitivities)."""
from __future__ import annotations

import math

import numpy as np
import sympy as sp

from ..errors import ModelError
from ..model.declarations import beyond
from ..model.symbols import par_symbol


def parameter_plan(flat) -> list:
    """How :meth:`CompiledModel.param_vector` computes the parameters: ``(name, info, binding, default)`` in an
    order where every bound parameter comes after those its expression uses; ``binding`` is that expression
    (None for a number), ``default`` the number (None for a binding). A cycle of bindings is a ModelError."""
    deps = {}
    for n, info in flat.parameters.items():
        deps[n] = {s.name for s in info.value.free_symbols} if isinstance(info.value, sp.Basic) else set()
    order, done = [], set()

    def visit(n, stack=()):
        if n in done:
            return
        if n in stack:
            raise ModelError(f"parameter bindings form a cycle: {' -> '.join(stack + (n,))}")
        for m in sorted(deps[n]):
            visit(m, stack + (n,))
        done.add(n)
        order.append(n)

    for n in sorted(deps):
        visit(n)
    plan = []
    for n in order:
        info = flat.parameters[n]
        if isinstance(info.value, sp.Basic) and not info.value.is_number:
            plan.append((n, info, info.value, None))
        else:
            plan.append((n, info, None, float(info.value)))
    return plan


def bound_message(flat, name: str, binding) -> str:
    """Why parameter ``name``, bound to ``binding`` in the model, cannot be overridden alone, and what to set."""
    free = sorted(str(s) for s in getattr(binding, "free_symbols", ()))
    owner = flat.parameters[name].owner if name in flat.parameters else ""
    return (f"parameter {name!r}{f' of {owner}' if owner else ''} is bound to {binding} in the model: set "
            f"{', '.join(repr(f) for f in free) or 'the parameters it depends on'} instead (an override of "
            f"{name!r} alone would disagree with them)")


def check_parameter(info, v) -> bool:
    """Check one parameter value (a number, or an array of values for a batch of runs) for finiteness and
    against the parameter's bounds (met within rounding: :func:`~acausal.model.declarations.beyond`); True when it
    is an array of values. Numbers take the fast path."""
    if isinstance(v, (float, int)) and not isinstance(v, bool):
        finite, low, high, batch = math.isfinite(v), v, v, False
    elif isinstance(v, (str, bytes, bool, np.bool_)):  # "0.5" or True would pass np.asarray as numbers
        raise ModelError(f"parameter {info.name!r} of {info.owner}: {v!r} is a {type(v).__name__}, not a number "
                         f"[{info.unit}]")
    else:
        try:
            arr = np.asarray(v, dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"parameter {info.name!r} of {info.owner}: {v!r} is not a number or an array of "
                             "numbers") from None
        finite, batch = bool(np.all(np.isfinite(arr))), arr.ndim > 0
        low, high = (arr.min(), arr.max()) if finite and arr.size else (math.inf, -math.inf)
    if not finite:
        raise ModelError(f"parameter {info.name!r} of {info.owner} is not finite: {v}")
    if info.min is not None and beyond(low, info.min, False):
        raise ModelError(f"parameter {info.name!r} of {info.owner} = {v} is below its minimum {info.min} "
                         f"[{info.unit}]")
    if info.nonzero and (v == 0 if not batch else bool(np.any(arr == 0))):
        raise ModelError(f"parameter {info.name!r} of {info.owner} is 0, which it must not be ({info.doc})")
    if info.max is not None and beyond(high, info.max, True):
        raise ModelError(f"parameter {info.name!r} of {info.owner} = {v} is above its maximum {info.max} "
                         f"[{info.unit}]")
    return batch


def binding_totals(params, wrt, bindings) -> dict:
    """``{parameter: {j: d parameter / d wrt[j]}}`` (sympy, nonzero entries only) through the chain of
    ``bindings`` (parameter -> expression of other parameters); a parameter named in ``wrt`` is independent."""
    wrt = tuple(wrt)
    exprs = {k: sp.sympify(e) for k, e in (bindings or {}).items() if k not in wrt}
    bound = {k: e.xreplace({s: par_symbol(s.name) for s in e.free_symbols}) for k, e in exprs.items()}
    memo: dict = {}

    def total(name, j):
        if (name, j) not in memo:
            if name == wrt[j]:
                memo[name, j] = sp.Integer(1)
            elif name in bound:
                e = bound[name]
                memo[name, j] = sp.Add(*[e.diff(s) * total(s.name, j) for s in e.free_symbols])
            else:
                memo[name, j] = sp.Integer(0)
        return memo[name, j]

    out = {}
    for name in params:
        col = {j: total(name, j) for j in range(len(wrt))}
        col = {j: e for j, e in col.items() if e != 0}
        if col:
            out[name] = col
    return out
