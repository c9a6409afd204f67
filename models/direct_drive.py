"""Direct drive: the same supply, driver, motor and gears move the ankle joint without the MACCEPA spring.

What changes against the paper's actuator (:class:`~acausal.models.cyberlegs.CyberlegsAnkle`) and why: the
series spring is removed and the gear output is the joint itself, so the motor must deliver the whole
biomechanical torque M(t) at the joint speed at every instant: no spring stores and returns energy, nothing
shifts the push-off power in time, so the peak power and the peak motor speed (860 times the joint speed) are
those of the gait itself. This is the comparison of the paper's Fig. 7 (there the bench's output motor plays
the direct drive), the reference every elastic alternative is measured against. The joint follows the gait
angle through an inverse constraint on the driver command; the gait moment acts as the load
(:class:`AnkleTorqueLoad`). The driver does not saturate: at 2 s per stride and faster the required duty
exceeds the EPOS2's 0.9 (1.11 at 2 s, 0.89 at 2.5 s; ``acausal compare`` flags the motor voltage), i.e. this
drive train could not follow there.
Registered as ``direct_drive`` (no precompression).

Measurement points: source, driver output, motor shaft and joint ("output"); ``link`` is the joint as well.
"""
from __future__ import annotations

from acausal import Model, Parameter, connect
from acausal.library.gait import AnkleTorqueLoad, GaitProfile, unit_cycle
from acausal.library.rotational import AngleSensor
from acausal.library.sensors import MechanicalPowerSensor

from .drive_train import add_drive_train, add_follower

MEASUREMENT_POINTS = [("source", "P_source.P"), ("driver", "P_driver.P"), ("motor", "P_motor.P"),
                      ("link", "P_output.P"), ("output", "P_output.P")]


class DirectDrive(Model):
    """Motor and gears (n = 860) moving the ankle along the gait angle against the gait moment."""

    body_mass = Parameter(60.0, unit="kg", min=1.0, doc="body mass scaling the gait torque (assumption)")
    stride_time = Parameter(2.0, unit="s", min=0.1, doc="stride duration")

    def build(self):
        gear_out = add_drive_train(self, saturate=False)
        self.P_output = MechanicalPowerSensor()
        self.load = AnkleTorqueLoad(stride_time=self.stride_time, body_mass=self.body_mass)
        connect(gear_out, self.P_output.flange_a)
        connect(self.P_output.flange_b, self.load.flange)
        # the joint follows the gait angle: the compiler solves for the driver command
        self.joint_ref = GaitProfile(stride_time=self.stride_time, profile=unit_cycle().angle_signal())
        self.joint_angle = AngleSensor()
        connect(self.load.flange, self.joint_angle.flange)
        add_follower(self, self.joint_angle.phi, self.joint_ref.y)
