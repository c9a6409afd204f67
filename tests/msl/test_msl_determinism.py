"""The ten MSL conformance examples give the same bytes in every fresh process, whatever the hash seed (the conformance suite's
goal: "deterministic across 10 fresh processes with different hash seeds").

Ten subprocesses, each with its own ``PYTHONHASHSEED``, two at a time, each compiling and running all ten examples
of ``tests/test_msl_conformance*.py`` from scratch at the default
settings (``sim.simulate(t_end)``), and writing as JSON, for each: the path that ran (``res.solver``), every event (time, number, zero function, direction), the
output times, a few trajectories at all outputs and the energy balance's residual, every float as its ``repr``
(the shortest string that reads back to the same double, so equal strings mean equal bits). An example that
fails records its error's type and message instead (none does: all ten run); LossyGearDemo3 also runs its
one-bearing-torque variant. In LossyGearDemo2 and LossyGearDemo3 the holding torques of elements stuck together
(their split, finding 3 of ``tests/msl/msl_conformance_findings.md``) are among the recorded signals.

The runs are shortened where the example's switching does not need the full time: the Rectifier to one mains
period (20 ms, 14 events), DiodeBridge2Pulse to one period, First and SeriesResonance (no switching) to 0.2 and
0.3 s; the stick/slip examples and DCPM_Start (its three time events) run their full time. Each process also
reports ``hash()`` of a fixed string, so the test sees that the seeds took effect.

Two tests on the same ten processes: the results, events compared by their zero function, must be byte-identical
(they are); and the events' numbers too (finding 5, fixed: a Ramp's two time events swapped their numbers with the
hash seed). Measured: about 5 s per process, the pair of tests 42-47 s on a two-core machine.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

#: each test here takes seconds (its simulations or its shared fixture): out of the quick lane
pytestmark = pytest.mark.slow

SEEDS = ("0", "1", "2", "3", "42", "1234", "31337", "65535", "2718281828", "4294967295")
ROOT = Path(__file__).resolve().parents[2]


def _examples():
    """(name, model factory, t_end, signals recorded) for the ten examples (eleven runs: LossyGearDemo3 twice)."""
    from tests.msl import test_msl_conformance as C
    from tests.msl import test_msl_conformance_circuits as E
    from tests.msl import test_msl_conformance_friction as F
    from tests.msl import test_msl_conformance_rectifier as R
    from tests.msl import test_msl_conformance_stickslip as S

    return [
        ("First", C.First, 0.2, ["inertia1.w", "inertia2.phi", "inertia3.w"]),
        ("DCPM_Start", C.DCPMStart, 2.0, ["dcpm.ia", "dcpm.wMechanical"]),
        ("CharacteristicIdealDiodes", E.CharacteristicIdealDiodes, 1.0,
         ["Ideal.i", "With_Ron_Goff.i", "With_Ron_Goff_Vknee.i", "With_Ron_Goff_Vknee.off"]),
        ("Rectifier", R.Rectifier, 0.02, ["Capacitor1.v", "Inductor1.i", "Inductor2.i", "D3.off"]),
        ("DiodeBridge2Pulse", E.DiodeBridge2PulseExample, 0.02, ["currentSensor.i", "rectifier.diode_p1.off"]),
        ("SeriesResonance", E.SeriesResonance, 0.3, ["currentSensor1.i", "capacitor2.v"]),
        ("LossyGearDemo1", S.LossyGearDemo, 0.5, ["Inertia1.w", "Inertia2.phi", "gear.tau_loss", "gear.stuck"]),
        ("LossyGearDemo2", lambda: S.LossyGearDemo(bearing=True), 0.5,
         ["Inertia1.w", "gear.stuck", "gear.sa", "bearingFriction.sa"]),
        ("LossyGearDemo3", S.LossyGearDemo3, 1.0,
         ["Inertia1.w", "gear.stuck", "gear.sa", "bearing_a.sa", "bearing_b.sa"]),
        ("LossyGearDemo3 (tau_bf2 = tau_bf1)", lambda: S.LossyGearDemo3(lumped=True), 1.0,
         ["Inertia1.w", "gear.tau_loss", "gear.stuck"]),
        ("Friction", F.Friction, 3.0, ["inertia1.w", "inertia2.w", "inertia3.phi", "clutch.stuck", "brake.tau"]),
    ]


def _run(factory, t_end, signals) -> dict:
    from acausal import AcausalError, compile_model

    try:
        sim = compile_model(factory())
        res = sim.simulate(t_end)
    except AcausalError as err:
        return {"error": f"{type(err).__name__}: {err}"}
    zeros = [str(z) for z in sim.event_zeros]
    return {"solver": res.solver,
            # each event: time, its index in sim.event_zeros, its zero function (what it is), direction
            "events": [[repr(float(t)), int(i), zeros[i] if i < len(zeros) else f"#{i}", str(direction)]
                       for t, i, direction in res.events],
            "t": [repr(float(v)) for v in res.t],
            "signals": {name: [repr(float(v)) for v in res[name]] for name in signals},
            "residual": repr(float(res.energy_balance().residual))}


def emit() -> None:
    """Run every example once and print the JSON record (what each subprocess does)."""
    out = {"hash": hash("acausal MSL determinism"), "examples": {}}
    for name, factory, t_end, signals in _examples():
        out["examples"][name] = _run(factory, t_end, signals)
    sys.stdout.write(json.dumps(out, sort_keys=True))


def _process(seed: str) -> tuple[str, subprocess.CompletedProcess]:
    env = {**os.environ, "PYTHONHASHSEED": seed}
    proc = subprocess.run([sys.executable, "-c", "from tests.msl.test_msl_determinism import emit; emit()"], cwd=ROOT,
                          env=env, capture_output=True, text=True, timeout=600)
    return seed, proc


def _first_difference(a: dict, b: dict) -> str:
    for name in a:
        if a[name] != b.get(name):
            for key in a[name]:
                if a[name][key] != b[name].get(key):
                    x, y = a[name][key], b[name].get(key)
                    if isinstance(x, dict):
                        key2 = next(k for k in x if x[k] != (y or {}).get(k))
                        x, y = x[key2], (y or {}).get(key2)
                        key = f"{key}[{key2}]"
                    if isinstance(x, list) and isinstance(y, list):
                        k = next((k for k, (u, v) in enumerate(zip(x, y)) if u != v), min(len(x), len(y)))
                        return f"{name}, {key}, item {k}: {x[k] if k < len(x) else '-'} against " \
                               f"{y[k] if k < len(y) else '-'}"
                    return f"{name}, {key}: {str(x)[:300]} against {str(y)[:300]}"
    return "the sets of examples differ"


def _without_event_numbers(examples: dict) -> dict:
    return {name: {**r, "events": [[t, zero, direction] for t, _, zero, direction in r["events"]]} if "events" in r
            else r for name, r in examples.items()}


@pytest.fixture(scope="module")
def records():
    """The JSON record of each of the ten processes, by seed (run once for the tests below)."""
    with ThreadPoolExecutor(max_workers=2) as pool:
        done = dict(pool.map(_process, SEEDS))
    for seed, proc in done.items():
        assert proc.returncode == 0, f"PYTHONHASHSEED={seed}: exit {proc.returncode}\n{proc.stderr[-3000:]}"
    out = {seed: json.loads(proc.stdout) for seed, proc in done.items()}
    # the seeds took effect: the same string hashes differently in (nearly) every process
    assert len({r["hash"] for r in out.values()}) >= len(SEEDS) - 1
    return out


def test_msl_examples_give_the_same_results_in_ten_processes_with_different_hash_seeds(records):
    """Solver, event times, zero functions and directions, outputs, trajectories and the balance's residual, or the
    error of an example that cannot run: the same bytes under all ten seeds (the events compared by their zero
    function, not by their number: see the next test)."""
    reference = records[SEEDS[0]]["examples"]
    assert len(reference) == len(_examples())
    ran = [name for name, r in reference.items() if "error" not in r]
    assert set(ran) == {name for name, *_ in _examples()}, ran
    for name in ("DCPM_Start", "Rectifier", "LossyGearDemo1", "LossyGearDemo2", "LossyGearDemo3 (tau_bf2 = tau_bf1)",
                 "Friction"):
        assert len(reference[name]["events"]) >= 3, name  # the shortened runs still switch
    for name, mode in (("CharacteristicIdealDiodes", "With_Ron_Goff_Vknee.off"),
                       ("DiodeBridge2Pulse", "rectifier.diode_p1.off")):  # no states: modes set sample by sample
        assert set(reference[name]["signals"][mode]) == {"0.0", "1.0"}, name
    reference = _without_event_numbers(reference)
    for seed in SEEDS[1:]:
        other = _without_event_numbers(records[seed]["examples"])
        same = json.dumps(other, sort_keys=True) == json.dumps(reference, sort_keys=True)
        assert same, f"PYTHONHASHSEED={seed} against {SEEDS[0]}: {_first_difference(reference, other)}"


def test_msl_examples_number_their_events_alike_in_ten_processes(records):
    """The same, with each event's number (its index in ``sim.event_zeros``, the order of the generated zero
    functions and of an exported FMU's event indicators) compared too (finding 5: a Ramp's two time events used to
    swap their numbers with the hash seed; they are now numbered in sympy's canonical order)."""
    reference = records[SEEDS[0]]["examples"]
    for seed in SEEDS[1:]:
        other = records[seed]["examples"]
        same = json.dumps(other, sort_keys=True) == json.dumps(reference, sort_keys=True)
        assert same, f"PYTHONHASHSEED={seed} against {SEEDS[0]}: {_first_difference(reference, other)}"
