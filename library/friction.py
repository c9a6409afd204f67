"""Friction laws of a gear train as swap-in shaft elements (1-D rotational, MSL sign conventions).

Every law is a rigid, massless shaft between ``flange_a`` (the driving side: motor and gear) and ``flange_b``
(the load side) whose friction torque goes to the support (``use_support=True`` exposes the housing and its
reaction ``support.tau = -tau_f``)::

    flange_a.phi = flange_b.phi,   w = der(phi)
    flange_a.tau + flange_b.tau = tau_f = F_max tanh(w / w_c) + d w
    loss_power = tau_f w >= 0

``F_max >= 0`` is the friction *budget* (the largest torque the contact can hold); the laws differ only in what it
depends on. Each term vanishes when its parameter is zero, so a law extends a simpler one by one parameter:

==================  ================================================  ==============================================
term                budget contribution                               physics (BAM, Duclusaud et al., ICRA 2025)
==================  ================================================  ==============================================
``coulomb``         ``tau_c``                                         dry friction of bearings and seals (M1, with
                                                                      ``d``)
``stribeck``        ``tau_s S(w)``                                    extra breakaway friction at low speed (M2)
``load``            ``k_l G``                                         mesh friction proportional to the load (M3;
                                                                      MSL ``LossyGear``'s torque-proportional loss)
``backdrive``       ``k_b |tau_a| (1 - tanh(P_a/P_s)) / 2``           extra mesh friction while the load drives the
                                                                      gear (power flows b -> a, ``P_a = tau_a w <
                                                                      0``; MSL's eta vs 1/eta)
``load_stribeck``   ``k_ls G S(w)``                                   load friction that is larger at rest (M4)
``directional``     ``|k_e tau_ext - k_m tau_a|``                     load friction weighted by side (M5; needs the
                    ``+ |k_es tau_ext - k_ms tau_a| S(w)``            external measure)
``quadratic``       ``S(w) (k_eq tau_ext^2 [|tau_ext| < |tau_a|]``    quadratic load friction while motor and load
                    ``+ k_mq tau_a^2 [|tau_ext| > |tau_a|])``         torques oppose (M6; BAM's pairing of names)
``unpowered``       ``tau_u (1 - enable)``                            friction of the train while the motor is not
                                                                      driven and the load back-drives it (the
                                                                      input ``enable``: BAM's models fit torque-off
                                                                      phases apart; the rotor's cogging, a gear
                                                                      mesh loaded by the rotor's own inertia)
==================  ================================================  ==============================================

``tau_a = flange_a.tau``; ``S(w) = exp(-(|w|_c / w_s)^alpha)`` is the Stribeck curve. **The load measure**
``G`` is, with ``load_measure="transmitted"`` (default), the torque at ``flange_a``, ``G = |tau_a|``: connect the
driving side there through massless parts (an EMF and an ideal gear: it is then the motor's air-gap torque through the
gear, BAM's "motor torque") and put the rotor's inertia on the ``flange_b`` side, so the budget does not depend on
accelerations (otherwise the law is an algebraic loop, which the compiler solves by Newton iterations, slower).
With ``load_measure="external"`` the law has an input ``tau_ext``, the external torque on the load (a pendulum's
gravity torque, BAM's "bias torque"), and ``G = |tau_ext - tau_a|``, BAM's definition (Rhoban/bam
``bam/model.py``, ``compute_frictions``): published M3-M6 parameter sets then mean here what they mean in BAM's
simulator. (Holding a load still, ``tau_a = -tau_ext``, so BAM's ``G`` is twice the transmitted torque.)

Smooth Coulomb law: ``tanh(w / w_c)`` replaces the sign of w (stiction becomes creep below about ``w_c``; default
0.01 rad/s, against the 0.024 rad/s resolution of a Dynamixel speed reading), which keeps the model free of events
so exact parameter sensitivities exist. ``loss_power >= 0`` at every instant because the budget is never negative.
For the same reason the Stribeck curve uses ``|w|_c = sqrt(w^2 + w_c^2)`` (its derivatives stay finite at rest;
the curve's value there is lower by a factor ``exp(-(w_c/w_s)^alpha)``, 1e-5 with the defaults).
"""
import sympy as sp

from acausal import Eq, Parameter, RealInput, Variable, der
from acausal.errors import ModelError
from acausal.model.partials import (PartialCompliantWithRelativeStates, PartialElementaryTwoFlangesAndSupport2,
                                    PartialFriction)

__all__ = ["GearFriction", "CoulombViscousFriction", "StribeckFriction", "LoadDependentFriction",
           "DirectionalFriction", "TERMS", "Clutch", "Brake"]

