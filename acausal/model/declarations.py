"""The declarations a component class makes (see :mod:`acausal.model.components`): :class:`Parameter`,
:class:`Variable` (:class:`Potential`, :class:`Flow`), :class:`Discrete`, :class:`Input`, with a start value
(:class:`Start`), an :class:`Event` and an :class:`Indeterminate`, and the bounds every given value is checked
against."""
from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from ..errors import ModelError
from .signals import as_signal_expr
from .symbols import par_symbol, var_symbol


class _Declaration:
    """Base of class-level declarations; knows its attribute name and owning class."""

    name: str = "?"

    def __set_name__(self, owner, name):
        self.name = name


class Parameter(_Declaration):
    """A constant of the model with an SI unit; its value can be changed per run without recompiling.

    ``default`` may be a number or ``None`` (then the user must give a value). ``min``/``max`` are checked on
    every run; a value outside them is a :class:`~acausal.errors.ModelError` naming the parameter. ``device``
    names the device (or test subject) a default belongs to when it is a datasheet number or an assumption about
    one device rather than a neutral value or a physical constant (``"maxon EC-4pole 30"``): a model that leaves
    such a parameter at its default says so in :meth:`CompiledModel.report
    <acausal.compiled_model.CompiledModel.report>` and :meth:`~acausal.compiled_model.CompiledModel.device_defaults`.

    For calibration (:class:`~acausal.identify.calibrate.Free.declared`): ``nominal`` is the parameter's typical
    magnitude (Modelica's ``nominal``: the optimiser's scale) and ``fit_range`` ``(lower, upper)`` the range a fit
    searches, a physical range for the class of device (wider than one datasheet's tolerance, inside ``min``/``max``).
    """

    listed_as = "parameter"  # the section of describe() that lists it (acausal.model.describe)

    def __init__(self, default=None, unit: str = "1", doc: str = "", min: float | None = None,
                 max: float | None = None, device: str = "", nonzero: bool = False, derived: str = "",
                 nominal: float | None = None, fit_range: tuple | None = None):
        if min is not None and max is not None and min > max:
            raise ModelError(f"Parameter({default!r}, {unit!r}): min {min} > max {max}; no value could meet both")
        if nominal is not None and not (isinstance(nominal, (int, float)) and not isinstance(nominal, bool)
                                        and 0 < nominal < float("inf")):
            raise ModelError(f"Parameter({default!r}, {unit!r}): nominal {nominal!r} must be a positive number "
                             "(the parameter's typical magnitude)")
        if fit_range is not None:
            try:
                lo, hi = (float(v) for v in fit_range)
            except (TypeError, ValueError):
                raise ModelError(f"Parameter({default!r}, {unit!r}): fit_range {fit_range!r} must be "
                                 "(lower, upper)") from None
            if not lo < hi or (min is not None and lo < min) or (max is not None and hi > max):
                raise ModelError(f"Parameter({default!r}, {unit!r}): fit_range {fit_range!r} must be increasing "
                                 f"and inside min/max ({min}, {max})")
            fit_range = (lo, hi)
        self.nominal, self.fit_range = nominal, fit_range
        self.default, self.unit, self.doc, self.min, self.max = default, unit, doc, min, max
        self.device, self.nonzero = device, nonzero
        self.derived = derived  # without a default: the rule the constructor sets it by when not given ("ki/kp")

    def __repr__(self):  # what help(Component) and a notebook show: default, unit, bounds, doc
        parts = [repr(self.default), f"unit={self.unit!r}"]
        parts += [f"{k}={v!r}" for k, v in (("min", self.min), ("max", self.max), ("nominal", self.nominal),
                                             ("fit_range", self.fit_range)) if v is not None]
        if self.nonzero:
            parts.append("nonzero=True")
        if self.doc:
            parts.append(f"doc={self.doc!r}")
        if self.device:
            parts.append(f"device={self.device!r}")
        return f"Parameter({', '.join(parts)})"

    def __get__(self, obj, owner=None):
        if obj is None:
            return self
        return par_symbol(obj._child_path(self.name))


class Variable(_Declaration):
    """A continuous unknown of time.

    ``start`` is the initial value (used as an initial condition when ``fixed=True``, else as a guess); ``min``
    and ``max`` bound the start values a component is given (an absolute temperature ``min=0``);
    ``state_select`` ("never", "avoid", "default", "prefer", "always") guides which variables index reduction
    keeps as states, as in Modelica.
    """

    listed_as = "variable"

    kind = "variable"

    def __init__(self, start: float = 0.0, unit: str = "1", doc: str = "", fixed: bool = False,
                 state_select: str = "default", nominal: float = 1.0, min: float | None = None,
                 max: float | None = None):
        if state_select not in _STATE_SELECT:
            raise ModelError(f"state_select must be one of {sorted(_STATE_SELECT)}, got {state_select!r}")
        if min is not None and max is not None and min > max:
            raise ModelError(f"{type(self).__name__}(unit={unit!r}): min {min} > max {max}; no value could meet both")
        self.start, self.unit, self.doc, self.fixed = start, unit, doc, fixed
        self.state_select, self.nominal = state_select, nominal
        self.min, self.max = min, max  # bounds of a start value given to it (Modelica's min/max attributes)

    def __repr__(self):
        parts = [f"start={self.start!r}", f"unit={self.unit!r}"]
        if self.fixed:
            parts.append("fixed=True")
        if self.state_select != "default":
            parts.append(f"state_select={self.state_select!r}")
        if self.doc:
            parts.append(f"doc={self.doc!r}")
        return f"{type(self).__name__}({', '.join(parts)})"

    def __get__(self, obj, owner=None):
        if obj is None:
            return self
        return var_symbol(obj._child_path(self.name))


