"""Conformance suite, part 2 (issue 21, item 6): the stick/slip examples of the Modelica Standard Library,
``Modelica.Mechanics.Rotational.Examples.LossyGearDemo1``, ``LossyGearDemo2``, ``LossyGearDemo3`` and
``Friction`` (Modelica Standard Library, Modelica Association, BSD-3-Clause), rebuilt from this library's
components (the gear is ``StickSlipGear``; the MSL's ``Clutch`` and ``Brake`` are the library's; a
``BearingFriction`` with stiction is a ``Brake`` at constant normal force, with a ``Damper`` for a friction torque
that grows with speed). Conventions and tolerances: ``tests/test_msl_conformance.py``; the other six examples: it,
``tests/test_msl_conformance_circuits.py`` and ``tests/test_msl_conformance_rectifier.py``.

They are checked against hand-written references of the MSL's friction elements (mode by mode, closed-form mode
changes or terminal events of a scipy integration): every mode change, the modes at the outputs, the speeds and
angles, the balance, and ``loss_power >= 0`` also at 1e-8 s and 1e-6 s on both sides of every event (the run
repeated with outputs there, which must not move any event). In LossyGearDemo2 and LossyGearDemo3 as the MSL
composes them, friction elements with stiction stick together on one rigid shaft; the split of their holding torque
is chosen by their :class:`~acausal.Indeterminate` rule (finding 3 of ``tests/msl_conformance_findings.md``).
"""
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from acausal import Model, Start, compile_model, connect
from acausal.library.blocks import Product, Ramp, SignalSource, Sine, Step
from acausal.library.friction import Brake, Clutch
from acausal.library.rotational import Damper, Fixed, Inertia, SignalTorque, SpringDamper, StickSlipGear

from .msl_support import ATOL, BALANCE_TOL, METHODS, RTOL, check_energy, phase_tol


# ==================================================================== 7-10. stick/slip: the gear demos and Friction
# Shared by the four examples below. A friction element's mode is +1 sliding forward, 0 stuck, -1 sliding backward
# (MSL's ``mode``); the library's PartialFriction elements carry it as ``stuck`` and ``forward``.
EVENT_T_TOL = 1e-6  # s: every mode change of a friction element (see the tests' docstrings for the margins)


def friction_mode(res, element: str) -> np.ndarray:
    """MSL's ``mode`` of a library stick/slip element at the outputs: 0 stuck, +1 forward, -1 backward."""
    return np.where(res[f"{element}.stuck"] == 1, 0, np.where(res[f"{element}.forward"] == 1, 1, -1))


def mode_changes(res, dense, element: str, side=1e-6) -> list:
    """Instants t > 0 where ``element`` changes mode: the events of ``res`` at which its mode ``side`` before
    differs from its mode ``side`` after, read from ``dense`` (the same run with outputs there, see
    :func:`check_losses_around_events`; or ``res`` itself, its outputs on either side of the event). A mode
    change can come from the element's own event (a stick, a breakaway) or from the event iteration after another
    one (a load that steps on at a time event breaks a stuck gear away), so it is read from the modes, not from
    which event fired."""
    mode = friction_mode(dense, element)
    out = []
    for t in sorted({float(t) for t, _, _ in res.events if t > 0}):
        k0 = np.searchsorted(dense.t, t - side, side="right") - 1  # the last output at or before t - side
        k1 = np.searchsorted(dense.t, t + side, side="left")  # the first at or after t + side
        if 0 <= k0 and k1 < dense.t.size and mode[k0] != mode[k1]:
            out.append(t)
    return out


def check_mode_changes(res, dense, element: str, ref_changes, t_tol=EVENT_T_TOL):
    """The element changes mode (:func:`mode_changes`) at the reference's instants t > 0, each within ``t_tol``;
    a stick followed by a breakaway at the same instant (a reversal passing straight through) counts once."""
    ref = sorted({round(t, 12) for t, _, _ in ref_changes if t > 0})
    got = mode_changes(res, dense, element)
    assert len(got) == len(ref), (element, got, ref)
    dt = np.max(np.abs(np.array(got) - np.array(ref))) if ref else 0.0
    assert dt < t_tol, (element, dt, got, ref)


def check_modes_at_outputs(res, element: str, ref_mode, ref_changes, clear=1e-5):
    """The element's mode equals the reference's at every output farther than ``clear`` from a mode change
    (there an instant off by ``EVENT_T_TOL`` may put the output on either side)."""
    t_change = np.array([t for t, _, _ in ref_changes] or [np.inf])
    far = np.min(np.abs(res.t[:, None] - t_change[None, :]), axis=1) > clear
    got = friction_mode(res, element)
    bad = far & (got != ref_mode)
    assert not bad.any(), f"{element}: mode {got[bad][:3]} against {ref_mode[bad][:3]} at t = {res.t[bad][:3]}"