#: the budget terms a law may have, in the order they are documented
TERMS = ("coulomb", "stribeck", "load", "backdrive", "load_stribeck", "directional", "quadratic", "unpowered")
#: the terms that need the external load torque (``load_measure="external"``)
EXTERNAL_TERMS = ("directional", "quadratic")


class GearFriction(PartialElementaryTwoFlangesAndSupport2):
    """A shaft with friction of the chosen ``terms`` (a subset of :data:`TERMS`) plus viscous friction ``d w``.

    Defaults (``tau_c``, ``d``, ``tau_s``, ``w_s``, ``alpha``, ``k_l``, ``k_b``) are zero or, for the shape
    parameters, of the order BAM published for Dynamixel servos (``w_s`` 2.6-4.2 rad/s, ``alpha`` 0.8-3 for the
    XL330; Rhoban/bam ``params/xl330``, Apache-2.0); sizes come from calibration.
    """

    tau_c = Parameter(0.0, unit="N.m", min=0.0, doc="Coulomb friction torque")
    d = Parameter(0.0, unit="N.m.s/rad", min=0.0, doc="viscous friction coefficient")
    tau_s = Parameter(0.0, unit="N.m", min=0.0, doc="Stribeck (breakaway) friction torque added at rest")
    w_s = Parameter(3.0, unit="rad/s", min=1e-9, doc="Stribeck speed (BAM xl330: 2.6-4.2 rad/s)")
    alpha = Parameter(2.0, unit="1", min=0.1, doc="Stribeck curve exponent (BAM xl330: 0.8-3)")
    k_l = Parameter(0.0, unit="1", min=0.0, doc="friction torque per unit of transmitted torque |flange_a.tau|")
    k_b = Parameter(0.0, unit="1", min=0.0, doc="extra friction per unit of transmitted torque when back-driven")
    P_s = Parameter(0.01, unit="W", min=1e-12, doc="power scale of the smooth back-drive switch")
    k_ls = Parameter(0.0, unit="1", min=0.0, doc="load friction per unit of G added at rest (Stribeck curve)")
    k_m = Parameter(0.0, unit="1", min=0.0, doc="directional load friction: weight of the motor torque")
    k_e = Parameter(0.0, unit="1", min=0.0, doc="directional load friction: weight of the external torque")
    k_ms = Parameter(0.0, unit="1", min=0.0, doc="the same at rest (Stribeck curve): motor torque")
    k_es = Parameter(0.0, unit="1", min=0.0, doc="the same at rest (Stribeck curve): external torque")
    k_mq = Parameter(0.0, unit="1/(N.m)", min=0.0, doc="quadratic load friction per motor torque squared")
    k_eq = Parameter(0.0, unit="1/(N.m)", min=0.0, doc="quadratic load friction per external torque squared")
    w_c = Parameter(0.01, unit="rad/s", min=1e-12, doc="speed scale of the smooth Coulomb law")
    tau_u = Parameter(0.0, unit="N.m", min=0.0, doc="Coulomb friction added while the motor is not driven")

    phi = Variable(unit="rad", doc="shaft angle relative to the support")
    w = Variable(unit="rad/s", doc="shaft speed relative to the support")
    budget = Variable(unit="N.m", doc="friction budget F_max >= 0 (torque the contact can hold)")
    tau_f = Variable(unit="N.m", doc="friction torque opposing w (flows to the support)")
    loss_power = Variable(unit="W", doc="dissipated power tau_f w >= 0")

    default_terms = ("coulomb",)

    def __init__(self, terms=None, use_support: bool = False, load_measure: str = "transmitted", **kw):
        terms = tuple(self.default_terms if terms is None else terms)
        if isinstance(terms, str) or not all(isinstance(t, str) for t in terms):
            raise ModelError(f"{type(self).__name__}: terms must be a tuple of names from {TERMS}, got {terms!r}")
        unknown = [t for t in terms if t not in TERMS]
        if unknown or len(set(terms)) != len(terms):
            raise ModelError(f"{type(self).__name__}: terms must be distinct names from {TERMS}, got {terms}")
        if load_measure not in ("transmitted", "external"):
            raise ModelError(f"{type(self).__name__}: load_measure must be 'transmitted' or 'external', got "
                             f"{load_measure!r}")
        needs = [t for t in terms if t in EXTERNAL_TERMS]
        if needs and load_measure != "external":
            raise ModelError(f"{type(self).__name__}: terms {needs} need load_measure='external' (the load's torque)")
        self.terms, self.load_measure = terms, load_measure
        super().__init__(use_support=use_support, **kw)
        if load_measure == "external":
            self.tau_ext = RealInput(doc="external torque on the load [N m] (e.g. a pendulum's gravity torque)")
        if "unpowered" in terms:
            self.enable = RealInput(doc="1 while the motor is driven, 0 while not (a servo's torque enable)")

    def budget_terms(self) -> dict:
        """term name -> its contribution to the budget (sympy), for the chosen terms."""
        w, tau_a = self.w, self.flange_a.tau
        ext = self.tau_ext.value if self.load_measure == "external" else None
        G = sp.Abs(ext - tau_a) if ext is not None else sp.Abs(tau_a)
        S = sp.exp(-(sp.sqrt(w**2 + self.w_c**2) / self.w_s) ** self.alpha)
        all_terms = {
            "coulomb": lambda: self.tau_c,
            "stribeck": lambda: self.tau_s * S,
            "load": lambda: self.k_l * G,
            "backdrive": lambda: self.k_b * sp.Abs(tau_a) * (1 - sp.tanh(tau_a * w / self.P_s)) / 2,
            "load_stribeck": lambda: self.k_ls * G * S,
            "directional": lambda: (sp.Abs(self.k_e * ext - self.k_m * tau_a)
                                    + sp.Abs(self.k_es * ext - self.k_ms * tau_a) * S),
            # BAM M6: on while the two torques have opposite signs; the external term where the motor's is larger
            "unpowered": lambda: self.tau_u * (1 - self.enable.value),
            "quadratic": lambda: S * (1 - sp.sign(ext) * sp.sign(tau_a)) / 2 * (
                (1 + sp.sign(sp.Abs(tau_a) - sp.Abs(ext))) / 2 * self.k_eq * ext**2
                + (1 + sp.sign(sp.Abs(ext) - sp.Abs(tau_a))) / 2 * self.k_mq * tau_a**2),
        }
        return {t: all_terms[t]() for t in self.terms}

    def equations(self):
        return [*super().equations(), Eq(self.phi, self.flange_a.phi - self.phi_support),
                Eq(self.flange_b.phi, self.flange_a.phi), Eq(self.w, der(self.phi)),
                Eq(self.budget, sp.Add(*self.budget_terms().values())),
                Eq(self.tau_f, self.budget * sp.tanh(self.w / self.w_c) + self.d * self.w),
                Eq(self.flange_a.tau + self.flange_b.tau, self.tau_f), Eq(self.loss_power, self.tau_f * self.w)]


