"""FrictionalMaccepa: the MACCEPA linkage with spring-force-dependent friction of its bar and pivots."""
import numpy as np
import pytest
import sympy as sp

from acausal import Model, ModelError, compile_model, connect, time
from acausal.library.gait import AnkleAngleSource
from acausal.library.maccepa import FrictionalMaccepa, Maccepa, spring_compression, spring_energy, torque
from acausal.library.rotational import Fixed, Inertia, Position

K, A_LINK, B_ARM = 132e3, 0.1, 0.06  # Maccepa defaults [N/m, m, m]


class _Swing(Model):
    """Foot fixed, moment arm prescribed: alpha(t) = a sin(w t)."""

    def __init__(self, link_cls, a=0.4, w=2 * np.pi, **kw):
        super().__init__(**kw)
        self.link_cls, self.a, self.w = link_cls, a, w

    def build(self):
        self.foot = Fixed()
        self.link = self.link_cls(P=0.008)
        self.arm = Position(phi_ref=self.a * sp.sin(self.w * time))
        connect(self.foot.flange, self.link.flange_a)
        connect(self.link.flange_b, self.arm.flange)


class _GaitReplay(Model):
    """The replay of the paper's bench: joint along the healthy gait, moment arm (with its inertia) prescribed."""

    def __init__(self, link_cls, **kw):
        super().__init__(**kw)
        self.link_cls = link_cls

    def build(self):
        self.ankle = AnkleAngleSource(stride_time=2.0)
        self.link = self.link_cls(P=0.008)
        self.arm_inertia = Inertia(J=0.02)
        self.arm = Position(phi_ref=0.3 * sp.sin(sp.pi * time))
        connect(self.ankle.flange, self.link.flange_a)
        connect(self.link.flange_b, self.arm_inertia.flange_a)
        connect(self.arm_inertia.flange_b, self.arm.flange)


@pytest.fixture(scope="module")
def swing():
    return compile_model(_Swing(FrictionalMaccepa))


@pytest.fixture(scope="module")
def gait_replay():
    return compile_model(_GaitReplay(FrictionalMaccepa))


@pytest.mark.parametrize("r_f, tau_0, w_c", [(1e-3, 0.0, 0.05), (4e-3, 0.3, 0.5), (0.25e-3, 1.0, 1e-3)])
def test_friction_torque_and_loss_follow_the_law(swing, r_f, tau_0, w_c):
    a, w, P = 0.4, 2 * np.pi, 0.008
    res = swing.simulate(1.0, n_points=401, params={"link.r_f": r_f, "link.tau_0": tau_0, "link.w_c": w_c})
    t = res.t
    alpha, w_rel = a * np.sin(w * t), a * w * np.cos(w * t)
    force = K * spring_compression(alpha, P, A_LINK, B_ARM)
    T = torque(alpha, P, K, A_LINK, B_ARM)
    assert np.allclose(res["link.alpha"], alpha, rtol=0, atol=1e-14)
    assert np.allclose(res["link.w_rel"], w_rel, rtol=1e-12, atol=1e-12)
    w_rel = res["link.w_rel"]  # at the reversals tanh(w_rel / w_c) magnifies its round-off by 1 / w_c
    tau_f = (tau_0 + r_f * force) * np.tanh(w_rel / w_c)
    assert np.allclose(res["link.spring_force"], force, rtol=1e-12)
    assert np.allclose(res["link.tau_f"], tau_f, rtol=1e-10, atol=1e-12)
    assert np.allclose(res["link.loss_power"], tau_f * w_rel, rtol=1e-10, atol=1e-12)
    assert (res["link.loss_power"] >= 0.0).all()
    # in parallel with the conservative linkage: T + tau_f acts on the arm, its reaction on the foot
    assert np.allclose(res["link.T"], T, rtol=1e-12, atol=1e-9)
    assert np.allclose(res["link.flange_b.tau"], T + tau_f, rtol=1e-10, atol=1e-9)
    assert np.allclose(res["link.flange_a.tau"], -(T + tau_f), rtol=1e-10, atol=1e-9)
    # at alpha = 0 (t = 0) the arm moves fastest and the spring force is k P
    assert res["link.tau_f"][0] == pytest.approx((tau_0 + r_f * K * P) * np.tanh(a * w / w_c), rel=1e-12)


def test_friction_loss_per_cycle_far_from_reversals(swing):
    """Above a few w_c the smooth law is Coulomb's: the loss per cycle is r_f k times the integral of
    compression |d alpha|, evaluated here by quadrature over alpha."""
    r_f, a, P = 2e-3, 0.4, 0.008
    res = swing.simulate(1.0, n_points=2001, params={"link.r_f": r_f, "link.w_c": 1e-4})
    x, wts = np.polynomial.legendre.leggauss(40)
    alpha = a * (x + 1) / 2
    one_way = np.sum(wts * spring_compression(alpha, P, A_LINK, B_ARM)) * a / 2  # integral over 0..a [m rad]
    coulomb = r_f * K * 4 * one_way                                              # 0 -> a -> 0 -> -a -> 0
    assert res.energy("link.loss_power")[-1] == pytest.approx(coulomb, rel=1e-6)


