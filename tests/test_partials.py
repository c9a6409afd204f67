"""Optional support flanges (MSL ``useSupport``): the reaction torque on the housing balances the torques on the
flanges, for the library's components and for a component written on the partials."""
import pytest

from acausal import Model, compile_model, connect
from acausal.library.drives import DCMotor
from acausal.library.electrical import ConstantVoltage, Ground
from acausal.library.rotational import Damper, Fixed, Inertia


def test_dc_motor_housing_takes_the_reaction():
    """At constant speed the rotor's inertia takes no torque: what the shaft delivers the housing takes back."""

    class M(Model):
        def build(self):
            self.src, self.gnd = ConstantVoltage(V=12.0), Ground()
            self.motor = DCMotor(use_support=True, tau_c=0.005)
            self.load, self.damper, self.fix = Inertia(J=1e-4), Damper(d=1e-3), Fixed()
            connect(self.src.p, self.motor.p)
            connect(self.src.n, self.motor.n, self.gnd.p)
            connect(self.motor.flange, self.load.flange_a)
            connect(self.load.flange_b, self.damper.flange_a)
            connect(self.motor.support, self.damper.flange_b, self.fix.flange)

    res = compile_model(M()).simulate(1.0, n_points=3, rtol=1e-9, atol=1e-12)
    tau_shaft, tau_housing = res["motor.flange.tau"][-1], res["motor.support.tau"][-1]
    assert tau_shaft < -0.1  # the load brakes the motor
    assert tau_shaft + tau_housing == pytest.approx(0.0, abs=1e-9)
    assert tau_housing == pytest.approx(res["motor.tau_e"][-1] - res["motor.tau_f"][-1], rel=1e-12)
