"""Electrical machines with the parameters of MSL ``Modelica.Electrical.Machines`` (names, records, sign conventions).

The armature current flows from ``pin_ap`` through the machine to ``pin_an`` (positive: motoring); the shaft torque
the machine delivers to its load is ``tauShaft = -flange.tau``. A machine is composed of the library's parts, as
the MSL builds it, and keeps its own energy accounts (the parts' are not counted again).
"""
import math
import numbers

from acausal import Eq, Model, ModelError, Parameter, Variable, connect
from acausal.model.connectors import Flange, Pin
from acausal.model.partials import check_option

from .electrical import EMF, Inductor, Resistor
from .rotational import Inertia

__all__ = ["DCPermanentMagnet"]

T20 = 293.15  # K: the temperature MSL's alpha20 coefficients refer to (20 degC)
_DATA = "MSL DcPermanentMagnetData"  # the machine the defaults describe (MSL 4.0 record)


class DCPermanentMagnet(Model):
    """Permanent-magnet DC machine (MSL ``Machines.BasicMachines.DCMachines.DC_PermanentMagnet``) with its
    record's parameters (``Machines.Utilities.ParameterRecords.DcPermanentMagnetData``)::

        pin_ap -- ra -- la -- airGapDC -- pin_an          va = Ra(TaOperational) ia + La dia/dt + turnsRatio wMechanical
                              |  (EMF)                     tauElectrical = turnsRatio ia
                              +-- inertiaRotor -- flange   Jr dw/dt = tauElectrical - tauShaft

    The air gap is an ideal :class:`~acausal.library.electrical.EMF` whose constant is MSL's ``turnsRatio``, the
    induced voltage at the nominal point over the nominal speed::

        turnsRatio = (VaNominal - Ra(TaNominal) IaNominal) / wNominal

    (the record's defaults: 95 V / 1425 rpm = 0.637 V s/rad, so the nominal 100 A make the nominal 63.66 N m).
    ``VaNominal <= Ra(TaNominal) IaNominal`` leaves no induced voltage and is refused, as MSL's assert does: at
    construction with a message naming ``VaNominal``, ``Ra`` and ``IaNominal``, and in a run that overrides them
    because ``turnsRatio`` (a parameter bound to them) is then below its minimum.

    The armature resistance follows MSL's linear law at fixed temperatures (MSL's ``useThermalPort=false``)::

        Ra(T) = Ra (1 + alphaRef (T - TaRef)),     alphaRef = alpha20a / (1 + alpha20a (TaRef - 293.15 K))

    at ``TaOperational`` in the armature (``ra.R``) and at ``TaNominal`` in ``turnsRatio``; with the record's
    ``alpha20a = 0`` it is ``Ra`` at every temperature. There is no thermal port.

    Not modelled: MSL's friction, core (eddy current), stray load and brush losses. The record sets them all to
    zero (``PRef = 0``, brush ``V = 0``), so at the record's values this is MSL's machine; a machine with
    friction gets it from a part on ``flange`` (e.g. :class:`~acausal.library.rotational.BearingFriction`).

    ``use_support=False`` (MSL ``useSupport``): the stator is fixed and ``Js`` is unused. ``use_support=True``: the
    stator is an inertia ``Js`` between the air gap's reaction and the ``support`` flange, so ``support`` takes
    the air-gap reaction minus what accelerates the stator (connect it to a ``Fixed`` or a housing).

    Readouts (MSL's names): ``va``, ``ia`` (from ``pin_ap`` in), ``phiMechanical``, ``wMechanical`` (rotor against
    stator), ``tauElectrical`` (air-gap torque), ``tauShaft``. Start values go on these, as in MSL's DCPM_Start:
    ``DCPermanentMagnet(ia=Start(0.0), wMechanical=Start(0.0), phiMechanical=Start(0.0))``. Accounts:
    ``loss_power`` = armature copper loss ``Ra(TaOperational) ia^2``; ``energy`` = ``La ia^2 / 2`` + kinetic
    energy of rotor (and stator). Defaults: the MSL 4.0 record (VaNominal 100 V, IaNominal 100 A, wNominal
    1425 rpm, Ra 0.05 ohm at TaRef = TaNominal = 20 degC, alpha20a 0, La 1.5 mH, Jr = Js = 0.15 kg m2) and
    TaOperational = 20 degC (MSL's DCPM_Start).
    """

    VaNominal = Parameter(100.0, unit="V", doc="nominal armature voltage (MSL record)", device=_DATA)
    IaNominal = Parameter(100.0, unit="A", doc="nominal armature current, > 0 motor, < 0 generator (MSL record)",
                          device=_DATA)
    wNominal = Parameter(1425 * 2 * math.pi / 60, unit="rad/s", min=1e-12, doc="nominal speed, 1425 rpm (MSL record)",
                         device=_DATA)
    TaNominal = Parameter(T20, unit="K", min=0.0, doc="nominal armature temperature (MSL record: 20 degC)")
    Ra = Parameter(0.05, unit="Ohm", min=0.0, doc="armature resistance at TaRef (MSL record)", device=_DATA)
    TaRef = Parameter(T20, unit="K", min=0.0, doc="reference temperature of Ra (MSL record: 20 degC)")
    alpha20a = Parameter(0.0, unit="1/K", doc="temperature coefficient of Ra at 20 degC (MSL record: 0)")
    La = Parameter(0.0015, unit="H", min=0.0, doc="armature inductance (MSL record)", device=_DATA)
    Jr = Parameter(0.15, unit="kg.m2", min=0.0, doc="rotor inertia (MSL record)", device=_DATA)
    Js = Parameter(0.15, unit="kg.m2", min=0.0, doc="stator inertia, with use_support only (MSL record: Js = Jr)",
                   device=_DATA)
    TaOperational = Parameter(T20, unit="K", min=0.0, doc="armature temperature in operation (MSL DCPM_Start: "
                                                          "20 degC)")
    turnsRatio = Parameter(None, unit="V.s/rad", min=1e-12, derived="(VaNominal - Ra(TaNominal) IaNominal) / wNominal",
                           doc="EMF and torque constant (MSL turnsRatio; derived, not set)")

    pin_ap = Pin(doc="positive armature pin")
    pin_an = Pin(doc="negative armature pin")
    flange = Flange(doc="shaft")
    va = Variable(unit="V", doc="armature voltage pin_ap.v - pin_an.v")
    ia = Variable(unit="A", doc="armature current into pin_ap")
    phiMechanical = Variable(unit="rad", doc="rotor angle against the stator")
    wMechanical = Variable(unit="rad/s", doc="rotor speed against the stator")
    tauElectrical = Variable(unit="N.m", doc="air-gap torque turnsRatio * ia")
    tauShaft = Variable(unit="N.m", doc="torque delivered at the shaft, -flange.tau")
    loss_power = Variable(unit="W", doc="armature copper loss Ra(TaOperational) ia^2")
    energy = Variable(unit="J", doc="La ia^2/2 + kinetic energy of rotor (and stator)")

    def __init__(self, use_support: bool = False, **kw):
        if "turnsRatio" in kw:
            raise ModelError(f"{type(self).__name__}: turnsRatio is derived from VaNominal, Ra, IaNominal and "
                             "wNominal (MSL: final); set those instead")
        check_option(self, "use_support", use_support, (True, False))
        super().__init__(**kw)
        self._check_nominal_point()
        self.use_support = use_support
        if use_support:
            self.support = Flange(doc="stator (housing): takes the reaction torque")

    def _check_nominal_point(self):
        """MSL's assert ``ViNominal > 0``, where the values are numbers (bindings are checked per run)."""
        names = ("VaNominal", "Ra", "IaNominal", "TaRef", "alpha20a", "TaNominal")
        va, ra, ia, t_ref, alpha, t_nom = (self.parameter_value(n) for n in names)
        if not all(isinstance(x, numbers.Real) for x in (va, ra, ia, t_ref, alpha, t_nom)):
            return
        ra_nom = ra * (1 + alpha / (1 + alpha * (t_ref - T20)) * (t_nom - t_ref))
        if not va - ra_nom * ia > 0:
            raise ModelError(f"{type(self).__name__}: VaNominal = {va!r} V must exceed Ra IaNominal = {ra_nom!r} Ohm * "
                             f"{ia!r} A = {ra_nom * ia!r} V (Ra at TaNominal): the induced voltage at the nominal "
                             "point, whose ratio to wNominal is the EMF constant turnsRatio, would be "
                             f"{va - ra_nom * ia!r} V; lower IaNominal or Ra, or raise VaNominal")

    def _resistance_at(self, T):
        """MSL ``convertResistance(Ra, TaRef, alpha20a, T)``."""
        alpha_ref = self.alpha20a / (1 + self.alpha20a * (self.TaRef - T20))
        return self.Ra * (1 + alpha_ref * (T - self.TaRef))

    def build(self):
        self._values["turnsRatio"] = (self.VaNominal - self._resistance_at(self.TaNominal) * self.IaNominal) \
            / self.wNominal
        self.ra = Resistor(R=self._resistance_at(self.TaOperational))
        self.la = Inductor(L=self.La)
        self.airGapDC = EMF(k=self.turnsRatio, use_support=self.use_support)
        self.inertiaRotor = Inertia(J=self.Jr)
        connect(self.pin_ap, self.ra.p)
        connect(self.ra.n, self.la.p)
        connect(self.la.n, self.airGapDC.p)
        connect(self.airGapDC.n, self.pin_an)
        connect(self.airGapDC.flange, self.inertiaRotor.flange_a)
        connect(self.inertiaRotor.flange_b, self.flange)
        if self.use_support:
            self.inertiaStator = Inertia(J=self.Js)
            connect(self.airGapDC.support, self.inertiaStator.flange_a)
            connect(self.inertiaStator.flange_b, self.support)

    def equations(self):
        kinetic = self.inertiaRotor.energy + (self.inertiaStator.energy if self.use_support else 0)
        return [Eq(self.va, self.pin_ap.v - self.pin_an.v), Eq(self.ia, self.pin_ap.i),
                Eq(self.phiMechanical, self.airGapDC.phi), Eq(self.wMechanical, self.airGapDC.w),
                Eq(self.tauElectrical, self.inertiaRotor.flange_a.tau), Eq(self.tauShaft, -self.flange.tau),
                Eq(self.loss_power, self.ra.loss_power), Eq(self.energy, self.la.energy + kinetic)]
