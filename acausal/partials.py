"""Partial models shared by the library, after the Modelica Standard Library (MSL).

Sign conventions: current flows from ``p`` through the component to ``n`` (``i = p.i``, flow into ``p`` positive);
``v = p.v - n.v``. A flange torque acts on the component; ``phi_rel = flange_b.phi - flange_a.phi`` and the
compliant torque ``tau = flange_b.tau`` (so a spring with positive elongation pulls ``flange_b`` back).
"""
from sympy import Eq

from .components import Component, Variable
from .connectors import Flange, Pin
from .symbols import der


class OnePort(Component):
    """Two pins, voltage drop ``v = p.v - n.v`` and current ``i`` from p to n (MSL ``OnePort``)."""

    p = Pin(doc="positive pin (current flows in here)")
    n = Pin(doc="negative pin")
    v = Variable(unit="V", doc="voltage drop p -> n")
    i = Variable(unit="A", doc="current from p through the component to n")

    def equations(self):
        return [Eq(self.v, self.p.v - self.n.v), Eq(0, self.p.i + self.n.i), Eq(self.i, self.p.i)]


class TwoPin(Component):
    """Two pins and ``v = p.v - n.v``, no current balance (MSL ``TwoPin``)."""

    p = Pin(doc="positive pin")
    n = Pin(doc="negative pin")
    v = Variable(unit="V", doc="voltage drop p -> n")

    def equations(self):
        return [Eq(self.v, self.p.v - self.n.v)]


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
        return [Eq(self.phi_rel, self.flange_b.phi - self.flange_a.phi),
                Eq(self.flange_b.tau, self.tau), Eq(self.flange_a.tau, -self.tau)]


class PartialCompliantWithRelativeStates(PartialCompliant):
    """:class:`PartialCompliant` plus relative speed ``w_rel = der(phi_rel)``."""

    w_rel = Variable(unit="rad/s", doc="relative angular velocity")

    def equations(self):
        return [*super().equations(), Eq(self.w_rel, der(self.phi_rel))]


class PartialElementaryOneFlangeAndSupport(Component):
    """One flange and a support flange (MSL ``PartialElementaryOneFlangeAndSupport2``); the support is optional:
    left unconnected, it carries no torque, so connect it to a :class:`Fixed` (or a housing) when the reaction
    matters. ``phi`` is the flange angle relative to the support."""

    flange = Flange(doc="driven flange")
    support = Flange(doc="support/housing flange")
    phi = Variable(unit="rad", doc="flange angle relative to the support")

    def equations(self):
        return [Eq(self.phi, self.flange.phi - self.support.phi)]


class OptionalSupport:
    """Mixin for a conditional support flange (MSL ``useSupport``): call ``self._init_support(use_support)`` in
    ``__init__``. With ``use_support=True`` the component gets a ``support`` flange that takes the reaction
    torque; otherwise its housing is fixed at angle 0 and no reaction is exposed. ``support_phi()`` is the
    support angle to use in equations."""

    def _init_support(self, use_support: bool):
        self.use_support = use_support
        if use_support:
            self.support = Flange(doc="support/housing flange")

    def support_phi(self):
        return self.support.phi if self.use_support else 0
