"""The permanent-magnet DC machine ``acausal.library.machines.DCPermanentMagnet`` (MSL ``DC_PermanentMagnet`` with
the record ``DcPermanentMagnetData``).

MSL's DCPM_Start (``tests/msl/test_msl_conformance.py``'s ``DCPMStart``, which uses the machine) against the same
machine composed of Resistor, Inductor, EMF and Inertia (how the conformance test built it before the library had
the machine: :class:`ComposedDCPMStart`) and against the exact solution that test uses, with its tolerance
``DCPM_TOL``; the energy balance; the refusal of a nominal point without induced voltage; the armature resistance's
temperature law; and the optional support (stator inertia, reaction torque).
"""
import math

import numpy as np
import pytest

from acausal import Model, ModelError, Start, compile_model, connect
from acausal.library.blocks import Ramp, Step
from acausal.library.electrical import EMF, ConstantVoltage, Ground, Inductor, Resistor, SignalVoltage
from acausal.library.machines import DCPermanentMagnet
from acausal.library.rotational import Fixed, Inertia, SignalTorque
from ..msl.msl_support import METHODS
from ..msl.test_msl_conformance import DCPM, DCPM_TOL, DCPMStart, dcpm_reference


class ComposedDCPMStart(Model):
    """DCPM_Start with the machine composed, as MSL's is inside, of the armature resistance ``Ra`` (Resistor),
    inductance ``La`` (Inductor, fixed at 0 A), the ideal converter (EMF with k = (VaNominal - Ra IaNominal) /
    wNominal, MSL's turns ratio) and the rotor inertia ``Jr`` (Inertia, at rest at 0 rad)."""

    def build(self):
        P = DCPM
        self.ramp = Ramp(height=P["Va"], duration=P["tRamp"], start_time=P["tStart"])
        self.signalVoltage = SignalVoltage()
        self.ground = Ground()
        self.ra = Resistor(R=P["Ra"])
        self.la = Inductor(L=P["La"], i=Start(0.0))
        self.emf = EMF(k=P["k"])
        self.rotor = Inertia(J=P["Jr"], phi=Start(0.0), w=Start(0.0))
        self.loadInertia = Inertia(J=P["JLoad"])
        self.loadStep = Step(height=-P["TLoad"], start_time=P["tStep"])
        self.loadTorque = SignalTorque()
        connect(self.ramp.y, self.signalVoltage.u)
        connect(self.signalVoltage.p, self.ra.p)
        connect(self.ra.n, self.la.p)
        connect(self.la.n, self.emf.p)
        connect(self.emf.n, self.signalVoltage.n, self.ground.p)
        connect(self.emf.flange, self.rotor.flange_a)
        connect(self.rotor.flange_b, self.loadInertia.flange_a)
        connect(self.loadStep.y, self.loadTorque.u)
        connect(self.loadTorque.flange, self.loadInertia.flange_b)


#: the machine's signals and the composed model's that are the same quantity
SAME = (("dcpm.ia", "la.i"), ("dcpm.wMechanical", "rotor.w"), ("dcpm.phiMechanical", "rotor.phi"))


@pytest.fixture(scope="module")
def machine_sim():
    return compile_model(DCPMStart())


@pytest.fixture(scope="module")
def composed_sim():
    return compile_model(ComposedDCPMStart())


