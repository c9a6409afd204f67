"""Which solved equations can give a value that is not finite from finite arguments.

The trust check's search for non-finite values (:func:`acausal.results.trust.nonfinite`) evaluates the model's unknowns
at sampled output times. Most of them cannot be infinite or NaN there: a sum, a product, a small integer power, a sine,
an absolute value or a piecewise choice of finite values is finite, and so is a quotient by an expression of
parameters that is not zero. :func:`plan` sorts a model's solved steps once into

* the unknowns whose equation holds an operation that can leave the finite numbers on finite arguments (a division
  by a variable, a root, a logarithm, an exponential, a larger or non-integer power, a function not listed here, a
  linear or Newton block) — these are evaluated at the samples;
* the parameter expressions the others divide by — checked per run (:func:`moderate`).

A value of a safe equation can still overflow when its arguments are huge (products of products of 1e100); the
analysis holds where the states, the parameters and the inverses of the divisors stay within :data:`MODERATE`,
which :func:`moderate` checks per run, and the trust check evaluates every unknown where they do not.
"""
from __future__ import annotations

import numpy as np
import sympy as sp

MODERATE = 1e20  # largest magnitude of a state, a parameter or a divisor's inverse for which the analysis holds
_SAFE_FUNCTIONS = (sp.sin, sp.cos, sp.atan, sp.tanh, sp.Abs, sp.sign, sp.Min, sp.Max, sp.floor, sp.ceiling,
                   sp.Piecewise, sp.functions.elementary.piecewise.ExprCondPair, sp.Add, sp.Mul)
_LOGIC = (sp.core.relational.Relational, sp.logic.boolalg.BooleanFunction)
MAX_POWER = 3  # integer powers up to this are safe: (1e20)^3 is far from overflow


def plan(cm) -> tuple:
    """``(names, divisors)`` of :mod:`this module <acausal.results.finite>` for the compiled model ``cm`` (found once
    per model): the unknowns to evaluate, and the parameter expressions the other unknowns divide by."""
    found = cm.derived.get("finite plan")
    if found is None:
        from ..compile.solve import Assign
        names, divisors = [], {}
        for st in cm.steps:
            if not isinstance(st, Assign):
                names.extend(st.vars)
            elif not isinstance(st.expr, (int, float)) and not _safe(sp.sympify(st.expr), cm, divisors):
                names.append(st.var)
        found = (names, list(divisors))
        cm.derived["finite plan"] = found
    return found


def moderate(cm, X, p, d, u, t) -> bool:
    """Whether the analysis holds for a run: its states ``X`` and parameters ``p`` within :data:`MODERATE` in
    magnitude and every divisor of :func:`plan` (a parameter expression, evaluated with ``p``) at least its
    inverse. False sends the trust check to evaluating every unknown."""
    if X.size and not np.abs(X).max() <= MODERATE:
        return False
    if np.size(p) and not np.abs(np.asarray(p, dtype=float)).max() <= MODERATE:
        return False
    divisors = plan(cm)[1]
    if not divisors:
        return True
    with np.errstate(all="ignore"):
        values = np.abs(np.array(cm.generator.expressions_function(divisors)(t, X[:, 0], p, d, u), dtype=float))
    return bool((values >= 1.0 / MODERATE).all())


def _safe(e, cm, divisors: dict) -> bool:
    """Whether ``e`` is finite whenever its symbols are (within :data:`MODERATE`) and the parameter expressions it
    divides by (collected into ``divisors``) are not zero."""
    if e.is_Number:
        return bool(e.is_finite)
    if e.is_Symbol or isinstance(e, (sp.logic.boolalg.BooleanTrue, sp.logic.boolalg.BooleanFalse)):
        return True
    if isinstance(e, sp.Pow):
        base, ex = e.args
        if not (ex.is_Integer and 0 < abs(int(ex)) <= MAX_POWER) or not _safe(base, cm, divisors):
            return False
        if ex > 0:
            return True
        if base.free_symbols and all(cm.has_parameter(str(s)) for s in base.free_symbols):
            divisors[base] = None
            return True
        return False
    if isinstance(e, _SAFE_FUNCTIONS + _LOGIC):
        return all(_safe(a, cm, divisors) for a in e.args)
    return False
