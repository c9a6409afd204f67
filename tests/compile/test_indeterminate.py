"""Friction elements stuck together on one rigid shaft (finding 3 of
``tests/msl/msl_conformance_findings.md``):
the equations give only the sum of their holding torques, and :class:`acausal.Indeterminate` says how the solver
splits it (equal fractions of each element's breakaway band), so that the group breaks away exactly when no split
holds the shaft any more.

The reference is closed form: a flywheel (J = 1 kg m2, 1 rad/s) braked by two brakes of 0.2 and 0.6 N m decelerates
at 0.8 rad/s2 and stops at 1.25 s; from 2 s a torque ramp of 1 N m/s pulls at it. Any split within both brakes'
limits holds it while the torque is at most 0.2 + 0.6 N m, so both break away at 2.8 s, and the shaft then
accelerates at (t - 2.8) rad/s2: w = (t - 2.8)**2 / 2.
"""
import numpy as np
import pytest

from acausal import Indeterminate, Model, ModelError, SimulationError, Start, compile_model, connect, export_fmu
from acausal.export.ccode import ExportError
from acausal.library.blocks import Ramp, SignalSource
from acausal.library.friction import Brake
from acausal.library.rotational import Inertia, SignalTorque
from acausal.backends.numpy.runtime import least_norm

LIMITS = (0.2, 0.6)  # N m: the brakes' breakaway torques (mu cgeo fn_max, peak 1)
T_STOP, T_RAMP, T_BREAK = 1.25, 2.0, 2.8  # s: stopped, the ramp starts, the pair breaks away


class TwoBrakesAndARamp(Model):
    """A flywheel, two brakes of different strength on its shaft, and a torque ramp from ``T_RAMP``."""

    def __init__(self, brake=Brake, **kw):
        super().__init__(**kw)
        self.brake = brake

    def build(self):
        self.body = Inertia(J=1.0, w=Start(1.0, fixed=True))
        self.one = SignalSource(signal=1.0)
        self.b1, self.b2 = self.brake(mu=LIMITS[0]), self.brake(mu=LIMITS[1])
        self.ramp, self.torque = Ramp(height=2.0, duration=2.0, start_time=T_RAMP), SignalTorque()
        connect(self.body.flange_b, self.b1.flange_a)
        connect(self.b1.flange_b, self.b2.flange_a)
        connect(self.one.y, self.b1.f_normalized, self.b2.f_normalized)
        connect(self.ramp.y, self.torque.u)
        connect(self.torque.flange, self.body.flange_a)


@pytest.fixture(scope="module")
def sim():
    return compile_model(TwoBrakesAndARamp())


def closed_form(t):
    return np.where(t < T_STOP, 1.0 - sum(LIMITS) * t, np.where(t < T_BREAK, 0.0, (t - T_BREAK) ** 2 / 2))


@pytest.mark.slow
@pytest.mark.parametrize("method", [None, "BDF", "LSODA"])
def test_two_brakes_hold_together_and_break_away_together(sim, method):
    """Stops at 1.25 s, holds, both brakes break away at 2.8 s (within 1e-9 s of each other and of the closed
    form), the speed within 1e-6 rad/s of the closed form; while stuck each brake holds its share of the ramp's
    torque in proportion to its limit, and the balance closes with every loss >= 0."""
    res = sim.simulate(3.5, n_points=701, **({"method": method} if method else {}))
    assert np.max(np.abs(res["body.w"] - closed_form(res.t))) < 1e-6
    for b in ("b1", "b2"):
        changes = [t for t, _, _ in res.events if abs(t - T_BREAK) < 1e-3]
        assert changes and all(abs(t - T_BREAK) < 1e-9 for t in changes), res.events
        stuck = res[f"{b}.stuck"]
        assert np.all(stuck[(res.t > T_STOP + 1e-6) & (res.t < T_BREAK - 1e-6)] == 1), b
        assert np.all(stuck[res.t > T_BREAK + 1e-6] == 0), b
        assert np.min(res[f"{b}.loss_power"]) >= -1e-12, b
    held = (res.t > T_RAMP + 0.05) & (res.t < T_BREAK - 1e-6)
    s1, s2 = res["b1.sa"][held], res["b2.sa"][held]
    assert np.allclose(s1 / s2, LIMITS[0] / LIMITS[1], rtol=1e-9)
    assert np.allclose(np.abs(s1 + s2), res.t[held] - T_RAMP, rtol=1e-9, atol=1e-12)
    b = res.energy_balance()
    assert abs(b.residual) < 1e-6


def test_the_compiled_path_says_why_it_does_not_run_the_split(sim):
    res = sim.simulate(1.0)
    assert "least-norm" in res.solver and "'b1.sa', 'b2.sa'" in res.solver


def test_an_fmu_of_a_split_block_is_refused_with_the_block_named(sim, tmp_path):
    with pytest.raises(ExportError, match=r"'b1.sa', 'b2.sa'.*least-norm"):
        export_fmu(sim, tmp_path / "two_brakes.fmu")


def test_weighted_least_norm_shares_in_proportion_to_the_scales():
    """sa1 + sa2 = 4 with scales 1 and 3: the shares 1 and 3 (equal fractions); a regular system is solved as it
    is; a singular direction in a variable not declared free raises."""
    A, b = np.array([[1.0, 1.0], [0.0, 0.0]]), np.array([4.0, 0.0])
    assert least_norm(A, b, np.array([1.0, 3.0])) == pytest.approx([1.0, 3.0])
    R = np.array([[2.0, 1.0], [1.0, 3.0]])
    assert least_norm(R, np.array([3.0, 4.0]), np.array([1.0, 5.0])) == pytest.approx(np.linalg.solve(R, [3, 4]))
    with pytest.raises(np.linalg.LinAlgError):
        least_norm(A, b, np.array([1.0, 3.0]), free=(True, False))
    batch = least_norm(np.stack([A, A]), np.stack([b, 2 * b]), np.array([[1.0, 3.0], [1.0, 1.0]]))
    assert batch == pytest.approx(np.array([[1.0, 3.0], [4.0, 4.0]]))


class LateRuleBrake(Brake):
    """A brake whose split rule uses its loss power, which the model computes after the block of its torque."""

    def indeterminates(self):
        return [Indeterminate(self.sa, self.loss_power, 1.0)]


class NotAVariable(Brake):
    def indeterminates(self):
        return [Indeterminate(self.mu, 0.0, 1.0)]


def test_a_split_rule_that_uses_a_later_variable_is_a_model_error():
    with pytest.raises(ModelError, match=r"Brake 'b1'.*Indeterminate\('b1.sa'\) uses b1.loss_power"):
        compile_model(TwoBrakesAndARamp(brake=LateRuleBrake))


def test_an_indeterminate_that_is_no_variable_is_a_model_error():
    with pytest.raises(ModelError, match=r"NotAVariable 'b1'.*Indeterminate\(b1.mu\) is not a variable"):
        compile_model(TwoBrakesAndARamp(brake=NotAVariable))


def test_without_the_rule_the_stuck_pair_is_singular():
    """The rule is what runs the pair: a brake that declares no Indeterminate leaves the block singular, and the
    run stops with the block named (the state before the fix)."""

    class PlainBrake(Brake):
        def indeterminates(self):
            return []

    with pytest.raises(SimulationError, match=r"singular.*'b[12].sa'"):
        compile_model(TwoBrakesAndARamp(brake=PlainBrake)).simulate(2.0, method="BDF")