@pytest.mark.slow
@pytest.mark.parametrize("method", METHODS)
def test_dcpm_start_with_the_machine_gives_the_composed_trajectories(machine_sim, composed_sim, method):
    """DCPM_Start over its 2 s with the machine and with the composed parts: armature current, speed and angle
    agree to DCPM_TOL of each peak (both integrate the same ODE at rtol 1e-6; the compiler picks other but
    equivalent states for the machine, so the two runs differ by the integrator's error), and each is within
    DCPM_TOL of the exact solution, as the conformance test asks. On the default path a run of both at rtol 1e-10
    agrees ten thousand times closer (the difference is the integrator's, not the model's). The derived EMF
    constant is the conformance test's k."""
    runs = [(dict(method=method), DCPM_TOL)]
    if method == "auto":
        runs.append((dict(rtol=1e-10, atol=1e-13), DCPM_TOL * 1e-4))
    for kw, tol in runs:
        res, ref_res = machine_sim.simulate(2.0, **kw), composed_sim.simulate(2.0, **kw)
        assert np.array_equal(res.t, ref_res.t)
        exact = dict(zip(("dcpm.ia", "dcpm.wMechanical", "dcpm.phiMechanical"), dcpm_reference(res.t)))
        for name, composed in SAME:
            peak = np.max(np.abs(ref_res[composed]))
            assert np.max(np.abs(res[name] - ref_res[composed])) < tol * peak, (kw, name)
            assert np.max(np.abs(res[name] - exact[name])) < max(tol, DCPM_TOL * 1e-4) * peak, (kw, name)
    assert res["dcpm.turnsRatio"][0] == pytest.approx(DCPM["k"], rel=1e-15)
    assert np.allclose(res["dcpm.tauElectrical"], DCPM["k"] * res["dcpm.ia"], rtol=1e-12, atol=1e-9)


def test_dcpm_start_energy_balance_closes(machine_sim):
    """The machine is one account: its copper loss ``Ra ia^2`` and its stored energy ``La ia^2/2 + Jr w^2/2``
    (its parts are not counted again), so DCPM_Start's balance (voltage source and load torque at the boundary)
    closes to 1e-6 relative; the loss is never negative."""
    res = machine_sim.simulate(2.0)
    acc = machine_sim.accounts
    assert acc.losses == ("dcpm.loss_power",)
    assert acc.stored == ("dcpm.energy", "loadInertia.energy")
    assert abs(res.energy_balance().residual) < 1e-6, res.energy_balance().table()
    ia, w = res["dcpm.ia"], res["dcpm.wMechanical"]
    assert np.allclose(res["dcpm.loss_power"], DCPM["Ra"] * ia**2, rtol=1e-12, atol=1e-9)
    assert np.allclose(res["dcpm.energy"], DCPM["La"] * ia**2 / 2 + DCPM["Jr"] * w**2 / 2, rtol=1e-12, atol=1e-9)
    assert res["dcpm.loss_power"].min() >= 0.0


def test_nominal_point_without_induced_voltage_is_refused(machine_sim):
    """VaNominal <= Ra IaNominal leaves no induced voltage, so no EMF constant (MSL's assert): refused at
    construction naming VaNominal, Ra and IaNominal (also at equality, IaNominal = 2000 A), and in a run that
    overrides IaNominal because the derived turnsRatio falls below its minimum. turnsRatio itself is not set."""
    for kw in (dict(IaNominal=2500.0), dict(IaNominal=2000.0), dict(VaNominal=4.0), dict(Ra=2.0)):
        with pytest.raises(ModelError, match="VaNominal = .* must exceed Ra IaNominal") as err:
            DCPermanentMagnet(**kw)
        assert "IaNominal" in str(err.value) and "turnsRatio" in str(err.value)
    with pytest.raises(ModelError, match="turnsRatio is derived"):
        DCPermanentMagnet(turnsRatio=0.6)
    with pytest.raises(ModelError, match="'dcpm.turnsRatio' .* below its minimum"):
        machine_sim.simulate(0.1, params={"dcpm.IaNominal": 2500.0})
    with pytest.raises(ModelError, match="'dcpm.turnsRatio' .* is bound to"):
        machine_sim.simulate(0.1, params={"dcpm.turnsRatio": 0.6})
    assert machine_sim.simulate(0.1, params={"dcpm.IaNominal": -100.0}).solver  # a generator's nominal point


