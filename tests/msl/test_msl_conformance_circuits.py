"""MSL conformance, the diode circuits and the resonance: ``CharacteristicIdealDiodes``,
``DiodeBridge2Pulse`` and ``SeriesResonance`` rebuilt from the library's components (sources, conventions and
tolerances: ``tests/msl/test_msl_conformance.py``)."""

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from acausal import Model, Parameter, Start, compile_model, connect, time
from acausal.model.connectors import Pin
from acausal.library.electrical import (Capacitor, CurrentSensor, Ground, IdealDiode, Inductor, PrescribedVoltage,
                                        Resistor)
from .msl_support import BALANCE_TOL, METHODS, check_energy, phase_tol


# ==================================================================== 3. Analog.Examples.CharacteristicIdealDiodes
# (name, Ron, Goff, Vknee, source offset): each diode in series with 1 mohm, driven by 10 V at 1 Hz
DIODES = (("Ideal", 0.0, 0.0, 0.0, 0.0), ("With_Ron_Goff", 0.1, 0.1, 0.0, -9.0),
          ("With_Ron_Goff_Vknee", 0.2, 0.2, 5.0, 0.0))


class CharacteristicIdealDiodes(Model):
    """MSL ``Analog.Examples.CharacteristicIdealDiodes``: three ideal diodes, each driven by its own sine source
    (10 V, 1 Hz; the one of ``With_Ron_Goff`` with a -9 V offset) through a 1 mohm resistor to the common ground:
    the totally ideal diode (Ron = Goff = Vknee = 0), one with Ron = Goff = 0.1, one displaced by Vknee = 5 V with
    Ron = Goff = 0.2. The MSL SineVoltage sources are PrescribedVoltage with the same expression of time."""

    def build(self):
        self.Ground1 = Ground()
        for name, Ron, Goff, Vknee, offset in DIODES:
            src = PrescribedVoltage(v_ref=offset + 10.0 * sp.sin(2 * sp.pi * time))
            d = IdealDiode(R_on=Ron, G_off=Goff, V_knee=Vknee)
            r = Resistor(R=1e-3)
            setattr(self, f"src_{name}", src)
            setattr(self, name, d)
            setattr(self, f"R_{name}", r)
            connect(src.p, d.p)
            connect(d.n, r.p)
            connect(r.n, src.n, self.Ground1.p)


def diode_with_resistor(v, Ron, Goff, Vk, R):
    """Closed form of an ideal diode (MSL characteristic) in series with R under the voltage v: the current and
    whether the diode conducts.

    Blocking: i = Goff v_d, so v = v_d (1 + Goff R). Conducting: v_d = Vk + Ron (i - Goff Vk), so
    i = (v - Vk + Ron Goff Vk) / (R + Ron). The two meet at v_d = Vk, i.e. v = Vk (1 + Goff R)."""
    on = v > Vk * (1 + Goff * R)
    return np.where(on, (v - Vk + Ron * Goff * Vk) / (R + Ron), Goff * v / (1 + Goff * R)), on


def test_characteristic_ideal_diodes_follow_the_piecewise_linear_law():
    """CharacteristicIdealDiodes over its 1 s (no states: every output is solved exactly, so the tolerance is
    round-off, 1e-9 of the peak current); the conducting mode agrees with the closed form at every output, the
    diode's own v-i pair lies on its characteristic, and the energy balance closes."""
    sim = compile_model(CharacteristicIdealDiodes())
    res = sim.simulate(1.0)
    for name, Ron, Goff, Vk, offset in DIODES:
        v = offset + 10.0 * np.sin(2 * np.pi * res.t)
        i, on = diode_with_resistor(v, Ron, Goff, Vk, 1e-3)
        assert np.max(np.abs(res[f"{name}.i"] - i)) < 1e-9 * np.max(np.abs(i)), name
        clear = np.abs(v - Vk * (1 + Goff * 1e-3)) > 1e-9  # exactly at the knee both modes hold
        assert np.array_equal((res[f"{name}.off"] == 0)[clear], on[clear]), name
        vd, idd = res[f"{name}.v"], res[f"{name}.i"]
        if Ron > 0:  # on its characteristic: i = Goff v below the knee, (v - Vk) / Ron + Goff Vk above
            law = np.where(vd > Vk, (vd - Vk) / Ron + Goff * Vk, Goff * vd)
            assert np.allclose(idd, law, rtol=1e-9, atol=1e-9), name
        else:  # the totally ideal diode: v = 0 while on, i = 0 while off, no loss
            assert np.all(np.abs(np.where(on, vd, idd)) < 1e-9) and np.all(vd <= 1e-9) and np.all(idd >= -1e-9)
    check_energy(res, sim)


