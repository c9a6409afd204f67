"""1-D rotational mechanics (MSL ``Modelica.Mechanics.Rotational`` names and sign conventions).

A flange torque acts *on* the component; power flowing into a component through a flange is
``flange.tau * der(flange.phi)``.
"""
import sympy as sp

from acausal import (Component, Discrete, Eq, Event, Input, Model, Parameter, RealInput, RealOutput, Variable, connect,
                     der)
from acausal.model.connectors import Flange
from acausal.model.partials import (PartialCompliant, PartialCompliantWithRelativeStates, PartialFriction,
                                    PartialElementaryOneFlangeAndSupport2, PartialGear, PartialTwoFlanges,
                                    check_option)

from .friction import GearFriction


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


class Pendulum(Component):
    """A pendulum on a horizontal shaft: a point mass ``m`` at distance ``l`` on a uniform arm of mass ``m_arm``.

    ``phi = flange.phi`` is the arm's angle from hanging down (positive counter-clockwise seen along the shaft),
    ``phi0`` the mounting offset (the arm hangs at ``phi = -phi0``)::

        J = m l^2 + m_arm l^2 / 3
        J dw/dt = flange.tau + tau_g,        tau_g = -(m + m_arm/2) g l sin(phi + phi0)

    ``energy`` = kinetic ``J w^2/2`` + potential ``(m + m_arm/2) g l (1 - cos(phi + phi0))`` (zero hanging down),
    so ``d energy/dt = flange.tau w``: gravity is conservative and stores, it does not dissipate.
    ``bias_output=True`` adds the output ``tau_bias`` = ``tau_g`` (for a friction law whose budget depends on the
    load's torque, :class:`~acausal.library.friction.GearFriction` with ``load_measure="external"``).
    ``g`` = 9.80665 m/s2 (standard gravity); the rig is that of BAM's test bench (Rhoban/bam ``testbench.Pendulum``).
    """

    m = Parameter(None, unit="kg", min=0.0, doc="point mass at the arm's end")
    l = Parameter(None, unit="m", min=0.0, doc="distance of the point mass from the shaft")
    m_arm = Parameter(0.0, unit="kg", min=0.0, doc="mass of the uniform arm (0: massless arm)")
    phi0 = Parameter(0.0, unit="rad", doc="mounting offset of the arm (a fit searches up to 17 deg either way)",
                     fit_range=(-0.3, 0.3), nominal=0.02)
    g = Parameter(9.80665, unit="m/s2", min=0.0, doc="standard gravity")
    flange = Flange(doc="shaft")
    phi = Variable(unit="rad", doc="arm angle from hanging down (plus the offset phi0)")
    w = Variable(unit="rad/s", doc="angular velocity")
    J = Variable(unit="kg.m2", doc="moment of inertia about the shaft")
    tau_g = Variable(unit="N.m", doc="gravity torque on the arm")
    energy = Variable(unit="J", doc="kinetic + potential energy")

    def __init__(self, bias_output: bool = False, **kw):
        super().__init__(**kw)
        self.bias_output = check_option(self, "bias_output", bias_output, (True, False))
        if bias_output:
            self.tau_bias = RealOutput(doc="gravity torque on the arm tau_g [N m] (BAM's bias torque)")

    def equations(self):
        lever = (self.m + self.m_arm / 2) * self.g * self.l
        out = [Eq(self.tau_bias.value, self.tau_g)] if self.bias_output else []
        return [*out, Eq(self.phi, self.flange.phi), Eq(self.w, der(self.phi)),
                Eq(self.J, self.m * self.l**2 + self.m_arm * self.l**2 / 3),
                Eq(self.tau_g, -lever * sp.sin(self.phi + self.phi0)),
                Eq(self.J * der(self.w), self.flange.tau + self.tau_g),
                Eq(self.energy, self.J * self.w**2 / 2 + lever * (1 - sp.cos(self.phi + self.phi0)))]


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


