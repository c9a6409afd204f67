"""Partial models shared by the library, after the Modelica Standard Library (MSL).

Sign conventions: current flows from ``p`` through the component to ``n`` (``i = p.i``, flow into ``p`` positive);
``v = p.v - n.v``. A flange torque acts on the component; ``phi_rel = flange_b.phi - flange_a.phi`` and the
compliant torque ``tau = flange_b.tau`` (so a spring with positive elongation pulls ``flange_b`` back). A component
with a housing extends a partial with an optional support (``use_support``), which owns the support flange and the
reaction torque on it; the component writes only its own law.
"""
import abc

import sympy as sp

from .components import Component, Discrete, Event, Indeterminate, Parameter, Variable
from .connectors import Flange, Pin
from ..errors import ModelError
from .symbols import Eq, der


def check_option(component, option: str, value, allowed: tuple):
    """``value`` if it is one of ``allowed``; otherwise a :class:`ModelError` naming the component's class and the
    option. For constructor options (``law``, ``use_support``, ...), which choose equations, not parameters."""
    if value not in allowed:
        choices = " or ".join(filter(None, [", ".join(map(repr, allowed[:-1])), repr(allowed[-1])]))
        raise ModelError(f"{type(component).__name__}: option {option} must be {choices}, got {value!r}")
    return value


class OnePort(Component):
    """Two pins, voltage drop ``v = p.v - n.v`` and current ``i`` from p to n (MSL ``OnePort``)."""

    p = Pin(doc="positive pin (current flows in here)")
    n = Pin(doc="negative pin")
    v = Variable(unit="V", doc="voltage drop p -> n")
    i = Variable(unit="A", doc="current from p through the component to n")

    def equations(self):
        return [*super().equations(), Eq(self.v, self.p.v - self.n.v), Eq(0, self.p.i + self.n.i),
                Eq(self.i, self.p.i)]


class TwoPin(Component):
    """Two pins and ``v = p.v - n.v``, no current balance (MSL ``TwoPin``)."""

    p = Pin(doc="positive pin")
    n = Pin(doc="negative pin")
    v = Variable(unit="V", doc="voltage drop p -> n")

    def equations(self):
        return [*super().equations(), Eq(self.v, self.p.v - self.n.v)]


class PartialTwoFlanges(Component):
    """Two flanges, no equations (MSL ``PartialTwoFlanges``)."""

    flange_a = Flange(doc="driving flange (left)")
    flange_b = Flange(doc="driven flange (right)")


class PartialCompliant(PartialTwoFlanges):
    """Relative angle and torque of a massless compliant element (MSL ``PartialCompliant``):
    ``phi_rel = flange_b.phi - flange_a.phi``, ``flange_b.tau = tau``, ``flange_a.tau = -tau``."""

    phi_rel = Variable(unit="rad", doc="relative rotation angle flange_b - flange_a")
    tau = Variable(unit="N.m", doc="torque between the flanges (= flange_b.tau)")

    def equations(self):
        return [*super().equations(), Eq(self.phi_rel, self.flange_b.phi - self.flange_a.phi),
                Eq(self.flange_b.tau, self.tau), Eq(self.flange_a.tau, -self.tau)]


class PartialCompliantWithRelativeStates(PartialCompliant):
    """:class:`PartialCompliant` plus relative speed ``w_rel = der(phi_rel)``."""

    w_rel = Variable(unit="rad/s", doc="relative angular velocity")

    def equations(self):
        return [*super().equations(), Eq(self.w_rel, der(self.phi_rel))]


