"""MSL-style sources (Step, Ramp, Sine, Product) against their closed forms, run-time parameters included; the ideal
diode's knee voltage (MSL ``IdealDiode.Vknee``) against the piecewise-linear characteristic."""
import numpy as np
import sympy as sp

from acausal import Model, compile_model, connect, time
from acausal.library.blocks import Product, Ramp, Sine, Step
from acausal.library.electrical import Ground, IdealDiode, PrescribedVoltage, Resistor


class _Sources(Model):
    def build(self):
        self.step = Step(height=2.0, offset=1.0, start_time=0.3)
        self.ramp = Ramp(height=3.0, duration=0.4, start_time=0.2)
        self.sine = Sine(amplitude=2.0, f=2.0, phase=0.5, offset=0.5, start_time=0.1)
        self.prod = Product()
        connect(self.step.y, self.prod.u1)
        connect(self.ramp.y, self.prod.u2)


def test_sources_follow_their_closed_forms_and_their_parameters_per_run():
    sim = compile_model(_Sources())
    t = np.linspace(0.0, 1.0, 101)
    res = sim.simulate(1.0, n_points=101)
    step = 1.0 + 2.0 * (t >= 0.3)
    ramp = 3.0 * np.clip((t - 0.2) / 0.4, 0.0, 1.0)
    sine = 0.5 + np.where(t < 0.1, 0.0, 2.0 * np.sin(2 * np.pi * 2.0 * (t - 0.1) + 0.5))
    assert np.allclose(res["step.y.value"], step, atol=1e-12)
    assert np.allclose(res["ramp.y.value"], ramp, atol=1e-12)
    assert np.allclose(res["sine.y.value"], sine, atol=1e-12)
    assert np.allclose(res["prod.y.value"], step * ramp, atol=1e-12)
    later = sim.simulate(1.0, n_points=101, params={"step.start_time": 0.55, "ramp.duration": 0.0})
    assert np.allclose(later["step.y.value"], 1.0 + 2.0 * (t >= 0.55), atol=1e-12)
    assert np.allclose(later["ramp.y.value"], 3.0 * (t >= 0.2), atol=1e-12)  # duration 0: a step


class _KneeDiode(Model):
    """A 5 V, 10 Hz sine drives a diode with a 0.7 V knee into 10 ohm."""

    def build(self):
        self.src = PrescribedVoltage(v_ref=5.0 * sp.sin(2 * sp.pi * 10 * time))
        self.d = IdealDiode(V_knee=0.7)
        self.R = Resistor(R=10.0)
        self.gnd = Ground()
        connect(self.src.p, self.d.p)
        connect(self.d.n, self.R.p)
        connect(self.R.n, self.src.n, self.gnd.p)


def test_diode_with_a_knee_follows_the_piecewise_linear_characteristic():
    """No states: the modes are settled at each output time, so the switch is exact to the sample."""
    res = compile_model(_KneeDiode()).simulate(0.2, rtol=1e-9, atol=1e-12, n_points=2001)
    v = 5.0 * np.sin(2 * np.pi * 10 * res.t)
    Ron, Goff, Vk, R = 1e-5, 1e-5, 0.7, 10.0
    on = (v - Vk) / (R + Ron)  # conducting: v = Vk + Ron i + R i
    off = Goff * v / (1 + Goff * R)  # blocking: i = Goff v_d, v = v_d + R i
    expect = np.where(v > Vk * (1 + Goff * R), on, off)  # the knee: s = 0 where v_d = Vk and i = Goff Vk
    assert np.allclose(res["R.i"], expect, rtol=1e-6, atol=1e-9)
    assert np.array_equal(res["d.off"] == 0, v > Vk * (1 + Goff * R))  # conducting exactly above the knee
    assert np.all(res["d.loss_power"] >= -1e-12)
    assert abs(res.energy_balance().residual) < 1e-6
