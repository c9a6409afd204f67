"""The facade (acausal.compiled_model): ``compile_once``, the one process cache of compiled models that the shipped
models share."""
import pytest

from acausal import compile_once
from acausal.compiled_model import _ONCE

from .circuit_models import RC


def test_an_equal_key_returns_the_same_compiled_model_without_building_again():
    builds = []

    def build():
        builds.append(1)
        return RC()
    key = ("test_rc", 1)
    _ONCE.pop(key, None)
    first = compile_once(key, build)
    assert compile_once(key, build) is first and builds == [1]
    assert compile_once(("test_rc", 2), build) is not first and builds == [1, 1]


def test_an_unhashable_key_is_refused_naming_it():
    with pytest.raises(TypeError, match=r"compile_once: the key \['rc'\] is not hashable"):
        compile_once(["rc"], RC)


@pytest.mark.slow
def test_the_shipped_models_compile_through_it():
    from acausal.models.bench.calibration import replay_model
    from acausal.models.servo.model import compiled
    assert replay_model() is replay_model() and compiled() is compiled()
    assert any(k[0] == "ankle_eq4_replay" for k in _ONCE) and any(k[0] == "servo_pendulum" for k in _ONCE)
