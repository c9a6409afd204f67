"""What a failed run says: the first non-finite unknown (the cause, not its consequences) with the component that
owns it and any parameter at zero that makes its system singular, or the state that changes fastest where an
integrator gave up. Used by :mod:`acausal.simulation.simulate` on the scipy path."""
from __future__ import annotations

import numpy as np
import sympy as sp

from ...errors import SimulationError
from ...compile.solve import step_vars


def zero_parameters_hint(cm, p, names) -> str:
    """A hint naming the parameters equal to zero of the components that own ``names`` (a zero resistance,
    capacitance or inertia makes a system singular although it lies inside the declared bounds)."""
    owners = {cm.flat.owner_of(n) for n in names} - {None}
    zero = [k for k, v in zip(cm.param_names, np.atleast_1d(p)) if np.ndim(v) == 0 and v == 0
            and k.rsplit(".", 1)[0] in owners]
    return (f"; {', '.join(f'{k} = 0' for k in zero)} makes the system singular: give a positive value"
            if zero else "")


def zero_divisors(cm, p) -> list:
    """The parameters equal to zero that an equation of ``cm`` divides by (a zero inside the declared bounds of a
    parameter its component divides by: ``i = v / R_on`` with ``R_on = 0``)."""
    zero = {k for k, v in zip(cm.param_names, np.atleast_1d(p)) if np.ndim(v) == 0 and v == 0}
    found = set()
    for st in cm.steps:
        expr = getattr(st, "expr", None)
        if zero and expr is not None and hasattr(expr, "atoms"):
            found |= {str(w.base) for w in expr.atoms(sp.Pow) if w.exp.is_negative and w.base.is_Symbol
                      and str(w.base) in zero}
    return sorted(found)


def divisor_hint(cm, p) -> str:
    """The sentence naming :func:`zero_divisors` and their components, or ``""``."""
    found = zero_divisors(cm, p)
    if not found:
        return ""
    paths = sorted({cm.flat.parameters[k].owner for k in found if k in cm.flat.parameters})
    owners = ", ".join(f"{cm.flat.components.get(o, 'component')} {o!r}" for o in paths)
    return (f"; {', '.join(f'{k} = 0' for k in found)} is divided by in an equation of {owners}: give a positive "
            "value (a component that divides by a parameter declares it nonzero=True or with a positive min)")


def non_finite_error(cm, t, x, p, d, u, where="rhs") -> SimulationError:
    """The error for a non-finite value at ``(t, x)``: the unknown that went non-finite first, its owner, the
    others after it, the non-finite states; with ``where="jac"`` and finite values, the Jacobian's entry."""
    # Evaluate at a numpy time so that a division by zero gives inf instead of raising, and name the
    # non-finite unknown computed *first* (the cause, e.g. y = sqrt(x)) rather than the first in name order
    # (often a derivative that merely depends on it, 'der(z)' for z' = y); the others follow as consequences.
    t_np = np.float64(t)
    x, p, d = (np.asarray(a, dtype=float) for a in (x, p, d))  # numpy scalars: a division by zero gives inf
    try:
        with np.errstate(all="ignore"):
            vals = cm.funcs["all_values"](t_np, x, p, d, u)
    except Exception:  # pragma: no cover - evaluation itself failed
        vals = []
    bad_state = [n for n, v in zip(cm.state_names, x) if not np.isfinite(v)]
    order = {v: k for k, st in enumerate(cm.steps) for v in step_vars(st)}
    value = dict(zip(cm.unknown_names, vals))
    bad = sorted((n for n, v in value.items() if not np.all(np.isfinite(v))),
                 key=lambda n: (order.get(n, len(order)), n))
    if bad:
        n = bad[0]
        owner = cm.flat.owner_of(n)
        return SimulationError(f"non-finite value at t = {t:.9g} s: {n!r} (of {owner or 'the model'}) = {value[n]}"
                               + (f"; then also {bad[1:]}" if len(bad) > 1 else "")
                               + (f"; non-finite states {bad_state}" if bad_state else "")
                               + zero_parameters_hint(cm, p, [n] + bad[1:]))
    if where == "jac":
        try:
            with np.errstate(all="ignore"):
                J = np.asarray(cm.funcs["jac"](t_np, x, p, d, u), dtype=float)
            i, j = np.argwhere(~np.isfinite(J))[0]
            return SimulationError(f"non-finite Jacobian at t = {t:.9g} s: d der({cm.state_names[i]}) / "
                                   f"d {cm.state_names[j]} = {J[i, j]} at {dict(zip(cm.state_names, x))}")
        except Exception:  # pragma: no cover
            pass
    return SimulationError(f"non-finite value at t = {t:.9g} s" + (f" in states {bad_state}" if bad_state else "")
                           + divisor_hint(cm, p))


def step_failure(cm, solver, msg, p, d, u, rtol, atol) -> SimulationError:
    """The error for a scipy integrator that gave up (``msg``): where, at which step size, and the state that
    changes fastest relative to its tolerance there."""
    t, x = solver.t, solver.y
    culprit = ""
    try:
        dx = cm.funcs["rhs"](t, x, p, d, u)
        scale = atol + rtol * np.abs(x)
        i = int(np.argmax(np.abs(dx) / scale))
        culprit = f"; fastest-changing state {cm.state_names[i]!r} = {x[i]:.6g} (d/dt = {dx[i]:.6g})"
    except Exception:  # pragma: no cover
        pass
    h = getattr(solver, "h_abs", None) or solver.step_size or 0.0
    return SimulationError(f"integration failed at t = {t:.9g} s with step size {h:.3g} s "
                           f"({solver.__class__.__name__}: {msg}){culprit}")
