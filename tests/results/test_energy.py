"""Energy accounting: a lossless network conserves its stored energy; a lossy one balances to 1e-6."""
import numpy as np
import pytest

from acausal import Model, Start, compile_model, connect
from acausal.library.electrical import EMF, Capacitor, Ground, Inductor
from acausal.library.rotational import Fixed, IdealGear, Inertia, Spring

from ..drive_models import MotorGearLoad


class Lossless(Model):
    """Charged capacitor -> inductor -> motor (EMF) -> inertia -> ideal gear -> inertia -> spring to ground."""

    def build(self):
        self.C = Capacitor(C=1e-3, v=Start(20.0))
        self.L = Inductor(L=1e-3, i=Start(0.0))
        self.emf = EMF(k=0.05)
        self.J1 = Inertia(J=1e-4)
        self.gear = IdealGear(ratio=10)
        self.J2 = Inertia(J=2e-3)
        self.spring = Spring(c=5.0)
        self.fixed = Fixed()
        self.gnd = Ground()
        connect(self.C.p, self.L.p)
        connect(self.L.n, self.emf.p)
        connect(self.emf.n, self.C.n, self.gnd.p)
        connect(self.emf.flange, self.J1.flange_a)
        connect(self.J1.flange_b, self.gear.flange_a)
        connect(self.gear.flange_b, self.J2.flange_a)
        connect(self.J2.flange_b, self.spring.flange_a)
        connect(self.spring.flange_b, self.fixed.flange)


def test_lossless_network_conserves_energy():
    sim = compile_model(Lossless())
    res = sim.simulate(0.5, rtol=1e-11, atol=1e-13, n_points=2001)
    stored = res["C.energy"] + res["L.energy"] + res["J1.energy"] + res["J2.energy"] + res["spring.energy"]
    assert stored[0] == pytest.approx(0.5 * 1e-3 * 20.0**2)
    assert np.max(np.abs(stored - stored[0])) / stored[0] < 1e-6
    # the energy really moves around (not a trivially static model)
    assert np.min(res["C.energy"]) < 0.5 * stored[0]
    mech = res["J1.energy"] + res["J2.energy"] + res["spring.energy"]
    assert np.max(mech) > 0.05 * stored[0]
    # sum of powers into all components through all their ports is zero at every instant
    ports = ["C.p", "C.n", "L.p", "L.n", "emf.p", "emf.n", "emf.flange", "J1.flange_a", "J1.flange_b",
             "gear.flange_a", "gear.flange_b", "J2.flange_a", "J2.flange_b", "spring.flange_a", "spring.flange_b"]
    into = {p.split(".")[0]: 0.0 for p in ports}
    for p in ports:
        into[p.split(".")[0]] = into[p.split(".")[0]] + res.power(p)
    total = sum(into.values())
    scale = np.max(np.abs(into["C"]))
    assert np.max(np.abs(total)) < 1e-9 * scale
    # the ideal gear and the EMF are lossless converters
    assert np.max(np.abs(into["gear"])) < 1e-9 * scale
    assert np.max(np.abs(into["emf"])) < 1e-9 * scale


def test_lossy_drive_energy_balance():
    sim = compile_model(MotorGearLoad())
    res = sim.simulate(0.5, rtol=1e-11, atol=1e-13, n_points=4001)
    source = -res.energy("src.p")[-1]
    dissipated = (res.energy("R.loss_power")[-1] + res.energy("damper.loss_power")[-1]
                  + res.energy("load_damper.loss_power")[-1])
    stored = sum(res[n][-1] - res[n][0] for n in ("L.energy", "rotor.energy", "load.energy"))
    assert source > 1.0
    assert source == pytest.approx(dissipated + stored, rel=1e-6)


