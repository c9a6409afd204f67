"""Conformance suite, part 2: the stick/slip examples of the Modelica Standard Library (Modelica
Association, BSD-3-Clause), ``Modelica.Mechanics.Rotational.Examples.LossyGearDemo1``, ``LossyGearDemo2``,
``LossyGearDemo3`` (this module) and ``Friction`` (``tests/msl/test_msl_conformance_friction.py``), rebuilt from this
library's components (the gear is ``StickSlipGear``; the MSL's ``Clutch``, ``Brake`` and ``BearingFriction`` are
the library's ``Clutch``, ``Brake`` and ``StickSlipBearingFriction``). Conventions and tolerances: ``tests/msl/test_msl_conformance.py``; the other six examples: it,
``tests/msl/test_msl_conformance_circuits.py`` and ``tests/msl/test_msl_conformance_rectifier.py``.

They are checked against hand-written references of the MSL's friction elements (mode by mode, closed-form mode
changes or terminal events of a scipy integration): every mode change, the modes at the outputs, the speeds and
angles, the balance, and ``loss_power >= 0`` also at 1e-8 s and 1e-6 s on both sides of every event (the run
repeated with outputs there, which must not move any event). In LossyGearDemo2 and LossyGearDemo3 as the MSL
composes them, friction elements with stiction stick together on one rigid shaft; the split of their holding torque
is chosen by their :class:`~acausal.Indeterminate` rule (finding 3 of ``tests/msl/msl_conformance_findings.md``).
"""
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from acausal import Model, Start, compile_model, connect
from acausal.library.blocks import Ramp, Sine, Step
from acausal.library.friction import StickSlipBearingFriction
from acausal.library.rotational import Fixed, Inertia, SignalTorque, StickSlipGear

from .msl_support import ATOL, METHODS, RTOL, check_energy
from .msl_stickslip_support import (check_losses_around_events, check_mode_changes, check_modes_at_outputs,
                                    friction_mode)


