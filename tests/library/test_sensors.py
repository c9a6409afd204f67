"""Power sensors: hand calculations, sign checks (a reversed sensor reads the opposite sign), and a motor whose
electrical input and mechanical output power are read by the sensors and checked against the port powers."""
import numpy as np
import pytest

from acausal import Model, Start, compile_model, connect
from acausal.library.electrical import EMF, ConstantVoltage, Ground, Inductor, Resistor
from acausal.library.rotational import Damper, Fixed, Inertia, TorqueSource
from acausal.library.sensors import ElectricalPowerSensor, MechanicalPowerSensor

V, R = 12.0, 4.0
TAU, D = 2.0, 0.5


class ResistorThroughSensor(Model):
    """12 V source -> sensor current path -> 4 ohm resistor -> ground; voltage path across the resistor."""

    def __init__(self, reverse_current=False, reverse_voltage=False, **kw):
        super().__init__(**kw)
        self.reverse_current, self.reverse_voltage = reverse_current, reverse_voltage

    def build(self):
        self.src = ConstantVoltage(V=V)
        self.sensor = ElectricalPowerSensor()
        self.R = Resistor(R=R)
        self.gnd = Ground()
        s = self.sensor
        c_in, c_out = (s.nc, s.pc) if self.reverse_current else (s.pc, s.nc)
        v_hi, v_lo = (s.nv, s.pv) if self.reverse_voltage else (s.pv, s.nv)
        connect(self.src.p, c_in)
        connect(c_out, self.R.p, v_hi)
        connect(self.R.n, self.src.n, self.gnd.p, v_lo)


class TorqueThroughSensor(Model):
    """Torque source -> mechanical sensor -> damper to ground (optionally the sensor mounted backwards)."""

    def __init__(self, reverse=False, **kw):
        super().__init__(**kw)
        self.reverse = reverse

    def build(self):
        self.src = TorqueSource(tau=TAU)
        self.sensor = MechanicalPowerSensor()
        self.damper = Damper(d=D)
        self.fixed = Fixed()
        a, b = (self.sensor.flange_b, self.sensor.flange_a) if self.reverse else \
            (self.sensor.flange_a, self.sensor.flange_b)
        connect(self.src.flange, a)
        connect(b, self.damper.flange_b)
        connect(self.damper.flange_a, self.fixed.flange)


def _run(model, t_end=1.0):
    return compile_model(model).simulate(t_end, rtol=1e-10, atol=1e-12, n_points=11)


def test_electrical_power_sensor_hand_calculation():
    res = _run(ResistorThroughSensor())
    assert np.allclose(res["sensor.P"], V**2 / R, rtol=1e-12)  # 36 W
    assert np.allclose(res["sensor.power.value"], V**2 / R, rtol=1e-12)
    assert np.allclose(res["sensor.i"], V / R) and np.allclose(res["sensor.v"], V)
    # invisible to the circuit: no voltage drop in the current path, no current in the voltage path
    assert np.allclose(res["sensor.pc.v"], res["sensor.nc.v"])
    assert np.allclose(res["sensor.pv.i"], 0) and np.allclose(res["sensor.nv.i"], 0)
    assert np.allclose(res["R.i"], V / R)
    # the reading is the power into the load, and the sensor absorbs none
    assert np.allclose(res["sensor.P"], res.power("R.p") + res.power("R.n"))
    absorbed = sum(res.power(f"sensor.{p}") for p in ("pc", "nc", "pv", "nv"))
    assert np.allclose(absorbed, 0, atol=1e-12)


@pytest.mark.parametrize("reverse_current, reverse_voltage, sign", [(True, False, -1), (False, True, -1),
                                                                    (True, True, 1)])
def test_electrical_power_sensor_signs(reverse_current, reverse_voltage, sign):
    res = _run(ResistorThroughSensor(reverse_current=reverse_current, reverse_voltage=reverse_voltage))
    assert np.allclose(res["sensor.P"], sign * V**2 / R, rtol=1e-12)
    assert np.allclose(res["R.i"], V / R)  # the circuit is the same whichever way the sensor sits


