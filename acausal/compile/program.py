"""The lowered program of a compiled model: one backend-neutral record per compile, which the numpy code generator
(:mod:`acausal.backends.numpy.printer`), the CasADi translation (:mod:`acausal.backends.casadi`) and the FMU's C code
(:mod:`acausal.export.ccode`) print, and nothing else.

A :class:`Program` holds, in the order every backend evaluates them:

* the layouts of the vectors a generated function takes: ``states``, ``unknowns`` (algebraic variables and state
  derivatives), ``params``, ``discretes`` (modes) and ``inputs`` (numeric input signals), by name;
* ``parameters``: every parameter with its binding (an expression of others, listed after them) or its default
  (:func:`~acausal.compile.parameters.parameter_plan`), and ``assertions``, the conditions on them;
* ``steps``: the solved steps in evaluation order: :class:`~acausal.compile.solve.Assign`,
  :class:`~acausal.compile.solve.LinearSolve` (``A y = b``) and :class:`~acausal.compile.solve.NewtonSolve` (residuals,
  their exact Jacobian, start guesses and the split rules of indeterminate tear variables); :meth:`Program.slice` gives
  the steps a set of symbols needs;
* ``events``: per event its zero function and what it assigns when the zero rises or falls, and the states it
  reinitialises;
* ``aliases``: the eliminated variables as expressions of the others;
* ``signal_calls`` and ``signal_orders``: every read of a numeric input, as ``(input, derivative order,
  argument)``, and the highest order per input: what a backend's form of each signal must provide.

:func:`lower` turns a printer's statement list into the same statements with their common subexpressions (sympy
``cse``) as temporaries, each placed just before its first use: every printer shares that rule.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import sympy as sp

from ..errors import ModelError
from .parameters import parameter_plan
from ..model.signals import SignalCall
from .solve import Assign, NewtonSolve, step_exprs, step_vars
from ..model.symbols import var_symbol


@dataclass(frozen=True)
class EventRule:
    """One event: its zero function (in variables, parameters, modes and time) and, as ``(name, expression)``
    pairs evaluated before any is made, the modes it sets when the zero crosses upwards (``rising``) or downwards
    (``falling``) and the states it restarts when it rises (``reinit``)."""

    origin: str
    zero: sp.Expr
    rising: tuple = ()
    falling: tuple = ()
    reinit: tuple = ()


@dataclass(frozen=True)
class Program:
    """The solved system of one compile as every backend prints it (see the module's docstring)."""

    states: tuple
    unknowns: tuple
    params: tuple
    discretes: tuple
    inputs: tuple
    parameters: tuple  # (name, info, binding or None, default or None), a bound parameter after those it uses
    assertions: tuple  # (condition, message, origin) on parameters
    steps: tuple
    events: tuple  # EventRule per event, in zero-function order
    aliases: dict = field(default_factory=dict)
    signal_orders: dict = field(default_factory=dict)  # input -> the highest derivative order read
    # derived from the steps (never given; dataclasses.replace derives them again): variable symbol -> index of the
    # step computing it; the variables of the Newton blocks; whether evaluating the unknowns cannot fail (every step
    # an assignment and no numeric input: a block can fail to converge, a signal refuse a time); and variable ->
    # its assignment's expression (when first asked for)
    defined_by: dict = field(init=False, repr=False, compare=False)
    newton_variables: tuple = field(init=False, repr=False, compare=False)
    plain: bool = field(init=False, repr=False, compare=False)
    _assigned: dict | None = field(init=False, default=None, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "defined_by", {var_symbol(v): k for k, st in enumerate(self.steps)
                                                for v in step_vars(st)})
        object.__setattr__(self, "newton_variables", tuple(v for st in self.steps if isinstance(st, NewtonSolve)
                                                           for v in st.vars))
        object.__setattr__(self, "plain", not self.inputs and all(isinstance(st, Assign) for st in self.steps))

    @property
    def zeros(self) -> list:
        """The event zero functions, in event order."""
        return [ev.zero for ev in self.events]

    @property
    def bindings(self) -> dict:
        """Bound parameters: name -> the expression of the others that gives its value."""
        return {name: binding for name, _, binding, _ in self.parameters if binding is not None}

    @property
    def signal_calls(self) -> list:
        """Every ``(input, order, argument)`` the steps and the events read, sorted."""
        calls = set()
        exprs = [e for st in self.steps for e in step_exprs(st)]
        exprs += [e for ev in self.events for e in [ev.zero] + [x for _, x in ev.rising + ev.falling + ev.reinit]]
        for e in exprs:
            if isinstance(e, sp.Basic) and e.has(SignalCall):
                calls |= {(c.args[0].name, int(c.args[1]), c.args[2]) for c in e.atoms(SignalCall)}
        return sorted(calls, key=lambda c: (c[0], c[1], sp.srepr(c[2])))

    def slice(self, targets) -> list:
        """Indices of the steps needed to compute the symbols ``targets`` (a backward slice), in evaluation order."""
        need, todo, seen = set(), list(targets), set()
        while todo:
            s = todo.pop()
            if s in seen:
                continue
            seen.add(s)
            k = self.defined_by.get(s)
            if k is None or k in need:
                continue
            need.add(k)
            for e in step_exprs(self.steps[k]):
                todo.extend(e.free_symbols)
        return sorted(need)

    def assignment(self, name: str):
        """The expression an explicit assignment computes variable ``name`` from, or None (a state, or a variable
        of a linear or Newton block)."""
        if self._assigned is None:
            object.__setattr__(self, "_assigned", {st.var: st.expr for st in self.steps if isinstance(st, Assign)})
        return self._assigned.get(str(name))

    def evaluation_order(self) -> list:
        """The variables the steps compute, in the order they compute them."""
        return [v for st in self.steps for v in step_vars(st)]

    @staticmethod
    def describe(st) -> str:
        """A numeric block as error messages name it: its variables and the components of its equations."""
        kind = "nonlinear block" if isinstance(st, NewtonSolve) else "linear block"
        return (f"the {kind} of {', '.join(repr(v) for v in st.vars)} (equations from "
                f"{', '.join(sorted(set(st.origins)))})")


def build_program(flat, system, signal_orders: dict) -> Program:
    """The program of a flattened model (aliases eliminated) and its solved system (``system.steps``), every
    expression in the model's variables (aliases resolved). An event that assigns anything but a mode, or
    reinitialises anything but a state, is a :class:`ModelError` naming its component."""
    from .checks import resolve
    states = tuple(system.states)
    events = []
    for ev in flat.events:
        rules = {}
        for direction, table in (("rising", ev.on_rising), ("falling", ev.on_falling)):
            pairs = []
            for sym, expr in table.items():
                name = getattr(sym, "name", str(sym))
                if name not in flat.discretes:
                    raise ModelError(f"event of {ev.origin} assigns {name!r}, which is not a discrete mode")
                pairs.append((name, resolve(sp.sympify(expr), flat)))
            rules[direction] = tuple(pairs)
        reinit = tuple((getattr(sym, "name", str(sym)), resolve(sp.sympify(expr), flat))
                       for sym, expr in ev.reinit.items())
        for name, _ in reinit:
            if name not in states:
                raise ModelError(f"event of {ev.origin} reinitialises {name!r}, which is not a state of the compiled "
                                 f"model (its states: {', '.join(states) or 'none'}); give it state_select='prefer' "
                                 "or 'always' if its derivative is in the equations")
        events.append(EventRule(ev.origin, resolve(ev.zero, flat), rules["rising"], rules["falling"], reinit))
    return Program(states, tuple(system.unknowns), tuple(sorted(flat.parameters)), tuple(sorted(flat.discretes)),
                   tuple(sorted(flat.inputs)), tuple(parameter_plan(flat)), tuple(flat.assertions),
                   tuple(system.steps), tuple(events), dict(flat.aliases), dict(signal_orders))


def numbered(prefix: str):
    """Fresh real symbols ``prefix0``, ``prefix1``, ... (common-subexpression temporaries)."""
    for i in itertools.count():
        yield sp.Symbol(f"{prefix}{i}", real=True)


def lower(items, prefix: str) -> list:
    """The statements of one generated function with their common subexpressions shared.

    ``items``: ``("assign", target, expression)`` or ``("code", text, payload)`` (verbatim, passed through). The
    result has the same statements, each assignment's expression reduced, preceded by ``("temp", symbol,
    expression)`` for every temporary (named ``prefix0``, ``prefix1``, ...) it is the first to use, after the
    temporaries that temporary uses: no temporary runs ahead of the step that defines its inputs."""
    exprs = [sp.sympify(e) for kind, _, e in items if kind == "assign"]
    reps, reduced = sp.cse(exprs, symbols=numbered(prefix), optimizations=None) if exprs else ([], [])
    rep_map = dict(reps)
    rank = {s: i for i, (s, _) in enumerate(reps)}
    out, emitted = [], set()

    def temps(expr):
        for s in sorted(expr.free_symbols & rep_map.keys(), key=rank.__getitem__):
            if s not in emitted:
                temps(rep_map[s])
                emitted.add(s)
                out.append(("temp", s, rep_map[s]))

    it = iter(reduced)
    for kind, target, payload in items:
        if kind == "assign":
            e = next(it)
            temps(e)
            out.append(("assign", target, e))
        else:
            out.append((kind, target, payload))
    return out