class Backlash(PartialCompliant):
    """Play of ``b`` between two rigid flanks (a dead zone in the drive train), smoothed over a small torque band:

        phi_rel = (b / 2) tanh(tau / tau_s)

    The relative angle sweeps across the play while the transmitted torque changes sign: a flank is in contact
    (``phi_rel -> +-b/2``) once ``|tau|`` exceeds a few ``tau_s`` (think of ``tau_s`` as the drag of the lubricated
    mesh that has to be overcome to cross the gap). The law is explicit in the torque, so with a massless element
    on either side the play is an algebraic relation the index reduction can differentiate (motor speed and
    acceleration pick up the gap crossings). The flanks are rigid: put a :class:`Spring` in series for their
    compliance. ``b = 0`` is a rigid shaft.

    The element is conservative; ``energy`` = integral of ``tau d(phi_rel)`` =
    ``(b/2) (tau tanh(tau/tau_s) - tau_s ln cosh(tau/tau_s))`` (>= 0, bounded by ``b tau_s ln2 / 2`` as
    ``|tau|`` grows), so ``der(energy) = tau w_rel`` holds exactly.
    """

    b = Parameter(0.0, unit="rad", min=0.0, doc="total play (flank to flank)")
    tau_s = Parameter(0.5, unit="N.m", min=1e-9, doc="torque band over which the flanks change contact")
    energy = Variable(unit="J", doc="stored energy of the smoothed law")

    def equations(self):
        x = self.tau / self.tau_s
        ln_cosh = sp.Abs(x) + sp.log(1 + sp.exp(-2 * sp.Abs(x))) - sp.log(2)  # ln cosh x without overflow
        return [*super().equations(), Eq(self.phi_rel, self.b / 2 * sp.tanh(x)),
                Eq(self.energy, self.b / 2 * (self.tau * sp.tanh(x) - self.tau_s * ln_cosh))]


class ElastoBacklash(PartialCompliantWithRelativeStates):
    """Play ``b`` between two stiff, damped flanks (MSL ``ElastoBacklash``, symmetric play, ``phi_rel0 = 0``)::

        dz = phi_rel - clamp(phi_rel, -b/2, b/2)        (deflection of the flank in contact; 0 in the gap)
        tau = c dz + d w_rel min(1, |dz| / phi_d)

    In the gap nothing is transmitted; in contact the flanks are a spring ``c`` with a damper ``d`` (the damping
    comes in over the first ``phi_d`` of deflection, so the torque stays continuous where MSL's switches). No event:
    the law is continuous, so exact parameter sensitivities exist; ``b = 0`` is a stiff damped shaft, whose
    sensitivity to ``b`` is ``-c sign(phi_rel) / 2``. ``energy = c dz^2 / 2``, ``loss_power = tau w_rel -
    der(energy) >= 0`` (the damper's), so ``der(energy) = tau w_rel - loss_power`` holds exactly.
    """

    b = Parameter(0.0, unit="rad", min=0.0, doc="total play (flank to flank)")
    c = Parameter(None, unit="N.m/rad", min=0.0, doc="stiffness of the flanks in contact")
    d = Parameter(0.0, unit="N.m.s/rad", min=0.0, doc="damping of the flanks in contact")
    phi_d = Parameter(1e-5, unit="rad", min=1e-15, doc="deflection over which the damping comes in")
    dz = Variable(unit="rad", doc="deflection of the flank in contact (0 in the gap)")
    energy = Variable(unit="J", doc="stored energy c dz^2 / 2")
    loss_power = Variable(unit="W", doc="dissipated power (damping in contact) >= 0")

    def equations(self):
        half = self.b / 2
        damping = self.d * sp.Min(1, sp.Abs(self.dz) / self.phi_d)
        return [*super().equations(), Eq(self.dz, self.phi_rel - sp.Min(sp.Max(self.phi_rel, -half), half)),
                Eq(self.tau, self.c * self.dz + damping * self.w_rel),
                Eq(self.energy, self.c * self.dz**2 / 2), Eq(self.loss_power, damping * self.w_rel**2)]


class IdealGear(PartialGear):
    """Ideal gear without inertia or losses: ``phi_a = ratio * phi_b``, ``0 = ratio * flange_a.tau + flange_b.tau``
    (angles relative to the support). ``ratio`` > 1 reduces speed from a to b."""

    def equations(self):
        return [*super().equations(), Eq(0, self.ratio * self.flange_a.tau + self.flange_b.tau)]