class CoulombViscousFriction(GearFriction):
    """Coulomb + viscous friction, ``tau_f = tau_c tanh(w/w_c) + d w`` (BAM M1)."""

    default_terms = ("coulomb",)


class StribeckFriction(GearFriction):
    """Coulomb + Stribeck + viscous: ``F_max = tau_c + tau_s exp(-(|w|_c/w_s)^alpha)`` (BAM M2)."""

    default_terms = ("coulomb", "stribeck")


class LoadDependentFriction(GearFriction):
    """Coulomb + load-dependent + viscous: ``F_max = tau_c + k_l |flange_a.tau|`` (BAM M3)."""

    default_terms = ("coulomb", "load")


class DirectionalFriction(GearFriction):
    """Load-dependent friction that is larger while the load back-drives the gear (BAM M4's direction
    dependence, MSL ``LossyGear``'s driving/back-driven efficiencies): ``F_max = tau_c + k_l |tau_a| +
    k_b |tau_a| (1 - tanh(tau_a w / P_s)) / 2``."""

    default_terms = ("coulomb", "load", "backdrive")


# --------------------------------------------------------------------------------------------- stick/slip
class _DryFriction(PartialFriction):
    """Coulomb friction with stiction, driven by a normal force: ``fn = fn_max f_normalized`` (clipped at 0);
    sliding it transmits ``mu cgeo fn`` against the motion, stuck it holds up to ``peak mu cgeo fn`` (MSL's
    constant ``mu_pos`` table, ``peak``, ``cgeo``, ``fn_max``)."""

    mu = Parameter(0.5, unit="1", min=0.0, doc="kinetic friction coefficient (MSL mu_pos, constant)")
    peak = Parameter(1.0, unit="1", min=1.0, doc="static / kinetic friction ratio")
    cgeo = Parameter(1.0, unit="m", min=0.0, doc="geometry constant: friction torque per unit of friction force")
    fn_max = Parameter(1.0, unit="N", min=0.0, doc="normal force at f_normalized = 1")
    f_normalized = RealInput(doc="normalized normal force (0: open, 1: fn_max)")
    loss_power = Variable(unit="W", doc="friction loss tau w >= 0")

    def _torques(self):
        slide = self.mu * self.cgeo * self.fn_max * sp.Max(self.f_normalized.value, 0)
        return slide, -slide, self.peak * slide, -self.peak * slide

    def _dry_friction(self, w, a, tau) -> list:
        slide_fwd, slide_bwd, _, _ = self._torques()
        return [*self.friction_equations(w, a, tau, slide_fwd, slide_bwd), Eq(self.loss_power, tau * w)]

    def breakaway(self) -> tuple:
        return self._torques()[2:]