def test_armature_resistance_follows_msl_temperature_law(machine_sim):
    """Ra(T) = Ra (1 + alphaRef (T - TaRef)) with alphaRef = alpha20a / (1 + alpha20a (TaRef - 20 degC)) (MSL's
    convertResistance): at TaOperational in the armature, at TaNominal in turnsRatio; per run, no recompilation.
    At the record's alpha20a = 0 every temperature gives Ra."""
    alpha, t_ref, t_nom, t_op = 0.004, 313.15, 348.15, 368.15
    res = machine_sim.simulate(0.01, n_points=3, params={"dcpm.alpha20a": alpha, "dcpm.TaRef": t_ref,
                                                        "dcpm.TaNominal": t_nom, "dcpm.TaOperational": t_op})
    alpha_ref = alpha / (1 + alpha * (t_ref - 293.15))
    r_op, r_nom = (DCPM["Ra"] * (1 + alpha_ref * (t - t_ref)) for t in (t_op, t_nom))
    assert res["dcpm.ra.R"][0] == pytest.approx(r_op, rel=1e-14)
    assert res["dcpm.turnsRatio"][0] == pytest.approx((100.0 - r_nom * 100.0) / DCPM["wNominal"], rel=1e-14)
    cold = machine_sim.simulate(0.01, n_points=3, params={"dcpm.TaOperational": 400.0})
    assert cold["dcpm.ra.R"][0] == DCPM["Ra"]


class SupportedMachine(Model):
    """10 V on a machine with ``use_support=True``: ``fixed`` holds the stator, or nothing does (``free``) and
    rotor and stator (Js = 0.3 kg m2) turn against each other, starting at rest."""

    def __init__(self, free: bool, **kw):
        super().__init__(**kw)
        self.free = free

    def build(self):
        self.source, self.ground = ConstantVoltage(V=10.0), Ground()
        self.dcpm = DCPermanentMagnet(use_support=True, Js=0.3, ia=Start(0.0), wMechanical=Start(0.0),
                                      phiMechanical=Start(0.0))
        self.dcpm_fixed_stator = DCPermanentMagnet(ia=Start(0.0), wMechanical=Start(0.0), phiMechanical=Start(0.0))
        connect(self.source.p, self.dcpm.pin_ap, self.dcpm_fixed_stator.pin_ap)
        connect(self.source.n, self.dcpm.pin_an, self.dcpm_fixed_stator.pin_an, self.ground.p)
        if not self.free:  # free: the support is left unconnected, so no torque acts on the stator from outside
            self.fixed = Fixed()
            connect(self.dcpm.support, self.fixed.flange)


def test_support_takes_the_reaction_and_carries_the_stator_inertia():
    """``use_support=True``. Stator held by a Fixed: the same run as a machine without support (its stator fixed
    inside), and the support takes the air-gap torque, ``support.tau = tauElectrical``. Stator free: rotor and
    stator exchange angular momentum only, ``Jr w_rotor + Js w_stator = 0``, ``wMechanical`` is their relative
    speed, and the energy balance (the stator's kinetic energy in the machine's account) closes to 1e-6 (at rtol
    1e-8: the run starts with a voltage step)."""
    res = compile_model(SupportedMachine(free=False)).simulate(0.5)
    for name in ("ia", "wMechanical", "phiMechanical"):
        ref = res[f"dcpm_fixed_stator.{name}"]
        assert np.max(np.abs(res[f"dcpm.{name}"] - ref)) < 1e-5 * np.max(np.abs(ref)), name
    assert np.allclose(res["dcpm.support.tau"], res["dcpm.tauElectrical"], rtol=1e-12, atol=1e-9)

    # the 10 V step at t = 0 makes a current transient the default rtol integrates to a balance of 1.1e-6 (the
    # library's limit at rtol 1e-6 is 1e-5); at rtol 1e-8 it closes to 4e-8
    res = compile_model(SupportedMachine(free=True)).simulate(0.5, rtol=1e-8, atol=1e-11)
    w_r, w_s = res["dcpm.inertiaRotor.w"], res["dcpm.inertiaStator.w"]
    assert np.max(np.abs(0.15 * w_r + 0.3 * w_s)) < 1e-6 * 0.15 * np.max(np.abs(w_r))
    assert np.allclose(res["dcpm.wMechanical"], w_r - w_s, rtol=1e-12, atol=1e-9)
    assert np.max(np.abs(w_r)) > 1.0  # it did turn
    assert abs(res.energy_balance().residual) < 1e-6, res.energy_balance().table()
    assert math.isclose(res["dcpm.energy"][-1], 0.0015 * res["dcpm.ia"][-1]**2 / 2 + 0.15 * w_r[-1]**2 / 2
                        + 0.3 * w_s[-1]**2 / 2, rel_tol=1e-12)
