"""Which solved equations can leave the finite numbers (:mod:`acausal.results.finite`): the trust check's search for
non-finite values evaluates only those where a run's states, parameters and divisors allow the analysis, and every
unknown where they do not. Each case below is one the check must still find."""
import numpy as np
import pytest
import sympy as sp
from sympy import Eq

from acausal import Component, Model, Parameter, Variable, compile_model, der
from acausal.results import finite
from acausal.results.trust import UntrustedResult, nonfinite

from ..drive_models import MotorGearLoad


def test_a_drive_of_sums_products_and_parameter_quotients_needs_no_evaluation():
    cm = compile_model(MotorGearLoad())
    names, divisors = finite.plan(cm)
    assert names == []
    assert {str(d) for d in divisors} == {"L.L", "gear.ratio", "gear.ratio**2*rotor.J + load.J"}
    res = cm.simulate(1.0, n_points=101, dense_output=False, trust="off")
    assert not res.evaluated() and nonfinite(res) == [] and not res.evaluated()


class _Ops(Component):
    """One state x = 2 - t (crossing zero at 2 s) and unknowns through each kind of operation."""
    k = Parameter(2.0)
    x = Variable(start=2.0, fixed=True)
    safe = Variable()
    root = Variable()
    quotient = Variable()
    log = Variable()
    power = Variable()
    exp = Variable()
    chosen = Variable()

    def equations(self):
        x = self.x
        return [Eq(der(x), -1.0), Eq(self.safe, self.k * x ** 2 + sp.sin(x) - abs(x) / self.k),
                Eq(self.root, sp.sqrt(x + 10)), Eq(self.quotient, 1 / (x + 10)), Eq(self.log, sp.log(x + 10)),
                Eq(self.power, (x + 10) ** 7), Eq(self.exp, sp.exp(x)),
                Eq(self.chosen, sp.Piecewise((x, x > 0), (self.k * x, True)))]


class _OpsModel(Model):
    def build(self):
        self.c = _Ops()


def test_roots_quotients_logarithms_large_powers_and_exponentials_are_evaluated():
    names, divisors = finite.plan(compile_model(_OpsModel()))
    assert set(names) == {"c.root", "c.quotient", "c.log", "c.power", "c.exp"}
    assert [str(d) for d in divisors] == ["c.k"]


class _Blowup(Component):
    """x grows like exp(t): past MODERATE at t = 47 s; y = x^3 overflows from t = 237 s."""
    x = Variable(start=1.0, fixed=True)
    y = Variable()

    def equations(self):
        return [Eq(der(self.x), self.x), Eq(self.y, self.x ** 3)]


class _BlowupModel(Model):
    def build(self):
        self.b = _Blowup()


def test_a_run_beyond_moderate_values_has_every_unknown_evaluated():
    cm = compile_model(_BlowupModel())
    assert finite.plan(cm)[0] == []  # a small power: finite on moderate arguments
    with pytest.raises(UntrustedResult, match=r"not finite: b\.y is inf"):
        cm.simulate(250.0, rtol=1e-6, atol=1e-9)
    res = cm.simulate(250.0, trust="off")
    assert not finite.moderate(cm, np.asarray(res.states), res.params, res.modes, res.inputs, 0.0)
    res = cm.simulate(40.0, trust="off")
    assert finite.moderate(cm, np.asarray(res.states), res.params, res.modes, res.inputs, 0.0)


def test_a_zero_parameter_divisor_has_every_unknown_evaluated():
    class Half(Component):
        d = Parameter(1.0)
        x = Variable(start=1.0, fixed=True)
        y = Variable()

        def equations(self):
            return [Eq(der(self.x), -self.x), Eq(self.y, self.x / self.d)]

    class M(Model):
        def build(self):
            self.h = Half()

    cm = compile_model(M())
    names, divisors = finite.plan(cm)
    assert names == [] and [str(d) for d in divisors] == ["h.d"]
    res = cm.simulate(1.0, params={"h.d": 0.0}, trust="off")
    assert not finite.moderate(cm, np.asarray(res.states), res.params, res.modes, res.inputs, 0.0)
    assert "h.y is inf" in nonfinite(res)[0]