class TorqueSource(PartialElementaryOneFlangeAndSupport2):
    """Prescribed torque ``tau(t)`` accelerating ``flange`` (``flange.tau = -tau``), reaction on the support."""

    tau = Input(unit="N.m", doc="driving torque")

    def equations(self):
        return [*super().equations(), Eq(self.flange.tau, -self.tau)]


class SignalTorque(PartialElementaryOneFlangeAndSupport2):
    """Torque source driven by a causal input ``u`` [N m] (``flange.tau = -u``), reaction on the support."""

    u = RealInput(doc="driving torque [N m]")

    def equations(self):
        return [*super().equations(), Eq(self.flange.tau, -self.u.value)]


class Position(PartialElementaryOneFlangeAndSupport2):
    """Prescribed angle (MSL ``Position`` with exact=true): ``flange.phi - support.phi = phi_ref(t)``.

    ``phi_ref`` is a number, a sympy expression of time or a :class:`acausal.Signal`; index reduction asks it for
    as many derivatives as the rest of the model needs. The source supplies whatever torque the motion takes.
    """

    phi_ref = Input(unit="rad", doc="prescribed angle")
    flange = Flange(doc="flange moved along phi_ref")

    def equations(self):
        return [*super().equations(), Eq(self.flange.phi - self.phi_support, self.phi_ref)]


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


class BearingFriction(GearFriction):
    """Rigid shaft with bearing friction to the support: ``tau_f = tau_c tanh(w / w_c) + d w``.

    The Coulomb + viscous law of :class:`~acausal.library.friction.GearFriction` (``flange_a.tau + flange_b.tau =
    tau_f``, the friction torque flows to the support, ``loss_power = tau_f w >= 0``) with a narrower smooth-sign
    scale by default (``w_c`` = 1e-3 rad/s, for shafts that turn fast); Coulomb friction uses the documented
    smooth law (see :class:`acausal.library.drives.DCMotor`).
    """

    w_c = Parameter(1e-3, unit="rad/s", min=1e-12, doc="speed scale of the smooth Coulomb law")
    default_terms = ("coulomb",)