def lossy_gear_reference(t_out, tau1, tau2, *, J1, J2, n, eta1, eta2, bf1, bf2, tau0=0.0, d=0.0, w0=0.0,
                         breaks=(), scan=1e-3):
    """Two inertias coupled by MSL ``Rotational.Components.LossyGear`` (one lossTable row [0, eta1, eta2, bf1,
    bf2]), shaft a with an optional bearing of stiction (MSL ``BearingFriction``, sliding ``tau0 + d |w|``, static
    ``tau0``), integrated mode by mode with scipy (DOP853, rtol 1e-12) between closed-form mode changes.

    Shaft a (speed w, drive tau1(t), inertia J1, bearing torque f, gear torque tau_a = gear.flange_a.tau) and
    shaft b (w / n, load tau2(t), inertia J2, tau_b = gear.flange_b.tau)::

        J1 a = tau1 - f - tau_a,        J2 a / n = tau2 - tau_b,        tau_loss = tau_a + tau_b / n

    The MSL's loss while rolling (LossyGear.mo: quadrant1..4, the quadrant chosen by the sign of tau_a -+ tau_bf_a
    with tau_bf_a = (bf1 - bf2) / (eta1 - 1/eta2), which picks the larger forward and the smaller backward one)::

        forward  (w > 0):  tau_loss = max((1 - eta1) tau_a + bf1, (1 - 1/eta2) tau_a + bf2)
        backward (w < 0):  tau_loss = min((1 - eta1) tau_a - bf1, (1 - 1/eta2) tau_a - bf2)

    Rolling, each of the two lines makes the equations linear in a; the left side minus the right is increasing
    in a, so the solution is the smaller of the two lines' roots forward (the max is above both lines) and the
    larger backward. Stuck (a = 0): tau_b = tau2, and the gear holds while tau2 / n lies between
    min(-eta1 tau_a - bf1, -tau_a/eta2 - bf2) and max(-eta1 tau_a + bf1, -tau_a/eta2 + bf2) for some tau_a =
    tau1 - f with |f| <= tau0 (when the gear and the bearing stick together, which share of the holding torque
    each takes is not unique, as the MSL's LossyGearDemo2 notes; the shaft breaks away when no share holds it).
    Both bounds fall with tau_a, so that is two margins of time alone, roots found by brentq::

        forward:   (tau1 - tau0) - max((bf1 - y) / eta1, eta2 (bf2 - y)) > 0,       y = tau2 / n
        backward:  min((-bf1 - y) / eta1, eta2 (-bf2 - y)) - (tau1 + tau0) > 0

    Rolling ends where w reaches 0 (an event of the integration); the margins then decide whether the gear sticks
    or reverses at once. ``breaks``: times where an input jumps (the integration stops there, each side evaluated
    on its own). Returns (w, phi) of shaft a at ``t_out`` (phi from 0), the mode there (+1, 0, -1) and the mode
    changes [(t, old, new)]."""

    def accel(t, w, s):
        f = s * tau0 + d * w
        roots = [(tau2(t) + n * k * (tau1(t) - f) - n * s * b) / (J2 / n + n * k * J1)
                 for k, b in ((eta1, bf1), (1 / eta2, bf2))]
        return min(roots) if s > 0 else max(roots)

    def margins(t):
        y = tau2(t) / n
        return ((tau1(t) - tau0) - max((bf1 - y) / eta1, eta2 * (bf2 - y)),
                min((-bf1 - y) / eta1, eta2 * (-bf2 - y)) - (tau1(t) + tau0))

    def settle(t):
        zf, zb = margins(t)
        return 1 if zf > 0 else -1 if zb > 0 else 0

    t_end = float(t_out[-1])
    cuts = sorted(b for b in breaks if 0 < b < t_end) + [t_end]
    W, PHI, MODE = np.zeros(t_out.size), np.zeros(t_out.size), np.zeros(t_out.size, int)
    changes, t, w, phi = [], 0.0, float(w0), 0.0
    s = int(np.sign(w0)) if w0 else settle(0.0)
    if s and not w0:
        changes.append((0.0, 0, s))
    while t < t_end:
        t_stop = next(c for c in cuts if c > t)
        t_left = np.nextafter(t_stop, 0.0)  # the inputs' values before a jump at t_stop
        if s == 0:
            t_hit, prev = None, t
            for tt in [*np.arange(t + scan, t_stop, scan), t_left]:
                z = margins(tt)
                if max(z) > 0:
                    k = int(z[1] > 0)
                    t_hit = brentq(lambda x: margins(x)[k], prev, tt, xtol=1e-15, rtol=1e-15)
                    s_new = 1 if k == 0 else -1
                    # the rolling solution starts from rest there: its acceleration is 0 (a check of the margins)
                    assert abs(accel(t_hit, 0.0, s_new)) < 1e-9 * (1 + abs(accel(t_hit + 1e-3, 0.0, s_new)))
                    break
                prev = tt
            t_next = t_hit if t_hit is not None else t_stop
            sel = (t_out >= t) & (t_out <= t_next)
            W[sel], PHI[sel], MODE[sel] = 0.0, phi, 0
            t = t_next
            s_new = s_new if t_hit is not None else (settle(t) if t < t_end else 0)
            if s_new:
                changes.append((t, 0, s_new))
            s = s_new
            continue
        stop = (lambda tt, x: x[0])
        stop.terminal, stop.direction = True, -s
        sol = solve_ivp(lambda tt, x: [accel(min(tt, t_left), x[0], s), x[0]], (t, t_stop), [w, phi],
                        method="DOP853", rtol=1e-12, atol=1e-14, events=stop, dense_output=True)
        assert sol.status >= 0, sol.message
        sel = (t_out >= t) & (t_out <= sol.t[-1])
        W[sel], PHI[sel] = sol.sol(t_out[sel])
        MODE[sel] = s
        t, w, phi = float(sol.t[-1]), float(sol.y[0, -1]), float(sol.y[1, -1])
        if sol.status == 1:  # w reached 0: stick, or reverse at once
            w, s_new = 0.0, settle(t)
            changes.append((t, s, 0))
            if s_new:
                changes.append((t, 0, s_new))
            s = s_new
    return W, PHI, MODE, changes


