"""Components and ``connect``; the declarations they make (parameters, variables, discrete modes, prescribed
inputs) are in :mod:`acausal.model.declarations` (and importable from here).

A component is a Python class. Class attributes declare what it has::

    class Resistor(OnePort):
        R = Parameter(1.0, unit="Ohm", min=0.0, doc="resistance")

        def equations(self):
            return [*super().equations(), Eq(self.v, self.R * self.i)]

* :class:`Parameter` - constant during a run, overridable per run without recompiling.
* :class:`Variable` - a continuous unknown with a start value (``fixed=True`` makes it an initial condition).
* :class:`Discrete` - a piecewise-constant mode changed only by events (ideal diode on/off, friction mode).
* :class:`Input` - a prescribed signal (number, sympy expression of time, or :class:`acausal.model.signals.Signal`).
* A connector instance (``p = Pin()``) declares a port; each component instance gets its own copy.

Composite models create sub-components and connections in :meth:`Component.build`::

    class Circuit(Model):
        def build(self):
            self.R = Resistor(R=10.0)
            self.C = Capacitor(C=1e-3)
            connect(self.R.n, self.C.p)

``build`` runs when the model is compiled, top-down, once every instance knows its hierarchical name; a
parameter may then be bound to an expression of the enclosing model's parameters (``Resistor(R=2 * self.R0)``).
Inside ``equations`` and ``build``, ``self.x`` is the sympy symbol of ``x`` named by its path (``"motor.R.i"``).
"""
from __future__ import annotations

import numpy as np

import sympy as sp

from .declarations import (Discrete, Event, Flow, Indeterminate, Input, Parameter, Potential, Start, Variable,
                           _outside, _within, _Declaration)  # (the declarations: part of this interface)
from ..errors import ConnectError, ModelError
from .describe import ClassOrInstanceMethod, describe_component, doc_table
from .symbols import time

__all__ = ["Parameter", "Variable", "Potential", "Flow", "Discrete", "Input", "Start", "Event",
           "Indeterminate", "Component", "Model", "Connector", "connect"]


# --------------------------------------------------------------------------------------------- components
_BUILDING: list["Component"] = []  # stack of models whose build() is running (for connect)


