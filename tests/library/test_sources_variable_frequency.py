"""``acausal.library.electrical.SineVoltageVariableFrequencyAndAmplitude`` (MSL
``Analog.Sources.SineVoltageVariableFrequencyAndAmplitude``): ``v = offset + V sin(phi)``, ``der(phi) = 2 pi f``.

At constant inputs it is MSL's SineVoltage (here a Sine signal into a SignalVoltage); under a ramped frequency its
phase is the integral of 2 pi f, known in closed form; what it delivers into a resistor is its ``source_power``,
and the energy balance closes.
"""
import numpy as np
import pytest
from scipy.integrate import quad

from acausal import Model, Start, compile_model, connect
from acausal.library.blocks import Ramp, SignalSource, Sine
from acausal.library.electrical import (Ground, Inductor, Resistor, SignalVoltage,
                                        SineVoltageVariableFrequencyAndAmplitude)
from ..msl.msl_support import METHODS

V0, F0 = 10.0, 50.0  # V, Hz: the constant inputs
# ramps: amplitude 10 -> 15 V over 1 s from t = 0; frequency 5 -> 45 Hz over 0.5 s from t = 0.1 s
AMP = dict(offset=10.0, height=5.0, start_time=0.0, duration=1.0)
FREQ = dict(offset=5.0, height=40.0, start_time=0.1, duration=0.5)


class ConstantInputs(Model):
    """The variable-frequency source at constant V0, F0 (``src``) and a SignalVoltage driven by a Sine of the same
    amplitude and frequency (``ref``), each into its own R-L load; ``src_cos`` starts at phase pi/2."""

    def build(self):
        self.amp, self.freq = SignalSource(signal=V0), SignalSource(signal=F0)
        self.src = SineVoltageVariableFrequencyAndAmplitude()
        self.src_cos = SineVoltageVariableFrequencyAndAmplitude(phi=Start(np.pi / 2))
        self.sine, self.ref = Sine(amplitude=V0, f=F0), SignalVoltage()
        self.ground = Ground()
        connect(self.amp.y, self.src.V, self.src_cos.V)
        connect(self.freq.y, self.src.f, self.src_cos.f)
        connect(self.sine.y, self.ref.u)
        for name, source in (("src", self.src), ("ref", self.ref)):
            r, ind = Resistor(R=2.0), Inductor(L=0.01, i=Start(0.0))
            setattr(self, f"r_{name}", r)
            setattr(self, f"l_{name}", ind)
            connect(source.p, r.p)
            connect(r.n, ind.p)
            connect(ind.n, source.n, self.ground.p)
        self.r_cos = Resistor(R=2.0)
        connect(self.src_cos.p, self.r_cos.p)
        connect(self.r_cos.n, self.src_cos.n, self.ground.p)


class RampedInputs(Model):
    """The source with ramped amplitude and frequency (AMP, FREQ) into a 2 ohm resistor."""

    def build(self):
        self.amp, self.freq = Ramp(**AMP), Ramp(**FREQ)
        self.src = SineVoltageVariableFrequencyAndAmplitude()
        self.r, self.ground = Resistor(R=2.0), Ground()
        connect(self.amp.y, self.src.V)
        connect(self.freq.y, self.src.f)
        connect(self.src.p, self.r.p)
        connect(self.r.n, self.src.n, self.ground.p)


def ramp(t, offset, height, start_time, duration):
    return offset + height * np.clip((t - start_time) / duration, 0.0, 1.0)


def ramped_phase(t):
    """The integral of 2 pi f from 0 for f = FREQ's ramp: 2 pi (f0 t + k s^2 / 2 + k T max(t - t0 - T, 0)) with
    s = clip(t - t0, 0, T), k = height / duration."""
    f0, t0, T = FREQ["offset"], FREQ["start_time"], FREQ["duration"]
    k = FREQ["height"] / T
    s = np.clip(t - t0, 0.0, T)
    return 2 * np.pi * (f0 * t + k * s**2 / 2 + k * T * np.maximum(t - t0 - T, 0.0))


@pytest.fixture(scope="module")
def ramped_sim():
    return compile_model(RampedInputs())


@pytest.mark.parametrize("method", METHODS)
def test_constant_inputs_give_the_sine_voltage(method):
    """At constant V and f the source is MSL's SineVoltage: its voltage and the current it drives into an R-L load
    agree with those of a SignalVoltage under a Sine block to 1e-9 of their peaks (its phase is the integral of a
    constant, which the integrators get to round-off: measured 3e-13); started at phi = pi/2 it is V cos(2 pi f t)."""
    res = compile_model(ConstantInputs()).simulate(0.2, method=method)
    assert np.max(np.abs(res["src.v"] - res["ref.v"])) < 1e-9 * V0
    peak = np.max(np.abs(res["l_ref.i"]))
    assert peak > 1.0
    assert np.max(np.abs(res["l_src.i"] - res["l_ref.i"])) < 1e-9 * peak
    assert np.max(np.abs(res["src_cos.v"] - V0 * np.cos(2 * np.pi * F0 * res.t))) < 1e-9 * V0


@pytest.mark.parametrize("method", METHODS)
def test_ramped_frequency_phase_is_the_integral_of_2_pi_f(ramped_sim, method):
    """Frequency ramped 5 -> 45 Hz (from 0.1 s over 0.5 s), amplitude 10 -> 15 V over 1 s: the phase is the closed
    form :func:`ramped_phase` (195 rad at 1 s) to 1e-7 of the phase travelled, a tenth of what rtol 1e-6 allows
    (measured: 6e-7 rad on the default path, 4e-6 rad with BDF), and the voltage is V(t) sin of it, to the same
    tolerance times V."""
    res = ramped_sim.simulate(1.0, method=method)
    phase = ramped_phase(res.t)
    tol = 1e-7 * phase[-1]
    assert np.max(np.abs(res["src.phi"] - phase)) < tol
    amplitude = ramp(res.t, **AMP)
    assert np.max(np.abs(res["src.v"] - amplitude * np.sin(phase))) < tol * np.max(amplitude)


@pytest.mark.parametrize("method", METHODS)
def test_energy_into_a_resistor_balances(ramped_sim, method):
    """The source is the model's one source account (``source_power``; the ground the only boundary): at every
    output it delivers what the resistor dissipates, the balance closes to 1e-6, and the energy delivered over 1 s
    is the closed form's, the integral of (V(t) sin(phase(t)))^2 / R, to 1e-6."""
    assert ramped_sim.accounts.sources == ("src.source_power",)
    res = ramped_sim.simulate(1.0, method=method)
    assert np.allclose(res["src.source_power"], res["r.loss_power"], rtol=1e-12, atol=1e-9)
    assert abs(res.energy_balance().residual) < 1e-6, res.energy_balance().table()
    exact, _ = quad(lambda t: (ramp(t, **AMP) * np.sin(ramped_phase(t)))**2 / 2.0, 0.0, 1.0, limit=500,
                    epsabs=0.0, epsrel=1e-11, points=[FREQ["start_time"], FREQ["start_time"] + FREQ["duration"]])
    assert res.energy("src.source_power")[-1] == pytest.approx(exact, rel=1e-6)