class Clutch(PartialCompliantWithRelativeStates, _DryFriction):
    """Clutch between two flanges (MSL ``Clutch``): friction torque ``tau = flange_b.tau`` opposing the relative
    speed ``w_rel = der(flange_b.phi - flange_a.phi)``; modes of :class:`~acausal.model.partials.PartialFriction`
    (stuck: the flanges turn together and ``tau`` is what couples them, up to ``peak mu cgeo fn``).
    ``loss_power = tau w_rel >= 0``."""

    a_rel = Variable(unit="rad/s2", doc="relative angular acceleration")

    def equations(self):
        return [*super().equations(), *self._dry_friction(self.w_rel, self.a_rel, self.tau)]

    def events(self):
        return self.friction_events(self.w_rel)


class _FrictionShaft(PartialElementaryTwoFlangesAndSupport2):
    """A rigid shaft whose friction torque ``tau = flange_a.tau + flange_b.tau`` acts against the support, opposing
    ``w = der(flange_a.phi - support angle)``: what :class:`Brake` and :class:`StickSlipBearingFriction` share
    (each with :class:`~acausal.model.partials.PartialFriction`, whose events it watches on ``w``)."""

    phi = Variable(unit="rad", doc="shaft angle relative to the support")
    w = Variable(unit="rad/s", doc="shaft speed relative to the support")
    a = Variable(unit="rad/s2", doc="shaft acceleration relative to the support")
    tau = Variable(unit="N.m", doc="friction torque on the shaft, opposing w")

    def equations(self):
        return [*super().equations(), Eq(self.phi, self.flange_a.phi - self.phi_support),
                Eq(self.flange_a.phi, self.flange_b.phi), Eq(self.w, der(self.phi)),
                Eq(self.tau, self.flange_a.tau + self.flange_b.tau)]

    def events(self):
        return self.friction_events(self.w)


class Brake(_FrictionShaft, _DryFriction):
    """Brake on a shaft (MSL ``Brake``): ``flange_a`` and ``flange_b`` turn together, the friction torque
    ``tau = flange_a.tau + flange_b.tau`` acts between the shaft and the support (its reaction on the support with
    ``use_support=True``), opposing ``w = der(flange_a.phi - support angle)``; stuck, the shaft stands still
    relative to the support up to ``peak mu cgeo fn``. ``loss_power = tau w >= 0``."""

    def equations(self):
        return [*super().equations(), *self._dry_friction(self.w, self.a, self.tau)]


class StickSlipBearingFriction(_FrictionShaft, PartialFriction):
    """Bearing friction with stiction (MSL ``Rotational.Components.BearingFriction``): a rigid shaft whose friction
    torque ``tau = flange_a.tau + flange_b.tau`` acts against the support, opposing ``w = der(flange_a.phi - support
    angle)``. Sliding it is MSL's ``tau_pos`` table as a line, ``tau = tau0 + d |w|`` against the motion
    (``tau_pos = [0, tau0; 1, tau0 + d]``); stuck, the shaft stands still relative to the support while the
    holding torque stays within ``peak tau0`` (the modes of :class:`~acausal.model.partials.PartialFriction`, shared
    with other friction elements stuck on the same shaft, as MSL's stuck groups). ``loss_power = tau w >= 0``.

    The smooth :class:`~acausal.library.rotational.BearingFriction` creeps through zero speed instead of sticking
    (no events, exact sensitivities); this one sticks, which MSL's ``LossyGearDemo2`` needs. Defaults: MSL's
    ``BearingFriction`` (``tau_pos = [0, 1]``: tau0 = 1 N m, no slope; ``peak = 1``)."""

    tau0 = Parameter(1.0, unit="N.m", min=0.0, doc="sliding friction torque at zero speed (MSL tau_pos at w = 0)")
    d = Parameter(0.0, unit="N.m.s/rad", min=0.0, doc="slope of the sliding friction torque with |w|")
    peak = Parameter(1.0, unit="1", min=1.0, doc="static / sliding friction ratio at rest")
    loss_power = Variable(unit="W", doc="friction loss tau w >= 0")

    def equations(self):
        slide_fwd, slide_bwd = self.tau0 + self.d * self.w, -self.tau0 + self.d * self.w
        return [*super().equations(), *self.friction_equations(self.w, self.a, self.tau, slide_fwd, slide_bwd),
                Eq(self.loss_power, self.tau * self.w)]

    def breakaway(self) -> tuple:
        return self.peak * self.tau0, -self.peak * self.tau0
