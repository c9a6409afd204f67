"""MSL conformance, ``Modelica.Electrical.Analog.Examples.Rectifier``: the full six-pulse
bridge rebuilt from the library's components, checked switching by switching against a scipy event-by-event
integration, and once more with its AC switched off by a Step and run a thousand times longer than its
commutations last (no event lost in long steps). Sources, conventions and tolerances:
``tests/msl/test_msl_conformance.py``."""

from functools import lru_cache

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from acausal import Model, Start, compile_model, connect, time
from acausal.library.blocks import Product, Sine, Step
from acausal.library.electrical import (Capacitor, ConstantCurrent, Ground, IdealDiode, Inductor, PrescribedVoltage,
                                        SignalVoltage)
from .msl_support import METHODS, check_energy, compiled_path_available

#: each test here takes seconds (its simulations or its shared fixture): out of the quick lane
pytestmark = pytest.mark.slow


# ==================================================================== 4. Analog.Examples.Rectifier
RECT = dict(VAC=400.0, f=50.0, LAC=60e-6, Ron=1e-3, Goff=1e-3, Vknee=2.0, CDC=15e-3, IDC=500.0)
RECT_DIODES = [f"D{k}" for k in range(1, 7)]  # D1-D3 from the lines to DC+, D4-D6 from DC- to the lines
KNEE_TOL = 1e-9  # V: diodes this close to their knee where the reference's switchings stall conduct together


class Rectifier(Model):
    """MSL ``Analog.Examples.Rectifier`` (B6 diode bridge): three sine sources, 400 V rms line to line, 50 Hz, in
    star with a floating star point, each behind a 60 uH line inductance; six ideal diodes (Ron = 1 mohm, Goff =
    1 mS, Vknee = 2 V) to a DC link of two 30 mF capacitors in series (the ground at their midpoint, each charged
    to half the no-load voltage 400 sqrt(2) V at the start) loaded by a 500 A current source. Two of the three line
    currents start at 0 (the third follows from the floating star, as in the MSL).

    ``t_off``: the AC sources are switched off at ``t_off`` (the MSL's Sine times a Step, through Product blocks into
    SignalVoltage sources), for the long run after the last crossing; None gives the MSL example as it is (the
    SineVoltage sources as PrescribedVoltage)."""

    def __init__(self, t_off=None, **kw):
        super().__init__(**kw)
        self.t_off = t_off

    def build(self):
        P = RECT
        V = P["VAC"] * np.sqrt(2 / 3)
        diode = dict(R_on=P["Ron"], G_off=P["Goff"], V_knee=P["Vknee"])
        self.Ground1 = Ground()
        if self.t_off is not None:
            self.switch = Step(height=-1.0, offset=1.0, start_time=self.t_off)
        for k in (1, 2, 3):
            phase = -2 * np.pi * (k - 1) / 3
            if self.t_off is None:
                src = PrescribedVoltage(v_ref=V * sp.sin(2 * sp.pi * P["f"] * time + phase))
            else:
                sine, gate, src = Sine(amplitude=V, f=P["f"], phase=phase), Product(), SignalVoltage()
                setattr(self, f"Sine{k}", sine)
                setattr(self, f"Gate{k}", gate)
            setattr(self, f"SineVoltage{k}", src)
            if self.t_off is not None:
                connect(sine.y, gate.u1)
                connect(self.switch.y, gate.u2)
                connect(gate.y, src.u)
            setattr(self, f"Inductor{k}", Inductor(L=P["LAC"], **({} if k == 1 else {"i": Start(0.0)})))
            setattr(self, f"D{k}", IdealDiode(**diode))
            setattr(self, f"D{k + 3}", IdealDiode(**diode))
        v0 = P["VAC"] * np.sqrt(2) / 2
        self.Capacitor1 = Capacitor(C=2 * P["CDC"], v=Start(v0))
        self.Capacitor2 = Capacitor(C=2 * P["CDC"], v=Start(v0))
        self.Load = ConstantCurrent(I=P["IDC"])
        connect(self.SineVoltage1.n, self.SineVoltage2.n, self.SineVoltage3.n)
        for k in (1, 2, 3):
            src, ind = getattr(self, f"SineVoltage{k}"), getattr(self, f"Inductor{k}")
            connect(src.p, ind.p)
            connect(ind.n, getattr(self, f"D{k}").p, getattr(self, f"D{k + 3}").n)
        connect(self.D1.n, self.D2.n, self.D3.n, self.Capacitor1.p, self.Load.p)
        connect(self.D4.p, self.D5.p, self.D6.p, self.Capacitor2.n, self.Load.n)
        connect(self.Capacitor1.n, self.Capacitor2.p, self.Ground1.p)