# ---------------------------------------------------------------- 7, 8. LossyGearDemo1 and LossyGearDemo2
# LossyGearDemo1/2: gear ratio 2, lossTable [0, 0.5, 0.5, 0, 0], Inertia1 1 kg m2, Inertia2 1.5 kg m2 (at rest at
# 0 rad), drive Sine(10 N m, 1 Hz), load Ramp(height 5, duration 2, offset -10) N m, StopTime 0.5 s; Demo2 adds
# BearingFriction(tau_pos = [0, 0.5; 1, 1], peak 1) between the drive and Inertia1.
GEAR_DEMO = dict(ratio=2.0, eta=0.5, J1=1.0, J2=1.5, amplitude=10.0, f=1.0, load_offset=-10.0, load_height=5.0,
                 load_duration=2.0, t_end=0.5)
# tau_pos [0, 0.5; 1, 1] with the table's linear extrapolation (MSL Extrapolation.LastTwoPoints): 0.5 + 0.5 |w|
DEMO2_BEARING = dict(tau0=0.5, d=0.5)


class LossyGearDemo(Model):
    """MSL ``Rotational.Examples.LossyGearDemo1`` (``bearing=False``) and ``LossyGearDemo2`` (``bearing=True``).

    The MSL's ``LossyGear`` under forward dynamics is the library's ``StickSlipGear`` (eta = eta_b = 0.5, no
    bearing torque). Demo2's ``BearingFriction`` (``tau_pos = [0, 0.5; 1, 1]``, peak 1) is the library's
    ``StickSlipBearingFriction`` (tau0 = 0.5 N m, d = 0.5 N m s/rad), one component as in the MSL (the smooth
    ``BearingFriction`` creeps through zero speed instead of sticking)."""

    def __init__(self, bearing: bool = False, **kw):
        super().__init__(**kw)
        self.bearing = bearing

    def build(self):
        P = GEAR_DEMO
        self.fixed = Fixed()
        self.gear = StickSlipGear(ratio=P["ratio"], eta=P["eta"], eta_b=P["eta"], use_support=True)
        self.Inertia1 = Inertia(J=P["J1"])
        self.Inertia2 = Inertia(J=P["J2"], phi=Start(0.0), w=Start(0.0))
        self.torque1, self.torque2 = SignalTorque(use_support=True), SignalTorque(use_support=True)
        self.DriveSine = Sine(amplitude=P["amplitude"], f=P["f"])
        self.load = Ramp(height=P["load_height"], duration=P["load_duration"], offset=P["load_offset"])
        connect(self.DriveSine.y, self.torque1.u)
        connect(self.load.y, self.torque2.u)
        connect(self.Inertia1.flange_b, self.gear.flange_a)
        connect(self.gear.flange_b, self.Inertia2.flange_a)
        connect(self.torque2.flange, self.Inertia2.flange_b)
        connect(self.fixed.flange, self.gear.support, self.torque1.support, self.torque2.support)
        if not self.bearing:
            connect(self.torque1.flange, self.Inertia1.flange_a)
            return
        B = DEMO2_BEARING
        self.bearingFriction = StickSlipBearingFriction(tau0=B["tau0"], d=B["d"], use_support=True)
        connect(self.torque1.flange, self.bearingFriction.flange_a)
        connect(self.bearingFriction.flange_b, self.Inertia1.flange_a)
        connect(self.fixed.flange, self.bearingFriction.support)


def gear_demo_reference(t, bearing: bool):
    P = GEAR_DEMO
    B = DEMO2_BEARING if bearing else dict(tau0=0.0, d=0.0)
    return lossy_gear_reference(
        t, lambda tt: P["amplitude"] * np.sin(2 * np.pi * P["f"] * tt),
        lambda tt: P["load_offset"] + P["load_height"] * min(max(tt, 0.0), P["load_duration"]) / P["load_duration"],
        J1=P["J1"], J2=P["J2"], n=P["ratio"], eta1=P["eta"], eta2=P["eta"], bf1=0.0, bf2=0.0, **B)