class LossyGear(PartialGear):
    """Gear mesh with a power-flow-dependent efficiency (MSL ``LossyGear`` without locking), massless.

    Kinematics ``phi_a = ratio * phi_b`` (relative to the support). Torques, with ``tau_a = flange_a.tau`` and the
    mode ``backdriven``::

        driving    (tau_a w_a >= 0, power flows a -> b):  tau_out = eta * ratio * tau_a
        back-driven (tau_a w_a < 0, power flows b -> a):  tau_out = ratio * tau_a / eta
        flange_b.tau = -tau_out

    so the mesh loses ``(1 - eta)`` of its input power when driven and ``(1/eta - 1)`` of its output power when
    back-driven: ``loss_power = tau_a w_a (1 - eff) >= 0`` in both.

    ``law="events"`` (default): the mode switches by state events on the zero crossings of ``w_a`` and of
    ``tau_a`` (the direction of the crossing and the other factor's sign decide the new mode); exact, and it does
    not chatter where the motion is prescribed. Under *forward* dynamics a gear at rest whose load torque lies
    inside the locking band (neither mode consistent) would chatter: this component has no locked mode.

    ``law="smooth"``: ``eff = eta ** tanh(P_out / P_s)`` with ``P_out = -flange_b.tau w_b`` the power leaving at
    the output (same sign as the input power ``tau_a w_a``), a documented smooth law without modes: it equals
    the event law to within ``1 - tanh(|P|/P_s)`` (below 0.1 % for ``|P| > 4 P_s``, P_s = 0.5 W by default), is
    lossless at zero power, keeps ``loss_power >= 0`` at every instant, and passes through zero speed without a
    locked phase (no stiction). Use it for forward simulation, and for inverse models with an inductor on the
    motor side: there the event law's efficiency jump at a motion reversal makes the current jump, and the
    energy of that jump (an impulse) never appears in an integrated power.
    """

    eta = Parameter(1.0, unit="1", min=1e-6, max=1.0, doc="mesh efficiency")
    w_a = Variable(unit="rad/s", doc="input speed")
    eff = Variable(unit="1", doc="torque efficiency factor in the present mode (eta or 1/eta)")
    input_power = Variable(unit="W", doc="power into the mesh at flange_a, tau_a w_a")
    loss_power = Variable(unit="W", doc="mesh loss (>= 0)")
    backdriven = Discrete(start=0.0, doc="1 while power flows from flange_b to flange_a")

    P_s = Parameter(0.5, unit="W", min=1e-12, doc="power scale of the smooth law (law='smooth' only)")
    laws = ("events", "smooth")

    def __init__(self, use_support: bool = False, law: str = "events", **kw):
        self.law = check_option(self, "law", law, self.laws)
        super().__init__(use_support=use_support, **kw)

    def _efficiency(self):
        if self.law == "smooth":
            # the output-side power -tau_b w_b has the sign of the input power (tau_a = -tau_b / (eff ratio)), and
            # written this way the torque relation stays explicit when the output torque is known (replays)
            return self.eta ** sp.tanh(-self.flange_b.tau * self.w_a / (self.ratio * self.P_s))
        m = self.backdriven
        return (1 - m) * self.eta + m / self.eta

    def equations(self):
        tau_a = self.flange_a.tau
        return [*super().equations(), Eq(self.w_a, der(self.phi_a)),
                Eq(self.eff, self._efficiency()),
                Eq(self.flange_b.tau, -self.eff * self.ratio * tau_a),
                Eq(self.input_power, tau_a * self.w_a),
                Eq(self.loss_power, self.input_power * (1 - self.eff))]

    def events(self):
        if self.law == "smooth":
            return []
        tau_a, w_a = self.flange_a.tau, self.w_a
        m = self.backdriven
        return [Event(w_a, on_rising={m: sp.StrictLessThan(tau_a, 0)}, on_falling={m: sp.StrictGreaterThan(tau_a, 0)},
                      doc="motion reverses"),
                Event(tau_a, on_rising={m: sp.StrictLessThan(w_a, 0)}, on_falling={m: sp.StrictGreaterThan(w_a, 0)},
                      doc="load reverses")]


class StickSlipGear(PartialGear, PartialFriction):
    """Gear mesh with direction-dependent efficiency and bearing friction that can stick (MSL ``LossyGear``'s
    semantics: modes Forward, Stuck, Backward), massless; for forward dynamics.

    With ``w_a = der(phi_a)`` and ``tau_a = flange_a.tau``, the torque the mesh and bearing consume, referred to
    flange_a, is ``tau_loss = tau_a + flange_b.tau / ratio`` (so the loss power is ``tau_loss w_a``). Sliding, it
    is the largest (forward, ``w_a > 0``) or smallest (backward) of the two power-flow cases::

        forward:   tau_loss = max((1 - eta) tau_a, (1 - 1/eta_b) tau_a) + tau_bf     (>= 0)
        backward:  tau_loss = min((1 - eta) tau_a, (1 - 1/eta_b) tau_a) - tau_bf     (<= 0)

    ``eta``: efficiency when power flows from flange_a to flange_b (MSL ``eta_mf1``), ``eta_b`` when it flows back
    (``eta_mf2``, default ``eta``), ``tau_bf``: bearing friction torque at flange_a (``tau_bf1 = tau_bf2``; the
    speed dependence of MSL's ``lossTable`` is not modelled). Stuck, ``der(w_a) = 0`` and ``tau_loss`` is what holds
    the gear, breaking away when it leaves the band between the two sliding values (the stick/slip machine of
    :class:`~acausal.model.partials.PartialFriction`, modes ``stuck`` and ``forward``, path parameter ``sa``).
    ``loss_power = tau_loss w_a >= 0`` in every mode. A gear that starts moving backward needs
    ``StickSlipGear(forward=0)``.
    """

    eta = Parameter(1.0, unit="1", min=1e-6, max=1.0, doc="mesh efficiency, power from flange_a to flange_b")
    eta_b = Parameter(None, unit="1", min=1e-6, max=1.0, doc="mesh efficiency, power from flange_b to flange_a "
                      "(default eta)")
    tau_bf = Parameter(0.0, unit="N.m", min=0.0, doc="bearing friction torque at flange_a")
    w_a = Variable(unit="rad/s", doc="input speed")
    a_a = Variable(unit="rad/s2", doc="input acceleration")
    tau_loss = Variable(unit="N.m", doc="torque consumed by mesh and bearing, referred to flange_a")
    loss_power = Variable(unit="W", doc="mesh and bearing loss tau_loss w_a (>= 0)")

    def build(self):
        if "eta_b" not in self._values:
            self._values["eta_b"] = self.eta

    def _loss(self):
        tau_a, mesh = self.flange_a.tau, ((1 - self.eta), (1 - 1 / self.eta_b))
        fwd = sp.Max(mesh[0] * tau_a, mesh[1] * tau_a) + self.tau_bf
        bwd = sp.Min(mesh[0] * tau_a, mesh[1] * tau_a) - self.tau_bf
        return fwd, bwd

    def equations(self):
        fwd, bwd = self._loss()
        return [*super().equations(), Eq(self.w_a, der(self.phi_a)),
                Eq(self.tau_loss, self.flange_a.tau + self.flange_b.tau / self.ratio),
                *self.friction_equations(self.w_a, self.a_a, self.tau_loss, fwd, bwd),
                Eq(self.loss_power, self.tau_loss * self.w_a)]

    def breakaway(self) -> tuple:
        return self._loss()

    def events(self):
        return self.friction_events(self.w_a)


