"""Conformance suite: examples of the Modelica Standard Library rebuilt from this library's
components, each run at the default simulation settings (``sim.simulate(t_end)``: rtol 1e-6, atol 1e-9, the
default path) and, where cheap, with ``method="BDF"`` (the scipy path), and checked against an independent
solution written here (a closed form, or a scipy integration of the same physics that does not use acausal), its
energy balance (``res.energy_balance().residual``) and ``loss_power >= 0`` of every loss at every output.

Parameter values and topologies are those of the MSL example sources (Modelica Standard Library, Modelica
Association, BSD-3-Clause; read from github.com/modelica/ModelicaStandardLibrary at b756f9d):

* ``Modelica.Mechanics.Rotational.Examples.First``
* ``Modelica.Electrical.Machines.Examples.DCMachines.DCPM_Start`` (machine data
  ``Machines.Utilities.ParameterRecords.DcPermanentMagnetData``)
* ``Modelica.Electrical.Analog.Examples.CharacteristicIdealDiodes``
* ``Modelica.Electrical.Analog.Examples.Rectifier``
* ``Modelica.Electrical.PowerConverters.Examples.ACDC.RectifierBridge2Pulse.DiodeBridge2Pulse``
* ``Modelica.Electrical.Analog.Examples.SeriesResonance``
* ``Modelica.Mechanics.Rotational.Examples.LossyGearDemo1``, ``LossyGearDemo2``, ``LossyGearDemo3`` and
  ``Friction`` (stick/slip: the gear is ``StickSlipGear``; the MSL's ``Clutch`` and ``Brake`` are the library's;
  a ``BearingFriction`` with stiction is a ``Brake`` at constant normal force, with a ``Damper`` for a friction
  torque that grows with speed)

The Rectifier is the full example (not a reduced one), checked switching by switching against a scipy
event-by-event integration; and once more with its AC switched off by a Step and run over a thousand times longer
than its commutations last, the test that no event is lost when the integrator makes long steps.

No Modelica code is copied: the examples are rebuilt with ``acausal.library`` components; where the MSL has a
component this library does not (the Graetz bridge), it is composed from library parts, and where the example is
rebuilt otherwise than with the MSL's component (SeriesResonance's variable-frequency source, written as its closed
form), the test's docstring says how.

Tolerances, in general: the library integrates with rtol 1e-6. Stateless examples are solved exactly at each
output (tolerance: round-off). Oscillating linear systems leave a phase error of about rtol per radian their mode
travels (:func:`phase_tol`), so their tolerance is stated from that phase, and a run at rtol 1e-9 must come a
hundred times closer (the error is the integrator's, not the model's). Every reference is computed at least a
hundred times tighter than the tolerance it checks. Energies are quadratic in the states, so the energy balance
closes to twice the state tolerance, or to 1e-5 (ten times rtol) where that is larger. Where a signal moves fast
around a switching instant the tolerance is stated from that slope.
This module has First and DCPM_Start; CharacteristicIdealDiodes, DiodeBridge2Pulse and SeriesResonance are in
``tests/msl/test_msl_conformance_circuits.py``, the Rectifier in ``tests/msl/test_msl_conformance_rectifier.py``, the
stick/slip examples (LossyGearDemo1-3, Friction) in ``tests/msl/test_msl_conformance_stickslip.py``; their shared
tolerances and checks in ``tests/msl/msl_support.py``.
Findings (library defects the suite exposed, and how they were fixed) are in ``tests/msl/msl_conformance_findings.md``.
"""
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from acausal import Model, Start, compile_model, connect
from acausal.library.blocks import Ramp, Sine, Step
from acausal.library.electrical import Ground, SignalVoltage
from acausal.library.machines import DCPermanentMagnet
from acausal.library.rotational import Damper, Fixed, IdealGear, Inertia, SignalTorque, Spring
from .msl_support import BALANCE_TOL, METHODS, check_energy, phase_tol


# ==================================================================== 1. Rotational.Examples.First
FIRST = dict(amplitude=10.0, f=5.0, Jmotor=0.1, Jload=2.0, ratio=10.0, damping=10.0, J2=2.0, c=1e4)


class First(Model):
    """MSL ``Rotational.Examples.First``: a sine torque (10 N m, 5 Hz) on the motor inertia (0.1 kg m2), an ideal
    gear 10:1 (support on the housing) to inertia2 (2 kg m2), a spring (1e4 N m/rad) to the load inertia (2 kg m2),
    and a damper (10 N m s/rad) from inertia2 to the housing. inertia2 starts at rest at 0 rad, the spring
    unstretched, the load at rest (MSL's fixed start values)."""

    def build(self):
        P = FIRST
        self.fixed = Fixed()
        self.sine = Sine(amplitude=P["amplitude"], f=P["f"])
        self.torque = SignalTorque(use_support=True)
        self.inertia1 = Inertia(J=P["Jmotor"])
        self.idealGear = IdealGear(ratio=P["ratio"], use_support=True)
        self.inertia2 = Inertia(J=P["J2"], phi=Start(0.0), w=Start(0.0))
        self.spring = Spring(c=P["c"])
        self.inertia3 = Inertia(J=P["Jload"], phi=Start(0.0), w=Start(0.0))  # phi: the spring starts unstretched
        self.damper = Damper(d=P["damping"])
        connect(self.sine.y, self.torque.u)
        connect(self.torque.flange, self.inertia1.flange_a)
        connect(self.inertia1.flange_b, self.idealGear.flange_a)
        connect(self.idealGear.flange_b, self.inertia2.flange_a)
        connect(self.inertia2.flange_b, self.spring.flange_a, self.damper.flange_a)
        connect(self.spring.flange_b, self.inertia3.flange_a)
        connect(self.damper.flange_b, self.fixed.flange, self.torque.support, self.idealGear.support)