_STATE_SELECT = {"never": 0, "avoid": 1, "default": 2, "prefer": 3, "always": 4}


class Potential(Variable):
    """Across variable of a connector (voltage, angle, temperature, signal value): equal when connected."""

    kind = "potential"


class Flow(Variable):
    """Through variable of a connector (current, torque, heat flow), positive into the component.

    Connected flows sum to zero; a flow whose port is connected to nothing is zero (the Modelica rule).
    """

    kind = "flow"


class Discrete(_Declaration):
    """A piecewise-constant mode variable, changed only by :class:`Event` assignments."""

    listed_as = "variable"

    def __init__(self, start: float = 0.0, doc: str = ""):
        self.start, self.doc = start, doc

    def __get__(self, obj, owner=None):
        if obj is None:
            return self
        return par_symbol(obj._child_path(self.name))


class Input(_Declaration):
    """A prescribed signal: a number, a sympy expression of :data:`acausal.time`, or a numeric
    :class:`~acausal.model.signals.Signal`. In equations ``self.u`` is the signal as a sympy expression; index
    reduction differentiates it as often as the structure needs."""

    listed_as = "input"

    def __init__(self, default=None, unit: str = "1", doc: str = ""):
        self.default, self.unit, self.doc = default, unit, doc

    def __get__(self, obj, owner=None):
        if obj is None:
            return self
        value = obj._inputs.get(self.name, self.default)
        if value is None:
            raise ModelError(f"{obj._describe()}: input {self.name!r} has no signal; pass {self.name}=...")
        return as_signal_expr(value, obj._child_path(self.name))


@dataclass(frozen=True)
class Start:
    """A start value for a variable given at construction: ``Inertia(w=Start(1.0, fixed=True))``."""

    value: float
    fixed: bool = True


@dataclass
class Event:
    """A state event: when ``zero`` crosses zero, apply the assignments to discrete modes.

    ``on_rising`` is applied when ``zero`` goes from negative to positive, ``on_falling`` the other way. Each
    maps a discrete symbol to an expression evaluated just before the event (pre-values of modes, values of
    continuous variables at the crossing). At initialisation the rising set is applied where ``zero > 0`` and
    the falling set where ``zero < 0`` until the modes stop changing.

    ``reinit`` (Modelica's ``reinit``) maps a *state* to the value it restarts from when ``zero`` rises (an
    expression evaluated just before the event, as the assignments are), before the modes are iterated; a
    variable that is not a state of the compiled model is a :class:`~acausal.errors.ModelError`. A reinit of a
    state that stores energy (a velocity) changes the stored energy at the event: the energy balance shows it.
    """

    zero: sp.Expr
    on_rising: dict = field(default_factory=dict)
    on_falling: dict = field(default_factory=dict)
    doc: str = ""
    reinit: dict = field(default_factory=dict)


@dataclass
class Indeterminate:
    """A variable the equations may leave undetermined in some mode, and the rule that picks its value then.

    Two friction elements stuck together on one rigid shaft (a bearing and a stuck gear: the MSL's LossyGearDemo2,
    "if both friction models are stuck, there is no unique solution") hold the shaft with the sum of their torques;
    the split between them is free. Where the equations of a block leave such variables free, the solver takes,
    among all the block's solutions, the one that minimises ``sum((var - nominal)**2 / scale)`` over the block's
    indeterminate variables (a weighted least-norm solution; ``nominal`` and ``scale`` are expressions, evaluated
    at that solution). Where the equations determine the variable, the rule changes nothing.

    A stick/slip element declares its holding torque with ``nominal`` the middle of its breakaway band and
    ``scale`` its half-width: the shares of a stuck group then use the same fraction of each element's band (for
    elements on one shaft), so they reach their limits together, exactly when no split can hold the shaft any
    more (:class:`~acausal.model.partials.PartialFriction`)."""

    var: sp.Symbol
    nominal: sp.Expr
    scale: sp.Expr
    doc: str = ""


def _outside(low, high, unit: str) -> str:
    """"outside its bounds [low, high] unit", with a hint for an absolute temperature (a degC slip)."""
    return (f"outside its bounds [{low if low is not None else '-inf'}, {high if high is not None else 'inf'}] {unit}"
            + (" (an absolute temperature: 25 degC is 298.15 K)" if unit == "K" else ""))


#: a value within this distance of a bound, relative to the bound, meets it: arithmetic such as ``18 * 1e-3`` lands
#: an ulp beyond 0.018, which is the bound itself, not a value outside it (a bound of 0 has no slack)
BOUND_RTOL = 1e-12


def beyond(value, bound: float, above: bool) -> bool:
    """Whether ``value`` lies above (``above``) or below ``bound`` by more than rounding (:data:`BOUND_RTOL`)."""
    slack = BOUND_RTOL * abs(bound)
    return bool(value > bound + slack) if above else bool(value < bound - slack)


def _within(d: Parameter, value: float) -> bool:
    """Whether a number given to parameter ``d`` is finite and lies within its declared bounds."""
    return not (value != value or abs(value) == float("inf") or (d.min is not None and beyond(value, d.min, False))
                or (d.max is not None and beyond(value, d.max, True)))
