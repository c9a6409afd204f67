"""The CYBERLEGs alpha-prosthesis ankle actuator (paper sections 2-3), assembled from library components.

::

    supply -[P1 source]- rectifier - PWM driver -[P2 driver]- DC motor -[P3 motor]- planetary 86:1
        - helical 10:1 -[P4 link]- MACCEPA -[P5 output]- ankle joint (moved along the healthy gait angle)

P1..P5 are power sensors at the paper's five measurement points (Fig. 6): source (electrical, supply -> driver
side), driver output (electrical, at the motor terminals), motor shaft, moment arm ("link") and joint
("output"), all mechanical ones positive in the direction supply -> joint.

Two ways to run the same components (``mode``):

* ``"replay"`` (the paper's Simulink approach): the joint angle theta(t) and the planned moment-arm angle phi(t)
  are prescribed; the moment-arm angle is imposed through an inverse constraint on the driver command, so the
  compiler's index reduction derives the motor current, voltages and every power. The driver does not saturate
  (check ``driver.d`` against ``d_max``: a larger duty means the motor could not follow).
* ``"closed_loop"``: a PID controller tracks phi_ref through the PWM driver within the bus voltage; the motor's
  speed and voltage limits show up as tracking error (paper Fig. 13) and change the energy.

Parameters that matter for the protocol are run-time parameters: ``link.P`` (precompression), stride time
(the model's ``stride_time``, bound into ``ankle`` and ``arm_ref``), ``link.k``; the
planned trajectory is a swappable input (``arm_ref.profile``), computed by :mod:`acausal.models.planning`.

Assumptions (not published in the sources at hand, see ``../shared/data/parameters.md``): lever lengths A = 0.1 m
and B = 0.06 m, body mass 60 kg, supply 48 V, helical-stage efficiency 0.9 and output-side friction.
"""
from __future__ import annotations

from acausal import Eq, Model, Parameter, Variable, connect
from acausal.library.gait import AnkleAngleSource, GaitProfile
from acausal.library.maccepa import Maccepa
from acausal.library.rotational import AngleSensor
from acausal.library.sensors import MechanicalPowerSensor

from .drive_train import add_arm_controller, add_drive_train, add_follower
from .planning import plan_moment_arm

#: the paper's measurement points, in chain order: (label, power variable)
MEASUREMENT_POINTS = [("source", "P_source.P"), ("driver", "P_driver.P"), ("motor", "P_motor.P"),
                      ("link", "P_link.P"), ("output", "P_output.P")]

#: the loss between consecutive points, by the components in between
LOSS_GROUPS = {
    "driver": ["supply.loss_power", "rect.loss_power", "driver.loss_power"],
    "motor": ["motor.loss_power"],
    "gearing": ["planetary.loss_power", "helical.loss_power"],
    "output": [],  # the MACCEPA is conservative: link - output is the change of spring energy
}

#: stored energies of the whole actuator
STORED = ["rect.bus_energy", "motor.energy", "planetary.energy", "helical.energy", "link.energy"]


class CyberlegsAnkle(Model):
    """The paper's ankle actuator on the test bench (see the module docstring)."""

    body_mass = Parameter(60.0, unit="kg", min=1.0, doc="body mass scaling the gait torque (assumption)")
    stride_time = Parameter(2.0, unit="s", min=0.1, doc="stride duration (paper: 1.2-3 s)")
    tracking_error = Variable(unit="rad", doc="moment-arm reference minus actual angle")

    def __init__(self, mode: str = "replay", **kw):
        if mode not in ("replay", "closed_loop"):
            raise ValueError(f"CyberlegsAnkle: mode must be 'replay' or 'closed_loop', got {mode!r}")
        super().__init__(**kw)
        self.mode = mode

    def build(self):
        gear_out = add_drive_train(self, saturate=self.mode == "closed_loop")
        self.P_link = MechanicalPowerSensor()
        self.link = Maccepa()
        self.P_output = MechanicalPowerSensor()
        self.ankle = AnkleAngleSource(stride_time=self.stride_time)
        connect(gear_out, self.P_link.flange_a)
        connect(self.P_link.flange_b, self.link.flange_b)
        # the output sensor measures power from the linkage into the joint (link.flange_a side is the foot)
        connect(self.link.flange_a, self.P_output.flange_a)
        connect(self.P_output.flange_b, self.ankle.flange)
        # moment-arm reference and how it is followed
        default = plan_moment_arm(P=0.008, k=132e3, A=0.1, B=0.06, body_mass=60.0)
        self.arm_ref = GaitProfile(stride_time=self.stride_time, profile=default.phi_profile)
        self.arm_angle = AngleSensor()
        connect(gear_out, self.arm_angle.flange)
        if self.mode == "replay":
            add_follower(self, self.arm_angle.phi, self.arm_ref.y)
        else:
            add_arm_controller(self, self.arm_ref.y, self.arm_angle.phi)

    def equations(self):
        return [Eq(self.tracking_error, self.arm_ref.y.value - self.arm_angle.phi.value)]



def condition_inputs(P: float, k: float = 132e3, A: float = 0.1, B: float = 0.06, body_mass: float = 60.0) -> dict:
    """Planned moment-arm trajectory for the condition, as the swappable input of the reference source."""
    return {"arm_ref.profile": plan_moment_arm(P, k, A, B, body_mass).phi_profile}
