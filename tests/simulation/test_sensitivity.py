"""Exact parameter sensitivities (CompiledModel.sensitivities) against finite differences and closed forms."""
import numpy as np
import pytest
import sympy as sp

import acausal
from acausal import Model, ModelError, Parameter, Start, compile_model, connect, time
from acausal.library.electrical import Capacitor, ConstantVoltage, Ground, Resistor
from acausal.library.gait import AnkleAngleSource
from acausal.library.rotational import Inertia, LossyGear, Position, TorqueSource

#: these tests touch which backend integrates a run: .ci/run runs them again without the accelerators
pytestmark = pytest.mark.backend


def _agree(exact, fd, rel, floor=1e-8):
    """Exact sensitivity vs finite difference: relative to the largest |fd|, or both ~0 (below the FD's noise)."""
    scale = np.max(np.abs(fd))
    if scale < floor:
        return np.max(np.abs(exact)) < floor
    return np.max(np.abs(exact - fd)) / scale < rel


# ---------------------------------------------------------------------------------------------- (a) stateless
@pytest.fixture(scope="module")
def lossy_replay():
    from acausal.models.ankle.actuator import AnkleActuator
    return compile_model(AnkleActuator.eq4(mode="replay", effects=("gear_load_dependent_loss",)))


@pytest.mark.parametrize("at", [{}, {"gear.eta": 0.85}])
def test_stateless_replay_matches_finite_differences(lossy_replay, at):
    cm = lossy_replay
    assert not cm.state_names
    t = np.linspace(0.05, 1.9, 400)
    wrt = ["gear.eta", "motor.R", "motor.J"]
    names = ["motor.i", "P_source.i", "joint_torque"]  # P_source.i is an eliminated alias
    values, sens = cm.sensitivities(t, wrt, names, params=at)
    ref = cm.evaluate(t, params=at, names=names)
    for n in names:
        assert values[n].shape == (400,) and sens[n].shape == (3, 400)
        np.testing.assert_allclose(values[n], ref[n], rtol=1e-12, atol=1e-12)
    p0 = cm.param_vector(at)
    for j, w in enumerate(wrt):
        base = p0[cm.param_index(w)]
        h = 1e-5 * abs(base)
        if w == "gear.eta" and base >= 1.0:  # at its maximum: one-sided, second order
            f = [cm.evaluate(t, params={**at, w: base - k * h}, names=names) for k in (0, 1, 2)]
            fd = {n: (3 * f[0][n] - 4 * f[1][n] + f[2][n]) / (2 * h) for n in names}
        else:
            fp = cm.evaluate(t, params={**at, w: base + h}, names=names)
            fm = cm.evaluate(t, params={**at, w: base - h}, names=names)
            fd = {n: (fp[n] - fm[n]) / (2 * h) for n in names}
        for n in names:
            assert np.all(np.isfinite(sens[n][j]))
            assert _agree(sens[n][j], fd[n], 1e-5, floor=1e-6), (w, n)
    # the signs the fingerprints rely on: a lossier gear and a larger inertia draw more current on average
    assert np.mean(np.abs(sens["motor.i"][2])) > 0


class _GearReplay(Model):
    """A prescribed motion through an event-law lossy gear into an inertia: no state, the mode switches."""

    def build(self):
        self.pos = Position(phi_ref=sp.sin(2 * sp.pi * time))
        self.gear = LossyGear(ratio=10.0, eta=0.8)
        self.load = Inertia(J=0.5)
        connect(self.pos.flange, self.gear.flange_a)
        connect(self.gear.flange_b, self.load.flange_a)


