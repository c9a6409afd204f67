"""Fit facts where the parameter is declared: a parameter's ``fit_range`` and ``nominal`` read by ``Free.declared``
(calibration and diagnosis alike), and a candidate's one record giving its own ``Free``."""
import numpy as np
import pytest

from acausal import DataError, Model, ModelError, Parameter, compile_model
from acausal.identify.calibrate import Free
from acausal.identify.verdict import Candidate
from acausal.library.rotational import Damper, Fixed, Inertia


class Drag(Damper):
    """A damper whose coefficient a fit may search."""

    d = Parameter(2.0, unit="N.m.s/rad", min=0.0, fit_range=(0.1, 10.0), nominal=1.0, doc="damping")


class Rig(Model):
    def build(self):
        from acausal import connect
        self.J, self.drag, self.fixed = Inertia(J=1.0), Drag(), Fixed()
        connect(self.J.flange_b, self.drag.flange_a)
        connect(self.drag.flange_b, self.fixed.flange)


def test_a_parameter_declares_its_fit_range_and_nominal_and_a_fit_reads_them():
    cm = compile_model(Rig())
    free = Free.declared(cm, "drag.d")
    assert free == Free("drag.d", 2.0, 0.1, 10.0, 1.0)  # started at the model's value
    with pytest.raises(DataError, match=r"'drag.d': start value 50 is outside its bounds \[0.1, 10\]"):
        Free.declared(cm, "drag.d", {"drag.d": 50.0})  # a start given beyond the range is refused, not clipped
    assert "fit_range=(0.1, 10.0)" in repr(Drag.d) and "nominal=1.0" in repr(Drag.d)


def test_a_fit_of_an_undeclared_range_or_an_unknown_parameter_is_refused_naming_it():
    cm = compile_model(Rig())
    with pytest.raises(DataError, match=r"'J.J'.*no fit_range"):
        Free.declared(cm, "J.J")
    with pytest.raises(DataError, match=r"'drag.c'.*no such parameter"):
        Free.declared(cm, "drag.c")


@pytest.mark.parametrize("kw, match", [({"fit_range": (1.0, 0.5)}, "increasing"),
                                       ({"fit_range": (-1.0, 1.0), "min": 0.0}, "inside min/max"),
                                       ({"fit_range": "0:1"}, "lower, upper"),
                                       ({"nominal": 0.0}, "positive"), ({"nominal": True}, "positive")])
def test_a_fit_range_or_nominal_that_cannot_hold_is_refused_at_the_declaration(kw, match):
    with pytest.raises(ModelError, match=match):
        Parameter(1.0, unit="1", **kw)


def test_the_shipped_baselines_take_their_fit_facts_from_the_components():
    from acausal.library.drives import DCMotor
    from acausal.library.servo import PositionServo
    from acausal.models.bench.calibration import START, free_parameter
    from acausal.models.servo.problem import ServoProblem
    r = free_parameter("motor.R")
    assert (r.lower, r.upper, r.scale) == (*DCMotor.R.fit_range, DCMotor.R.nominal) and r.start == START["motor.R"]
    assert START["motor.b"] == DCMotor.b.default  # the datasheet start is the motor's declared default
    kt = next(f for f in ServoProblem.base_free(None, {}) if f.name == "servo.kt")
    assert (kt.start, kt.lower, kt.upper, kt.scale) == (PositionServo.kt.default, *PositionServo.kt.fit_range,
                                                        PositionServo.kt.nominal)


def test_a_candidate_gives_its_own_free_parameter_from_its_probe_or_zero():
    hard = Candidate("limit", "x.t_v", 0.0, (0.0, 2.0), 0.1, probe=0.25)
    assert hard.free({}) == Free("x.t_v", 0.25, 0.0, 2.0, 0.1)
    assert hard.free({"x.t_v": 3.0}).start == 2.0
    soft = Candidate("gain", "x.k", 1.0, (0.3, 1.0), 0.1)
    assert soft.free({}).start == 1.0 and soft.free({"x.k": 0.5}).start == 0.5


def test_a_models_effect_record_is_the_diagnosis_candidate_itself():
    from acausal.models.bench.diagnosis import AnkleProblem
    from acausal.models.servo import effects as fx
    from acausal.models.servo.problem import ServoProblem
    assert all(isinstance(e, Candidate) for e in fx.EFFECTS.values())
    assert all(isinstance(c, Candidate) for c in AnkleProblem.candidates.values())
    e = fx.EFFECTS["goal_rate_limit"]
    assert (e.parameter, e.unit, e.zero, e.bounds, e.probe) == ("servo.goal_rate_limit.t_v", "s/rad", 0.0, (0.0, 2.0),
                                                                0.25)
    assert np.isclose(e.free({}).start, 0.25)