# ==================================================================== 5. PowerConverters DiodeBridge2Pulse
BRIDGE2 = dict(Vrms=110.0, f=50.0, R=20.0, Ron=1e-5, Goff=1e-5, Vknee=0.0)  # MSL example and DiodeBridge2Pulse defaults


class DiodeBridge2Pulse(Model):
    """The Graetz bridge of MSL ``PowerConverters.ACDC.DiodeBridge2Pulse``, composed of four library IdealDiodes
    (no library counterpart): diode_p1 ac_p -> dc_p, diode_p2 ac_n -> dc_p, diode_n1 dc_n -> ac_p, diode_n2
    dc_n -> ac_n, their parameters bound to the bridge's RonDiode, GoffDiode, VkneeDiode (MSL defaults)."""

    RonDiode = Parameter(1e-5, unit="Ohm", min=0.0, doc="closed diode resistance")
    GoffDiode = Parameter(1e-5, unit="S", min=0.0, doc="opened diode conductance")
    VkneeDiode = Parameter(0.0, unit="V", min=0.0, doc="diode forward threshold voltage")
    ac_p, ac_n, dc_p, dc_n = Pin(), Pin(), Pin(), Pin()

    def build(self):
        kw = dict(R_on=self.RonDiode, G_off=self.GoffDiode, V_knee=self.VkneeDiode)
        self.diode_p1, self.diode_p2 = IdealDiode(**kw), IdealDiode(**kw)
        self.diode_n1, self.diode_n2 = IdealDiode(**kw), IdealDiode(**kw)
        connect(self.ac_p, self.diode_p1.p, self.diode_n1.n)
        connect(self.ac_n, self.diode_p2.p, self.diode_n2.n)
        connect(self.diode_p1.n, self.diode_p2.n, self.dc_p)
        connect(self.diode_n1.p, self.diode_n2.p, self.dc_n)


class DiodeBridge2PulseExample(Model):
    """MSL ``PowerConverters.Examples.ACDC.RectifierBridge2Pulse.DiodeBridge2Pulse``: 110 V rms, 50 Hz into the
    bridge, 20 ohm load through a current sensor (the MSL's mean/rms blocks are left out: the test computes what
    it needs)."""

    def build(self):
        P = BRIDGE2
        self.ground = Ground()
        self.sinevoltage = PrescribedVoltage(v_ref=np.sqrt(2) * P["Vrms"] * sp.sin(2 * sp.pi * P["f"] * time))
        self.rectifier = DiodeBridge2Pulse()
        self.resistor = Resistor(R=P["R"])
        self.currentSensor = CurrentSensor()
        connect(self.sinevoltage.p, self.rectifier.ac_p)
        connect(self.sinevoltage.n, self.rectifier.ac_n, self.ground.p)
        connect(self.rectifier.dc_p, self.resistor.p)
        connect(self.resistor.n, self.currentSensor.p)
        connect(self.currentSensor.n, self.rectifier.dc_n)


def bridge2_reference(v, R, Ron, Goff, Vk):
    """Exact load current of the Graetz bridge on R under the AC voltage v (ac_n at 0 V), by enumeration: each
    diode conducts or blocks, i_d = G (v_d - Vk) + Goff Vk with G = 1/Ron or Goff (the MSL characteristic written
    for both modes), the two DC potentials follow from KCL (a 2x2 linear system), and the one pattern whose
    diodes all lie on their own branch is the solution (the characteristic is continuous and increasing, so it
    is unique). Returns the load current (dc_p -> dc_n through R)."""
    out = np.empty_like(v)
    for j, vac in enumerate(v):
        for pattern in range(16):
            on = [(pattern >> b) & 1 for b in range(4)]  # p1, p2, n1, n2
            G = [1 / Ron if o else Goff for o in on]
            c0 = Goff * Vk
            # unknowns x = dc_p, y = dc_n; diodes p1: vac -> x, p2: 0 -> x, n1: y -> vac, n2: y -> 0
            # KCL dc_p: G1 (vac - x - Vk) + G2 (0 - x - Vk) + 2 c0 = (x - y)/R
            # KCL dc_n: (x - y)/R = G3 (y - vac - Vk) + G4 (y - 0 - Vk) + 2 c0
            A = np.array([[G[0] + G[1] + 1 / R, -1 / R], [-1 / R, G[2] + G[3] + 1 / R]])
            b = np.array([G[0] * (vac - Vk) - G[1] * Vk + 2 * c0, G[2] * (vac + Vk) + G[3] * Vk - 2 * c0])
            x, y = np.linalg.solve(A, b)
            vd = np.array([vac - x, -x, y - vac, y])
            tol = 1e-9 * (1 + abs(vac))
            if all((vd[k] >= Vk - tol) if on[k] else (vd[k] <= Vk + tol) for k in range(4)):
                out[j] = (x - y) / R
                break
        else:
            raise AssertionError(f"no consistent diode pattern at v = {vac}")
    return out