def first_reference(t):
    """The same mechanics as an ODE in the load-side angles, integrated by scipy (DOP853, rtol 1e-11).

    The gear is rigid and massless: phi1 = n phi2, so the motor inertia appears at inertia2 as n^2 J1 and the motor
    torque as n tau(t)::

        (J2 + n^2 J1) phi2'' = n tau(t) - d phi2' - c (phi2 - phi3)
        J3 phi3''            = c (phi2 - phi3)
    """
    P = FIRST
    n, J = P["ratio"], P["J2"] + P["ratio"]**2 * P["Jmotor"]

    def rhs(tt, x):
        phi2, w2, phi3, w3 = x
        tau = P["amplitude"] * np.sin(2 * np.pi * P["f"] * tt)
        spring = P["c"] * (phi2 - phi3)
        return [w2, (n * tau - P["damping"] * w2 - spring) / J, w3, spring / P["Jload"]]

    sol = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0, 0.0, 0.0], method="DOP853", t_eval=t, rtol=1e-11, atol=1e-13)
    return sol.y


@pytest.fixture(scope="module")
def first_sim():
    return compile_model(First())


# the spring mode (w^2 = c (1/(J2 + n^2 J1) + 1/J3), 76 rad/s, 12 Hz) is undamped at the load: it travels 76 rad
FIRST_TOL = phase_tol(76.0)


@pytest.mark.parametrize("method", METHODS)
def test_first_drive_train_follows_its_ode(first_sim, method):
    """MSL First over its 1 s: angles and speeds of all three inertias against the scipy ODE, to FIRST_TOL of each
    signal's peak (3e-4: the spring mode's phase error); on the default path a run at rtol 1e-9 comes a hundred
    times closer. The motor inertia turns n = 10 times the gear output (to round-off). The energy balance (the
    damper the only loss) closes to twice the state tolerance."""
    runs = [(dict(method=method), FIRST_TOL)]
    if method == "auto":
        runs.append((dict(rtol=1e-9, atol=1e-12), FIRST_TOL * 1e-2))
    for kw, tol in runs:
        res = first_sim.simulate(1.0, **kw)
        phi2, w2, phi3, w3 = first_reference(res.t)
        for name, ref in (("inertia2.phi", phi2), ("inertia2.w", w2), ("inertia3.phi", phi3), ("inertia3.w", w3)):
            assert np.max(np.abs(res[name] - ref)) < tol * np.max(np.abs(ref)), (kw, name)
        assert np.allclose(res["inertia1.w"], FIRST["ratio"] * res["inertia2.w"], rtol=1e-12, atol=1e-12)
        check_energy(res, first_sim, max(2 * tol, BALANCE_TOL))
    assert res.energy("damper.loss_power")[-1] > 0.0


# ==================================================================== 2. Machines DCPM_Start
# DcPermanentMagnetData defaults: Ra 0.05 ohm, La 1.5 mH, Jr 0.15 kg m2, VaNominal 100 V, IaNominal 100 A,
# wNominal 1425 rpm, all losses off (friction, core, stray load and brush parameters PRef = 0, brush V = 0), alpha 0.
DCPM = dict(Va=100.0, tStart=0.2, tRamp=0.8, TLoad=63.66, tStep=1.5, JLoad=0.15, Ra=0.05, La=0.0015, Jr=0.15,
            VaNominal=100.0, IaNominal=100.0, wNominal=1425 * 2 * np.pi / 60)
DCPM["k"] = (DCPM["VaNominal"] - DCPM["Ra"] * DCPM["IaNominal"]) / DCPM["wNominal"]  # MSL: ViNominal / wNominal


