"""Model errors name the user's mistake, not a symptom of it (a RecursionError, an
over-determined system blamed on the neighbours, a silently dropped component)."""
import pytest

from acausal import ConnectError, Model, ModelError, StructureError, compile_model, connect
from acausal.library.blocks import Gain, Step
from acausal.library.electrical import ConstantVoltage, Ground, Resistor


class Divider(Model):
    """A source across R; ``mistake`` makes one of the errors under test."""

    def __init__(self, mistake=None, **kw):
        self.mistake = mistake
        super().__init__(**kw)

    def build(self):
        self.src, self.R, self.gnd = ConstantVoltage(V=1.0), Resistor(R=1.0), Ground()
        connect(self.src.p, self.R.p)
        connect(self.R.n, self.src.n, self.gnd.p)
        if self.mistake == "twice":
            self.R = Resistor(R=2.0)
        elif self.mistake == "two names":
            self.R2 = self.R
        elif self.mistake == "itself":
            self.me = self


@pytest.mark.parametrize("mistake, message", [
    ("twice", r"Divider \(top level\): 'R' is assigned twice \(a Resistor, already connected, then a Resistor\)"),
    ("two names", r"one Resistor instance under two names, 'R' and 'R2'"),
    ("itself", r"self.me = self; a component cannot contain itself"),
])
def test_a_component_misused_is_named(mistake, message):
    with pytest.raises(ModelError, match=message):
        compile_model(Divider(mistake))


def test_two_outputs_connected_are_named():
    class TwoOut(Model):
        def build(self):
            self.a, self.b, self.g = Step(height=1.0), Step(height=2.0), Gain(k=1.0)
            connect(self.a.y, self.b.y)
            connect(self.a.y, self.g.u)

    with pytest.raises(ConnectError, match=r"joins 2 outputs \('a.y', 'b.y'\); one output drives a signal"):
        compile_model(TwoOut())


def test_a_sane_divider_still_compiles():
    assert compile_model(Divider()).simulate(0.1)["R.i"][-1] == pytest.approx(1.0)


def test_an_over_determined_user_component_is_named_not_its_neighbour():
    """A user's one-port that fixes both its voltage law and its current (5 equations for its 4 unknowns): the
    error names it first (Modelica's local balance), not the resistor beside it where the matching ran out."""
    from acausal import Eq, Parameter
    from acausal.model.partials import OnePort

    class MyLoad(OnePort):
        R = Parameter(1.0)

        def equations(self):
            return [*super().equations(), Eq(self.v, self.R * self.i), Eq(self.i, 1.0)]

    class Circuit(Model):
        def build(self):
            self.src, self.R1, self.load, self.gnd = ConstantVoltage(V=1.0), Resistor(R=1.0), MyLoad(R=2.0), Ground()
            connect(self.src.p, self.R1.p)
            connect(self.R1.n, self.load.p)
            connect(self.load.n, self.src.n, self.gnd.p)

    with pytest.raises(StructureError, match=r"^MyLoad 'load' has 5 equation\(s\) for 4 unknown\(s\) of its own \(too "
                                         r"many\).*the likely culprit"):
        compile_model(Circuit())


def test_an_inertia_without_its_torque_balance_is_named_first():
    """An inertia written without its torque balance among six other components: named first, not last of 7."""
    from acausal import Eq, Parameter, Variable, der
    from acausal.library.rotational import Damper, Fixed, Inertia, Spring
    from acausal.model.partials import PartialTwoFlanges

    class NoBalance(PartialTwoFlanges):
        J = Parameter(1.0)
        phi = Variable()
        w = Variable()

        def equations(self):
            return [Eq(self.phi, self.flange_a.phi), Eq(self.phi, self.flange_b.phi), Eq(self.w, der(self.phi))]

    class Chain(Model):
        def build(self):
            self.f, self.s, self.j = Fixed(), Spring(c=10.0), NoBalance(J=1.0)
            self.d, self.j2 = Damper(d=1.0), Inertia(J=1.0)
            connect(self.f.flange, self.s.flange_a)
            connect(self.s.flange_b, self.j.flange_a)
            connect(self.j.flange_b, self.d.flange_a)
            connect(self.d.flange_b, self.j2.flange_a)

    with pytest.raises(StructureError, match=r"^NoBalance 'j' has 3 equation\(s\) for 4 unknown\(s\) of its own \(too "
                                         r"few\)"):
        compile_model(Chain())


def test_every_component_of_the_shipped_models_balances_locally():
    """The rule that names a user's unbalanced component holds for every library part the shipped models use
    (31 classes: supply to pendulum), so it never blames a library part."""
    from acausal.models.ankle.actuator import AnkleActuator
    from acausal.models.servo.model import ServoPendulum
    from acausal.compile.structure.balance import unbalanced

    for model in (AnkleActuator(mode="closed_loop"), AnkleActuator(), ServoPendulum()):
        model._ensure_built()
        assert unbalanced(model) == []


def test_text_is_never_executed_as_an_expression():
    """`ExpressionSignal("...")` and `der("...")` ran the text through sympify (Python's eval);
    both refuse text, naming what to give instead."""
    from acausal import ExpressionSignal, SignalError, der

    with pytest.raises(SignalError, match=r"got the string '__import__\(.os.\)'.*would be executed as code"):
        ExpressionSignal('__import__("os")')
    with pytest.raises(ModelError, match=r"der\('x'\): give a variable .*self.x, not 'x'"):
        der("x")


def test_a_part_whose_name_holds_a_dot_is_refused_naming_the_sub_component_it_collides_with():
    from acausal import Model
    from acausal.library.electrical import Resistor

    class Divider(Model):
        def build(self):
            self.R = Resistor()

    class Clash(Model):
        def build(self):
            self.a = Divider()
            setattr(self, "a.R", Resistor())  # would share the path of a's own resistor

    with pytest.raises(ModelError, match=r"a part named 'a.R' \(a Resistor\).*'a' holds its own"):
        compile_model(Clash())
