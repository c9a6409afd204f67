"""Issue 39's hostile-user sweep (tests/trust_sweep_findings.md): each finding's reproduction, with the clear outcome
it now gets (an error naming the argument, option, key or file at fault, or a flagged answer). The test names
carry the finding's number."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from acausal import ModelError, compile_model

from .circuit_models import RC


@pytest.fixture(scope="module")
def rc():
    sim = compile_model(RC(v_ref=1.0, R=1.0, C=1.0))
    return sim, sim.simulate(1.0)


def test_3_energy_of_something_that_is_not_a_power_is_refused_and_an_efficiency_above_one_is_flagged(rc):
    sim, res = rc
    for name, unit in (("C.v", "V"), ("R.R", "Ohm"), ("C.energy", "J")):
        with pytest.raises(ModelError, match=rf"energy: '{name}' \[{unit}\] is not a power \(W\)"):
            res.energy(name)
    with pytest.raises(ModelError, match=r"efficiency: 'C.v' \[V\] is not a power"):
        res.energy_balance(between=("src", "C.v"))
    # ports, components and power variables still integrate; the source delivers what R loses and C stores
    e_src, e_loss = res.energy("src")[-1], res.energy("R.loss_power")[-1]
    assert e_src < 0 < e_loss  # power into the source is negative: it delivers
    assert abs(-e_src - e_loss - 0.5 * res["C.v"][-1] ** 2) < 1e-5 * -e_src  # rtol 1e-6 of the run
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        eta = res.energy_balance(between=("R.loss_power", "src")).efficiency
    assert eta > 1 and any("> 1" in str(w.message) and "ends reversed" in str(w.message) for w in caught)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a sane efficiency warns about nothing
        assert 0 < res.efficiency("src", "C") < 1


@pytest.mark.parametrize("window, message", [
    ((2.0, 3.0), r"window: t0 = 2 s is outside the run \(0..1 s\)"),
    ((0.8, 0.2), r"window: t0 = 0.8 s must be before t1 = 0.2 s"),
    (("a", 0.05), r"window: t0 must be a time in s \(a finite number\), got 'a'"),
    ((0.0, float("nan")), r"window: t1 must be a time in s"),
])
def test_4_an_energy_balance_window_outside_the_run_or_reversed_is_refused(rc, window, message):
    _, res = rc
    with pytest.raises(ModelError, match=message):
        res.energy_balance(*window)
    with pytest.raises(ModelError, match=message):
        res.sankey(None, *window)


def test_5_one_output_point_is_refused(rc):
    sim, _ = rc
    with pytest.raises(ModelError, match=r"n_points must be an integer >= 2 .* got 1; for one time give t_eval"):
        sim.simulate(1.0, n_points=1)
    assert sim.simulate(1.0, t_eval=[1.0]).t.tolist() == [1.0]  # one time, asked for as such


@pytest.mark.parametrize("settings, message", [
    (dict(rtol="1e-6"), r"simulate: rtol must be a number \(or one per state\), got the str '1e-6'"),
    (dict(rtol=float("inf")), r"simulate: rtol must be positive and below 1"),
    (dict(atol=float("inf")), r"simulate: atol must be finite and not negative"),
    (dict(atol=[1e-9, 1e-9]), r"simulate: atol has 2 values for 1 state \['C.v'\]"),
    (dict(rtol=[1e-6, 1e-6, 1e-6]), r"simulate: rtol has 3 values for 1 state"),
    (dict(max_step="0.01"), r"max_step must be a number, got the str '0.01'"),
    (dict(first_step=10.0, method="BDF"), r"first_step = 10 s is longer than the run \(1 s"),
    (dict(max_steps=3, method="CVODES"), r"max_steps limits a scipy integrator's steps; method='CVODES'"),
])
def test_6_integrator_settings_are_checked_naming_the_setting(rc, settings, message):
    sim, _ = rc
    with pytest.raises(ModelError, match=message):
        sim.simulate(1.0, **settings)
    if set(settings) <= {"rtol", "atol"}:  # the tolerances are sensitivities' settings too
        with pytest.raises(ModelError, match=message.replace("simulate", "sensitivities")):
            sim.sensitivities([0.0, 1.0], ["R.R"], **settings)


def test_6_one_tolerance_per_state_is_taken(rc):
    sim, _ = rc
    res = sim.simulate(1.0, atol=[1e-9], rtol=[1e-6])
    assert abs(res["C.v"][-1] - (1 - np.exp(-1.0))) < 1e-5


def test_19_the_result_and_batch_api_name_the_argument_at_fault(rc, tmp_path):
    sim, res = rc
    for key in (0, None, ["C.v"]):
        with pytest.raises(ModelError, match=r"index it by a variable's name \(a str"):
            res[key]
        assert key not in res if not isinstance(key, list) else True
    for between in (("src",), "src", 3):
        with pytest.raises(ModelError, match=r"between must be a pair \(a, b\) of names"):
            res.energy_balance(between=between)
    with pytest.raises(ModelError, match=r"names: pattern must be a str"):
        res.names(3)
    with pytest.raises(ModelError, match=rf"to_csv: {tmp_path} is a folder; give a file path"):
        res.to_csv(tmp_path)
    with pytest.raises(ModelError, match=r"to_csv: the folder /no/such/dir of /no/such/dir/x.csv does not exist"):
        res.to_csv("/no/such/dir/x.csv")
    with pytest.raises(ModelError, match=r"sankey: ax must be a matplotlib Axes"):
        res.sankey(ax=3)
    with pytest.raises(ModelError, match=r"simulate_many: params\[0\] is 1, not a dict of parameter overrides"):
        sim.simulate_many(1.0, [1, 2])
    from acausal.sweep import sweep
    with pytest.raises(ModelError, match=r"sweep: args must be a list .* got 5"):
        sweep(abs, 5, executor="serial")
    with pytest.raises(ModelError, match=r"sweep: fn must be a function"):
        sweep(3, [1], executor="serial")
    assert sweep(abs, [-1, 2], executor="serial") == [1, 2]


@pytest.mark.parametrize("call, message", [
    (lambda sim: sim.simulate("1.0"), r"t_end must be a number, got the str '1.0'"),
    (lambda sim: sim.simulate(True), r"t_end must be a number, got the bool True"),
    (lambda sim: sim.simulate(1.0, t_start="0.05"), r"t_start must be a number, got the str"),
    (lambda sim: sim.simulate(1.0, dense_output="no"), r"dense_output must be True or False, got 'no'"),
    (lambda sim: sim.simulate_many(1.0, [{}], dense_output="no"), r"dense_output must be True or False"),
    (lambda sim: sim.simulate(1.0, starts={"C.v": "1"}), r"start value of 'C.v' must be a number, got the str"),
    (lambda sim: sim.sensitivities([0.0, 1.0], ["R.R"], substeps=-1), r"substeps must be a positive integer"),
    (lambda sim: sim.device_defaults({"R.RR": 1}), r"unknown parameter 'R.RR' .* did you mean 'R.R'"),
])
def test_23_loose_acceptance_in_simulate_and_friends_is_gone(rc, call, message):
    sim, _ = rc
    with pytest.raises(ModelError, match=message):
        call(sim)


def test_23_max_steps_is_honoured_on_auto_by_the_scipy_path(rc):
    sim, _ = rc
    from acausal import SimulationError
    with pytest.raises(SimulationError, match=r"took 3 steps"):
        sim.simulate(1.0, max_steps=3)
    res = sim.simulate(1.0, max_steps=100_000)
    assert "max_steps" in res.solver
