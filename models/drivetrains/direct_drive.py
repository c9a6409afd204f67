"""Direct drive: the same supply, driver, motor and gears move the ankle joint without the MACCEPA spring.

What changes against the paper's actuator (:class:`~acausal.models.ankle.actuator.AnkleActuator`) and why: the
series spring is removed and the gear output is the joint itself, so the motor must deliver the whole
biomechanical torque M(t) at the joint speed at every instant: no spring stores and returns energy, nothing
shifts the push-off power in time, so the peak power and the peak motor speed (860 times the joint speed) are
those of the gait itself. This is the comparison of the paper's Fig. 7 (there the bench's output motor plays
the direct drive), the reference every elastic alternative is measured against. The joint follows the gait
angle through an inverse constraint on the driver command; the gait moment acts as the load
(:class:`AnkleTorqueLoad`, scaled by the model's ``body_mass``). The driver does not saturate: at 2 s per stride
and faster the required duty exceeds the EPOS2's 0.9 (1.11 at 2 s, 0.89 at 2.5 s; ``acausal compare`` flags the
motor voltage), i.e. this drive train could not follow there.
Registered as ``direct_drive`` (no precompression).

Measurement points: source, driver output, motor (k i w) and joint ("output"); ``link`` is the joint as well.
"""
from __future__ import annotations

from acausal import connect
from acausal.library.gait import AnkleTorqueLoad, GaitProfile, unit_cycle
from acausal.library.rotational import AngleSensor
from acausal.library.sensors import MechanicalPowerSensor

from ..ankle.actuator import DriveTrain


class DirectDrive(DriveTrain):
    """Motor and gears (n = 860) moving the ankle along the gait angle against the gait moment."""

    shared_points = {"link": "output"}
    #: the gait moment resists the joint's motion (False) or drives it (True: :class:`BenchOutputMotor`)
    load_pushes = False

    def build(self):
        gear_out = self.build_drive()
        self.P_output = MechanicalPowerSensor()
        self.load = AnkleTorqueLoad(stride_time=self.stride_time, body_mass=self.body_mass, pushes=self.load_pushes)
        connect(gear_out, self.P_output.flange_a)
        connect(self.P_output.flange_b, self.load.flange)
        # the joint follows the gait angle: the compiler solves for the driver command
        self.joint_ref = GaitProfile(stride_time=self.stride_time, profile=unit_cycle().angle_signal())
        self.joint_angle = AngleSensor()
        connect(self.load.flange, self.joint_angle.flange)
        self.add_follower(self.joint_angle.phi, self.joint_ref.y)


class BenchOutputMotor(DirectDrive):
    """The paper's "direct drive" of Fig. 7 as it ran on the bench: the output motor that imposes the gait angle
    on the joint while the actuator under test pushes it with the gait moment (4.1: "the output motor applies the
    healthy gait ankle angles"). Its mechanical power is the joint power with the sign turned: it is back-driven
    where the actuator delivers work (push-off) and drives where the joint absorbs it, and its non-regenerative
    supply keeps none of what it brakes. Registered as ``bench_output_motor``.

    Guesses (the output drive train is not published): the actuator's own motor class, driver, 860:1 gears and
    supply, with the preset's values for them; only the sense of the load differs from :class:`DirectDrive`."""

    load_pushes = True