def speed_tol(peak: float) -> float:
    """Tolerance [rad/s] of a speed that peaks at ``peak`` in a stick/slip run: ten times the integrator's local
    error bound, rtol |w| + atol (these runs' speeds are small, 0.03-0.05 rad/s in the gear demos, so atol counts).
    An angle integrates that error over the run: ``speed_tol(peak) * t_end``."""
    return 10 * (RTOL * peak + ATOL)


def check_gear_demo(sim, res, method, bearing: bool):
    """The checks of LossyGearDemo1/2 against :func:`gear_demo_reference` (tolerances in the tests' docstrings)."""
    P = GEAR_DEMO
    n, t_end = P["ratio"], P["t_end"]
    w, phi, mode, changes = gear_demo_reference(res.t, bearing)
    dense = check_losses_around_events(sim, res, t_end, method=method)
    for element in ("gear", "bearingFriction") if bearing else ("gear",):
        check_mode_changes(res, dense, element, changes)
        check_modes_at_outputs(res, element, mode, changes)
    tol = speed_tol(np.max(np.abs(w)))
    assert np.max(np.abs(res["Inertia1.w"] - w)) < tol
    assert np.max(np.abs(res["Inertia2.w"] - w / n)) < tol / n
    assert np.max(np.abs(res["Inertia2.phi"] - phi / n)) < tol * t_end / n
    assert np.max(np.abs(res["Inertia1.w"][mode == 0])) < tol  # stuck means standing still
    check_energy(res, sim)
    # the MSL's check of its own LossyGear: the power flowing into the gear through its flanges is its loss_power
    into = dense.power("gear.flange_a") + dense.power("gear.flange_b")
    assert np.max(np.abs(into - dense["gear.loss_power"])) < 1e-9 * max(1.0, np.max(np.abs(into)))
    return w, mode, changes


@pytest.fixture(scope="module")
def gear_demo1_sim():
    return compile_model(LossyGearDemo())


@pytest.mark.slow
@pytest.mark.parametrize("method", METHODS)
def test_lossy_gear_demo1_sticks_and_rolls_as_the_msl_gear(gear_demo1_sim, method):
    """LossyGearDemo1 over its 0.5 s: the load (-10 N m, a ramp) back-drives the gear from rest, the sine drive
    stops it (stuck at 80 ms), breaks it away forward (0.200 s), stops it again (0.371 s) and the load wins once
    more (0.465 s): "the friction in the gear will take all modes" (MSL). Checked against the hand-written
    MSL gear (:func:`lossy_gear_reference`):

    * each mode change within EVENT_T_TOL = 1e-6 s: a stick is where the speed reaches 0, so an error dw in
      the speed moves it by dw / |a|; the speed's error is held to about rtol |w|max + atol = 4e-8 rad/s and the
      gear arrives at |a| >= 1 rad/s2 (0.2 rad/s2 in Demo2): 2e-7 s at most (measured 5e-8). A breakaway is
      where the holding torque, a function of the inputs alone while stuck, leaves the band: exact to round-off;
    * the mode at every output 10 us or more from a change;
    * Inertia1.w and Inertia2.w within :func:`speed_tol` (4e-7 rad/s against a peak of 0.042; measured 8e-8),
      Inertia2.phi within that times the run's 0.5 s; standing still within the same while stuck;
    * the energy balance, loss_power >= 0 at every output and at 1e-8 and 1e-6 s on both sides of every event,
      and (the MSL example's own check) the power into the gear's two flanges equals its loss_power."""
    res = gear_demo1_sim.simulate(GEAR_DEMO["t_end"], method=method)
    w, mode, changes = check_gear_demo(gear_demo1_sim, res, method, bearing=False)
    assert [(old, new) for _, old, new in changes] == [(0, -1), (-1, 0), (0, 1), (1, 0), (0, -1)]
    assert friction_mode(res, "gear")[1] == -1


