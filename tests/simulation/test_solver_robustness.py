"""Robustness of the algebraic blocks: damped Newton, and failure messages that say when, where
and what to try.

* A junction diode with series resistance, discharging a capacitor from 20 V, is a Newton block on the junction
  voltage: the full Newton step from the start value 0 V overflows the exponential, so plain Newton (no line
  search) fails, damped Newton converges; on the scipy path and on the default (compiled) path.
* Every failure of a numeric block (no convergence, singular Jacobian, residual not finite, singular linear solve)
  names the time ``t = ... s``, the block's variables and the components of its equations, the last iterate, and
  a hint (start values, ``method='BDF'``, ``max_step``); at the start of a run and in its middle.
"""
from __future__ import annotations

import re

import numpy as np
import pytest
import sympy as sp

from acausal import (Discrete, Eq, Event, Model, Parameter, SimulationError, Start, Variable, compile_model, connect,
                     der, time)
from acausal.backends.numpy import runtime
from acausal.library.electrical import Capacitor, Ground, Resistor
from acausal.model.partials import OnePort
from acausal.compile.solve import NewtonSolve

#: these tests touch which backend integrates a run: .ci/run runs them again without the accelerators
pytestmark = pytest.mark.backend

I_S, V_T, R_S, C, V0 = 1e-12, 0.025, 10.0, 1e-3, 20.0


def _time_in(msg: str) -> float:
    m = re.search(r"t = ([-+0-9.eE]+) s", msg)
    assert m, f"no time in message: {msg}"
    return float(m.group(1))


def _assert_hint(msg: str, var: str) -> None:
    assert f"'{var}'" in msg, msg
    assert "last iterate" in msg and "start value" in msg and "Start(" in msg, msg
    assert "simulate(starts={...}) gives initial values" in msg, msg  # a run's starts do not seed the block
    assert "method='BDF'" in msg and "max_step" in msg, msg


class JunctionDiode(OnePort):
    """Shockley diode with series resistance: ``i = I_s (exp(v_j / V_T) - 1)``, ``v = v_j + R_s i``."""

    I_s = Parameter(I_S, unit="A", min=0.0, doc="saturation current")
    V_T = Parameter(V_T, unit="V", min=0.0, doc="thermal voltage")
    R_s = Parameter(R_S, unit="Ohm", min=0.0, doc="series resistance")
    v_j = Variable(unit="V", doc="junction voltage")

    def equations(self):
        return [*super().equations(), Eq(self.i, self.I_s * (sp.exp(self.v_j / self.V_T) - 1)),
                Eq(self.v, self.v_j + self.R_s * self.i)]


class Discharge(Model):
    """A capacitor at 20 V discharging through the junction diode."""

    def build(self):
        self.C = Capacitor(C=C, v=Start(V0, fixed=True))
        self.D = JunctionDiode()
        self.gnd = Ground()
        connect(self.C.p, self.D.p)
        connect(self.D.n, self.C.n, self.gnd.p)


class ShockleyDiode(OnePort):
    Is = Parameter(I_S, unit="A", min=0.0, doc="saturation current")
    Vt = Parameter(V_T, unit="V", min=0.0, doc="thermal voltage")

    def equations(self):
        return [*super().equations(), Eq(self.i, self.Is * (sp.exp(self.v / self.Vt) - 1))]


class ResistorDiode(Model):
    """A resistor and a diode in series across a 5 V capacitor: tearing iterates on the resistor's voltage, and from
    its start value 0 V (5 V across the diode) Newton creeps by about V_T per iteration: it does not converge in 60
    (a start value near the solution, 4.3 V, is what helps)."""

    def __init__(self, guess=None, **kw):
        super().__init__(**kw)
        self.guess = guess

    def build(self):
        self.C = Capacitor(C=C, v=Start(5.0, fixed=True))
        self.R = Resistor(R=100.0) if self.guess is None else Resistor(R=100.0, v=Start(self.guess, fixed=False))
        self.D = ShockleyDiode()
        self.gnd = Ground()
        connect(self.C.p, self.R.p)
        connect(self.R.n, self.D.p)
        connect(self.D.n, self.C.n, self.gnd.p)


class NoRootLater(Model):
    """``atan(y) + tanh(y) = x`` has a root only while ``x < pi/2 + 1`` (2.5708); ``x`` rises at 1 per second."""

    x = Variable(start=0.0, fixed=True)
    y = Variable()
    z = Variable(start=0.0, fixed=True)

    def equations(self):
        return [Eq(der(self.x), 1), Eq(sp.atan(self.y) + sp.tanh(self.y), self.x), Eq(der(self.z), sp.tanh(self.y))]


class NoRootLaterAlgebraic(Model):
    """The same block with time itself on the right: no states, evaluated at the output times all at once."""

    y = Variable()

    def equations(self):
        return [Eq(sp.atan(self.y) + sp.tanh(self.y), time)]


LIMIT = np.pi / 2 + 1


