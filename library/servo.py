"""A hobby position servo (Dynamixel-type), assembled from library parts.

::

    position_ref --> [DutyPositionController] --duty--> [PWMDriver] --> [SwitchedResistor R] --> [EMF kt/ratio]
    enable ---------------^        ^                      bus_p/bus_n      (torque enable)            |
                                   |                                                          [IdealGear ratio]
    position <-- [AngleSensor] ----+------ flange <-- [Inertia armature] <-- [GearFriction] <--------+

The firmware's proportional law commands the PWM duty; the bridge puts ``duty * v_bus`` on the winding (lossless,
no quiescent draw: what a hobby servo's electronics dissipate is not measured and does not move the arm); the
winding is a resistance behind the torque-enable switch (inductance neglected: its time constant is far below the
~5 ms sampling of the logs); the EMF and the gear are ideal, and all mechanical loss is in the swap-in friction
law between the gear and the rotor inertia (:mod:`acausal.library.friction`). The rotor's inertia is lumped at
the output as ``armature`` (the reflected inertia, BAM's term) *after* the friction, so the friction's load
measure is the air-gap torque through the gear, as in BAM's models.

Parameters are those seen at the output shaft, as BAM identifies them: ``kt`` [N m/A] (motor constant times the
gear ratio; also the back-EMF constant in V s/rad), ``R`` [ohm], ``armature`` [kg m2]. Defaults are BAM's published
XL330 model m1 (Rhoban/bam ``params/xl330/m1.json``, Apache-2.0: kt 0.3867, R 4.017, armature 0.001814,
Kc 0.01283, Kv 0.003662), ``ratio`` = 288.35 (XL330-M288's nominal ratio; the output behaviour does not depend on
it, only the split of kt between motor and gear does).
"""
from acausal import Model, Parameter, RealInput, connect
from acausal.connectors import Flange, Pin

from .control import DutyPositionController
from .drives import PWMDriver
from .electrical import EMF, SwitchedResistor
from .friction import GearFriction
from .rotational import AngleSensor, IdealGear, Inertia

__all__ = ["PositionServo"]


class PositionServo(Model):
    """A position servo with its firmware P law, ready to drive a load at ``flange``.

    Connectors: ``flange`` (output shaft), ``bus_p``/``bus_n`` (supply), inputs ``position_ref`` [rad] and
    ``enable`` (torque enable, 0/1). ``friction_terms``: the terms of the friction law (see
    :class:`~acausal.library.friction.GearFriction`; default Coulomb + viscous). The sub-components are readable:
    ``ctrl.y`` (duty), ``winding.i`` (motor current), ``friction.tau_f``/``friction.loss_power``,
    ``winding.loss_power``, ``armature.energy``.
    """

    kt = Parameter(0.3867, unit="N.m/A", min=1e-9, doc="torque constant at the output (BAM xl330 m1)",
                   device="Dynamixel XL330-M288")
    R = Parameter(4.017, unit="Ohm", min=1e-9, doc="winding resistance (BAM xl330 m1)", device="Dynamixel XL330-M288")
    armature = Parameter(0.001814, unit="kg.m2", min=0.0, doc="rotor inertia reflected to the output (BAM xl330 m1)",
                         device="Dynamixel XL330-M288")
    ratio = Parameter(288.35, unit="1", min=1e-9, doc="gear ratio (XL330-M288 nominal)", device="Dynamixel XL330-M288")
    kp = Parameter(None, unit="1", min=0.0, doc="firmware position gain (register value)")
    error_gain = Parameter(None, unit="1/rad", min=0.0, doc="duty per rad of error per unit of kp")
    d_max = Parameter(1.0, unit="1", min=0.0, max=1.0, doc="largest duty magnitude")
    tau_c = Parameter(0.01283, unit="N.m", min=0.0, doc="Coulomb friction at the output (BAM xl330 m1 Kc)",
                      device="Dynamixel XL330-M288")
    d = Parameter(0.003662, unit="N.m.s/rad", min=0.0, doc="viscous friction at the output (BAM xl330 m1 Kv)",
                  device="Dynamixel XL330-M288")

    flange = Flange(doc="output shaft")
    bus_p = Pin(doc="supply +")
    bus_n = Pin(doc="supply -")
    position_ref = RealInput(doc="commanded position [rad]")
    enable = RealInput(doc="torque enable (1 on, 0 off)")

    def __init__(self, friction_terms=("coulomb",), **kw):
        self.friction_terms = tuple(friction_terms)  # checked by GearFriction
        super().__init__(**kw)

    def build(self):
        self.ctrl = DutyPositionController(kp=self.kp, error_gain=self.error_gain, d_max=self.d_max)
        self.driver = PWMDriver()  # lossless: the XL330's bridge losses are in the winding's fitted R
        self.winding = SwitchedResistor(R=self.R)
        self.emf = EMF(k=self.kt / self.ratio)
        self.gear = IdealGear(ratio=self.ratio)
        self.friction = GearFriction(terms=self.friction_terms, tau_c=self.tau_c, d=self.d)
        self.rotor = Inertia(J=self.armature)
        self.sensor = AngleSensor()
        connect(self.bus_p, self.driver.bus_p)
        connect(self.bus_n, self.driver.bus_n)
        connect(self.driver.mot_p, self.winding.p)
        connect(self.winding.n, self.emf.p)
        connect(self.emf.n, self.driver.mot_n)
        connect(self.enable, self.ctrl.enable, self.winding.closed)
        connect(self.emf.flange, self.gear.flange_a)
        connect(self.gear.flange_b, self.friction.flange_a)
        connect(self.friction.flange_b, self.rotor.flange_a)
        connect(self.rotor.flange_b, self.flange, self.sensor.flange)
        connect(self.position_ref, self.ctrl.position_ref)
        connect(self.sensor.phi, self.ctrl.position)
        connect(self.ctrl.y, self.driver.u)