def test_mechanical_power_sensor_hand_calculation():
    res = _run(TorqueThroughSensor())
    assert np.allclose(res["sensor.tau"], TAU, rtol=1e-12)
    assert np.allclose(res["sensor.w"], TAU / D, rtol=1e-10)
    assert np.allclose(res["sensor.P"], TAU**2 / D, rtol=1e-10)  # 8 W, all of it dissipated in the damper
    assert np.allclose(res["sensor.power.value"], res["sensor.P"])
    assert np.allclose(res["sensor.P"], res["damper.loss_power"], rtol=1e-10)
    # rigid and lossless: the same power leaves through flange_b as enters through flange_a
    assert np.allclose(res.power("sensor.flange_a"), res["sensor.P"], rtol=1e-10)
    assert np.allclose(res.power("sensor.flange_a") + res.power("sensor.flange_b"), 0, atol=1e-9)
    assert np.allclose(res["sensor.flange_a.phi"], res["sensor.flange_b.phi"])


def test_mechanical_power_sensor_reversed():
    res = _run(TorqueThroughSensor(reverse=True))
    assert np.allclose(res["sensor.tau"], -TAU, rtol=1e-12)
    assert np.allclose(res["sensor.w"], TAU / D, rtol=1e-10)  # the speed does not depend on mounting
    assert np.allclose(res["sensor.P"], -TAU**2 / D, rtol=1e-10)
    assert np.allclose(res["damper.loss_power"], TAU**2 / D, rtol=1e-10)


class MeteredMotor(Model):
    """A DC motor started from rest, electrical power metered at its terminals, mechanical at its shaft."""

    def build(self):
        self.src = ConstantVoltage(V=24.0)
        self.p_el = ElectricalPowerSensor()
        self.R = Resistor(R=0.7)
        self.L = Inductor(L=6.53e-5, i=Start(0.0))
        self.emf = EMF(k=0.0273)
        self.p_mech = MechanicalPowerSensor()
        self.rotor = Inertia(J=1.6e-5, phi=Start(0.0), w=Start(0.0))
        self.damper = Damper(d=1.3e-4)
        self.fixed = Fixed()
        self.gnd = Ground()
        connect(self.src.p, self.p_el.pc)
        connect(self.p_el.nc, self.p_el.pv, self.R.p)
        connect(self.R.n, self.L.p)
        connect(self.L.n, self.emf.p)
        connect(self.emf.n, self.src.n, self.gnd.p, self.p_el.nv)
        connect(self.emf.flange, self.p_mech.flange_a)
        connect(self.p_mech.flange_b, self.rotor.flange_a)
        connect(self.rotor.flange_b, self.damper.flange_b)
        connect(self.damper.flange_a, self.fixed.flange)


def test_power_sensors_on_a_motor():
    sim = compile_model(MeteredMotor())
    res = sim.simulate(0.2, rtol=1e-11, atol=1e-12, n_points=2001)
    i, w = res["L.i"], res["rotor.w"]
    assert np.allclose(res["p_el.P"], 24.0 * i, rtol=1e-10, atol=1e-9)
    assert np.allclose(res["p_mech.P"], 0.0273 * i * w, rtol=1e-9, atol=1e-9)
    # the motor's electrical power = copper loss + magnetic energy rate + mechanical power at the shaft
    balance = res["R.loss_power"] + res["L.v"] * i + res["p_mech.P"]  # L.v * i = d(L i^2/2)/dt
    assert np.max(np.abs(res["p_el.P"] - balance)) < 1e-6 * np.max(np.abs(res["p_el.P"]))
    # integrated: electrical energy in = copper loss + stored + damper loss
    e_in = res.energy("p_el.P")[-1]
    stored = res["L.energy"][-1] + res["rotor.energy"][-1]
    lost = res.energy("R.loss_power")[-1] + res.energy("damper.loss_power")[-1]
    assert e_in == pytest.approx(stored + lost, rel=1e-6)
    assert res.energy("p_mech.P")[-1] == pytest.approx(res["rotor.energy"][-1]
                                                       + res.energy("damper.loss_power")[-1], rel=1e-6)