@pytest.mark.parametrize("knee", [False, True], ids=["MSL", "Ron0.05_Vknee0.7"])
def test_diode_bridge_2pulse_is_rectified_sine_minus_two_diode_drops(knee):
    """DiodeBridge2Pulse over its 0.1 s (no states: round-off tolerance 1e-9 of the peak current) against the
    exact bridge; with the MSL's defaults and again with a 0.7 V knee and 0.05 ohm per diode (run-time parameters
    of the bridge, no recompilation). The closed form of the question, (|v| - 2 Vknee) / (R + 2 Ron) while
    |v| > 2 Vknee and 0 otherwise, holds to the leakage of the two blocking diodes, Goff |v| <= 1.6 mA. The mean
    load current of the MSL run is 2 sqrt(2) Vrms / (pi R) to the same order."""
    P = BRIDGE2
    sim = compile_model(DiodeBridge2PulseExample())
    Ron, Vk = (0.05, 0.7) if knee else (P["Ron"], P["Vknee"])
    res = sim.simulate(0.1, params={"rectifier.RonDiode": Ron, "rectifier.VkneeDiode": Vk} if knee else None)
    v = np.sqrt(2) * P["Vrms"] * np.sin(2 * np.pi * P["f"] * res.t)
    exact = bridge2_reference(v, P["R"], Ron, P["Goff"], Vk)
    i = res["currentSensor.i"]
    assert np.max(np.abs(i - exact)) < 1e-9 * np.max(np.abs(exact))
    simple = np.maximum(np.abs(v) - 2 * Vk, 0.0) / (P["R"] + 2 * Ron)
    assert np.max(np.abs(i - simple)) < P["Goff"] * np.sqrt(2) * P["Vrms"]
    assert np.all(i >= -P["Goff"] * np.sqrt(2) * P["Vrms"])  # rectified: never more than leakage backwards
    if not knee:
        mean = np.trapezoid(i, res.t) / res.t[-1]
        assert mean == pytest.approx(2 * np.sqrt(2) * P["Vrms"] / (np.pi * P["R"]), rel=1e-3)
    check_energy(res, sim)


# ==================================================================== 6. Analog.Examples.SeriesResonance
RLC = dict(R=0.5, L=0.1 / (2 * np.pi), C=0.001 / (2 * np.pi), V=1.0, ramp_height=200.0, ramp_duration=1.0)


class SeriesResonance(Model):
    """MSL ``Analog.Examples.SeriesResonance``: a sine (and a cosine) source of constant amplitude 1 V whose
    frequency a Ramp sweeps from 0 to 200 Hz over 1 s drives R = 0.5 ohm, L = 0.1/(2 pi) H, C = 0.001/(2 pi) F in
    series (resonance at 100 Hz), the current through a current sensor; inductor current and capacitor voltage
    start at 0.

    The MSL ``SineVoltageVariableFrequencyAndAmplitude`` integrates its phase, der(phi) = 2 pi f, from phi = 0; with
    f = f0 + k t (the ramp) that phase is 2 pi (f0 t + k t^2 / 2) in closed form, so the source here is a
    PrescribedVoltage of that expression, with ``f0`` and ``k`` parameters of the model (k = 200 Hz/s, the ramp's
    height over its duration; f0 = 0)."""

    f0 = Parameter(0.0, unit="Hz", doc="frequency at t = 0")
    k = Parameter(RLC["ramp_height"] / RLC["ramp_duration"], unit="Hz/s", doc="frequency sweep rate")

    def build(self):
        P = RLC
        phase = 2 * sp.pi * (self.f0 * time + self.k * time**2 / 2)
        for n, wave in ((1, sp.sin), (2, sp.cos)):
            src = PrescribedVoltage(v_ref=P["V"] * wave(phase))
            ind, cap = Inductor(L=P["L"], i=Start(0.0)), Capacitor(C=P["C"], v=Start(0.0))
            res, sensor, gnd = Resistor(R=P["R"]), CurrentSensor(), Ground()
            for name, c in (("voltage", src), ("inductor", ind), ("capacitor", cap), ("resistor", res),
                            ("currentSensor", sensor), ("ground", gnd)):
                setattr(self, f"{name}{n}", c)
            connect(src.p, ind.p)
            connect(ind.n, cap.p)
            connect(cap.n, res.p)
            connect(res.n, sensor.p)
            connect(sensor.n, src.n, gnd.p)