def test_stateless_with_modes_settled_per_sample():
    cm = compile_model(_GearReplay())
    assert not cm.state_names and cm.event_zeros
    t = np.linspace(0.01, 0.99, 50)
    wrt, names = ["gear.eta", "load.J"], ["pos.flange.tau", "gear.loss_power"]
    values, sens = cm.sensitivities(t, wrt, names)
    res = cm.simulate(0.99, t_start=0.01, t_eval=t)
    assert 0 < res.modes.mean() < 1  # both modes occur
    for j, w in enumerate(wrt):
        base, h = cm.param_vector()[cm.param_index(w)], 1e-6
        rp = cm.simulate(0.99, t_start=0.01, t_eval=t, params={w: base + h})
        rm = cm.simulate(0.99, t_start=0.01, t_eval=t, params={w: base - h})
        for n in names:
            np.testing.assert_allclose(values[n], res[n], rtol=1e-12, atol=1e-12)
            assert _agree(sens[n][j], (rp[n] - rm[n]) / (2 * h), 1e-7), (w, n)


# ---------------------------------------------------------------------------------------------- (b) with a state
@pytest.fixture(scope="module")
def thermal_replay():
    from acausal.models.ankle.actuator import AnkleActuator
    return compile_model(AnkleActuator.eq4(mode="replay", effects=("winding_temperature",)))


def _simulate(cm, params, t):
    return cm.simulate(float(t[-1]), params=params, t_eval=t, rtol=1e-11, atol=1e-13, dense_output=False)


@pytest.mark.parametrize("heating", [0.1, 1e-9])
def test_stateful_replay_matches_finite_differences(thermal_replay, heating):
    """winding.C = 1/winding_heating: the sensitivity follows the binding; at 1e-9 (the minimum, effect off)
    it is the fingerprint of the effect and must be finite (a one-sided difference from there)."""
    cm = thermal_replay
    assert cm.state_names == ["winding.T"]
    t = np.linspace(0.0, 2.0, 101)
    wrt = ["winding_heating", "motor.R"]
    names = ["P_source.i", "motor.i"]
    at = {"winding_heating": heating}
    values, sens = cm.sensitivities(t, wrt, names, params=at)
    res = _simulate(cm, at, t)
    for n in names:
        np.testing.assert_allclose(values[n], res[n], rtol=1e-7, atol=1e-9)
        assert np.all(np.isfinite(sens[n]))
    for j, w in enumerate(wrt):
        base = cm.param_vector(at)[cm.param_index(w)]
        if w == "winding_heating" and heating < 1e-6:  # at the minimum: forward, second order
            h = 1e-3
            f = [_simulate(cm, {**at, w: base + k * h}, t) for k in (0, 1, 2)]
            fd = {n: (-3 * f[0][n] + 4 * f[1][n] - f[2][n]) / (2 * h) for n in names}
        else:
            h = 1e-2 * base
            fp, fm = _simulate(cm, {**at, w: base + h}, t), _simulate(cm, {**at, w: base - h}, t)
            fd = {n: (fp[n] - fm[n]) / (2 * h) for n in names}
        for n in names:  # (motor.i depends on neither: the motion is prescribed)
            assert _agree(sens[n][j], fd[n], 2e-5), (w, n)
    # heating raises the resistance, hence the supply current, more and more over the run
    assert sens["P_source.i"][0][0] == 0.0 and np.mean(sens["P_source.i"][0][-10:]) > 0


# ---------------------------------------------------------------------------------------------- (c) closed form
class _RC(Model):
    """10 V source charging C through R = 2 * half_R (a bound parameter) from 0 V."""

    half_R = Parameter(50.0, unit="Ohm", min=0.0)

    def build(self):
        self.src = ConstantVoltage(V=10.0)
        self.gnd = Ground()
        self.R = Resistor(R=2 * self.half_R)
        self.C = Capacitor(C=1e-3, v=Start(0.0))
        connect(self.src.p, self.R.p)
        connect(self.R.n, self.C.p)
        connect(self.C.n, self.src.n, self.gnd.p)


