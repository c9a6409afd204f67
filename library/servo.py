"""A hobby position servo (Dynamixel-type), assembled from library parts.

::

    position_ref -[goal]-> (+) -[error]-> [Gain kp*error_gain] -[duty]-> [DutyOutput] --duty--> [PWMDriver]
                            ^-                                      enable --^         bus_p -[bus]-^   |
                            |                                                               [SwitchedResistor R]
                            |                                                                [EMF kt/ratio]
    position <-[position]- [AngleSensor] <-[drive]- [Inertia armature] <-- [GearFriction] <-- [IdealGear ratio]
                                 |
                                 +-[output]-> flange

The firmware's proportional law commands the PWM duty; the bridge puts ``duty * v_bus`` on the winding (lossless,
no quiescent draw: what a hobby servo's electronics dissipate is not measured and does not move the arm); the
winding is a resistance behind the torque-enable switch (inductance neglected: its time constant is far below the
~5 ms sampling of the logs); the EMF and the gear are ideal, and all mechanical loss is in the swap-in friction
law between the gear and the rotor inertia (:mod:`acausal.library.friction`). The rotor's inertia is lumped at
the output as ``armature`` (the reflected inertia, BAM's term) *after* the friction, so the friction's load
measure is the air-gap torque through the gear, as in BAM's models.

**Insertion slots** (the ``-[name]->`` above): ``inserts`` puts elements into the servo without changing its class,
each ``(slot, name, factory)`` with ``factory()`` returning a component that becomes ``servo.<name>``: ``goal`` (the
goal the firmware tracks), ``position`` (the reading it regulates), ``error``, ``duty`` (before the limit) take a
causal block with input ``u`` and output ``y`` (:mod:`acausal.library.firmware`,
:class:`~acausal.library.blocks.Bias`); ``bus`` a two-pin element in series with the supply (a
:class:`~acausal.library.electrical.Resistor`: supply sag); ``drive`` a two-flange element between the rotor and the
shaft the encoder reads (play in the gear train ahead of an encoder on the output shaft, as in the XL330, whose
magnetic encoder reads the output: :class:`~acausal.library.rotational.ElastoBacklash`); ``output`` a two-flange
element between the shaft the encoder reads and the output flange (play behind the encoder: a motor-side encoder, a
loose horn or coupling). Elements of one slot are chained in the order given. ``winding`` replaces the winding (one
element at most, built with the servo's ``R``, named ``winding``): a
:class:`~acausal.library.electrical.CurrentLimitedResistor` for a driver's current limit.

Parameters are those seen at the output shaft, as BAM identifies them: ``kt`` [N m/A] (motor constant times the
gear ratio; also the back-EMF constant in V s/rad), ``R`` [ohm], ``armature`` [kg m2]. Defaults are BAM's published
XL330 model m1 (Rhoban/bam ``params/xl330/m1.json``, Apache-2.0: kt 0.3867, R 4.017, armature 0.001814,
Kc 0.01283, Kv 0.003662), ``ratio`` = 288.35 (XL330-M288's nominal ratio; the output behaviour does not depend on
it, only the split of kt between motor and gear does).
"""
from acausal import Model, ModelError, Parameter, RealInput, connect
from acausal.model.connectors import Flange, Pin

from .blocks import Gain
from .control import DutyOutput, Feedback
from .drives import PWMDriver
from .electrical import EMF, SwitchedResistor
from .friction import GearFriction
from .rotational import AngleSensor, IdealGear, Inertia

__all__ = ["PositionServo", "SLOTS"]

#: the insertion slots of :class:`PositionServo` and the ports an element in each must have ("winding" replaces
#: the winding instead of being chained: its element also takes the input ``closed`` and the servo's ``R``)
SLOTS = {"goal": ("u", "y"), "position": ("u", "y"), "error": ("u", "y"), "duty": ("u", "y"), "bus": ("p", "n"),
         "drive": ("flange_a", "flange_b"), "output": ("flange_a", "flange_b"), "winding": ("p", "n", "closed")}


