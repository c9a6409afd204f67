"""MACCEPA and gait-load components inside compiled models."""
import numpy as np
import pytest
import sympy as sp

from acausal import Model, compile_model, connect, time
from acausal.library.gait import AnkleAngleSource, AnkleTorqueLoad, unit_cycle
from acausal.library.maccepa import Maccepa, spring_energy, torque
from acausal.library.rotational import Position


class _Replay(Model):
    def build(self):
        self.ankle = AnkleAngleSource(stride_time=2.0)
        self.link = Maccepa(P=0.008)
        self.arm = Position(phi_ref=0.3 * sp.sin(sp.pi * time))
        connect(self.ankle.flange, self.link.flange_a)
        connect(self.link.flange_b, self.arm.flange)


@pytest.fixture(scope="module")
def replay():
    return compile_model(_Replay())


@pytest.mark.parametrize("P", [0.0, 0.002, 0.008, 0.018])
def test_maccepa_component_torque_is_eq3(replay, P):
    res = replay.simulate(2.0, n_points=101, params={"link.P": P})
    alpha = res["link.alpha"]
    assert np.allclose(alpha, res["arm.flange.phi"] - res["ankle.theta"])
    assert np.allclose(res["link.T"], torque(alpha, P, 132e3, 0.1, 0.06), rtol=1e-12, atol=1e-9)
    assert np.allclose(res["link.energy"], spring_energy(alpha, P, 132e3, 0.1, 0.06), rtol=1e-12, atol=1e-12)
    # the foot receives +T, the moment arm -T
    assert np.allclose(res["link.flange_a.tau"], -res["link.T"])
    assert np.allclose(res["link.flange_b.tau"], res["link.T"])


def test_maccepa_work_equals_stored_energy_change(replay):
    res = replay.simulate(1.3, n_points=261)  # not a whole period: the energy changes
    work = res.energy("link.flange_a") + res.energy("link.flange_b")
    d_e = res["link.energy"] - res["link.energy"][0]
    assert abs(d_e[-1]) > 1.0
    assert np.allclose(work, d_e, rtol=1e-6, atol=1e-6 * np.max(np.abs(d_e)))


def test_stride_time_and_body_mass_are_run_time_parameters():
    class Load(Model):
        def build(self):
            self.ankle = AnkleAngleSource()
            self.load = AnkleTorqueLoad()
            connect(self.ankle.flange, self.load.flange)

    sim = compile_model(Load())
    cyc = unit_cycle()
    for T_s, m in ((1.2, 60.0), (3.0, 75.0)):
        res = sim.simulate(T_s, n_points=51, params={"ankle.stride_time": T_s, "load.stride_time": T_s,
                                                      "load.body_mass": m})
        assert np.allclose(res["ankle.theta"], cyc.angle(res.t / T_s))
        assert np.allclose(res["load.M"], m * cyc.torque(res.t / T_s))
        # net work done on the load over one stride: 0.219 J/kg (packaged data, spline), times the mass;
        # 51 output points put every quadrature interval inside one 2 %-wide spline piece: exact integrals
        w = -res.energy("ankle.flange")[-1]
        assert w == pytest.approx(m * cyc.work_per_stride().net, rel=1e-6)