class Gearbox(Model):
    """A gear stage: input inertia, lossy mesh, output bearing friction and output inertia::

        flange_a -- [J_a] -- LossyGear(ratio, eta) -- BearingFriction(tau_c, d) -- [J_b] -- flange_b

    ``loss_power`` = mesh + bearing loss; ``energy`` = kinetic energy of both inertias. Stages compose by
    connecting ``flange_b`` of one to ``flange_a`` of the next (the paper: planetary 86:1, max. efficiency 70 %,
    input inertia 0.7 g cm2, then helical 10:1). ``law`` selects the mesh's switching (see :class:`LossyGear`).
    """

    ratio = Parameter(1.0, unit="1", nonzero=True, doc="transmission ratio (0 would lock flange_a)")
    eta = Parameter(1.0, unit="1", min=1e-6, max=1.0, doc="mesh efficiency")
    J_a = Parameter(0.0, unit="kg.m2", min=0.0, doc="inertia on the input side")
    J_b = Parameter(0.0, unit="kg.m2", min=0.0, doc="inertia on the output side")
    tau_c = Parameter(0.0, unit="N.m", min=0.0, doc="output bearing Coulomb friction")
    d = Parameter(0.0, unit="N.m.s/rad", min=0.0, doc="output bearing viscous friction")
    w_c = Parameter(BearingFriction.w_c.default, unit="rad/s", min=1e-12,
                    doc="speed scale of the bearing's smooth Coulomb law (see BearingFriction)")
    flange_a = Flange(doc="input (fast) side")
    flange_b = Flange(doc="output (slow) side")
    loss_power = Variable(unit="W", doc="mesh + bearing losses")
    energy = Variable(unit="J", doc="kinetic energy of J_a and J_b")

    def __init__(self, law: str = "events", **kw):
        super().__init__(**kw)
        self.law = check_option(self, "law", law, LossyGear.laws)

    def build(self):
        self.inertia_a = Inertia(J=self.J_a)
        self.mesh = LossyGear(ratio=self.ratio, eta=self.eta, law=self.law)
        self.bearing = BearingFriction(tau_c=self.tau_c, d=self.d, w_c=self.w_c)
        self.inertia_b = Inertia(J=self.J_b)
        connect(self.flange_a, self.inertia_a.flange_a)
        connect(self.inertia_a.flange_b, self.mesh.flange_a)
        connect(self.mesh.flange_b, self.bearing.flange_a)
        connect(self.bearing.flange_b, self.inertia_b.flange_a)
        connect(self.inertia_b.flange_b, self.flange_b)

    def equations(self):
        return [Eq(self.loss_power, self.mesh.loss_power + self.bearing.loss_power),
                Eq(self.energy, self.inertia_a.energy + self.inertia_b.energy)]


