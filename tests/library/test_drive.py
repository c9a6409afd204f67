"""Acceptance: the motor_gear_load drive train forward (index 3 as a flat DAE) and inverse (prescribed motion)."""
import numpy as np
import pytest

from acausal import compile_model

from ..drive_models import (J_LOAD, J_ROTOR, K, L, N, R, MotorGearLoad, MotorGearLoadInverse,
                           VoltageForMotion, inverse_solution, steady_state)


@pytest.fixture(scope="module")
def forward():
    return compile_model(MotorGearLoad())


def test_forward_steady_state_matches_analytic(forward):
    res = forward.simulate(5.0, rtol=1e-10, atol=1e-12, n_points=11)  # time constant ~0.3 s: 5 s is 16 tau
    w_load, i = steady_state()
    assert res["load.w"][-1] == pytest.approx(w_load, rel=1e-6)
    assert res["L.i"][-1] == pytest.approx(i, rel=1e-6)
    assert res["rotor.w"][-1] == pytest.approx(N * w_load, rel=1e-6)
    # aliases answer by name: the gear's output flange angle is the load angle
    assert np.allclose(res["gear.flange_b.phi"], res["load.phi"])
    assert np.allclose(res["gear.flange_a.tau"] * N, -res["gear.flange_b.tau"])


def test_forward_needs_index_reduction(forward):
    red = forward.reduction
    assert red.differentiations == 2  # the gear constraint on two inertias' angles, differentiated twice
    assert red.index == 3
    assert len(forward.state_names) == 3  # L.i and one inertia's angle and speed; the other is a dummy


def test_parameter_override_without_recompiling(forward):
    for r in (0.5, 0.9):
        res = forward.simulate(5.0, params={"R.R": r}, rtol=1e-10, atol=1e-12, n_points=3)
        w_load, i = steady_state(R_=r)
        assert res["load.w"][-1] == pytest.approx(w_load, rel=1e-6)
        assert res["R.R"][0] == r


def test_inverse_high_index_matches_hand_derived():
    sim = compile_model(MotorGearLoadInverse())
    assert sim.state_names == ["L.i"]  # the whole mechanism is prescribed
    res = sim.simulate(1.0, rtol=1e-10, atol=1e-12, n_points=201)
    i, v_motor, p_supply = inverse_solution(res.t)
    scale_i = np.max(np.abs(i))
    assert np.max(np.abs(res["L.i"] - i)) / scale_i < 1e-6
    assert np.max(np.abs(res["emf.v"] + res["L.v"] - v_motor)) / np.max(np.abs(v_motor)) < 1e-6
    supply = -res["src.v"] * res["src.i"]  # power delivered by the source
    assert np.max(np.abs(supply - p_supply)) / np.max(np.abs(p_supply)) < 1e-6
    # the reference values at t = 1 s
    assert res["L.i"][-1] == pytest.approx(-28.93567455541526, rel=1e-6)
    assert supply[-1] == pytest.approx(-694.4561893299663, rel=1e-6)
    # index reduction derived the rotor's speed and acceleration exactly from the prescribed load angle
    w = 2 * np.pi
    assert np.allclose(res["rotor.w"], N * 0.3 * w * np.cos(w * res.t), rtol=1e-12, atol=1e-9)
    assert np.allclose(res["rotor.a"], -N * 0.3 * w**2 * np.sin(w * res.t), rtol=1e-12, atol=1e-8)


def test_inverse_third_derivative_voltage():
    sim = compile_model(VoltageForMotion())
    assert sim.state_names == []  # purely algebraic after index reduction: no integrator
    assert sim.reduction.differentiations == 3  # the inductor needs the 3rd derivative of the target
    res = sim.simulate(1.0, n_points=101)
    t = res.t
    w = 2 * np.pi
    J = J_ROTOR + J_LOAD / N**2
    om = 0.3 * w * np.cos(w * t) * N
    acc = -0.3 * w**2 * np.sin(w * t) * N
    jerk = -0.3 * w**3 * np.cos(w * t) * N
    i = J * acc / K
    v = R * i + L * J * jerk / K + K * om
    assert np.max(np.abs(res["src.v"] - v)) / np.max(np.abs(v)) < 1e-9
    assert np.max(np.abs(res["L.i"] - i)) / np.max(np.abs(i)) < 1e-9


def test_inverse_with_numeric_signal_and_swap_without_recompiling():
    """A numeric periodic signal (Fourier) provides its own derivatives; swapping it needs no recompilation."""
    from acausal import FourierSeries, Model, connect
    from acausal.library.rotational import Inertia, Position

    class Prescribed(Model):
        def build(self):
            self.pos = Position(phi_ref=FourierSeries(0.0, [0.0], [0.3], period=1.0))
            self.J = Inertia(J=2.0)
            connect(self.pos.flange, self.J.flange_a)

    sim = compile_model(Prescribed())
    res = sim.simulate(1.0, n_points=51)
    t = res.t
    assert np.allclose(res["J.a"], -0.3 * (2 * np.pi) ** 2 * np.sin(2 * np.pi * t), atol=1e-9)
    assert np.allclose(res["pos.flange.tau"], 2.0 * 0.3 * (2 * np.pi) ** 2 * np.sin(2 * np.pi * t), atol=1e-8)
    res2 = sim.simulate(1.0, n_points=51, inputs={"pos.phi_ref": FourierSeries(0.0, [0.0], [0.6], period=1.0)})
    assert np.allclose(res2["J.a"], 2 * res["J.a"], atol=1e-9)
    assert np.allclose(res.der("pos.phi_ref", 2), res["J.a"])


def test_evaluation_vectorised_over_time_and_parameter_batch():
    """A stateless model evaluated for B parameter sets x N times in one call: shape (B, N), each row exact."""
    sim = compile_model(VoltageForMotion())
    t = np.linspace(0.0, 1.0, 57)
    Rs = [0.5, 0.7, 0.9]
    p = sim.param_batch([{"R.R": r} for r in Rs])
    vals = sim.evaluate(t, params=p)
    v = np.broadcast_to(vals["src.v"], (len(Rs), t.size))
    for k, r in enumerate(Rs):
        single = sim.evaluate(t, params={"R.R": r})["src.v"]
        assert np.allclose(v[k], single, rtol=1e-14, atol=1e-12)
    assert not np.allclose(v[0], v[2])


def test_evaluating_named_variables_gives_what_the_whole_evaluation_gives():
    """``evaluate(names=...)`` computes only the steps the names need: a state, unknowns and aliases equal the
    whole evaluation's (and the states' own rows), over a parameter batch too; an unknown name is named."""
    from acausal import ModelError
    sim = compile_model(MotorGearLoad())
    t = np.linspace(0.0, 0.5, 23)
    x = np.vstack([np.sin(3 * t), t, 50 * t])
    names = ["R.loss_power", "L.i", "R.i", "L.v", "L.p.i"]
    for params in (None, sim.param_batch([{"R.R": 0.5}, {"R.R": 0.9}])):
        picked = sim.evaluate(t, x=x, params=params, names=names)
        whole = sim.evaluate(t, x=x, params=params)
        assert list(picked) == names
        for n in ("R.loss_power", "L.v"):
            np.testing.assert_array_equal(picked[n], np.broadcast_to(whole[n], picked[n].shape))
        np.testing.assert_array_equal(picked["L.i"], np.broadcast_to(x[0], picked["L.i"].shape))
        np.testing.assert_allclose(picked["R.i"], picked["L.i"], rtol=0, atol=0)  # an alias of the state
    with pytest.raises(ModelError, match="R.nope"):
        sim.evaluate(t, x=x, names=["R.nope"])