@pytest.mark.parametrize("t_end", [2.0, 1.3])  # a whole cycle (no net change of spring energy) and part of one
def test_energy_balance_of_a_gait_replay(gait_replay, t_end):
    assert "link.loss_power" in gait_replay.accounts.losses
    assert "link.energy" in gait_replay.accounts.stored
    res = gait_replay.simulate(t_end, n_points=int(400 * t_end) + 1,
                               params={"link.r_f": 2e-3, "link.tau_0": 0.2, "link.w_c": 0.05})
    work = res.energy("link.flange_a")[-1] + res.energy("link.flange_b")[-1]
    loss = res.energy("link.loss_power")[-1]
    stored = res["link.energy"][-1] - res["link.energy"][0]
    assert loss > 1.0 and np.all(res["link.loss_power"] >= 0.0)
    assert work == pytest.approx(loss + stored, rel=1e-6)
    assert abs(res.energy_balance().residual) < 1e-6        # the whole rig, accounts found by convention


@pytest.mark.parametrize("rig", [_Swing, _GaitReplay])
def test_zero_friction_is_the_lossless_linkage(rig):
    lossless = compile_model(rig(Maccepa)).simulate(2.0, n_points=201)
    zero = compile_model(rig(FrictionalMaccepa)).simulate(2.0, n_points=201,
                                                          params={"link.r_f": 0.0, "link.tau_0": 0.0})
    assert np.all(zero["link.loss_power"] == 0.0)
    for name in ("link.alpha", "link.T", "link.tau", "link.energy", "link.compression", "link.flange_a.tau",
                 "link.flange_b.tau", "arm.flange.tau"):
        assert np.array_equal(zero[name], lossless[name]), name      # bit for bit
    assert np.allclose(zero["link.energy"], spring_energy(zero["link.alpha"], 0.008, K, A_LINK, B_ARM), rtol=1e-12)


def test_lossless_maccepa_has_no_loss_account():
    sim = compile_model(_Swing(Maccepa))
    assert not sim.accounts.losses and "link.energy" in sim.accounts.stored


@pytest.mark.parametrize("name, value", [("r_f", -1e-3), ("tau_0", -0.1), ("d", -0.1), ("w_c", 0.0),
                                         ("w_c", -0.05)])
def test_bad_friction_parameters_are_named(swing, name, value):
    with pytest.raises(ModelError, match=rf"'link\.{name}'.*below its minimum"):
        swing.simulate(1.0, n_points=11, params={f"link.{name}": value})


def test_bad_default_given_at_construction_is_named():
    class Rig(Model):
        def build(self):
            self.foot, self.arm = Fixed(), Position(phi_ref=0.1 * sp.sin(time))
            self.link = FrictionalMaccepa(w_c=0.0)
            connect(self.foot.flange, self.link.flange_a)
            connect(self.link.flange_b, self.arm.flange)

    with pytest.raises(ModelError, match=r"FrictionalMaccepa: parameter 'w_c' = 0.0 is outside its bounds"):
        compile_model(Rig()).simulate(1.0, n_points=11)  # refused where it is given, before the path is known


def test_viscous_part_adds_d_w_squared_and_grows_at_faster_swings(swing):
    """``d w_rel`` adds ``d w_rel^2`` to the loss; on the same swing made twice as fast the Coulomb loss per cycle
    stays and the viscous loss per cycle doubles (it scales with the speed)."""
    d, r_f = 0.5, 1e-3
    base = {"link.r_f": r_f, "link.w_c": 1e-4}
    res = swing.simulate(1.0, n_points=2001, params={**base, "link.d": d})
    plain = swing.simulate(1.0, n_points=2001, params=base)
    w_rel = res["link.w_rel"]
    np.testing.assert_allclose(res["link.tau_f"] - plain["link.tau_f"], d * w_rel, rtol=1e-10, atol=1e-12)
    viscous = res.energy("link.loss_power")[-1] - plain.energy("link.loss_power")[-1]
    a, w = 0.4, 2 * np.pi
    assert viscous == pytest.approx(d * a**2 * w**2 / 2, rel=1e-6)   # int_0^1 d (a w cos wt)^2 dt
    fast = compile_model(_Swing(FrictionalMaccepa, w=4 * np.pi)).simulate(0.5, n_points=2001,
                                                                         params={**base, "link.d": d})
    fast_plain = compile_model(_Swing(FrictionalMaccepa, w=4 * np.pi)).simulate(0.5, n_points=2001, params=base)
    fast_viscous = fast.energy("link.loss_power")[-1] - fast_plain.energy("link.loss_power")[-1]
    assert fast_viscous == pytest.approx(2 * viscous, rel=1e-6)
    assert fast_plain.energy("link.loss_power")[-1] == pytest.approx(plain.energy("link.loss_power")[-1], rel=1e-3)