class PartialOptionalSupport(Component, abc.ABC):
    """A conditional support (housing) flange and the reaction torque on it (MSL ``useSupport``).

    ``use_support=True`` gives the component a ``support`` flange with ``support.tau = support_torque()``: the
    torque on the housing that balances those at the flanges (for a massless element minus their sum). Left
    unconnected, the support carries no torque, so connect it to a ``Fixed`` (or a housing) when the reaction
    matters. ``use_support=False``: the housing is fixed at angle 0 and no reaction is exposed. ``phi_support`` is
    the support angle to write relative angles with (``support.phi``, or 0). The flag is structural (it changes
    the equations), so it is a constructor argument, not a parameter.
    """

    def __init__(self, use_support: bool = False, **kw):
        check_option(self, "use_support", use_support, (True, False))
        super().__init__(**kw)
        self.use_support = bool(use_support)
        if self.use_support:
            self.support = Flange(doc="support/housing flange")

    @property
    def phi_support(self):
        """Angle of the support: ``support.phi``, or 0 when the housing is fixed (``use_support=False``)."""
        return self.support.phi if self.use_support else 0

    @abc.abstractmethod
    def support_torque(self):
        """The torque acting on the support (the reaction), as an expression."""

    def equations(self):
        eqs = super().equations()
        return [*eqs, Eq(self.support.tau, self.support_torque())] if self.use_support else eqs


class PartialElementaryOneFlangeAndSupport2(PartialOptionalSupport):
    """One flange and an optional support (MSL ``PartialElementaryOneFlangeAndSupport2``) of a massless element:
    the support takes the reaction ``support.tau = -flange.tau``. Angles relative to the support are
    ``flange.phi - phi_support``."""

    flange = Flange(doc="driven flange")

    def support_torque(self):
        return -self.flange.tau


class PartialElementaryTwoFlangesAndSupport2(PartialTwoFlanges, PartialOptionalSupport):
    """Two flanges and an optional support (MSL ``PartialElementaryTwoFlangesAndSupport2``) of a massless element:
    the support takes the reaction ``support.tau = -(flange_a.tau + flange_b.tau)``. Angles relative to the
    support are ``flange_a.phi - phi_support`` and ``flange_b.phi - phi_support``."""

    def support_torque(self):
        return -(self.flange_a.tau + self.flange_b.tau)


class PartialGear(PartialElementaryTwoFlangesAndSupport2):
    """Kinematics of a massless gear stage on an optional support (MSL ``IdealGear``'s): with the flange angles
    relative to the support, ``phi_a = ratio * phi_b``; ``ratio`` > 1 reduces speed from a to b. A subclass
    writes the torque law, one equation between ``flange_a.tau`` and ``flange_b.tau``."""

    ratio = Parameter(1.0, unit="1", nonzero=True,
                      doc="transmission ratio phi_a / phi_b (negative: the output turns the other way; 0 would lock "
                          "flange_a)")
    phi_a = Variable(unit="rad", doc="flange_a (input) angle relative to the support")
    phi_b = Variable(unit="rad", doc="flange_b (output) angle relative to the support")

    def equations(self):
        return [*super().equations(), Eq(self.phi_a, self.flange_a.phi - self.phi_support),
                Eq(self.phi_b, self.flange_b.phi - self.phi_support), Eq(self.phi_a, self.ratio * self.phi_b)]


class PartialElementaryRotationalToElectrical(OnePort, PartialElementaryOneFlangeAndSupport2):
    """An electrical one-port driving a shaft that turns against an optional support (the frame of MSL ``EMF``):
    pins ``p``, ``n`` with ``v`` and ``i`` (:class:`OnePort`), the ``flange`` with the reaction
    ``support.tau = -flange.tau``, and the shaft's angle and speed relative to the support,
    ``phi = flange.phi - phi_support``, ``w = der(phi)``. A subclass writes the conversion law (``v`` and
    ``flange.tau`` from ``w`` and ``i``); one with rotor inertia is not elementary and overrides
    :meth:`support_torque`."""

    flange = Flange(doc="shaft")
    phi = Variable(unit="rad", doc="flange angle relative to the support")
    w = Variable(unit="rad/s", doc="angular velocity relative to the support")

    def equations(self):
        return [*super().equations(), Eq(self.phi, self.flange.phi - self.phi_support), Eq(self.w, der(self.phi))]