def test_rc_closed_form():
    cm = compile_model(_RC())
    t = np.linspace(0.0, 0.5, 51)
    V, R, C = 10.0, 100.0, 1e-3
    e = np.exp(-t / (R * C))
    wrt = ["R.R", "C.C", "src.V", "half_R"]
    values, sens = cm.sensitivities(t, wrt, ["C.v", "R.i"], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(values["C.v"], V * (1 - e), rtol=0, atol=1e-8)
    dv = sens["C.v"]
    np.testing.assert_allclose(dv[0], -V * t / (R**2 * C) * e, rtol=0, atol=1e-8)  # dv/dR [V/Ohm]
    np.testing.assert_allclose(dv[1], -V * t / (R * C**2) * e, rtol=0, atol=1e-3)  # dv/dC [V/F]
    np.testing.assert_allclose(dv[2], 1 - e, rtol=0, atol=1e-8)  # dv/dV
    # R.R is named in wrt, so it is independent there: half_R then acts only through... nothing
    np.testing.assert_allclose(dv[3], 0.0, atol=1e-12)
    # without R.R in wrt, half_R follows its binding R.R = 2 * half_R: the chain rule gives 2 dv/dR
    _, s2 = cm.sensitivities(t, ["half_R"], ["C.v"], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(s2["C.v"][0], 2 * dv[0], rtol=0, atol=1e-8)
    # overriding R.R alone would disagree with half_R: an error naming the binding
    with pytest.raises(ModelError, match=r"'R.R' of R is bound to 2\*half_R.*set 'half_R' instead"):
        cm.sensitivities(t, ["half_R"], ["C.v"], params={"R.R": 100.0})
    # the current i = (V - v)/R: di/dR = -(V - v)/R^2 - (dv/dR)/R
    np.testing.assert_allclose(sens["R.i"][0], -V * e / R**2 + V * t / (R**3 * C) * e, rtol=0, atol=1e-9)
    _, s5 = cm.sensitivities(t, ["C.C"], ["C.v"], method="LSODA", rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(s5["C.v"][0], dv[1], rtol=0, atol=1e-3)
    # every state and unknown by default
    v2, s4 = cm.sensitivities(t[1:], ["C.C"], names=None)
    assert set(v2) == set(cm.state_names) | set(cm.unknown_names)
    np.testing.assert_allclose(s4["C.v"][0], dv[1][1:], rtol=1e-6, atol=1e-3)


# ---------------------------------------------------------------------------------------------- (d) errors
def test_unknown_names_are_reported():
    cm = compile_model(_RC())
    with pytest.raises(ModelError, match=r"unknown parameter 'R.RR'.*did you mean 'R.R'"):
        cm.sensitivities([0.1], ["R.RR"], ["C.v"])
    with pytest.raises(ModelError, match=r"unknown variable 'C.vv'"):
        cm.sensitivities([0.1], ["R.R"], ["C.vv"])


def test_events_with_states_are_not_supported():
    class Driven(Model):
        def build(self):
            self.src = TorqueSource(tau=sp.sin(time))
            self.motor = Inertia(J=0.1)
            self.gear = LossyGear(ratio=10.0, eta=0.8)
            self.load = Inertia(J=0.5)
            connect(self.src.flange, self.motor.flange_a)
            connect(self.motor.flange_b, self.gear.flange_a)
            connect(self.gear.flange_b, self.load.flange_a)

    cm = compile_model(Driven())
    assert cm.state_names and cm.event_zeros
    with pytest.raises(ModelError, match="events and states are not supported"):
        cm.sensitivities([0.5], ["gear.eta"], ["load.w"])


class _Gait(Model):
    stride = Parameter(1.5, unit="s", min=0.1)

    def build(self):
        self.ankle = AnkleAngleSource(stride_time=self.stride)
        self.foot = Inertia(J=0.01)
        connect(self.ankle.flange, self.foot.flange_a)


def test_parameter_in_signal_argument_is_not_supported():
    cm = compile_model(_Gait())
    t = np.linspace(0.0, 1.0, 11)
    for w in ("ankle.stride_time", "stride"):  # directly, and through the binding chain
        with pytest.raises(ModelError, match=rf"'{w}'.*argument of the input signal"):
            cm.sensitivities(t, [w], ["foot.flange_a.tau"])
    values, sens = cm.sensitivities(t, ["foot.J"], ["foot.flange_a.tau"])  # other parameters are fine
    np.testing.assert_allclose(sens["foot.flange_a.tau"][0] * 0.01, values["foot.flange_a.tau"], atol=1e-12)
