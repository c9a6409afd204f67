"""Flatten a hierarchical model into one list of equations over hierarchically named variables.

Connection semantics (as in Modelica), level by level: at each composite model, the ports of its direct
sub-components are *inside* connectors and its own ports are *outside* connectors. Connected ports form
connection sets; in each set the potentials are equal and ``sum(inside flows) - sum(outside flows) = 0``. An
inside port connected to nothing forms a set of its own, so its flow is zero (the Modelica rule); the top-level
model's own ports are likewise treated as unconnected. A ``required`` port left unconnected is an error.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from ..model.components import Component, Connector
from ..model.declarations import _STATE_SELECT, Discrete, Flow, Input, Parameter, Potential, Variable
from ..errors import ConnectError, ModelError
from ..model.signals import Signal
from ..model.symbols import split_der, var_symbol


@dataclass
class VarInfo:
    name: str
    owner: str
    unit: str = "1"
    doc: str = ""
    start: float = 0.0
    fixed: bool = False
    start_given: bool = False
    state_select: int = 2
    nominal: float = 1.0
    kind: str = "variable"  # "variable", "potential" or "flow"


@dataclass
class ParInfo:
    name: str
    owner: str
    value: object  # float or sympy expression of other parameters
    unit: str = "1"
    doc: str = ""
    min: float | None = None
    max: float | None = None
    device: str = ""  # the device whose datasheet default this is, when the value was left at that default
    nonzero: bool = False  # 0 is refused (a divisor, a ratio that would lock a drive)
    nominal: float | None = None  # typical magnitude (a fit's scale)
    fit_range: tuple | None = None  # (lower, upper) a fit searches


@dataclass
class DiscreteInfo:
    name: str
    owner: str
    start: float = 0.0
    doc: str = ""


@dataclass
class InputInfo:
    name: str  # token, e.g. "pos.phi_ref"
    owner: str
    signal: Signal
    unit: str = "1"
    doc: str = ""


@dataclass
class FlatEquation:
    residual: sp.Expr
    origin: str  # "Resistor 'R1'" or "connect(a, b)"
    written: tuple | str = ""  # as the component wrote it: its two sides, or the text; see text

    @property
    def text(self) -> str:
        """The equation as the component wrote it ("R.v = R.R*R.i"; see FlatModel.written), printed when asked
        for (printing every equation of a model took a fifth of its compile time)."""
        if isinstance(self.written, tuple):
            lhs, rhs = self.written
            return f"{sp.sstr(lhs)} = {sp.sstr(rhs)}"
        return self.written


@dataclass
class FlatEvent:
    zero: sp.Expr
    on_rising: dict
    on_falling: dict
    origin: str
    reinit: dict = field(default_factory=dict)  # state -> value when zero rises


@dataclass
class FlatModel:
    name: str
    variables: dict = field(default_factory=dict)
    parameters: dict = field(default_factory=dict)
    discretes: dict = field(default_factory=dict)
    inputs: dict = field(default_factory=dict)
    equations: list = field(default_factory=list)
    events: list = field(default_factory=list)
    components: dict = field(default_factory=dict)  # path -> class name
    aliases: dict = field(default_factory=dict)  # name -> expression in kept variables / parameters
    alias_info: dict = field(default_factory=dict)  # eliminated name -> its variable's info (unit, doc)
    # eliminated variables with a fixed start whose alias class is a constant (an expression of parameters, e.g.
    # a capacitor voltage clamped by a source): name -> fixed start, checked at initialisation
    fixed_constants: dict = field(default_factory=dict)
    written: list = field(default_factory=list)  # the equations as written, before alias elimination
    time_events: dict = field(default_factory=dict)  # mode name -> threshold time (expression of parameters)
    # variable name -> (nominal, scale, origin): the rule for a variable the equations may leave free (Indeterminate)
    indeterminates: dict = field(default_factory=dict)
    # (condition on parameters, message, origin): what every run's parameters must meet (Component.assertions)
    assertions: list = field(default_factory=list)

    def equations_of(self, component: str | None = None) -> list:
        """The equations as written (:class:`FlatEquation`, ``text`` set) of the component at path
        ``component`` and everything inside it, with the connections made inside it (all when None)."""
        if not component:
            return list(self.written)
        inside = component + "."

        def within(path):
            return path == component or path.startswith(inside)

        out = []
        for e in self.written:
            if e.origin.startswith("connect("):
                members = e.origin[len("connect("):-1].split(", ")
                keep = all(m.startswith(inside) for m in members)
            elif e.origin.startswith("unconnected port "):
                keep = within(e.origin.split("'")[1])
            else:
                keep = within(e.origin.split("'")[1]) if "'" in e.origin else False
            if keep:
                out.append(e)
        return out

    def owner_of(self, name: str) -> str:
        base, _ = split_der(name)
        if base in self.variables:
            return self.variables[base].owner
        return base.rsplit(".", 1)[0] if "." in base else ""


def _walk(root: Component):
    """All components below ``root`` (root included), sorted by path."""
    out, stack = [], [root]
    while stack:
        c = stack.pop()
        out.append(c)
        stack.extend(c._children.values())
    return sorted(out, key=lambda c: c._path)


def flatten(model: Component) -> FlatModel:
    if model._parent is not None:
        raise ModelError(f"{model._describe()} is part of another model; compile the top-level model")
    model._set_path("")
    model._ensure_built()
    flat = FlatModel(name=type(model).__name__)
    comps = _walk(model)
    for c in comps:
        flat.components[c._path] = type(c).__name__
        _collect_declarations(c, flat)
    for c in comps:
        origin = c._describe()
        for eq in c.equations():
            res = _residual(eq, origin)
            written = (eq.lhs, eq.rhs) if isinstance(eq, sp.Equality) else (sp.Integer(0), res)
            flat.equations.append(FlatEquation(res, origin, written))
        for ev in c.events():
            flat.events.append(FlatEvent(sp.sympify(ev.zero), dict(ev.on_rising), dict(ev.on_falling), origin,
                                         dict(ev.reinit)))
        for ind in c.indeterminates():
            name = getattr(ind.var, "name", None)
            if name not in flat.variables:
                raise ModelError(f"{origin}: Indeterminate({ind.var!r}) is not a variable of the model")
            flat.indeterminates[name] = (sp.sympify(ind.nominal), sp.sympify(ind.scale), origin)
        for cond, message in c.assertions():
            flat.assertions.append((cond, message, origin))
    for c in comps:
        if not isinstance(c, Connector):
            _connection_equations(c, flat, is_root=c is model)
    _check_parameter_bindings(flat)
    _check_assertions(flat)
    flat.written = list(flat.equations)
    return flat


def _check_assertions(flat) -> None:
    """Each assertion is a relation of parameters only (it is checked before a run, from the parameter vector)."""
    for cond, message, origin in flat.assertions:
        if not isinstance(cond, sp.core.relational.Relational):
            raise ModelError(f"{origin}: assertion {cond!r} ({message}) is not a relation such as "
                             "self.u_max >= self.u_min")
        other = sorted(s.name for s in cond.free_symbols if s.name not in flat.parameters)
        if other:
            raise ModelError(f"{origin}: assertion {cond} ({message}) uses {', '.join(other)}, which "
                             f"{'is not a parameter' if len(other) == 1 else 'are not parameters'}")


def _residual(eq, origin):
    if isinstance(eq, sp.Equality):
        res = eq.lhs - eq.rhs
        if res.is_number:  # written unevaluated (acausal.Eq): one that holds always or never is an error here
            raise ModelError(f"{origin}: the equation {sp.sstr(eq.lhs)} = {sp.sstr(eq.rhs)} "
                             f"{'holds whatever the variables are' if res == 0 else 'can never hold'}: it determines "
                             "nothing; write equations of the component's variables")
        return res
    if isinstance(eq, bool) or eq in (sp.true, sp.false):
        raise ModelError(f"{origin}: an equation evaluated to {eq}; write equations with sympy.Eq(lhs, rhs)")
    try:
        return sp.sympify(eq)
    except (sp.SympifyError, TypeError) as exc:
        raise ModelError(f"{origin}: cannot read equation {eq!r}: {exc}") from None


def _collect_declarations(c: Component, flat: FlatModel):
    origin = c._path or "(top level)"
    for name, d in c.declarations().items():
        path = c._child_path(name)
        if isinstance(d, Parameter):
            value = c._values.get(name, d.default)
            if value is None:
                raise ModelError(f"{c._describe()}: parameter {name!r} has no value and no default")
            if not isinstance(value, (sp.Basic, int, float)):
                try:
                    value = float(value)
                except (TypeError, ValueError):
                    raise ModelError(f"{c._describe()}: parameter {name!r} = {value!r} is not a number "
                                     "or an expression of parameters") from None
            device = d.device if name not in c._values else ""
            flat.parameters[path] = ParInfo(path, origin, value, d.unit, d.doc, d.min, d.max, device, d.nonzero,
                                            d.nominal, d.fit_range)
        elif isinstance(d, Variable):
            st = c._starts.get(name)
            kind = "flow" if isinstance(d, Flow) else "potential" if isinstance(d, Potential) else "variable"
            flat.variables[path] = VarInfo(
                path, origin, d.unit, d.doc,
                start=float(st.value) if st else float(d.start),
                fixed=st.fixed if st else d.fixed,
                start_given=st is not None or d.fixed or d.start != 0.0,
                state_select=_STATE_SELECT[d.state_select], nominal=d.nominal, kind=kind)
        elif isinstance(d, Discrete):
            st = c._starts.get(name)
            flat.discretes[path] = DiscreteInfo(path, origin, float(st.value) if st else float(d.start), d.doc)
        elif isinstance(d, Input):
            value = c._inputs.get(name, d.default)
            if isinstance(value, Signal):
                flat.inputs[path] = InputInfo(path, origin, value, d.unit, d.doc)


def _connector_vars(port: Connector):
    pots, flows = [], []
    for name, d in type(port).declarations().items():
        if isinstance(d, Flow):
            flows.append(name)
        elif isinstance(d, Potential):
            pots.append(name)
    return pots, flows


def _connection_equations(m: Component, flat: FlatModel, is_root: bool):
    inside = [p for child in m._children.values() if not isinstance(child, Connector)
              for p in child._children.values() if isinstance(p, Connector)]
    outside = [p for p in m._children.values() if isinstance(p, Connector)]
    parent = {id(p): id(p) for p in inside + outside}

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    connected = set()
    for a, b in m._connections:
        connected.update((id(a), id(b)))
        parent[find(id(a))] = find(id(b))
    sets: dict[int, list] = {}
    for p in inside + outside:
        if id(p) in connected or p in inside or is_root:
            sets.setdefault(find(id(p)), []).append(p)
    is_outside = {id(p) for p in outside}
    for members in sorted(sets.values(), key=lambda ms: min(p._path for p in ms)):
        members.sort(key=lambda p: p._path)
        if len(members) == 1 and id(members[0]) not in connected:
            p = members[0]
            if p.required and id(p) not in is_outside:
                raise ConnectError(f"port {p._path!r} ({type(p).__name__}) of {p._parent._describe()} "
                                   "is required but not connected")
        origin = "connect(" + ", ".join(p._path for p in members) + ")"
        pots, flows = _connector_vars(members[0])
        for name in pots:
            ref = var_symbol(members[0]._child_path(name))
            for p in members[1:]:
                flat.equations.append(FlatEquation(var_symbol(p._child_path(name)) - ref, origin,
                                                   (var_symbol(p._child_path(name)), ref)))
        for name in flows:
            total = sum((-1 if id(p) in is_outside else 1) * var_symbol(p._child_path(name)) for p in members)
            flat.equations.append(FlatEquation(sp.sympify(total), origin if len(members) > 1 or id(members[0]) in connected
                                               else f"unconnected port {members[0]._path!r} (flow = 0)",
                                               (sp.Integer(0), total)))


def _check_parameter_bindings(flat: FlatModel):
    names = set(flat.parameters)
    for p in flat.parameters.values():
        if isinstance(p.value, sp.Basic):
            unknown = {s.name for s in p.value.free_symbols} - names
            if unknown:
                raise ModelError(f"parameter {p.name!r} is bound to {p.value}, which uses {sorted(unknown)}: "
                                 "not parameters of the model")