def rlc_reference_sweep(t, wave, f0=0.0, k=RLC["ramp_height"]):
    """The series RLC under V wave(2 pi (f0 t + k t^2/2)), by scipy (DOP853, rtol 1e-11):
    L i' = v(t) - R i - vC, C vC' = i, from rest. Returns (i, vC) at t."""
    P = RLC

    def rhs(tt, x):
        v = P["V"] * wave(2 * np.pi * (f0 * tt + k * tt**2 / 2))
        return [(v - P["R"] * x[0] - x[1]) / P["L"], x[0] / P["C"]]

    return solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0], method="DOP853", t_eval=t, rtol=1e-11, atol=1e-14).y


def rlc_closed_form(t, f):
    """Closed form under V sin(2 pi f t) from rest: the steady state from the phasor (j w - A) X = b V plus the
    homogeneous transient expm(A t) (x0 - x_ss(0)), for x = (i, vC), A = [[-R/L, -1/L], [1/C, 0]], b = (1/L, 0)."""
    P = RLC
    w = 2 * np.pi * f
    A = np.array([[-P["R"] / P["L"], -1 / P["L"]], [1 / P["C"], 0.0]])
    X = np.linalg.solve(1j * w * np.eye(2) - A, np.array([P["V"] / P["L"], 0.0]))  # v = Im(V e^{jwt})
    steady = np.imag(X[:, None] * np.exp(1j * w * t[None, :]))
    x0 = -np.imag(X)  # the transient cancels the steady state's start
    return steady + np.array([expm(A * tt) @ x0 for tt in t]).T


@pytest.fixture(scope="module")
def rlc_sim():
    return compile_model(SeriesResonance())


# the response oscillates near 100 Hz and remembers its past for the transient's time constant 2 L / R = 64 ms
# (Q = 20): about 40 rad of phase
RLC_TOL = phase_tol(40.0)


@pytest.mark.slow
@pytest.mark.parametrize("method", METHODS)
def test_series_resonance_sweep_follows_the_rlc(rlc_sim, method):
    """SeriesResonance over its 1 s (sweep 0 -> 200 Hz through the 100 Hz resonance): both circuits' currents and
    capacitor voltages against scipy to RLC_TOL of each peak (on the default path also at rtol 1e-9, a hundred
    times closer); the current's peak lies where the sweep has passed the resonance (it passes 100 Hz at 0.5 s,
    the envelope lags: within 0.5-0.6 s); the energy balance to twice the state tolerance."""
    runs = [(dict(method=method), RLC_TOL)]
    if method == "auto":
        runs.append((dict(rtol=1e-9, atol=1e-12), RLC_TOL * 1e-2))
    for kw, tol in runs:
        res = rlc_sim.simulate(1.0, **kw)
        for n, wave in ((1, np.sin), (2, np.cos)):
            i, vC = rlc_reference_sweep(res.t, wave)
            assert np.max(np.abs(res[f"currentSensor{n}.i"] - i)) < tol * np.max(np.abs(i)), (kw, n)
            assert np.max(np.abs(res[f"capacitor{n}.v"] - vC)) < tol * np.max(np.abs(vC)), (kw, n)
            assert 0.5 < res.t[np.argmax(np.abs(res[f"currentSensor{n}.i"]))] < 0.6
        check_energy(res, rlc_sim, max(2 * tol, BALANCE_TOL))


def test_series_resonance_at_fixed_resonance_frequency_matches_the_closed_form(rlc_sim):
    """The same circuit at a fixed 100 Hz (parameters f0 = 100 Hz, k = 0 per run, no recompilation): current and
    capacitor voltage against the closed form (steady state + transient) to RLC_TOL of the peak. At resonance the
    current builds up as (V / R) (1 - e^{-t R / 2L}) sin(w t) (Q = 20): its amplitude sqrt(i^2 + (w C vC)^2)
    follows that envelope within 1 % once the start's beat has decayed."""
    res = rlc_sim.simulate(0.5, params={"f0": 100.0, "k": 0.0})
    i, vC = rlc_closed_form(res.t, 100.0)
    assert np.max(np.abs(res["currentSensor1.i"] - i)) < RLC_TOL * np.max(np.abs(i))
    assert np.max(np.abs(res["capacitor1.v"] - vC)) < RLC_TOL * np.max(np.abs(vC))
    late = res.t > 0.2
    w = 2 * np.pi * 100.0
    amplitude = np.hypot(res["currentSensor1.i"], w * RLC["C"] * res["capacitor1.v"])[late]
    envelope = RLC["V"] / RLC["R"] * (1 - np.exp(-res.t[late] * RLC["R"] / (2 * RLC["L"])))
    assert np.max(np.abs(amplitude - envelope)) < 1e-2 * envelope.max()
    check_energy(res, rlc_sim, max(2 * RLC_TOL, BALANCE_TOL))