# ---------------------------------------------------------------------------------------------- damped Newton
@pytest.fixture(scope="module")
def discharge():
    cm = compile_model(Discharge())
    blocks = [s for s in cm.steps if isinstance(s, NewtonSolve)]
    assert [b.vars for b in blocks] == [["D.v_j"]]  # the junction voltage is the iteration variable
    return cm


def test_plain_newton_fails_on_the_diode_block(discharge, monkeypatch):
    """Without the line search (no halving) the first step, 0 V -> 20 V across the junction, overflows exp."""
    monkeypatch.setattr(runtime, "LINE_SEARCH_HALVINGS", 0)
    with pytest.raises(SimulationError, match=r"'D\.v_j'.* at t = 0 s: the residual is not finite"):
        discharge.simulate(0.05, method="BDF")


@pytest.mark.slow
@pytest.mark.parametrize("method", ["BDF", "LSODA", "auto"])
def test_damped_newton_solves_the_diode_block(discharge, method):
    res = discharge.simulate(0.05, method=method, n_points=51, rtol=1e-8, atol=1e-10)
    if method == "auto":
        assert "compiled path" in res.solver, res.solver  # IDAS, its algebraic start from the damped Newton
    v, vj, i = res["C.v"], res["D.v_j"], res["D.i"]
    assert v[0] == pytest.approx(V0)
    assert np.allclose(i, I_S * np.expm1(vj / V_T), rtol=1e-9, atol=1e-15)  # the junction law holds
    assert np.allclose(v, vj + R_S * i, rtol=1e-9, atol=1e-12)
    assert 0.5 < vj[0] < 0.8 and i[0] == pytest.approx((V0 - vj[0]) / R_S, rel=1e-9)  # ~1.9 A at the start
    assert np.all(np.diff(v) < 0) and v[-1] < 1.0  # discharged through the diode's knee within 50 ms
    ref = discharge.simulate(0.05, method="Radau", n_points=51, rtol=1e-10, atol=1e-12)
    assert np.max(np.abs(v - ref["C.v"])) < 1e-5 * V0


def test_damped_newton_on_samples_and_on_one_point_where_plain_newton_diverges(monkeypatch):
    """Newton on ``atan(y) = c`` from 5 overshoots further at every step (|y0| > 1.39): the line search brings
    every sample in, vectorised over samples and at one point alike."""
    def fun(y, c):
        return (np.arctan(y[0]) - c,), ((1.0 / (1.0 + y[0] ** 2),),)

    c = np.array([0.5, np.arctan(0.1)])
    label = runtime.Block("nonlinear", ["y"], ["Test 'T'"], [5.0])
    with monkeypatch.context() as mp:
        mp.setattr(runtime, "LINE_SEARCH_HALVINGS", 0)
        with pytest.raises(SimulationError, match="'y'"):
            runtime.newton(fun, (5.0,), (c,), label, t=np.array([0.0, 1.0]))
    y, = runtime.newton(fun, (5.0,), (c,), label, t=np.array([0.0, 1.0]))
    assert np.allclose(np.arctan(y), c, rtol=0, atol=1e-14)
    assert y[1] == pytest.approx(0.1, rel=1e-12)
    y0, = runtime.newton(fun, (5.0,), (0.5,), label, t=0.0)  # the scalar path agrees
    assert y0 == pytest.approx(y[0], rel=1e-14)


# ---------------------------------------------------------------------------------------------- messages
@pytest.mark.parametrize("method", ["BDF", "auto"])
def test_no_convergence_at_the_start_names_time_block_and_hint(method):
    cm = compile_model(ResistorDiode())
    with pytest.raises(SimulationError, match="did not converge") as exc:
        cm.simulate(0.3, t_start=0.25, method=method)
    msg = str(exc.value)
    assert _time_in(msg) == 0.25  # the run's start (initialisation at t0)
    assert "Diode 'D'" in msg and "Resistor 'R'" in msg  # every component whose equations are in the block
    assert "(start 0)" in msg
    _assert_hint(msg, "R.v")
    # as the hint says: a start value near the solution makes it converge
    res = compile_model(ResistorDiode(guess=4.3)).simulate(0.3, t_start=0.25, method=method)
    v_d = res["D.v"]
    assert np.allclose((res["C.v"] - v_d) / 100.0, I_S * np.expm1(v_d / V_T), rtol=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["BDF", "LSODA", "auto"])
def test_no_root_in_the_middle_of_a_run_names_its_time(method):
    cm = compile_model(NoRootLater())
    with pytest.raises(SimulationError, match="Newton iteration for the nonlinear block of 'y'") as exc:
        cm.simulate(4.0, method=method, n_points=41)
    msg = str(exc.value)
    assert 2.0 < _time_in(msg) <= 4.0, msg  # at (or where the integrator tried past) x = 2.5708
    assert "NoRootLater" in msg
    _assert_hint(msg, "y")