@lru_cache(maxsize=None)
def rectifier_reference(t_end, n_points, t_off=np.inf):
    """The B6 bridge written out by hand and integrated by scipy, event by event (Radau, rtol 1e-9, atol 1e-8).

    States x = (i2, i3, vC1, vC2), i1 = -i2 - i3 (floating star); DC+ at P = vC1, DC- at N = -vC2. Each diode is
    conducting or blocking; in both modes i_d = G (v_d - Vk) + Goff Vk with G = 1/Ron or Goff (the MSL
    characteristic), so the junction potential a_k of line k follows from its KCL, i_k + i_lower = i_upper::

        a_k = (i_k + G_lower (N - Vk) + G_upper (P + Vk)) / (G_upper + G_lower)
        L i_k' = S + e_k - a_k,   S = mean(a - e)  (the star point: the currents sum to zero)
        C vC1' = sum(i_upper) - IDC,   C vC2' = sum(i_lower) - IDC

    A diode switches where v_d - Vk crosses zero (the sign of the MSL's curve parameter in both modes), found as a
    terminal event of the integration; the other diodes whose sign the switch reverses (the lower diode in series
    with an upper one whose current dies) switch at the same instant, and the run restarts in the new modes. Where
    the diodes meet at a common knee (all six at 55.7 ms once the AC is off) the restarts make no progress, two
    diodes trading the lead on round-off (1e-13 V); after three such restarts every diode within ``KNEE_TOL`` of its
    knee conducts. The switchings at an instant are each diode's net change of mode there. Returns (t, X, events)
    with X the states at ``n_points`` output times from 0 to ``t_end`` and events [(t, diode name, turned on)]."""
    P = RECT
    V, C, L, Vk, Goff, I = P["VAC"] * np.sqrt(2 / 3), 2 * P["CDC"], P["LAC"], P["Vknee"], P["Goff"], P["IDC"]
    phase = 2 * np.pi * np.arange(3) / 3

    def emf(t):
        return np.zeros(3) if t >= t_off else V * np.sin(2 * np.pi * P["f"] * t - phase)

    def nodes(x, on):
        i = np.array([-x[0] - x[1], x[0], x[1]])
        Pv, Nv = x[2], -x[3]
        G = np.where(on, 1 / P["Ron"], Goff)
        a = (i + G[3:] * (Nv - Vk) + G[:3] * (Pv + Vk)) / (G[:3] + G[3:])
        return a, G[:3] * (a - Pv - Vk) + Goff * Vk, G[3:] * (Nv - a - Vk) + Goff * Vk, Pv, Nv

    def rhs(t, x, on):
        a, iu, il, _, _ = nodes(x, on)
        e = emf(t)
        di = (np.mean(a - e) + e - a) / L
        return [di[1], di[2], (iu.sum() - I) / C, (il.sum() - I) / C]

    def knee(x, on):
        a, _, _, Pv, Nv = nodes(x, on)
        return np.concatenate([a - Pv, Nv - a]) - Vk

    t_out = np.linspace(0.0, t_end, n_points)
    x = np.array([0.0, 0.0, P["VAC"] * np.sqrt(2) / 2, P["VAC"] * np.sqrt(2) / 2])
    on = np.zeros(6, bool)
    for _ in range(6):  # consistent modes at the start
        on = knee(x, on) > 0
    X, events, t = np.empty((4, n_points)), [], 0.0
    arrived, stalled = on.copy(), 0
    while t < t_end:
        t_stop = t_off if t < t_off < t_end else t_end
        watch = []
        for k in range(6):
            fn = (lambda kk, m: (lambda tt, xx: knee(xx, m)[kk]))(k, on.copy())
            fn.terminal, fn.direction = True, (-1 if on[k] else 1)
            watch.append(fn)
        sol = solve_ivp(lambda tt, xx, m=on.copy(): rhs(tt, xx, m), (t, t_stop), x, method="Radau", rtol=1e-9,
                        atol=1e-8, events=watch, dense_output=True)
        assert sol.status >= 0, sol.message
        sel = (t_out >= t) & (t_out <= sol.t[-1])
        if sel.any():
            X[:, sel] = sol.sol(t_out[sel])
        if sol.t[-1] > t:
            arrived, stalled = on.copy(), 0  # the modes with which the run reached this instant
        else:
            stalled += 1
        t, x = sol.t[-1], sol.y[:, -1]
        if sol.status == 1 and stalled > 2:  # a common knee: the diodes at it trade the lead without progress
            on = arrived | (np.abs(knee(x, on)) < KNEE_TOL)
        elif sol.status == 1:
            k = next(k for k in range(6) if sol.t_events[k].size)
            on = on.copy()
            on[k] = not on[k]
            for _ in range(6):  # the other diodes whose curve parameter the switch reversed follow at once
                now = knee(x, on) > 0
                now[k] = on[k]
                if np.array_equal(now, on):
                    break
                on = now
        if sol.status == 1:  # the switchings at t: the net change of each diode's mode since the run reached t
            events = [e for e in events if e[0] < t] + [(t, RECT_DIODES[j], bool(on[j]))
                                                         for j in np.flatnonzero(on != arrived)]
    return t_out, X, events