class PositionServo(Model):
    """A position servo with its firmware P law, ready to drive a load at ``flange``.

    Connectors: ``flange`` (output shaft), ``bus_p``/``bus_n`` (supply), inputs ``position_ref`` [rad] and
    ``enable`` (torque enable, 0/1). ``friction_terms``: the terms of the friction law (see
    :class:`~acausal.library.friction.GearFriction`; default Coulomb + viscous) and its ``load_measure``
    (``"external"`` adds the input ``load_torque``: BAM's measure); ``inserts``: elements put into its slots
    (module docstring). The sub-components are readable: ``ctrl.y`` (duty), ``winding.i`` (motor
    current), ``sensor.phi`` (the encoder's reading), ``friction.tau_f``/``friction.loss_power``,
    ``winding.loss_power``, ``rotor.energy``.

    Fit ranges (``fit_range``, ``nominal``: what a calibration searches) are wide physical ranges for a small
    hobby or robot servo, not tuned to the XL330 whose values (BAM's xl330 m1 set) are the defaults.
    """

    kt = Parameter(0.3867, unit="N.m/A", min=1e-9, doc="torque constant at the output (BAM xl330 m1)",
                   device="Dynamixel XL330-M288", fit_range=(0.01, 10.0), nominal=0.3)
    R = Parameter(4.017, unit="Ohm", min=1e-9, doc="winding resistance (BAM xl330 m1)", device="Dynamixel XL330-M288",
                  fit_range=(0.1, 100.0), nominal=3.0)
    armature = Parameter(0.001814, unit="kg.m2", min=0.0, doc="rotor inertia reflected to the output (BAM xl330 m1)",
                         device="Dynamixel XL330-M288", fit_range=(1e-6, 0.1), nominal=1e-3)
    ratio = Parameter(288.35, unit="1", min=1e-9, doc="gear ratio (XL330-M288 nominal)", device="Dynamixel XL330-M288")
    kp = Parameter(None, unit="1", min=0.0, doc="firmware position gain (register value)")
    error_gain = Parameter(None, unit="1/rad", min=0.0, doc="duty per rad of error per unit of kp")
    d_max = Parameter(1.0, unit="1", min=0.0, max=1.0, doc="largest duty magnitude")
    tau_c = Parameter(0.01283, unit="N.m", min=0.0, doc="Coulomb friction at the output (BAM xl330 m1 Kc)",
                      device="Dynamixel XL330-M288", fit_range=(0.0, 2.0), nominal=0.01)
    d = Parameter(0.003662, unit="N.m.s/rad", min=0.0, doc="viscous friction at the output (BAM xl330 m1 Kv)",
                  device="Dynamixel XL330-M288", fit_range=(0.0, 1.0), nominal=0.003)

    flange = Flange(doc="output shaft")
    bus_p = Pin(doc="supply +")
    bus_n = Pin(doc="supply -")
    position_ref = RealInput(doc="commanded position [rad]")
    enable = RealInput(doc="torque enable (1 on, 0 off)")

    def __init__(self, friction_terms=("coulomb",), inserts=(), load_measure: str = "transmitted", **kw):
        self.friction_terms = tuple(friction_terms)  # checked by GearFriction
        self.load_measure = load_measure
        self.inserts = tuple(tuple(i) for i in inserts)
        for item in self.inserts:
            if len(item) != 3 or item[0] not in SLOTS or not callable(item[2]) or not str(item[1]).isidentifier():
                raise ModelError(f"PositionServo: an insert is (slot, name, factory) with slot one of "
                                 f"{', '.join(SLOTS)}, got {item!r}")
        names = [i[1] for i in self.inserts]
        if len(set(names)) != len(names):
            raise ModelError(f"PositionServo: insert names must be distinct, got {names}")
        if sum(i[0] == "winding" for i in self.inserts) > 1:
            raise ModelError("PositionServo: one element at most replaces the winding (slot 'winding')")
        super().__init__(**kw)
        if load_measure == "external":
            self.load_torque = RealInput(doc="external torque on the load [N m], for the friction's load measure")

    def _chain(self, slot: str, start, end=()):
        """Connect ``start`` through the elements inserted in ``slot`` (in order) to the ports ``end``; returns the
        chain's last port (``start`` itself when the slot is empty)."""
        a, b = SLOTS[slot]
        for _, name, factory in (i for i in self.inserts if i[0] == slot):
            element = factory()
            if not all(hasattr(element, port) for port in (a, b)):
                raise ModelError(f"PositionServo: insert {name!r} in slot {slot!r} must have ports {a!r} and "
                                 f"{b!r}; {type(element).__name__} has not")
            if hasattr(self, name):
                raise ModelError(f"PositionServo: insert name {name!r} is taken by a part of the servo")
            setattr(self, name, element)
            connect(start, getattr(element, a))
            start = getattr(element, b)
        if end:
            connect(start, *end)
        return start

    def build(self):
        self.error = Feedback()
        self.gain = Gain(k=self.kp * self.error_gain)
        self.ctrl = DutyOutput(d_max=self.d_max)
        self.driver = PWMDriver(ideal=True)  # lossless: the XL330's bridge losses are in the winding's fitted R
        replaced = [i for i in self.inserts if i[0] == "winding"]
        self.winding = replaced[0][2](R=self.R) if replaced else SwitchedResistor(R=self.R)
        if not all(hasattr(self.winding, port) for port in SLOTS["winding"]):
            raise ModelError(f"PositionServo: the element replacing the winding must have ports "
                             f"{SLOTS['winding']}; {type(self.winding).__name__} has not")
        self.emf = EMF(k=self.kt / self.ratio)
        self.gear = IdealGear(ratio=self.ratio)
        self.friction = GearFriction(terms=self.friction_terms, load_measure=self.load_measure, tau_c=self.tau_c,
                                     d=self.d)
        if self.load_measure == "external":
            connect(self.load_torque, self.friction.tau_ext)
        if "unpowered" in self.friction_terms:
            connect(self.enable, self.friction.enable)
        self.rotor = Inertia(J=self.armature)
        self.sensor = AngleSensor()
        self._chain("bus", self.bus_p, (self.driver.bus_p,))
        connect(self.bus_n, self.driver.bus_n)
        connect(self.driver.mot_p, self.winding.p)
        connect(self.winding.n, self.emf.p)
        connect(self.emf.n, self.driver.mot_n)
        connect(self.enable, self.ctrl.enable, self.winding.closed)
        connect(self.emf.flange, self.gear.flange_a)
        connect(self.gear.flange_b, self.friction.flange_a)
        connect(self.friction.flange_b, self.rotor.flange_a)
        shaft = self._chain("drive", self.rotor.flange_b)  # the shaft the encoder reads
        connect(shaft, self.sensor.flange)
        self._chain("output", shaft, (self.flange,))
        self._chain("goal", self.position_ref, (self.error.u1,))
        self._chain("position", self.sensor.phi, (self.error.u2,))
        self._chain("error", self.error.y, (self.gain.u,))
        self._chain("duty", self.gain.y, (self.ctrl.u,))
        connect(self.ctrl.y, self.driver.u)