def check_losses_around_events(sim, res, t_end, offsets=(-1e-6, -1e-8, 0.0, 1e-8, 1e-6), balance=True,
                               t_tol=EVENT_T_TOL, **kw):
    """``loss_power >= 0`` of every loss at the mode changes too: the run is repeated with outputs at each event
    of the first run and on both sides of it (1e-8 and 1e-6 s away); its events must be those of the first run
    (within ``t_tol``: where the outputs lie does not change the answer). ``kw``: the first run's settings.
    Returns the repeated run."""
    te = np.array([t for t, _, _ in res.events])
    extra = (te[:, None] + np.array(offsets)[None, :]).ravel()
    t_eval = np.unique(np.concatenate([res.t, extra[(extra >= 0) & (extra <= t_end)]]))
    dense = sim.simulate(t_end, t_eval=t_eval, **kw)
    got = [t for t, _, _ in dense.events]
    assert len(got) == len(te) and np.max(np.abs(np.array(got) - te), initial=0.0) < t_tol, (got, te)
    check_energy(dense, sim, BALANCE_TOL if balance else np.inf)
    return dense


def moved_residual(res) -> float:
    """The energy balance's residual [J] over the largest energy that moved (a boundary's work, a loss or a
    change of stored energy). ``Balance.residual`` divides by the energy *delivered*; in MSL Friction the
    drive delivers 24 J while the brake and clutch dissipate 9 kJ of the inertias' initial kinetic energy, so
    that ratio measures the dissipation's accuracy against the 24 J (the trust check divides as here)."""
    b = res.energy_balance()
    terms = [*b.sources.values(), *b.boundary.values(), *b.losses.values(), *b.stored.values()]
    return (sum(b.sources.values()) + sum(b.boundary.values()) - sum(b.losses.values())
            - sum(b.stored.values())) / max(abs(v) for v in terms)