class BacklashOscillator(Model):
    """Inertia - backlash - spring to ground, released from a wound-up spring: the play is crossed twice per
    period, and the backlash's smoothed law stores (and returns) a little energy."""

    def build(self):
        from acausal.library.rotational import Backlash
        self.J = Inertia(J=1e-3, phi=Start(0.2), w=Start(0.0))
        self.play = Backlash(b=0.05, tau_s=0.02)
        self.spring = Spring(c=2.0)
        self.fixed = Fixed()
        connect(self.J.flange_b, self.play.flange_a)
        connect(self.play.flange_b, self.spring.flange_a)
        connect(self.spring.flange_b, self.fixed.flange)


def test_backlash_is_conservative_and_crosses_its_play():
    res = compile_model(BacklashOscillator()).simulate(1.0, rtol=1e-10, atol=1e-12, n_points=2001)
    stored = res["J.energy"] + res["spring.energy"] + res["play.energy"]
    assert np.max(np.abs(stored - stored[0])) < 1e-6 * stored[0]
    rel = res["play.phi_rel"]
    assert rel.min() < -0.024 and rel.max() > 0.024  # both flanks reached (play 0.05 rad)
    assert np.all(res["play.energy"] >= -1e-15)


class _GearIntoSpring(Model):
    """A motor's inertia drives a spring and a link through an ideal gear: the gear's output angle is an algebraic
    unknown (``gear.phi_b = motor angle / ratio``) whose derivative the model does not compute."""

    def build(self):
        from acausal.library.electrical import PrescribedVoltage, Resistor
        from acausal.library.rotational import Damper
        import sympy as sp
        from acausal import time
        self.src, self.R, self.gnd = PrescribedVoltage(v_ref=5 * sp.sin(7 * time)), Resistor(R=0.5), Ground()
        self.emf, self.rotor = EMF(k=0.03), Inertia(J=1e-5, phi=Start(0.0), w=Start(0.0))
        self.gear, self.spring = IdealGear(ratio=50), Spring(c=20.0)
        self.link, self.joint, self.house = Inertia(J=0.01), Damper(d=0.2), Fixed()
        connect(self.src.p, self.R.p); connect(self.R.n, self.emf.p); connect(self.emf.n, self.src.n, self.gnd.p)
        connect(self.emf.flange, self.rotor.flange_a); connect(self.rotor.flange_b, self.gear.flange_a)
        connect(self.gear.flange_b, self.spring.flange_a); connect(self.spring.flange_b, self.link.flange_a)
        connect(self.link.flange_b, self.joint.flange_a); connect(self.joint.flange_b, self.house.flange)


@pytest.mark.parametrize("method", ["auto", "BDF"])
def test_flange_energy_through_an_algebraic_angle_is_integrated_not_differenced(method):
    sim = compile_model(_GearIntoSpring())
    assert str(sim.rate_expr("gear.phi_b")) == "der(rotor.phi)/gear.ratio"  # through gear.phi_b = rotor.phi/ratio
    res = sim.simulate(2.0, method=method, rtol=1e-9, atol=1e-12, n_points=201)  # a coarse output grid
    through = res.energy("gear.flange_a")[-1] + res.energy("gear.flange_b")[-1]  # an ideal gear passes it all on
    assert abs(through) < 1e-9 * abs(res.energy("gear.flange_a")[-1])
    b = res.energy_balance()
    assert "gear" not in [k for k, v in b.boundary.items() if abs(v) > b._roundoff]
    assert abs(b.residual) < 1e-7


def test_a_results_ends_are_its_first_and_last_outputs_without_evaluating_the_rest():
    """``Result.ends`` (the trust check's stored-energy change): computed variables, states and aliases at the
    first and last output, the same before and after the outputs are evaluated."""
    sim = compile_model(MotorGearLoad())
    res = sim.simulate(0.2, method="LSODA", trust="off", n_points=51)
    computed = ["L.energy", "rotor.energy", sim.state_names[0]]
    early = res.ends(computed)
    assert not res.evaluated()  # two times evaluated, not every output
    names = computed + ["R.p.i", "src.i"]  # aliases: from the outputs
    early = res.ends(names)
    for n in names:
        assert early[n] == pytest.approx((res[n][0], res[n][-1]), rel=1e-12, abs=1e-15), n
    assert res.ends(names) == early
