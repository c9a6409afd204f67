"""1-D rotational mechanics (MSL ``Modelica.Mechanics.Rotational`` names and sign conventions).

A flange torque acts *on* the component; power flowing into a component through a flange is
``flange.tau * der(flange.phi)``.
"""
from sympy import Eq

from acausal import Component, Input, Parameter, RealInput, RealOutput, Variable, der
from acausal.connectors import Flange
from acausal.partials import PartialCompliant, PartialCompliantWithRelativeStates, PartialTwoFlanges


class _OptionalSupport:
    """Mixin: ``use_support=True`` adds a ``support`` flange; otherwise the support is fixed (angle 0)."""

    def _init_support(self, use_support):
        self.use_support = use_support
        if use_support:
            self.support = Flange(doc="support/housing flange")

    def support_phi(self):
        return self.support.phi if self.use_support else 0


class Fixed(Component):
    """Flange fixed at angle ``phi0``."""

    phi0 = Parameter(0.0, unit="rad", doc="fixed angle")
    flange = Flange(doc="fixed flange")

    def equations(self):
        return [Eq(self.flange.phi, self.phi0)]


class Inertia(PartialTwoFlanges):
    """Rigid rotating body, ``J dw/dt = flange_a.tau + flange_b.tau``; stores ``energy = J w^2 / 2``."""

    J = Parameter(1.0, unit="kg.m2", min=0.0, doc="moment of inertia")
    phi = Variable(unit="rad", doc="absolute rotation angle")
    w = Variable(unit="rad/s", doc="absolute angular velocity")
    a = Variable(unit="rad/s2", doc="absolute angular acceleration")
    energy = Variable(unit="J", doc="kinetic energy J w^2/2")

    def equations(self):
        return [Eq(self.phi, self.flange_a.phi), Eq(self.phi, self.flange_b.phi), Eq(self.w, der(self.phi)),
                Eq(self.a, der(self.w)), Eq(self.J * self.a, self.flange_a.tau + self.flange_b.tau),
                Eq(self.energy, self.J * self.w**2 / 2)]


class Damper(PartialCompliantWithRelativeStates):
    """Linear damper, ``tau = d w_rel``; dissipates ``loss_power = tau w_rel >= 0``."""

    d = Parameter(0.0, unit="N.m.s/rad", min=0.0, doc="damping constant")
    loss_power = Variable(unit="W", doc="dissipated power")

    def equations(self):
        return [*super().equations(), Eq(self.tau, self.d * self.w_rel), Eq(self.loss_power, self.tau * self.w_rel)]


class Spring(PartialCompliant):
    """Linear torsion spring, ``tau = c (phi_rel - phi_rel0)``; stores ``energy = c (phi_rel - phi_rel0)^2/2``."""

    c = Parameter(1.0, unit="N.m/rad", min=0.0, doc="spring constant")
    phi_rel0 = Parameter(0.0, unit="rad", doc="unstretched relative angle")
    energy = Variable(unit="J", doc="stored elastic energy")

    def equations(self):
        return [*super().equations(), Eq(self.tau, self.c * (self.phi_rel - self.phi_rel0)),
                Eq(self.energy, self.c * (self.phi_rel - self.phi_rel0)**2 / 2)]


class SpringDamper(PartialCompliantWithRelativeStates):
    """Linear spring and damper in parallel."""

    c = Parameter(1.0, unit="N.m/rad", min=0.0, doc="spring constant")
    d = Parameter(0.0, unit="N.m.s/rad", min=0.0, doc="damping constant")
    phi_rel0 = Parameter(0.0, unit="rad", doc="unstretched relative angle")
    loss_power = Variable(unit="W", doc="dissipated power")
    energy = Variable(unit="J", doc="stored elastic energy")

    def equations(self):
        return [*super().equations(), Eq(self.tau, self.c * (self.phi_rel - self.phi_rel0) + self.d * self.w_rel),
                Eq(self.loss_power, self.d * self.w_rel**2),
                Eq(self.energy, self.c * (self.phi_rel - self.phi_rel0)**2 / 2)]