# ---------------------------------------------------------------- the MSL LossyGear written out by hand
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
    bearing torque). Demo2's ``BearingFriction`` with stiction has no single library component (the library's
    ``BearingFriction`` is smooth and creeps instead of sticking): its Coulomb part with stiction, 0.5 N m at rest
    and sliding (peak 1), is a ``Brake`` held at its full normal force (mu 0.5, fn_max 1 N, cgeo 1 m, a
    ``SignalSource`` of 1 as the MSL's constant input) and its slope, 0.5 N m per rad/s, a ``Damper`` to the
    housing on the same shaft."""

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
        self.bearingFriction = Brake(mu=B["tau0"], fn_max=1.0, cgeo=1.0, use_support=True)
        self.bearingSlope = Damper(d=B["d"])
        self.bearingNormal = SignalSource(signal=1.0)
        connect(self.bearingNormal.y, self.bearingFriction.f_normalized)
        connect(self.torque1.flange, self.bearingFriction.flange_a, self.bearingSlope.flange_b)
        connect(self.bearingFriction.flange_b, self.Inertia1.flange_a)
        connect(self.fixed.flange, self.bearingFriction.support, self.bearingSlope.flange_a)


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
        self.bearing_a = Brake(mu=bf_a, fn_max=1.0, cgeo=1.0)
        self.bearing_b = Brake(mu=bf_b, fn_max=1.0, cgeo=1.0)
        self.normal = SignalSource(signal=1.0)
        connect(self.normal.y, self.bearing_a.f_normalized, self.bearing_b.f_normalized)
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
FRICTION = dict(J1=1.0, J2=0.05, J3=1.0, w1=90.0, w2=90.0, w3=100.0, c=160.0, d=1.0, mu=0.5, fn_clutch=160.0,
                fn_brake=1600.0, amplitude=200.0, f=50 / np.pi, t_switch=0.5, t_end=3.0)


class Friction(Model):
    """MSL ``Rotational.Examples.Friction`` ("drive train with clutch and brake"): a motor torque on inertia3 drives
    inertia2 through a clutch (closed from the start: it slips, inertia3 being 10 rad/s faster), then a spring-
    damper to inertia1 behind a brake; at 0.5 s the motor switches off and the brake closes.

    The MSL's components map one to one: ``Clutch`` and ``Brake`` (with the MSL's defaults mu 0.5, peak 1, cgeo
    1 m), ``SpringDamper``, ``Inertia``, ``SignalTorque`` fed by ``Sine`` times a ``Step`` (``Product``), the
    brake's ``Step`` and, for the MSL's ``Constant(k=1)``, a ``SignalSource`` of 1. One setting is the library's
    own: the clutch starts sliding backward (its relative speed inertia2 - inertia3 is -10 rad/s), which a
    library friction element must be told (``forward=0``; the MSL's initial equations find it from the speed)."""

    def build(self):
        P = FRICTION
        self.fixed = Fixed()
        self.torque = SignalTorque(use_support=True)
        self.inertia3 = Inertia(J=P["J3"], phi=Start(0.0, fixed=True), w=Start(P["w3"], fixed=True))
        self.clutch = Clutch(mu=P["mu"], fn_max=P["fn_clutch"], forward=0)
        self.inertia2 = Inertia(J=P["J2"], phi=Start(0.0, fixed=True), w=Start(P["w2"], fixed=True))
        self.spring = SpringDamper(c=P["c"], d=P["d"])
        self.inertia1 = Inertia(J=P["J1"], phi=Start(0.0, fixed=True), w=Start(P["w1"], fixed=True))
        self.brake = Brake(mu=P["mu"], fn_max=P["fn_brake"], use_support=True)
        self.const = SignalSource(signal=1.0)
        self.step = Step(start_time=P["t_switch"])
        self.step2 = Step(height=-1.0, offset=1.0, start_time=P["t_switch"])
        self.sine = Sine(amplitude=P["amplitude"], f=P["f"])
        self.product = Product()
        connect(self.torque.flange, self.inertia3.flange_a)
        connect(self.inertia3.flange_b, self.clutch.flange_a)
        connect(self.clutch.flange_b, self.inertia2.flange_a)
        connect(self.inertia2.flange_b, self.spring.flange_a)
        connect(self.spring.flange_b, self.brake.flange_a)
        connect(self.brake.flange_b, self.inertia1.flange_a)
        connect(self.sine.y, self.product.u1)
        connect(self.step2.y, self.product.u2)
        connect(self.product.y, self.torque.u)
        connect(self.const.y, self.clutch.f_normalized)
        connect(self.step.y, self.brake.f_normalized)
        connect(self.torque.support, self.fixed.flange, self.brake.support)


def friction_reference(t_out):
    """MSL Friction written out by hand and integrated by scipy (DOP853, rtol 1e-11), mode by mode.

    States x = (phi1, w1, phi2, w2, phi3, w3); spring torque ts = c (phi1 - phi2) + d (w1 - w2); motor tm(t) =
    200 sin(100 t) before 0.5 s, 0 after; clutch friction tc (positive opposing w2 - w3), brake friction tb
    (positive opposing w1), sliding +-80 N m and +-800 N m (0 before 0.5 s: the MSL's brake is free with no
    normal force)::

        J3 w3' = tm + tc,     J2 w2' = ts - tc,     J1 w1' = -ts - tb

    Stuck clutch: w2' = w3' = (tm + ts) / (J2 + J3) and tc = J3 w3' - tm is what holds; stuck brake: w1' = 0,
    tb = -ts. Sliding ends where the relative speed reaches 0 (the element sticks, or slides on the other way if
    its holding torque is over the limit at once); sticking ends where the holding torque crosses +-limit, all
    found as terminal events of the integration. The clutch and the brake are not on one rigid body (the spring is
    between them), so their holding torques are unique. Returns x at ``t_out``, the clutch's and the brake's mode
    there and their mode changes {"clutch": [(t, old, new)], "brake": [...]}."""
    P = FRICTION
    J1, J2, J3, c, d = P["J1"], P["J2"], P["J3"], P["c"], P["d"]
    lim_c, lim_b = P["mu"] * P["fn_clutch"], P["mu"] * P["fn_brake"]
    t_sw, t_end = P["t_switch"], float(t_out[-1])

    def motor(t):
        return P["amplitude"] * np.sin(2 * np.pi * P["f"] * t) if t < t_sw else 0.0

    def brake_limit(t):
        return lim_b if t >= t_sw else 0.0

    def dynamics(t, x, mc, mb):
        ts, tm = c * (x[0] - x[2]) + d * (x[1] - x[3]), motor(t)
        if mc == 0:
            a2 = a3 = (tm + ts) / (J2 + J3)
            tc = J3 * a3 - tm
        else:
            tc = mc * lim_c
            a3, a2 = (tm + tc) / J3, (ts - tc) / J2
        if mb == 0:
            a1, tb = 0.0, -ts
        else:
            tb = mb * brake_limit(t)
            a1 = (-ts - tb) / J1
        return np.array([x[1], a1, x[3], a2, x[5], a3]), tc, tb

    def terminal(fn, direction):
        fn.terminal, fn.direction = True, direction
        return fn

    X, modes = np.zeros((6, t_out.size)), {"clutch": np.zeros(t_out.size, int), "brake": np.zeros(t_out.size, int)}
    changes = {"clutch": [], "brake": []}
    t, x, m = 0.0, np.array([0.0, P["w1"], 0.0, P["w2"], 0.0, P["w3"]]), {"clutch": -1, "brake": 1}
    while t < t_end:
        t_stop = t_sw if t < t_sw else t_end
        t_left = np.nextafter(t_stop, 0.0)
        watch = []  # (element, new mode or None for "sticks", zero function)
        if m["clutch"]:
            watch.append(("clutch", None, terminal(lambda tt, xx: xx[3] - xx[5], -m["clutch"])))
        else:
            for sgn in (1, -1):
                watch.append(("clutch", sgn, terminal(
                    lambda tt, xx, s=sgn: s * dynamics(min(tt, t_left), xx, 0, m["brake"])[1] - lim_c, 1)))
        if t >= t_sw:
            if m["brake"]:
                watch.append(("brake", None, terminal(lambda tt, xx: xx[1], -m["brake"])))
            else:
                for sgn in (1, -1):
                    watch.append(("brake", sgn, terminal(
                        lambda tt, xx, s=sgn: s * dynamics(tt, xx, m["clutch"], 0)[2] - lim_b, 1)))
        mc, mb = m["clutch"], m["brake"]
        sol = solve_ivp(lambda tt, xx: dynamics(min(tt, t_left), xx, mc, mb)[0], (t, t_stop), x, method="DOP853",
                        rtol=1e-11, atol=1e-12, events=[fn for _, _, fn in watch], dense_output=True)
        assert sol.status >= 0, sol.message
        sel = (t_out >= t) & (t_out <= sol.t[-1])
        X[:, sel] = sol.sol(t_out[sel])
        modes["clutch"][sel], modes["brake"][sel] = mc, mb
        t, x = float(sol.t[-1]), sol.y[:, -1].copy()
        if sol.status == 1:
            element, new, _ = watch[next(k for k in range(len(watch)) if sol.t_events[k].size)]
            if new is None:  # sticks: the relative speed is exactly 0 from here
                new = 0
                if element == "clutch":
                    x[3] = x[5] = (J2 * x[3] + J3 * x[5]) / (J2 + J3)
                else:
                    x[1] = 0.0
            changes[element].append((t, m[element], new))
            m[element] = new
        # settle: an element that is stuck with its holding torque over the limit slides on at once
        _, tc, tb = dynamics(t, x, m["clutch"], m["brake"])
        for element, hold, limit in (("clutch", tc, lim_c), ("brake", tb, brake_limit(t))):
            if m[element] == 0 and abs(hold) > limit and t >= (0.0 if element == "clutch" else t_sw):
                changes[element].append((t, 0, int(np.sign(hold))))
                m[element] = int(np.sign(hold))
    return X, modes, changes


@pytest.fixture(scope="module")
def friction_sim():
    return compile_model(Friction())


# the motor's drive turns 50 rad of phase at 100 rad/s before 0.5 s, inertia2 rings on the spring at 57 rad/s until
# its damping (2 J2 / d = 0.1 s) forgets it, about 6 rad, and inertia3 and inertia2 swing at 12.3 rad/s from 1.66 s
# to the end, 16 rad: about 72 rad in all
FRICTION_TOL = phase_tol(72.0)
FRICTION_T_TOL = 1e-5  # s, mode changes (see the test)


def check_friction(sim, res, tol, t_tol, dense=None):
    """The checks of MSL Friction against :func:`friction_reference` (tolerances in the test's docstring);
    ``dense``: the run repeated with outputs around its events (:func:`check_losses_around_events`), from which
    the mode changes are read (without it, from ``res``'s own outputs on both sides of the events)."""
    P = FRICTION
    X, modes, changes = friction_reference(res.t)
    for element in ("clutch", "brake"):
        check_mode_changes(res, res if dense is None else dense, element, changes[element], t_tol)
        check_modes_at_outputs(res, element, modes[element], changes[element])
    assert [(o, n) for _, o, n in changes["clutch"]] == [(-1, 0), (0, -1), (-1, 0), (0, -1), (-1, 0)]
    assert [(o, n) for _, o, n in changes["brake"]] == [(1, 0)]
    for k, name in enumerate(("inertia1", "inertia2", "inertia3")):
        assert np.max(np.abs(res[f"{name}.w"] - X[2 * k + 1])) < tol * P["w3"], name
        assert np.max(np.abs(res[f"{name}.phi"] - X[2 * k])) < tol * np.max(np.abs(X[2 * k])), name
    assert np.max(np.abs(res["inertia1.w"][modes["brake"] == 0])) < tol * P["w3"]
    assert np.max(np.abs((res["inertia2.w"] - res["inertia3.w"])[modes["clutch"] == 0])) < tol * P["w3"]
    for run in (res,) if dense is None else (res, dense):
        assert abs(moved_residual(run)) < max(2 * tol, BALANCE_TOL), run.energy_balance().table()
        check_energy(run, sim, np.inf)  # losses >= 0 (the balance as above)


@pytest.mark.parametrize("method", METHODS)
def test_friction_clutch_and_brake_stick_and_slip_as_the_msl(friction_sim, method):
    """MSL Friction over its 3 s. The reference (:func:`friction_reference`): the clutch slips until 6.8 ms,
    holds, slips again from 59 ms (the motor's 200 N m sine exceeds what its 80 N m can pass) and holds from
    0.109 s; at 0.5 s the motor stops and the brake closes: the clutch slips (inertia3 coasts down at 80 rad/s2),
    the brake stops inertia1 at 0.641 s and holds it, and at 1.66 s inertia3 has slowed to inertia2's speed and the
    clutch holds for the rest of the run, inertia3 and inertia2 swinging on the spring against the held inertia1.

    The speeds are those of an oscillating system, so the suite's phase tolerance applies (FRICTION_TOL = 2.9e-4,
    the phase the modes travel is in its comment), and a run at rtol 1e-9 must come a hundred times closer:

    * the clutch's and the brake's mode changes, each within FRICTION_T_TOL = 1e-5 s (measured: 2.3e-7 s on the
      default path, 6.4e-6 s on BDF: the 1.66 s stick is where w3, falling at 80 rad/s2, meets w2, so an error of
      w3 moves it by that error over 80 rad/s2), 1e-7 s at rtol 1e-9 (measured 5e-10); the modes at every output
      10 us or more from a change;
    * the three speeds within FRICTION_TOL of 100 rad/s (measured: 2.3e-4 rad/s on the default path, 4.2e-3 on
      BDF, 3.5e-7 at rtol 1e-9) and the angles within FRICTION_TOL of their peak; inertia1 standing still while
      the brake holds, inertia2 and inertia3 turning together while the clutch holds;
    * the energy balance over the largest energy moved (:func:`moved_residual`: the brake and the clutch
      dissipate the inertias' 9.25 kJ of kinetic energy, the motor delivers 24 J) to twice the state tolerance;
      losses >= 0 at every output and around every event (the run repeated with outputs there), at the default
      settings and at rtol 1e-9 (where those outputs once made the compiled path lose the breakaway at 0.534 s:
      finding 4, :func:`test_friction_does_not_depend_on_the_output_grid`)."""
    P = FRICTION
    res = friction_sim.simulate(P["t_end"], method=method)
    dense = check_losses_around_events(friction_sim, res, P["t_end"], balance=False, t_tol=FRICTION_T_TOL,
                                       method=method)
    check_friction(friction_sim, res, FRICTION_TOL, FRICTION_T_TOL, dense)
    if method == "auto":
        tight = friction_sim.simulate(P["t_end"], rtol=1e-9, atol=1e-12)
        dense = check_losses_around_events(friction_sim, tight, P["t_end"], balance=False,
                                           t_tol=FRICTION_T_TOL * 1e-2, rtol=1e-9, atol=1e-12)
        check_friction(friction_sim, tight, FRICTION_TOL * 1e-2, FRICTION_T_TOL * 1e-2, dense)


@pytest.mark.parametrize("n_points", [101, 351, 701, 1201, 1551, 1701, 5001])
def test_friction_does_not_depend_on_the_output_grid(friction_sim, n_points):
    """MSL Friction at the default settings with other output grids than 501 points: the same checks. Where the
    outputs lie must not change the answer. (Finding 4, fixed: of 40 grids from 101 to 5001 outputs, 351, 701, 1201,
    1551, 1701 and 5001 lost a breakaway on the compiled path: a clutch kept stuck by the knee rule with its
    holding torque a hair past the limit never crossed again, and a relative speed leaving its exact zero by
    round-off right after a breakaway stuck the clutch again. :func:`acausal.modes.knee_offsets` watches both
    from where they are.)"""
    res = friction_sim.simulate(FRICTION["t_end"], n_points=n_points)
    check_friction(friction_sim, res, FRICTION_TOL, FRICTION_T_TOL)