class SelfLockingGear(PartialGear):
    """Non-backdrivable (self-locking) gear stage, e.g. a worm gear whose friction angle is at least its lead
    angle; massless. The load cannot drive the input: when it pushes in the direction of motion the input still
    has to turn the gear, and with the input unpowered the gear holds any load at standstill.

    Kinematics ``phi_a = ratio * phi_b`` (relative to the support). With the power leaving at the output
    ``P_out = -flange_b.tau * w_b`` and the input torque factor ``g``::

        flange_a.tau = -(1 - hold) * g * flange_b.tau / ratio          (so input power = (1 - hold) g P_out)
        driving     (P_out > 0):  g = 1 / eta        (input power P_out / eta)
        overhauling (P_out < 0):  g = eta_back <= 0  (the input still delivers eta_back P_out >= 0; nothing returns)

    For a worm of lead angle lambda and friction angle rho: ``eta = tan(lambda) / tan(lambda + rho)`` and
    ``eta_back = tan(lambda - rho) / tan(lambda)``; self-locking means ``rho >= lambda``, i.e. ``eta_back <= 0``
    and ``eta <= 1/2`` (for small angles). Defaults: the most efficient self-locking worm, lambda = rho =
    5.71 deg (friction coefficient 0.1): eta = 0.495, eta_back = 0 (assumptions, no such stage in the paper).

    Smooth law (no modes, like :class:`LossyGear` with ``law="smooth"``)::

        g = 1 + tanh(x) * (a + b tanh(x)),   x = P_out / P_s,
        a = (1/eta - eta_back) / 2,  b = (1/eta + eta_back) / 2 - 1

    which tends to ``1/eta`` for ``x >> 1`` and to ``eta_back`` for ``x << -1`` and keeps
    ``loss_power = input_power - P_out = (g - 1) P_out >= 0`` at every instant (``a + b tanh(x) > 0``).

    ``hold`` (input, 0..1) is the share of the output torque the locked mesh passes to the housing instead of the
    input: 1 while the input side is unpowered (motor driver switched off), 0 in normal operation. Holding is a
    standstill state: use ``hold > 0`` only while the gear does not turn (a self-locking gear with an unpowered
    input cannot turn). At standstill any input torque between ``eta_back`` and ``1/eta`` times the output
    torque over ``ratio`` is admissible, and ``(1 - hold)`` lies in that band because ``eta_back <= 0``.
    """

    eta = Parameter(0.495, unit="1", min=1e-6, max=1.0, doc="efficiency when driving (worm: tan l / tan(l + r))")
    eta_back = Parameter(0.0, unit="1", min=-1.0, max=0.0,
                         doc="efficiency when the load overhauls (<= 0: self-locking; worm: tan(l - r) / tan l)")
    P_s = Parameter(0.5, unit="W", min=1e-12, doc="power scale of the smooth law")
    hold = RealInput(doc="share of the output torque held by the locked mesh (0..1; 1 = input unpowered)")
    w_b = Variable(unit="rad/s", doc="output speed")
    g = Variable(unit="1", doc="input torque factor (1/eta driving, eta_back overhauling)")
    output_power = Variable(unit="W", doc="power leaving at flange_b, -flange_b.tau w_b")
    input_power = Variable(unit="W", doc="power into the gear at flange_a")
    loss_power = Variable(unit="W", doc="input minus output power (>= 0)")

    def equations(self):
        tau_a, tau_b = self.flange_a.tau, self.flange_b.tau
        x = sp.tanh(-tau_b * self.w_b / self.P_s)
        a = (1 / self.eta - self.eta_back) / 2
        b = (1 / self.eta + self.eta_back) / 2 - 1
        return [*super().equations(), Eq(self.w_b, der(self.phi_b)),
                Eq(self.g, 1 + x * (a + b * x)),
                Eq(tau_a, -(1 - self.hold.value) * self.g * tau_b / self.ratio),
                Eq(self.output_power, -tau_b * self.w_b),
                Eq(self.input_power, tau_a * self.ratio * self.w_b),
                Eq(self.loss_power, self.input_power - self.output_power)]
