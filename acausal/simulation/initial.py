"""Consistent initial states of a run: start values, fixed starts met by the free states (a minimum-norm
Gauss-Newton iteration), over-specified or inconsistent starts named. The C runtime of an exported FMU does the same
(``export/templates/fmi2_runtime.c``)."""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..errors import ModelError, SimulationError


def number(value, what: str) -> float:
    """``value`` as a float; a ModelError naming ``what`` when it is not a real number (a string or a bool is not:
    ``"1.0"`` and ``True`` are slips, taken literally elsewhere in Python)."""
    if isinstance(value, (str, bytes, bool, np.bool_)):
        raise ModelError(f"{what} must be a number, got the {type(value).__name__} {value!r}")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ModelError(f"{what} must be a number, got {value!r}") from None


def whole(value, what: str, least: int, why: str = "", then: str = "") -> int:
    """``value`` as an int >= ``least``; a ModelError naming ``what`` otherwise (a bool is no number here):
    "``what`` must be a positive integer``why``, got ``value````then``"."""
    if not isinstance(value, (int, np.integer)) or isinstance(value, (bool, np.bool_)) or value < least:
        kind = {0: "a non-negative integer", 1: "a positive integer"}.get(least, f"an integer >= {least}")
        raise ModelError(f"{what} must be {kind}{why}, got {value!r}{then}")
    return int(value)


def initialize(cm, t0, p, d, u, starts: dict | None = None) -> np.ndarray:
    """Consistent initial states.

    States take their start values; variables with ``fixed=True`` (or given in ``starts``) that are not states
    are met by adjusting the states that are not fixed, by a minimum-norm Gauss-Newton iteration from the
    start values. Inconsistent or over-specified initial conditions raise an error naming the variables.
    """
    flat = cm.flat
    if starts is not None and not isinstance(starts, Mapping):
        raise ModelError(f"starts must be a dict by variable name, got {type(starts).__name__}")
    starts = dict(starts or {})
    if starts:
        names = set(cm.names()) | set(flat.variables)
        for k, v in starts.items():
            if k not in names:
                raise cm.unknown_name_error(k, "variable", sorted(names))
            starts[k] = number(v, f"start value of {k!r}")
            if not np.isfinite(starts[k]):
                raise ModelError(f"starts={{{k!r}: {starts[k]}}}: the start value of {k!r} must be a finite number")
    x = np.empty(len(cm.state_names))
    fixed_state = np.zeros(len(cm.state_names), dtype=bool)
    for i, n in enumerate(cm.state_names):
        info = flat.variables.get(n)
        x[i] = info.start if info else 0.0
        if info is not None and info.fixed:
            fixed_state[i] = True
        if n in starts:
            x[i] = starts.pop(n)
            fixed_state[i] = True
        if not np.isfinite(x[i]):
            raise ModelError(f"the start value of {n!r} is {x[i]} (its Start(...) in the model); a start value must "
                             "be a finite number")
    targets = {}  # non-state fixed variables: name -> value
    if "fixed non-states" not in cm.derived:  # which they are is structure: found once per model
        states = set(cm.state_names)
        cm.derived["fixed non-states"] = [n for n, info in flat.variables.items() if info.fixed and n not in states]
    for n in cm.derived["fixed non-states"]:
        targets[n] = flat.variables[n].start
    for n, v in starts.items():
        targets[n] = float(v)
    # fixed starts of variables that alias elimination found to be constant (parameter expressions)
    for n, v in getattr(flat, "fixed_constants", {}).items():
        targets.setdefault(n, v)
    if not targets:
        return x
    free = np.flatnonzero(~fixed_state)
    names_t = sorted(targets)
    want = np.array([targets[n] for n in names_t])

    def resid(xf):
        xx = x.copy()
        xx[free] = xf
        vals = _value_lookup(cm, t0, xx, p, d, u)
        return np.array([vals(n) for n in names_t]) - want

    xf = x[free].copy()
    scale = np.maximum(1.0, np.abs(want))
    for _ in range(50):
        r = resid(xf)
        if np.all(np.abs(r) <= 1e-10 * scale):
            break
        if free.size == 0:
            break
        J = np.empty((r.size, free.size))
        for j in range(free.size):
            h = 1e-7 * max(1.0, abs(xf[j]))
            e = xf.copy()
            e[j] += h
            J[:, j] = (resid(e) - r) / h
        step, *_ = np.linalg.lstsq(J, -r, rcond=None)
        xf = xf + step
        if np.max(np.abs(step)) < 1e-14 * max(1.0, np.max(np.abs(xf))):
            break
    r = resid(xf)
    if not np.all(np.abs(r) <= 1e-7 * scale):
        const = getattr(flat, "fixed_constants", {})
        bad = [f"{n} (wanted {targets[n]:.6g}, got {targets[n] + ri:.6g}"
               + (f", which the equations make the constant {flat.aliases.get(n)})" if n in const else ")")
               for n, ri in zip(names_t, r) if abs(ri) > 1e-7 * max(1.0, abs(targets[n]))]
        fixed_states = [cm.state_names[i] for i in np.flatnonzero(fixed_state)]
        raise SimulationError(
            "inconsistent initial conditions: cannot meet " + ", ".join(bad)
            + (f" with the states {[cm.state_names[i] for i in free]} free" if free.size else " (no state is free)")
            + (f" and {fixed_states} fixed" if fixed_states else ""))
    x[free] = xf
    return x


def _value_lookup(cm, t, x, p, d, u):
    vals = dict(zip(cm.unknown_names, cm.funcs["all_values"](t, x, p, d, u)))
    vals.update(zip(cm.state_names, x))
    aliases = cm.flat.aliases

    def get(name):
        if name in vals:
            return float(vals[name])
        if name in aliases:
            return float(cm.eval_expr(aliases[name], vals, p, d, t))
        raise cm.unknown_name_error(name, "variable", cm.names())

    return get
