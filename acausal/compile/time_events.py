"""Time events, as Modelica has them: relations of time with a threshold of parameters become modes switched by
state events at their thresholds (the pipeline stage after alias elimination, before structural analysis)."""
from __future__ import annotations

import sympy as sp

from .flatten import DiscreteInfo, FlatEvent, FlatModel
from ..model.symbols import par_symbol, time

_TIME_EVENT = "time_event"  # prefix of the discrete modes that stand for relations of time


def time_events(flat: FlatModel) -> None:
    """Time events, as Modelica has them: every relation of time with a threshold of parameters in the equations
    (``time < start_time`` in a Step's Piecewise) becomes a mode ``time_event<k>`` (1 from the threshold on) set
    by a state event on ``time - threshold``, and the relation reads the mode. So the integrator stops exactly at
    the threshold and restarts there (a jump or a kink in time is not stepped over), and the relation changes
    value only at that event, on both simulation paths and in an exported FMU."""
    params = set(flat.parameters)
    thresholds: dict = {}

    def convert(rel):
        if not isinstance(rel, (sp.StrictLessThan, sp.LessThan, sp.StrictGreaterThan, sp.GreaterThan)):
            return None
        e = sp.expand(rel.lhs - rel.rhs)
        slope = e.diff(time)
        if not e.has(time) or not slope.is_number or slope == 0:
            return None
        rest = e - slope * time
        if rest.has(time) or any(sym.name not in params for sym in rest.free_symbols):
            return None
        c = sp.nsimplify(-rest / slope) if rest.is_number else -rest / slope
        if c not in thresholds:
            name = f"{_TIME_EVENT}{len(thresholds)}"
            thresholds[c] = par_symbol(name)
            flat.discretes[name] = DiscreteInfo(name, "(time events)", 0.0, f"1 from t = {c} s on")
            flat.time_events[name] = c
            flat.events.append(FlatEvent(time - c, {thresholds[c]: 1}, {thresholds[c]: 0}, f"time event t = {c}"))
        after = thresholds[c] > sp.Rational(1, 2)  # time >= c
        before = thresholds[c] < sp.Rational(1, 2)
        upward = isinstance(rel, (sp.StrictGreaterThan, sp.GreaterThan))  # e > 0
        return after if upward == (slope > 0) else before

    def rewrite(expr):
        expr = sp.sympify(expr)
        if not expr.has(time) or not expr.atoms(sp.Rel):
            return expr
        # in a canonical order (not the set's, which differs per hash seed): the events' numbers are part of the
        # result (res.events, the generated code, an FMU's event indicators)
        rep = {r: c for r in sorted(expr.atoms(sp.Rel), key=sp.default_sort_key) if (c := convert(r)) is not None}
        return expr.xreplace(rep) if rep else expr

    for eq in flat.equations:
        eq.residual = rewrite(eq.residual)
    for name in list(flat.aliases):
        flat.aliases[name] = rewrite(flat.aliases[name])
