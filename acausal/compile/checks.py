"""What ``compile_model`` checks of a flattened, index-reduced model before it solves and generates code: every
symbol is something the model declares, and every derivative of a numeric input that the equations use is one its
signal provides."""
from __future__ import annotations

import sympy as sp

from ..errors import ModelError, SignalError
from .flatten import FlatModel
from ..model.signals import SignalCall
from ..model.symbols import split_der, time


def resolve(expr, flat: FlatModel):
    """Replace eliminated aliases in an expression by what they stand for."""
    rep = {s: flat.aliases[s.name] for s in expr.free_symbols if s.name in flat.aliases}
    return expr.xreplace(rep) if rep else expr


def check_symbols(flat, system):
    """Every symbol of an equation or event is a variable, parameter, mode, input or time (ModelError naming
    the equation's or event's component otherwise)."""
    known = set(flat.parameters) | set(flat.discretes) | set(flat.inputs)
    base = set(flat.variables)

    def stranger(expr):
        for s in sp.sympify(expr).free_symbols:
            if not (s is time or split_der(s.name)[0] in base or s.name in known or s.name in flat.aliases):
                return s.name
        return None

    for r, o in zip(system.residuals, system.origins):
        name = stranger(r)
        if name is not None:
            raise ModelError(f"equation from {o} uses {name!r}, which is no variable, parameter or input of "
                             "the model")
    for ev in flat.events:
        for e in [ev.zero, *ev.on_rising.values(), *ev.on_falling.values(), *ev.reinit.values()]:
            name = stranger(e)
            if name is not None:
                raise ModelError(f"event of {ev.origin} uses {name!r}, which is no variable, parameter, mode or "
                                 "input of the model")


def _signal_orders(flat, system) -> dict:
    """Input token -> ``(highest derivative order, origin)`` that the (index-reduced) equations and the event zero
    functions read of it."""
    need: dict = {}
    exprs = list(zip(system.residuals, system.origins)) + [(resolve(ev.zero, flat), ev.origin) for ev in flat.events]
    for r, o in exprs:
        if r.has(SignalCall):
            for c in r.atoms(SignalCall):
                tok, order = c.args[0].name, int(c.args[1])
                if order > need.get(tok, (-1, ""))[0]:
                    need[tok] = (order, o)
    return need


def check_signal_orders(flat, system) -> dict:
    """The derivatives of numeric inputs that the (index-reduced) equations use are ones their signals have;
    returns token -> the highest order used."""
    need = _signal_orders(flat, system)
    for tok, (order, o) in need.items():
        info = flat.inputs[tok]
        mo = info.signal.max_order
        if mo is not None and order > mo:
            raise SignalError(
                f"input {tok!r} of {info.owner}: index reduction needs its derivative of order {order} (for "
                f"{o}), but its signal {type(info.signal).__name__} provides derivatives only up to order {mo}")
    return {tok: order for tok, (order, _) in need.items()}