class Component:
    """Base class of every component, connector and model (see the module docstring).

    ``describe()`` (on the class or an instance) lists the parameters, ports, inputs and variables; ``help()``
    shows the same parameter table after the class's own docstring."""

    doc_string = ""
    describe = ClassOrInstanceMethod(describe_component)

    def __init_subclass__(cls, **kw):
        super().__init_subclass__(**kw)
        if cls.__name__ not in ("Model", "Connector") and any(isinstance(d, Parameter) for d in cls.declarations().values()):
            doc = cls.__doc__ or ""
            rest = [ln for ln in doc.splitlines()[1:] if ln.strip()]
            pad = min((len(ln) - len(ln.lstrip()) for ln in rest), default=0) * " "
            cls.__doc__ = doc.rstrip() + "\n\n" + "\n".join(pad + ln for ln in doc_table(cls).splitlines())

    def __init__(self, doc: str = "", **values):
        if not isinstance(doc, str):  # Resistor(0.386): a value without its name would become the doc text
            raise ModelError(f"{type(self).__name__}({doc!r}, ...): the first positional argument is the doc "
                             f"text; give parameters by name, e.g. {type(self).__name__}(name=value)")
        object.__setattr__(self, "_path", "")
        object.__setattr__(self, "_parent", None)
        object.__setattr__(self, "_attr_name", None)
        object.__setattr__(self, "_children", {})
        object.__setattr__(self, "_connections", [])
        object.__setattr__(self, "_built", False)
        object.__setattr__(self, "_init_kwargs", dict(values, doc=doc))
        self._values: dict = {}
        self._starts: dict = {}
        self._inputs: dict = {}
        self.doc = doc
        for name, tpl in self._declared_ports():
            setattr(self, name, tpl._clone())
        decl = self.declarations()
        for key, value in values.items():
            d = decl.get(key)
            if isinstance(d, Parameter):
                if value is None:  # not "no value": the class may have a default the user did not mean to drop
                    has = d.default is not None
                    raise ModelError(f"{type(self).__name__}: parameter {key!r} = None; give a number [{d.unit}]"
                                     + (f" or leave it out for its default {d.default!r} {d.unit}" if has else
                                        " (it has no default)"))
                if isinstance(value, (str, bytes, bool, np.bool_)) or \
                        (isinstance(value, np.ndarray) and value.dtype.kind in "bSUO"):  # "0.5" parsed, True as 1
                    kind = f"an array of {value.dtype}" if isinstance(value, np.ndarray) else \
                        f"a {'bool' if isinstance(value, np.bool_) else type(value).__name__}"
                    raise ModelError(f"{type(self).__name__}: parameter {key!r} = {value!r} is {kind}; give a "
                                     f"number [{d.unit}] or an expression of parameters")
                if isinstance(value, sp.Basic) and value.is_number and not (value.is_real and value.is_finite):
                    raise ModelError(f"{type(self).__name__}: parameter {key!r} = {value} is not a finite real "
                                     f"number [{d.unit}]")
                if isinstance(value, (int, float, np.integer, np.floating)) and not _within(d, float(value)):
                    raise ModelError(f"{type(self).__name__}: parameter {key!r} = {value!r} is "
                                     + ("not finite" if value != value or abs(value) == float("inf") else
                                        _outside(d.min, d.max, d.unit)))
                self._values[key] = value
            elif isinstance(d, (Variable, Discrete)):
                self._starts[key] = self._start(key, d, value)
            elif isinstance(d, Input):
                self._inputs[key] = value
            else:
                known = ", ".join(sorted(k for k, v in decl.items() if not isinstance(v, Component)))
                raise ModelError(f"{type(self).__name__}: unknown parameter, variable or input {key!r}; "
                                 f"known: {known}")

    def _start(self, key, d, value) -> Start:
        """The start value given for variable or mode ``key`` (declared ``d``): a number or a :class:`Start`,
        checked (a real number within the variable's bounds, ``fixed`` a bool) where it is given."""
        st = value if isinstance(value, Start) else Start(value, getattr(d, "fixed", False))
        unit = getattr(d, "unit", "1")
        v = st.value
        bad = isinstance(v, (str, bytes, bool, np.bool_))
        if not bad:
            try:
                v = float(v)
            except (TypeError, ValueError):
                bad = True
        if bad:
            raise ModelError(f"{type(self).__name__}: start of {key!r} = {st.value!r} is a "
                             f"{type(st.value).__name__}; give a number [{unit}]")
        if not isinstance(st.fixed, (bool, np.bool_)):
            raise ModelError(f"{type(self).__name__}: Start({st.value!r}, fixed={st.fixed!r}) for {key!r}: fixed "
                             "must be True or False")
        low, high = getattr(d, "min", None), getattr(d, "max", None)
        if (low is not None and v < low) or (high is not None and v > high):
            raise ModelError(f"{type(self).__name__}: start of {key!r} = {v:g} is {_outside(low, high, unit)}")
        return Start(v, bool(st.fixed))

    # ---- declarations
    @classmethod
    def declarations(cls) -> dict:
        """All class-level declarations (parameters, variables, modes, inputs, port templates), base classes first."""
        out = {}
        for klass in reversed(cls.__mro__):
            for k, v in vars(klass).items():
                if isinstance(v, (_Declaration, Component)):
                    out[k] = v
        return out

    @classmethod
    def _declared_ports(cls):
        return [(k, v) for k, v in cls.declarations().items() if isinstance(v, Component)]

    def __set_name__(self, owner, name):  # a connector/component declared as a class attribute
        object.__setattr__(self, "_attr_name", name)

    def _clone(self):
        return type(self)(**self._init_kwargs)

    # ---- hierarchy
    def __setattr__(self, name, value):
        if isinstance(value, Component) and not name.startswith("_"):
            if value is self:
                raise ModelError(f"{self._describe()}: self.{name} = self; a component cannot contain itself")
            if not name.isidentifier():
                raise ModelError(f"{self._describe()}: a part named {name!r} (a {type(value).__name__}): a part's "
                                 "name must be a Python name; a '.' in it would collide with the path of a part of "
                                 "a sub-component" + (f" ({name.split('.')[0]!r} holds its own)" if "." in name
                                                      else ""))
            if value._parent is not None and value._parent is not self:
                raise ModelError(f"{value._describe()} is already part of {value._parent._describe()}; "
                                 f"create a new instance for {self._child_path(name)!r}")
            old_name = value._attr_name if value._parent is self else None
            if old_name is not None and old_name != name and self._children.get(old_name) is value:
                raise ModelError(f"{self._describe()}: one {type(value).__name__} instance under two names, "
                                 f"{self._child_path(old_name)!r} and {self._child_path(name)!r}; create a new "
                                 "instance for each")
            replaced = self._children.get(name)
            if replaced is not None and replaced is not value and _connected(self, replaced):
                raise ModelError(f"{self._describe()}: {self._child_path(name)!r} is assigned twice (a "
                                 f"{type(replaced).__name__}, already connected, then a {type(value).__name__}); "
                                 "the first would be dropped with its connections: give each its own name")
            object.__setattr__(value, "_parent", self)
            object.__setattr__(value, "_attr_name", name)
            self._children[name] = value
            value._set_path(self._child_path(name))
        object.__setattr__(self, name, value)

    def _set_path(self, path: str):
        object.__setattr__(self, "_path", path)
        for name, child in self._children.items():
            child._set_path(self._child_path(name))

    def _child_path(self, name: str) -> str:
        return f"{self._path}.{name}" if self._path else name

    def _describe(self) -> str:
        return f"{type(self).__name__} {self._path!r}" if self._path else f"{type(self).__name__} (top level)"

    @property
    def path(self) -> str:
        """Hierarchical name of this instance ("" for the top-level model)."""
        return self._path

    @property
    def children(self) -> dict:
        return dict(self._children)

    def _ensure_built(self):
        if not self._built:
            object.__setattr__(self, "_built", True)
            _BUILDING.append(self)
            try:
                self.build()
            finally:
                _BUILDING.pop()
        for child in list(self._children.values()):
            child._ensure_built()

    # ---- what subclasses write
    def build(self):
        """Create sub-components and connections (composite models)."""

    def equations(self) -> list:
        """Equations as ``sympy.Eq`` or residual expressions (``expr == 0``)."""
        return []

    def events(self) -> list:
        """State events (:class:`Event`) of this component."""
        return []

    def indeterminates(self) -> list:
        """Variables the equations may leave undetermined in some mode (:class:`Indeterminate`), with the rule
        that picks their values there."""
        return []

    def assertions(self) -> list:
        """Conditions on this component's parameters that every run must meet (Modelica's ``assert`` on
        parameters): ``(condition, message)`` pairs, the condition a sympy relation of parameters
        (``self.u_max >= self.u_min``). Checked by :meth:`CompiledModel.param_vector
        <acausal.compiled_model.CompiledModel.param_vector>` for the defaults and every run's overrides; a run that
        breaks one is a ModelError naming the component, the message and the values."""
        return []

    # ---- values
    def parameter_value(self, name: str):
        d = self.declarations()[name]
        return self._values.get(name, d.default)

    # sympy helpers usable in equations
    @property
    def time(self):
        return time