MIN_BAND = 1e-12  # N m: the smallest half-width of a breakaway band a stuck group's split uses (an open brake's 0)


class PartialFriction(Component):
    """The stick/slip machine of a friction element (MSL ``PartialFriction``): modes forward, stuck, backward.

    A subclass declares its relative speed ``w`` and acceleration ``a`` (``a = der(w)``), its friction torque
    ``tau`` (positive opposing forward motion), writes :meth:`breakaway` (the limits at which it breaks away), and
    calls :meth:`friction_equations` with the torque it transmits while sliding forward/backward and
    :meth:`friction_events` with its speed::

        tau = stuck sa + (1 - stuck) (forward slide_fwd + (1 - forward) slide_bwd)      a = (1 - stuck) sa

    The path parameter ``sa`` is the holding torque while stuck and the acceleration while sliding, so every
    mode has the same structure; the compiler leaves ``sa`` to the numeric block solve (its coefficients vanish in
    one mode or the other). Events: sliding forward, ``w`` falling through 0 sticks; stuck, ``sa`` rising above
    ``break_fwd`` breaks away forward and falling below ``break_bwd`` backward (checked right after sticking, so a
    reversal under load passes straight through); sliding backward mirrors it. An element at rest starts forward
    and sticks at once if it moves backward; one moving backward at the start needs ``forward=0``.
    """

    sa = Variable(doc="path parameter: holding torque [N m] while stuck, acceleration [rad/s2] while sliding")
    stuck = Discrete(start=0.0, doc="1 while stuck")
    forward = Discrete(start=1.0, doc="1 while sliding forward, 0 backward (meaningless while stuck)")

    def friction_equations(self, w, a, tau, slide_fwd, slide_bwd) -> list:
        S, F = self.stuck, self.forward
        return [Eq(a, der(w)), Eq(tau, S * self.sa + (1 - S) * (F * slide_fwd + (1 - F) * slide_bwd)),
                Eq(a, (1 - S) * self.sa)]

    @abc.abstractmethod
    def breakaway(self) -> tuple:
        """``(break_fwd, break_bwd)``: the holding torques at which the element breaks away forward and backward
        (expressions; ``break_bwd <= break_fwd``), what its events and its share of a stuck group use."""
        raise ModelError(f"{type(self).__name__}: a friction element writes breakaway(), the holding torques at "
                         "which it breaks away forward and backward")

    def indeterminates(self) -> list:
        """The holding torque ``sa`` while stuck is free when another stuck element holds the same shaft: the shares
        are chosen as equal fractions of each element's band (``nominal`` its middle, ``scale`` its half-width, at
        least :data:`MIN_BAND` N m), so that the stuck group breaks away when no share holds it any more
        (:class:`~acausal.model.components.Indeterminate`)."""
        fwd, bwd = self.breakaway()
        return [Indeterminate(self.sa, (fwd + bwd) / 2, sp.Max((fwd - bwd) / 2, MIN_BAND),
                              doc="holding torque while stuck: its share of a stuck group")]

    def friction_events(self, w) -> list:
        S, F = self.stuck, self.forward
        break_fwd, break_bwd = self.breakaway()
        sliding_fwd, sliding_bwd = (1 - S) * F, (1 - S) * (1 - F)
        # forward side: the speed while sliding forward, the margin to breaking away forward while stuck, -1 while
        # sliding backward (no crossing there); the backward side mirrors it
        z_fwd = S * (self.sa - break_fwd) + sliding_fwd * w - sliding_bwd
        z_bwd = S * (self.sa - break_bwd) + sliding_bwd * w + sliding_fwd
        return [Event(z_fwd, on_rising={S: 0, F: 1}, on_falling={S: S + sliding_fwd},
                      doc="forward: stops (sticks) or breaks away"),
                Event(z_bwd, on_falling={S: 0, F: 0}, on_rising={S: S + sliding_bwd},
                      doc="backward: stops (sticks) or breaks away")]
