"""Issue 39, item 6: model errors name the user's mistake, not a symptom of it (a RecursionError, an
over-determined system blamed on the neighbours, a silently dropped component)."""
import pytest

from acausal import ConnectError, Model, ModelError, compile_model, connect
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