class DCPMStart(Model):
    """MSL ``Machines.Examples.DCMachines.DCPM_Start``: an armature voltage ramp (0 -> 100 V from 0.2 s over 0.8 s)
    starts a permanent-magnet DC machine with a load inertia of 0.15 kg m2; at 1.5 s a load torque of 63.66 N m
    (the nominal torque) steps on.

    The machine is the library's ``DCPermanentMagnet`` (MSL ``DC_PermanentMagnet``) at its defaults, which are the
    record ``DcPermanentMagnetData``'s, with MSL's ``useSupport=false`` and ``TaOperational`` = 20 degC and, as in
    the example, ``phiMechanical``, ``wMechanical`` and ``ia`` fixed at 0. With the default record every loss the
    library's machine leaves out (friction, core, stray load, brushes) is zero in MSL's too; the same machine
    composed of Resistor, Inductor, EMF and Inertia gives the same trajectories (``tests/library/test_machines.py``). The
    MSL ``TorqueStep(stepTorque=-TLoad)`` is a Step block into a SignalTorque."""

    def build(self):
        P = DCPM
        self.ramp = Ramp(height=P["Va"], duration=P["tRamp"], start_time=P["tStart"])
        self.signalVoltage = SignalVoltage()
        self.ground = Ground()
        self.dcpm = DCPermanentMagnet(phiMechanical=Start(0.0), wMechanical=Start(0.0), ia=Start(0.0))
        self.loadInertia = Inertia(J=P["JLoad"])
        self.loadStep = Step(height=-P["TLoad"], start_time=P["tStep"])
        self.loadTorque = SignalTorque()
        connect(self.ramp.y, self.signalVoltage.u)
        connect(self.signalVoltage.p, self.dcpm.pin_ap)
        connect(self.dcpm.pin_an, self.signalVoltage.n, self.ground.p)
        connect(self.dcpm.flange, self.loadInertia.flange_a)
        connect(self.loadStep.y, self.loadTorque.u)
        connect(self.loadTorque.flange, self.loadInertia.flange_b)


def dcpm_reference(t):
    """Exact solution of the linear machine by matrix exponentials, piece by piece between the input's corners.

    States z = (ia, w, phi); inputs are piecewise polynomial (the ramp linear, the load torque constant), so the
    augmented state (z, 1, t - t_k) evolves by ``expm`` exactly::

        La ia' = v(t) - Ra ia - k w,    (Jr + JL) w' = k ia + tau_load(t),    phi' = w
    """
    P = DCPM
    J = P["Jr"] + P["JLoad"]
    slope = P["Va"] / P["tRamp"]
    corners = [0.0, P["tStart"], P["tStart"] + P["tRamp"], P["tStep"], np.inf]

    def piece(t0):
        """Matrix of the augmented system on the piece that starts at t0: v = v0 + s (t - t0), tau = tau0."""
        v0 = 0.0 if t0 < P["tStart"] else slope * (min(t0, P["tStart"] + P["tRamp"]) - P["tStart"])
        s = slope if P["tStart"] <= t0 < P["tStart"] + P["tRamp"] else 0.0
        tau0 = -P["TLoad"] if t0 >= P["tStep"] else 0.0
        A = np.zeros((5, 5))
        A[0, :] = [-P["Ra"] / P["La"], -P["k"] / P["La"], 0.0, v0 / P["La"], s / P["La"]]
        A[1, :] = [P["k"] / J, 0.0, 0.0, tau0 / J, 0.0]
        A[2, 1] = 1.0
        A[4, 3] = 1.0  # d(t - t0)/dt = 1
        return A

    out = np.empty((3, t.size))
    z = np.zeros(3)
    for t0, t1 in zip(corners[:-1], corners[1:]):
        A = piece(t0)
        sel = (t >= t0) & (t < t1) if np.isfinite(t1) else t >= t0
        for j in np.flatnonzero(sel):
            out[:, j] = (expm(A * (t[j] - t0)) @ np.concatenate([z, [1.0, 0.0]]))[:3]
        if np.isfinite(t1):
            z = (expm(A * (t1 - t0)) @ np.concatenate([z, [1.0, 0.0]]))[:3]
    return out


DCPM_TOL = phase_tol(60.0)


@pytest.fixture(scope="module")
def dcpm_sim():
    return compile_model(DCPMStart())


@pytest.mark.parametrize("method", METHODS)
def test_dcpm_start_follows_the_linear_machine(dcpm_sim, method):
    """DCPM_Start over its 2 s: armature current, speed and angle against the exact solution, to DCPM_TOL of each
    peak (the electromechanical mode, w_n = k / sqrt(La J) = 30 rad/s with damping 0.56, rings after each of
    the input's three corners: at most 60 rad over the run). Physical sanity from the closed form too: before
    the load step the machine runs up to nearly the no-load speed Va / k (within 1 %: the current still
    accelerating the inertias), after it the current settles at TLoad / k, the nominal 100 A."""
    res = dcpm_sim.simulate(2.0, method=method)
    ia, w, phi = dcpm_reference(res.t)
    for name, ref in (("dcpm.ia", ia), ("dcpm.wMechanical", w), ("dcpm.phiMechanical", phi)):
        assert np.max(np.abs(res[name] - ref)) < DCPM_TOL * np.max(np.abs(ref)), name
    assert np.allclose(res["loadInertia.w"], res["dcpm.wMechanical"], rtol=1e-12, atol=1e-12)
    k = DCPM["k"]
    before = np.searchsorted(res.t, DCPM["tStep"]) - 1
    assert res["dcpm.wMechanical"][before] == pytest.approx(DCPM["Va"] / k, rel=1e-2)
    assert res["dcpm.ia"][-1] == pytest.approx(DCPM["TLoad"] / k, rel=1e-2)
    check_energy(res, dcpm_sim)