class Model(Component):
    """A component made of components: override :meth:`build`; may also add equations of its own."""


class Connector(Component):
    """A port. Subclasses declare :class:`Potential` and :class:`Flow` variables and a ``domain``.

    Ports of the same domain can be connected. ``required=True`` makes leaving the port unconnected an error
    (default for causal inputs).
    """

    listed_as = "port"
    drives = False  # a causal output (connectors.RealOutput) drives what it is connected to; connect() checks one

    domain = "abstract"
    required_default = False

    def __init__(self, doc: str = "", required: bool | None = None, **values):
        super().__init__(doc=doc, **values)
        self._init_kwargs["required"] = required
        self.required = self.required_default if required is None else required

    def __repr__(self):
        return f"<{type(self).__name__} {self._path!r}>"


def _connected(model, child) -> bool:
    """Whether a port of ``child`` (a sub-component of ``model``) appears in ``model``'s connections."""
    return any(p._parent is child for pair in model._connections for p in pair)


def connect(*ports: Connector):
    """Connect ports: their potentials are equal and their flows sum to zero (flow into a component positive).

    Must be called inside a model's :meth:`~Component.build`. Ports of different domains (a pin and a flange)
    raise :class:`~acausal.errors.ConnectError` naming both.
    """
    if not _BUILDING:
        raise ConnectError("connect() must be called inside a model's build() method")
    model = _BUILDING[-1]
    if len(ports) < 2:
        raise ConnectError(f"{model._describe()}: connect() needs at least two ports")
    for p in ports:
        if not isinstance(p, Connector):
            raise ConnectError(f"{model._describe()}: connect() got {p!r}, which is not a port")
    first = ports[0]
    for p in ports[1:]:
        if p.domain != first.domain:
            raise ConnectError(
                f"cannot connect {type(first).__name__} {first.path!r} ({first.domain}) with "
                f"{type(p).__name__} {p.path!r} ({p.domain}): ports of different kinds")
    for p in ports:
        owner = p._parent
        if owner is not model and (owner is None or owner._parent is not model):
            raise ConnectError(f"{model._describe()}: port {p.path!r} is neither a port of this model nor of one of "
                               "its direct sub-components")
    driving = [p for p in ports if p.drives and p._parent is not model]
    if len(driving) > 1:
        raise ConnectError(f"{model._describe()}: connect({', '.join(repr(p.path) for p in ports)}) joins "
                           f"{len(driving)} outputs ({', '.join(repr(p.path) for p in driving)}); one output drives "
                           "a signal, which inputs read")
    for p in ports[1:]:
        model._connections.append((first, p))


