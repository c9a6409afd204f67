"""The replayed series-elastic ankle that the alternative actuators share (paper sections 2-3, Fig. 6).

::

    supply -[P_source]- (rectifier) - driver -[P_driver]- motor -[P_motor]- planetary 86:1 - 10:1 stage
        -[P_link]- elastic link -[P_output]- ankle joint (moved along the healthy gait angle)

Like :class:`~acausal.models.cyberlegs.CyberlegsAnkle` in ``mode="replay"``: the gear output ("moment arm")
follows a planned angle ``phi(t)`` through an inverse constraint on the driver command, the bench moves the
joint along the gait angle ``theta(t)``, and the elastic link between them makes the joint torque. The planned
angle is the swappable input ``arm_ref.profile`` (a 1-periodic signal of the gait fraction). The five
measurement points are the paper's (source, driver output, motor shaft, moment arm "link", joint "output"),
mechanical ones positive in the direction supply -> joint.

:class:`ElasticAnkleReplay` takes the drive-train options of :func:`~acausal.models.drive_train.add_drive_train`
(``supply``, ``output_stage``, ``driver_cls``) and builds its link with :meth:`ElasticAnkleReplay.make_link`
(default: the paper's MACCEPA); subclasses change the link. With the defaults it is the paper's actuator.
"""
from __future__ import annotations

from acausal import Model, Parameter, connect
from acausal.library.blocks import SignalConstraint
from acausal.library.drives import PWMDriver
from acausal.library.gait import AnkleAngleSource, GaitProfile
from acausal.library.maccepa import Maccepa
from acausal.library.rotational import AngleSensor
from acausal.library.sensors import MechanicalPowerSensor

from .drive_train import add_drive_train, drive_train_accounts
from .planning import plan_moment_arm

#: the paper's measurement points, in chain order: (label, power variable)
MEASUREMENT_POINTS = [("source", "P_source.P"), ("driver", "P_driver.P"), ("motor", "P_motor.P"),
                      ("link", "P_link.P"), ("output", "P_output.P")]


class ElasticAnkleReplay(Model):
    """Drive train, elastic link and bench joint, replayed along a planned moment-arm angle (module docstring).

    ``supply``: ``"rectifier"`` (paper) or ``"battery"``; ``output_stage``: ``"helical"`` (paper) or
    ``"self_locking"``; ``driver_cls``: the driver's class (default the paper's PWM driver)."""

    body_mass = Parameter(60.0, unit="kg", min=1.0, doc="body mass scaling the gait torque (assumption)")
    stride_time = Parameter(2.0, unit="s", min=0.1, doc="stride duration (paper: 1.2-3 s)")

    def __init__(self, supply: str = "rectifier", output_stage: str = "helical", driver_cls=PWMDriver, **kw):
        super().__init__(**kw)
        self.options = dict(supply=supply, output_stage=output_stage)
        self.driver_cls = driver_cls

    def make_link(self):
        """The elastic element between moment arm (``flange_b``) and joint (``flange_a``): the MACCEPA."""
        return Maccepa()

    def default_profile(self):
        """The planned moment-arm angle used when no input is given (MACCEPA at 8 mm, 132 N/mm)."""
        return plan_moment_arm(P=0.008, k=132e3, A=0.1, B=0.06, body_mass=60.0).phi_profile

    def build(self):
        gear_out = add_drive_train(self, saturate=False, driver_cls=self.driver_cls, **self.options)
        self.P_link = MechanicalPowerSensor()
        self.link = self.make_link()
        self.P_output = MechanicalPowerSensor()
        self.ankle = AnkleAngleSource(stride_time=self.stride_time)
        connect(gear_out, self.P_link.flange_a)
        connect(self.P_link.flange_b, self.link.flange_b)
        connect(self.link.flange_a, self.P_output.flange_a)
        connect(self.P_output.flange_b, self.ankle.flange)
        self.arm_ref = GaitProfile(stride_time=self.stride_time, profile=self.default_profile())
        self.arm_angle = AngleSensor()
        self.follow = SignalConstraint()
        connect(gear_out, self.arm_angle.flange)
        connect(self.arm_angle.phi, self.follow.u)
        connect(self.arm_ref.y, self.follow.target)
        connect(self.follow.y, self.driver.u)


def accounts(supply: str = "rectifier", output_stage: str = "helical") -> dict:
    """Loss groups and stored energies of an :class:`ElasticAnkleReplay` (the link is conservative)."""
    acc = drive_train_accounts(supply, output_stage)
    acc["loss_groups"]["output"] = []
    acc["stored"].append("link.energy")
    return acc
