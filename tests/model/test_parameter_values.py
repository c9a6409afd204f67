"""Parameter values that are not numbers are refused where they are given, naming the parameter (nothing
silently wrong): a string is not parsed into a number, a bool is not
taken as 1, and an array given to ``simulate`` (a batch) is pointed to the batch API instead of failing inside
numpy."""
import numpy as np
import pytest

from acausal import ModelError, compile_model
from acausal.library.electrical import Resistor

from ..circuit_models import RC


@pytest.fixture(scope="module")
def sim():
    return compile_model(RC(v_ref=1.0))


@pytest.mark.parametrize("value", ["0.5", "0.5 ohm", True, b"1", np.True_, np.array([True, False])])
def test_a_component_refuses_a_parameter_that_is_not_a_number(value):
    """numpy's bool too (it was a 1 ohm resistor that described itself as ``R = True Ohm``)."""
    with pytest.raises(ModelError, match=r"Resistor: parameter 'R' = .* is (a str|a bool|a bytes|an array of bool); "
                                         r"give a number \[Ohm\]"):
        Resistor(R=value)


@pytest.mark.parametrize("value", ["2.0", True])
def test_a_run_refuses_a_parameter_that_is_not_a_number(sim, value):
    with pytest.raises(ModelError, match=r"parameter 'R.R' of R: .* is a (str|bool), not a number \[Ohm\]"):
        sim.simulate(0.1, params={"R.R": value})


@pytest.mark.parametrize("value", [[2.0, 3.0], np.array([2.0, 3.0])])
def test_an_array_given_to_simulate_points_to_the_batch_api(sim, value):
    with pytest.raises(ModelError, match=r"simulate runs one parameter set, but 'R.R' is an array of values.*"
                                         r"simulate_many"):
        sim.simulate(0.1, params={"R.R": value})
    runs = sim.simulate_many(0.1, [{"R.R": 2.0}, {"R.R": 3.0}])  # what the message points to works
    assert runs[0]["C.v"][-1] > runs[1]["C.v"][-1] > 0.0


def test_numpy_numbers_are_numbers(sim):
    res = sim.simulate(0.1, params={"R.R": np.float32(2.0), "C.C": np.int64(1)})
    assert res["C.v"][-1] == pytest.approx(1 - np.exp(-0.1 / 2.0), rel=1e-5)


@pytest.mark.parametrize("value, why", [(-0.4, r"outside its bounds \[0.0, inf\] Ohm"), (float("nan"), "not finite"),
                                        (float("inf"), "not finite"),
                                        (np.int64(-1), r"outside its bounds \[0.0, inf\] Ohm"),
                                        (np.float32(np.nan), "not finite")])
def test_a_number_outside_the_bounds_is_refused_where_it_is_given(value, why):
    with pytest.raises(ModelError, match=rf"Resistor: parameter 'R' = .* is {why}"):
        Resistor(R=value)


def test_the_energy_of_a_component_is_the_power_into_it_through_all_its_ports(sim):
    """``res.energy("R")`` of a two-pin resistor: what flows in at p and out at n, its loss (``efficiency`` took
    the same name already)."""
    res = sim.simulate(1.0, rtol=1e-10, atol=1e-12)
    assert res.energy("R")[-1] == pytest.approx(res.energy("R.loss_power")[-1], rel=1e-6)


def test_none_for_a_parameter_is_refused_naming_its_default():
    """``Resistor(R=None)`` said "no value and no default" at compile time, though the default is 1 ohm."""
    with pytest.raises(ModelError, match=r"Resistor: parameter 'R' = None; give a number \[Ohm\] or leave it out for "
                                         r"its default 1.0 Ohm"):
        Resistor(R=None)