def diode_events(sim, res) -> dict:
    """The diode switchings of a run: {(diode, turned on): times}. Each library event of an IdealDiode assigns its
    ``off`` mode; 'rising' (the curve parameter rises through zero) turns it on."""
    out = {}
    for t, i, direction in res.events:
        target = sim.event_assignments(i, True)[0][0] if i < len(sim.event_zeros) else ""
        if target.endswith(".off"):
            out.setdefault((target[:-4], direction == "rising"), []).append(t)
    return out


def check_same_switchings(sim, res, ref_events, t_tol=1e-6):
    """Every diode switches on and off as often as in the reference, each time within ``t_tol``."""
    ref = {}
    for t, name, turned_on in ref_events:
        ref.setdefault((name, turned_on), []).append(t)
    got = diode_events(sim, res)
    assert set(got) == set(ref), (sorted(got), sorted(ref))
    for key in ref:
        assert len(got[key]) == len(ref[key]), (key, got[key], ref[key])
        dt = np.max(np.abs(np.array(got[key]) - np.array(ref[key])))
        assert dt < t_tol, (key, dt)


def check_modes_consistent(res, tol=1e-3):
    """At every output each diode's mode agrees with its curve parameter: s >= 0 while conducting (s is the
    current above Goff Vknee, A), s <= 0 while blocking (s is the voltage above the knee, V), both to ``tol``
    (1 mA or 1 mV, well below what the other checks resolve)."""
    for d in RECT_DIODES:
        s, off = res[f"{d}.s"], res[f"{d}.off"]
        bad = ((off == 0) & (s < -tol)) | ((off == 1) & (s > tol))
        assert not bad.any(), f"{d}: mode against s at t = {res.t[bad][:3]} (s = {s[bad][:3]}, off = {off[bad][:3]})"


def check_rectifier(sim, res, t_end, n_points, t_off=np.inf):
    """The rectifier checks against the scipy reference at the run's outputs.

    * switchings: each diode's on/off instants within 1e-6 s (rtol over the 10 ms half-period is 1e-8 s: a
      hundred times that);
    * uDC = vC1 + vC2 within 1e-5 of its 566 V peak (ten times rtol: a capacitor voltage, its slope bounded by
      1200 A / 15 mF, so a switching instant off by 1e-8 s moves it by 1e-3 V);
    * the three line currents within 1e-4 of their peak (or of IDC, if larger): around a commutation they change
      by up to 566 V / 120 uH = 4.7e6 A/s, so a switching instant off by 2e-8 s moves them by 0.1 A, 1e-4 of 1170 A;
    * the modes consistent with the curve parameters at every output, the energy balance, losses >= 0."""
    t, X, events = rectifier_reference(t_end, n_points, t_off)
    assert np.allclose(res.t, t, rtol=0, atol=1e-12)
    check_same_switchings(sim, res, events)
    udc = res["Capacitor1.v"] + res["Capacitor2.v"]
    assert np.max(np.abs(udc - X[2] - X[3])) < 1e-5 * np.max(np.abs(X[2] + X[3]))
    lines = np.array([-X[0] - X[1], X[0], X[1]])
    peak = max(np.max(np.abs(lines)), RECT["IDC"])  # the load current where the outputs see no commutation
    for k in range(3):
        assert np.max(np.abs(res[f"Inductor{k + 1}.i"] - lines[k])) < 1e-4 * peak, f"Inductor{k + 1}.i"
    check_modes_consistent(res)
    check_energy(res, sim)
    return t, X, events


@pytest.fixture(scope="module")
def rectifier_sim():
    return compile_model(Rectifier())


