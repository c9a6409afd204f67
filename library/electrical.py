"""Analog electrical components (MSL ``Modelica.Electrical.Analog`` names and sign conventions).

Current flows from pin ``p`` through the component to pin ``n``; power into a one-port is ``v*i``.
"""
from sympy import Eq

from acausal import Component, Input, Parameter, RealInput, RealOutput, Variable, der
from acausal.connectors import Flange, Pin
from acausal.partials import OnePort


class Ground(Component):
    """Reference potential: ``p.v = 0``."""

    p = Pin(doc="ground pin")

    def equations(self):
        return [Eq(self.p.v, 0)]


class Resistor(OnePort):
    """Ideal linear resistor, ``v = R i``; dissipates ``loss_power = v i >= 0``."""

    R = Parameter(1.0, unit="Ohm", min=0.0, doc="resistance")
    loss_power = Variable(unit="W", doc="dissipated power v*i")

    def equations(self):
        return [*super().equations(), Eq(self.v, self.R * self.i), Eq(self.loss_power, self.v * self.i)]


class Conductor(OnePort):
    """Ideal linear conductor, ``i = G v``."""

    G = Parameter(1.0, unit="S", min=0.0, doc="conductance")

    def equations(self):
        return [*super().equations(), Eq(self.i, self.G * self.v)]


class Capacitor(OnePort):
    """Ideal capacitor, ``i = C dv/dt``; stores ``energy = C v^2 / 2``."""

    C = Parameter(1.0, unit="F", min=0.0, doc="capacitance")
    energy = Variable(unit="J", doc="stored energy C v^2/2")

    def equations(self):
        return [*super().equations(), Eq(self.i, self.C * der(self.v)), Eq(self.energy, self.C * self.v**2 / 2)]


class Inductor(OnePort):
    """Ideal inductor, ``v = L di/dt``; stores ``energy = L i^2 / 2``."""

    L = Parameter(1.0, unit="H", min=0.0, doc="inductance")
    energy = Variable(unit="J", doc="stored energy L i^2/2")

    def equations(self):
        return [*super().equations(), Eq(self.v, self.L * der(self.i)), Eq(self.energy, self.L * self.i**2 / 2)]


class ConstantVoltage(OnePort):
    """Ideal constant voltage source, ``v = V`` (p is the + terminal). The power it delivers is ``-v*i``."""

    V = Parameter(1.0, unit="V", doc="source voltage")

    def equations(self):
        return [*super().equations(), Eq(self.v, self.V)]


class PrescribedVoltage(OnePort):
    """Voltage source following a prescribed signal ``v_ref(t)`` (number, sympy expression or Signal)."""

    v_ref = Input(unit="V", doc="prescribed voltage")

    def equations(self):
        return [*super().equations(), Eq(self.v, self.v_ref)]


class SignalVoltage(OnePort):
    """Voltage source driven by a causal input: ``v = u.value`` (MSL ``SignalVoltage``)."""

    u = RealInput(doc="voltage command [V]")

    def equations(self):
        return [*super().equations(), Eq(self.v, self.u.value)]


class ConstantCurrent(OnePort):
    """Ideal constant current source: ``i = I`` flows from p to n through the source."""

    I = Parameter(1.0, unit="A", doc="source current")

    def equations(self):
        return [*super().equations(), Eq(self.i, self.I)]


class SignalCurrent(OnePort):
    """Current source driven by a causal input: ``i = u.value``."""

    u = RealInput(doc="current command [A]")

    def equations(self):
        return [*super().equations(), Eq(self.i, self.u.value)]


class CurrentSensor(OnePort):
    """Ideal ammeter in series: ``v = 0``, output ``i_out = i`` (current p -> n)."""

    i_out = RealOutput(doc="measured current [A]")

    def equations(self):
        return [*super().equations(), Eq(self.v, 0), Eq(self.i_out.value, self.i)]


class VoltageSensor(Component):
    """Ideal voltmeter: no current, output ``v_out = p.v - n.v``."""

    p = Pin(doc="positive pin")
    n = Pin(doc="negative pin")
    v_out = RealOutput(doc="measured voltage [V]")

    def equations(self):
        return [Eq(self.p.i, 0), Eq(self.n.i, 0), Eq(self.v_out.value, self.p.v - self.n.v)]


class EMF(OnePort):
    """Ideal electromechanical converter (MSL ``EMF``): ``v = k w``, ``flange.tau = -k i``.

    ``k`` [N m/A = V s/rad] is both the torque and the back-EMF constant, so the converter is lossless:
    electrical power in ``v i`` equals mechanical power out ``-flange.tau w``. With ``use_support=True`` the
    reaction torque acts on the ``support`` flange; otherwise the housing is fixed.
    """

    k = Parameter(1.0, unit="N.m/A", doc="transformation coefficient (torque and back-EMF constant)")
    phi = Variable(unit="rad", doc="flange angle relative to the support")
    w = Variable(unit="rad/s", doc="angular velocity relative to the support")
    flange = Flange(doc="shaft")

    def __init__(self, use_support: bool = False, **kw):
        super().__init__(**kw)
        self.use_support = use_support
        if use_support:
            self.support = Flange(doc="housing")

    def equations(self):
        support_phi = self.support.phi if self.use_support else 0
        eqs = [*super().equations(), Eq(self.phi, self.flange.phi - support_phi), Eq(self.w, der(self.phi)),
               Eq(self.v, self.k * self.w), Eq(self.flange.tau, -self.k * self.i)]
        if self.use_support:
            eqs.append(Eq(self.support.tau, -self.flange.tau))
        return eqs