def test_vectorised_evaluation_names_a_failing_sample():
    cm = compile_model(NoRootLaterAlgebraic())
    with pytest.raises(SimulationError) as exc:
        cm.simulate(4.0, n_points=41)["y"]
    msg = str(exc.value)
    t_fail = _time_in(msg)
    assert LIMIT < t_fail <= 4.0 and np.isclose(t_fail, np.round(t_fail, 1))  # an output time past pi/2 + 1
    _assert_hint(msg, "y")
    ok = cm.simulate(2.5, n_points=26)
    assert np.allclose(np.arctan(ok["y"]) + np.tanh(ok["y"]), ok.t, rtol=0, atol=1e-12)


def test_singular_jacobian_and_non_finite_start_name_time_and_iterate():
    label = runtime.Block("nonlinear", ["a.x", "a.y"], ["Thing 'a'"], [0.0, 0.0])

    def fun(y, s):  # r = (x + y - s, 2 x + 2 y - 2 s): a Jacobian of rank 1
        return (y[0] + y[1] - s, 2 * y[0] + 2 * y[1] - 2 * s), ((1.0, 1.0), (2.0, 2.0))

    with pytest.raises(SimulationError, match=r"'a\.x', 'a\.y' \(equations from Thing 'a'\) at t = 1\.5 s: "
                                              r"singular Jacobian") as exc:
        runtime.newton(fun, (0.0, 0.0), (1.0,), label, t=1.5)
    _assert_hint(str(exc.value), "a.y")

    def fun2(y, s):  # r = (x + y - s, x - s y): singular where s = -1
        return (y[0] + y[1] - s, y[0] - s * y[1]), ((1.0, 1.0), (1.0, -s))

    with pytest.raises(SimulationError, match=r"at t = 3 s: singular Jacobian; last iterate 'a\.x' = 0"):
        runtime.newton(fun2, (0.0, 0.0), (np.array([1.0, -1.0]),), label, t=np.array([2.0, 3.0]))  # 2nd sample

    def log_fun(y, s):
        return (np.log(y[0]) - s,), ((1.0 / y[0],),)

    one = runtime.Block("nonlinear", ["D.v"], ["Diode 'D'"], [0.0])
    with pytest.raises(SimulationError, match=r"at t = 0\.5 s: the residual is not finite at the start values; "
                                              r"last iterate 'D\.v' = 0 \(start 0\)") as exc:
        runtime.newton(log_fun, (0.0,), (1.0,), one, t=0.5)
    _assert_hint(str(exc.value), "D.v")


def test_singular_linear_block_names_time_and_variables():
    label = runtime.Block("linear", ["m.a", "m.b"], ["Mesh 'm'"])
    t = np.linspace(0.0, 3.0, 7)
    with pytest.raises(SimulationError) as exc:
        runtime.linsolve([[1.0, 1.0], [t - 1.0, 1.0]], [1.0, 2.0], label, t)  # singular where t - 1 = 1
    msg = str(exc.value)
    assert _time_in(msg) == 2.0
    assert "'m.a', 'm.b'" in msg and "Mesh 'm'" in msg and "method='BDF'" in msg and "max_step" in msg
    a, b = runtime.linsolve([[1.0, 1.0], [-t, 1.0]], [1.0, 2.0], label, t)  # regular for t >= 0
    assert np.allclose(a + b, 1.0) and np.allclose(-t * a + b, 2.0)


class _Breaker(OnePort):
    """The users' guide's latching breaker as a careless author writes it: R_on, divided by, declared min 0 only."""

    I_trip = Parameter(5.0, unit="A", min=0.0)
    R_on = Parameter(1e-3, unit="Ohm", min=0.0)
    G_off = Parameter(1e-6, unit="S", min=0.0)
    tripped = Discrete(start=0.0)

    def equations(self):
        closed = 1 - self.tripped
        return [*super().equations(), Eq(self.i, closed * self.v / self.R_on + self.tripped * self.G_off * self.v)]

    def events(self):
        return [Event(self.i - self.I_trip, on_rising={self.tripped: 1})]


class _Trip(Model):
    def build(self):
        from acausal.library.electrical import ConstantVoltage, Ground, Inductor, Resistor
        self.src, self.brk, self.gnd = ConstantVoltage(V=12.0), _Breaker(R_on=0.0), Ground()
        self.R, self.L = Resistor(R=1.0), Inductor(L=0.1, i=Start(0.0))
        connect(self.src.p, self.brk.p)
        connect(self.brk.n, self.R.p)
        connect(self.R.n, self.L.p)
        connect(self.L.n, self.src.n, self.gnd.p)


@pytest.mark.parametrize("method", ["auto", "BDF"])
def test_a_parameter_at_zero_that_an_equation_divides_by_is_named_not_a_zero_division_traceback(method):
    cm = compile_model(_Trip())
    with pytest.raises(SimulationError, match=r"brk.R_on = 0 is divided by in an equation of _Breaker 'brk'"):
        cm.simulate(0.5, **({} if method == "auto" else {"method": method}))