@pytest.mark.parametrize("method", METHODS)
def test_rectifier_b6_bridge_follows_the_piecewise_linear_reference(rectifier_sim, method):
    """MSL Rectifier over its 0.1 s at the default 501 outputs: 62 diode switchings, uDC and the line currents
    against the event-by-event scipy reference (tolerances in :func:`check_rectifier`); the DC voltage sags under
    the 500 A load from its no-load 566 V, staying within 470-570 V."""
    res = rectifier_sim.simulate(0.1, method=method)
    check_rectifier(rectifier_sim, res, 0.1, 501)
    udc = res["Capacitor1.v"] + res["Capacitor2.v"]
    assert 470.0 < udc.min() and udc.max() < 570.0
    assert sum(len(v) for v in diode_events(rectifier_sim, res).values()) >= 60


@pytest.mark.parametrize("method", ["auto", "LSODA", "Radau", "BDF"])
def test_rectifier_b6_bridges_energy_balance_closes_to_the_trust_limit_on_every_path(rectifier_sim, method):
    """The MSL Rectifier at default settings on the compiled path and on each of the scipy path's implicit
    integrators: the trust checks pass, its 62 switchings are found, and the balance closes well within the trust
    limit (0.1 % at rtol 1e-6; here 2e-7 compiled, 1.3e-6 LSODA, 2.7e-9 Radau, 2.6e-6 BDF)."""
    from acausal.results.run_balance import residual
    from acausal.results.trust import balance_limit

    res = rectifier_sim.simulate(0.1, method=method)
    assert res.trust == []
    assert len(res.events) == 62
    assert residual(res, 1e-12)[2] < balance_limit(1e-6) / 100
    check_energy(res, rectifier_sim)


def test_rectifier_with_coarse_output_loses_no_event(rectifier_sim):
    """The MSL Rectifier with 11 outputs (10 ms apart, a half-period): the integrator takes long steps between
    them, and every switching must still be found (the same checks as at 501 outputs). On the compiled path this
    is the case of a diode turning on and off again inside one output interval while another diode crosses in it
    too (finding 2 of ``tests/msl/msl_conformance_findings.md``)."""
    res = rectifier_sim.simulate(0.1, n_points=11)
    if compiled_path_available():
        assert "compiled path" in res.solver, res.solver
    check_rectifier(rectifier_sim, res, 0.1, 11)


# ---------------------------------------------------------------- the bridge run far past its last crossing
T_OFF, T_LONG = 0.04, 100.0


@pytest.fixture(scope="module")
def rectifier_off_sim():
    return compile_model(Rectifier(t_off=T_OFF))


@pytest.mark.parametrize("method", ["auto", "BDF"])
def test_rectifier_switched_off_runs_long_steps_without_losing_an_event(rectifier_off_sim, method):
    """No event is lost in a test built to make long steps. The MSL Rectifier with its AC sources
    switched off by a Step at 0.04 s, run to 100 s at the default 501 outputs (0.2 s apart): two periods of
    commutations, then the line currents die out, the 500 A load discharges the DC link until all six diodes
    conduct at 55.7 ms and carry it as a freewheeling current, and nothing changes for the remaining 99.9 s.

    Checks: the switchings, uDC and line currents against the reference as in :func:`check_rectifier`; no switching
    after 0.06 s; the same switchings as a 0.1 s run of the same model at 0.2 ms outputs; and the run ends in the
    closed-form steady state: each diode carries IDC / 3, the line currents are zero and each capacitor holds
    vC = -(Vknee + Ron (IDC / 3 - Goff Vknee)) (one upper and one lower diode in series per leg, the midpoint at
    the ground by symmetry), all six diodes conducting."""
    P = RECT
    res = rectifier_off_sim.simulate(T_LONG, method=method)
    _, _, events = check_rectifier(rectifier_off_sim, res, T_LONG, 501, T_OFF)
    assert max(t for t, _, _ in events) < 0.06
    assert max(max(v) for v in diode_events(rectifier_off_sim, res).values()) < 0.06
    short = rectifier_off_sim.simulate(0.1, method=method)
    check_same_switchings(rectifier_off_sim, short, rectifier_reference(0.1, 501, T_OFF)[2])
    check_same_switchings(rectifier_off_sim, res, [(t, d, bool(on)) for (d, on), ts in
                                                   diode_events(rectifier_off_sim, short).items() for t in ts])
    vC = -(P["Vknee"] + P["Ron"] * (P["IDC"] / 3 - P["Goff"] * P["Vknee"]))
    assert res["Capacitor1.v"][-1] == pytest.approx(vC, rel=1e-6)
    assert res["Capacitor2.v"][-1] == pytest.approx(vC, rel=1e-6)
    for k in (1, 2, 3):
        assert abs(res[f"Inductor{k}.i"][-1]) < 1e-6
    for d in RECT_DIODES:
        assert res[f"{d}.off"][-1] == 0
        assert res[f"{d}.i"][-1] == pytest.approx(P["IDC"] / 3, rel=1e-6)