class IdealGear(PartialTwoFlanges, _OptionalSupport):
    """Ideal gear without inertia or losses: ``phi_a = ratio * phi_b``, ``0 = ratio * flange_a.tau + flange_b.tau``
    (angles relative to the support). ``ratio`` > 1 reduces speed from a to b."""

    ratio = Parameter(1.0, unit="1", doc="transmission ratio flange_a.phi / flange_b.phi")
    phi_a = Variable(unit="rad", doc="flange_a angle relative to the support")
    phi_b = Variable(unit="rad", doc="flange_b angle relative to the support")

    def __init__(self, use_support: bool = False, **kw):
        super().__init__(**kw)
        self._init_support(use_support)

    def equations(self):
        eqs = [Eq(self.phi_a, self.flange_a.phi - self.support_phi()),
               Eq(self.phi_b, self.flange_b.phi - self.support_phi()),
               Eq(self.phi_a, self.ratio * self.phi_b), Eq(0, self.ratio * self.flange_a.tau + self.flange_b.tau)]
        if self.use_support:
            eqs.append(Eq(self.support.tau, -self.flange_a.tau - self.flange_b.tau))
        return eqs


class TorqueSource(Component, _OptionalSupport):
    """Prescribed torque ``tau(t)`` accelerating ``flange`` (``flange.tau = -tau``), reaction on the support."""

    tau = Input(unit="N.m", doc="driving torque")
    flange = Flange(doc="driven flange")

    def __init__(self, use_support: bool = False, **kw):
        super().__init__(**kw)
        self._init_support(use_support)

    def equations(self):
        eqs = [Eq(self.flange.tau, -self.tau)]
        if self.use_support:
            eqs.append(Eq(self.support.tau, self.tau))
        return eqs


class SignalTorque(Component, _OptionalSupport):
    """Torque source driven by a causal input ``u`` [N m] (``flange.tau = -u``)."""

    u = RealInput(doc="driving torque [N m]")
    flange = Flange(doc="driven flange")

    def __init__(self, use_support: bool = False, **kw):
        super().__init__(**kw)
        self._init_support(use_support)

    def equations(self):
        eqs = [Eq(self.flange.tau, -self.u.value)]
        if self.use_support:
            eqs.append(Eq(self.support.tau, self.u.value))
        return eqs


class Position(Component, _OptionalSupport):
    """Prescribed angle (MSL ``Position`` with exact=true): ``flange.phi - support.phi = phi_ref(t)``.

    ``phi_ref`` is a number, a sympy expression of time or a :class:`acausal.Signal`; index reduction asks it for
    as many derivatives as the rest of the model needs. The source supplies whatever torque the motion takes.
    """

    phi_ref = Input(unit="rad", doc="prescribed angle")
    flange = Flange(doc="flange moved along phi_ref")

    def __init__(self, use_support: bool = False, **kw):
        super().__init__(**kw)
        self._init_support(use_support)

    def equations(self):
        eqs = [Eq(self.flange.phi - self.support_phi(), self.phi_ref)]
        if self.use_support:
            eqs.append(Eq(self.support.tau, -self.flange.tau))
        return eqs


class SpeedSensor(Component):
    """Ideal absolute speed sensor: ``w.value = der(flange.phi)``, no torque."""

    flange = Flange(doc="measured flange")
    w = RealOutput(doc="angular velocity [rad/s]")

    def equations(self):
        return [Eq(self.flange.tau, 0), Eq(self.w.value, der(self.flange.phi))]


class AngleSensor(Component):
    """Ideal absolute angle sensor: ``phi.value = flange.phi``, no torque."""

    flange = Flange(doc="measured flange")
    phi = RealOutput(doc="angle [rad]")

    def equations(self):
        return [Eq(self.flange.tau, 0), Eq(self.phi.value, self.flange.phi)]


class TorqueSensor(PartialTwoFlanges):
    """Ideal torque sensor between two flanges: rigid, ``tau.value = flange_a.tau`` (torque transmitted a -> b)."""

    tau = RealOutput(doc="transmitted torque [N m]")

    def equations(self):
        return [Eq(self.flange_a.phi, self.flange_b.phi), Eq(self.flange_a.tau + self.flange_b.tau, 0),
                Eq(self.tau.value, self.flange_a.tau)]