@pytest.mark.slow
@pytest.mark.parametrize("method", METHODS)
def test_lossy_gear_demo2_gear_and_bearing_stick_together(method):
    """LossyGearDemo2 over its 0.5 s: the same drive train with a bearing of stiction (0.5 N m) and a speed-
    proportional part (0.5 N m s/rad) on the gear's input shaft. The gear and the bearing are on one rigid shaft,
    so they stick and break away together: the load back-drives from rest, the shaft sticks at 63.6 ms, breaks
    away forward at 0.230 s, sticks at 0.308 s and goes backward at 0.473 s (:func:`lossy_gear_reference` with
    the bearing: the shaft holds while some share of the holding torque is within both elements' limits). Same
    checks and tolerances as LossyGearDemo1, for the gear's and the bearing's modes. While stuck, the split of
    the holding torque (their :class:`~acausal.Indeterminate` rule) keeps each element within its own band:
    the bearing within its 0.5 N m, the gear within its two power-flow cases (eta 0.5: between 0.5 tau_a and
    -tau_a)."""
    sim = compile_model(LossyGearDemo(bearing=True))
    res = sim.simulate(GEAR_DEMO["t_end"], method=method)
    _, mode, changes = check_gear_demo(sim, res, method, bearing=True)
    assert [(old, new) for _, old, new in changes] == [(0, -1), (-1, 0), (0, 1), (1, 0), (0, -1)]
    stuck = res["gear.stuck"] == 1
    assert stuck.sum() > 100 and np.all(res["bearingFriction.stuck"][stuck] == 1)
    assert np.all(np.abs(res["bearingFriction.sa"][stuck]) <= DEMO2_BEARING["tau0"] + 1e-9)
    tau_a, held = res["gear.flange_a.tau"][stuck], res["gear.sa"][stuck]
    assert np.all(held <= np.maximum(0.5 * tau_a, -tau_a) + 1e-9)
    assert np.all(held >= np.minimum(0.5 * tau_a, -tau_a) - 1e-9)


# ---------------------------------------------------------------- 9. LossyGearDemo3
# LossyGear(ratio 1, lossTable [0, 0.25, 0.25, 0.625, 2.5], no support), Inertia1 and Inertia2 1e-3 kg m2 both
# at 10 rad/s (Inertia2's angle and speed fixed), torque1 = Step(height 0), torque2 = Step(1 N m at 0.5 s),
# StopTime 1 s.
GEAR_DEMO3 = dict(ratio=1.0, eta=0.25, bf1=0.625, bf2=2.5, J=1e-3, w0=10.0, t_step=0.5, load=1.0, t_end=1.0)


def demo3_bearings(eta1, eta2, bf1, bf2, ratio):
    """The MSL LossyGear's bearing torques on each side from its lossTable (LossyGear.mo: tau_bf1 = |tau_bf_a eta1
    + tau_bf_b / ratio| with flange_a driving, tau_bf2 = |tau_bf_a / eta2 + tau_bf_b / ratio| with flange_b
    driving): tau_bf_a = (bf1 - bf2) / (eta1 - 1/eta2), tau_bf_b = ratio (bf1 - eta1 tau_bf_a)."""
    a = (bf1 - bf2) / (eta1 - 1 / eta2)
    return a, ratio * (bf1 - eta1 * a)


class LossyGearDemo3(Model):
    """MSL ``Rotational.Examples.LossyGearDemo3`` ("a situation where the driving side of the LossyGear model is not
    obvious"): two small inertias at 10 rad/s coast down through a gear of efficiency 0.25 with bearing friction
    that depends on which side drives (tau_bf1 = 0.625 N m with flange_a driving, tau_bf2 = 2.5 N m with flange_b
    driving); at 0.5 s a load of 1 N m pulls at the output.

    ``StickSlipGear`` has one bearing torque for both driving sides (it is the MSL's bearing on side b, ``tau_bf_b /
    ratio``, with none on side a), so the MSL's gear is composed as the MSL documents it: a bearing on each side of
    the mesh, tau_bf_a = 0.5 N m and tau_bf_b = 0.5 N m (:func:`demo3_bearings`), each a ``Brake`` at its full
    normal force, around a ``StickSlipGear(eta=0.25)`` without bearing torque. ``lumped=True`` is the variant the
    library can build in one piece, ``StickSlipGear(tau_bf=0.625)``: the MSL's lossTable with tau_bf2 = tau_bf1."""

    def __init__(self, lumped: bool = False, **kw):
        super().__init__(**kw)
        self.lumped = lumped

    def build(self):
        P = GEAR_DEMO3
        self.Inertia1 = Inertia(J=P["J"], w=Start(P["w0"]))
        self.Inertia2 = Inertia(J=P["J"], phi=Start(0.0, fixed=True), w=Start(P["w0"], fixed=True))
        self.torque1, self.torque2 = SignalTorque(), SignalTorque()
        self.step = Step(height=0.0)
        self.step1 = Step(height=P["load"], start_time=P["t_step"])
        connect(self.step.y, self.torque1.u)
        connect(self.step1.y, self.torque2.u)
        connect(self.torque1.flange, self.Inertia1.flange_a)
        connect(self.Inertia2.flange_b, self.torque2.flange)
        if self.lumped:
            self.gear = StickSlipGear(ratio=P["ratio"], eta=P["eta"], tau_bf=P["bf1"])
            connect(self.Inertia1.flange_b, self.gear.flange_a)
            connect(self.gear.flange_b, self.Inertia2.flange_a)
            return
        bf_a, bf_b = demo3_bearings(P["eta"], P["eta"], P["bf1"], P["bf2"], P["ratio"])
        self.gear = StickSlipGear(ratio=P["ratio"], eta=P["eta"])
        self.bearing_a = StickSlipBearingFriction(tau0=bf_a)
        self.bearing_b = StickSlipBearingFriction(tau0=bf_b)
        connect(self.Inertia1.flange_b, self.bearing_a.flange_a)
        connect(self.bearing_a.flange_b, self.gear.flange_a)
        connect(self.gear.flange_b, self.bearing_b.flange_a)
        connect(self.bearing_b.flange_b, self.Inertia2.flange_a)


def gear_demo3_reference(t, bf2):
    P = GEAR_DEMO3
    return lossy_gear_reference(t, lambda tt: 0.0, lambda tt: P["load"] if tt >= P["t_step"] else 0.0,
                                J1=P["J"], J2=P["J"], n=P["ratio"], eta1=P["eta"], eta2=P["eta"], bf1=P["bf1"],
                                bf2=bf2, w0=P["w0"], breaks=(P["t_step"],))


def check_gear_demo3(sim, res, method, bf2, elements):
    P = GEAR_DEMO3
    w, phi, mode, changes = gear_demo3_reference(res.t, bf2)
    dense = check_losses_around_events(sim, res, P["t_end"], method=method)
    for element in elements:
        check_mode_changes(res, dense, element, changes)
        check_modes_at_outputs(res, element, mode, changes)
    tol = speed_tol(np.max(np.abs(w)))
    for name in ("Inertia1.w", "Inertia2.w"):
        assert np.max(np.abs(res[name] - w)) < tol, name
    assert np.max(np.abs(res["Inertia2.phi"] - phi)) < tol * P["t_end"]
    check_energy(res, sim)
    return w, mode, changes


@pytest.mark.slow
@pytest.mark.parametrize("method", METHODS)
def test_lossy_gear_demo3_coasts_down_and_holds_the_load(method):
    """LossyGearDemo3 as the MSL has it (bearings on both sides of the mesh). From 10 rad/s the gear coasts down
    exactly at the boundary of the two driving sides (the MSL gear's flange_a.tau is tau_bf_a = 0.5 N m, where both
    of its quadrant formulas give a loss of 1 N m; in the composition each bearing brakes its own inertia and the
    mesh between them transmits nothing), decelerating at 500 rad/s2, and sticks at 0.02 s;
    at 0.5 s the 1 N m load would have to back-drive the gear (flange_b driving), whose limit is tau_bf2 =
    2.5 N m: the gear holds to the end. Checked against :func:`lossy_gear_reference` (the MSL's lumped law, not the
    composition): the stick instant within EVENT_T_TOL, speeds within :func:`speed_tol`, modes of the gear and
    both bearings, energy balance, losses >= 0 around the events; and the closed form: w = 10 - 500 t to the stop."""
    sim = compile_model(LossyGearDemo3())
    res = sim.simulate(GEAR_DEMO3["t_end"], method=method)
    w, mode, changes = check_gear_demo3(sim, res, method, GEAR_DEMO3["bf2"], ("gear", "bearing_a", "bearing_b"))
    assert [(old, new) for _, old, new in changes] == [(1, 0)] and changes[0][0] == pytest.approx(0.02, abs=1e-12)
    rolling = res.t < 0.02
    assert np.max(np.abs(res["Inertia1.w"][rolling] - (10 - 500 * res.t[rolling]))) < speed_tol(10.0)


@pytest.mark.parametrize("method", METHODS)
def test_lossy_gear_demo3_with_one_bearing_torque(method):
    """The variant of LossyGearDemo3 the library builds in one piece, ``StickSlipGear(tau_bf=0.625)`` (the MSL's
    lossTable with tau_bf2 = tau_bf1 = 0.625 N m, the bearing all on side b): the coast-down is the MSL's (the loss
    is 1 N m with either driving side: w = 10 - 500 t, stuck at 0.02 s), but at 0.5 s the load's 1 N m exceeds
    the 0.625 N m the gear now holds when back-driven, and it breaks away forward, accelerating at
    (1 - 0.625) / (J (1 + 1/eta)) = 75 rad/s2 to 37.5 rad/s at 1 s (flange_b driving: tau_loss = (1 - 1/eta)
    tau_a + tau_bf). Against :func:`lossy_gear_reference` with tau_bf2 = 0.625 and these closed forms, with the
    tolerances of LossyGearDemo1 (the speed peaks at 37.5 rad/s)."""
    sim = compile_model(LossyGearDemo3(lumped=True))
    res = sim.simulate(GEAR_DEMO3["t_end"], method=method)
    w, mode, changes = check_gear_demo3(sim, res, method, GEAR_DEMO3["bf1"], ("gear",))
    assert [(old, new) for _, old, new in changes] == [(1, 0), (0, 1)]
    assert changes[0][0] == pytest.approx(0.02, abs=1e-12) and changes[1][0] == GEAR_DEMO3["t_step"]
    closed = np.where(res.t < 0.02, 10 - 500 * res.t, np.where(res.t < 0.5, 0.0, 75.0 * (res.t - 0.5)))
    assert np.max(np.abs(res["Inertia1.w"] - closed)) < speed_tol(37.5)
    assert res["gear.tau_loss"][-1] == pytest.approx(0.85, rel=1e-9)  # -3 tau_a + 0.625, tau_a = -J 75


# ---------------------------------------------------------------- 10. Rotational.Examples.Friction
# inertia3 1 kg m2 at 100 rad/s, Clutch(fn_max 160 N; mu_pos [0, 0.5], peak 1, cgeo 1 by default) with a constant
# f_normalized of 1, inertia2 0.05 kg m2 at 90 rad/s, SpringDamper(c 160 N m/rad, d 1 N m s/rad) unstretched,
# Brake(fn_max 1600 N, defaults as the clutch) with f_normalized = Step(at startTime 0.5 s), inertia1 1 kg m2 at
# 90 rad/s; the drive 200 sin(2 pi (50/pi) t) N m times Step(height -1, offset 1, at 0.5 s); StopTime 3 s.
