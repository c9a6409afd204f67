"""Backend parity (issue 38, item 3): every shipped model and the MSL conformance examples run on every backend
that accepts them, and the backends agree.

Backends: the scipy path (``method="BDF"``, the reference; ``method="Radau"`` on three models with diode and breaker
events), the compiled path (``method="CVODES"``: CasADi CVODES, or IDAS for a model with a Newton block) and an
exported FMI 2.0 Model Exchange FMU run by fmpy (its CVODE and the FMU's C event iteration). Models:

* every model of ``acausal compare --list`` (:mod:`acausal.models.ankle.registry`), as the protocol runs it
  (library preset, 8 mm, 1.2 s/stride, the model's condition inputs); the windings run the replay's FMU with
  their parameters set through FMI;
* the paper's Eq. (4) bench model in closed loop with gear backlash (the virtual bench's truth, outside the
  registry);
* the servo on a pendulum (:mod:`acausal.models.servo.model`) replaying a shipped recording;
* every model of the users' guide (``docs/*.md``: the chapters' imports, classes and the assignments those use,
  nothing of their runs), those that no backend can run checked to fail alike on both paths;
* the ten MSL conformance examples (``tests/test_msl_determinism.py``'s list, eleven runs);
* the models ``tests/test_fmu.py`` exports.

Each run is short (a fraction of a second to 1.6 s of model time) but still switches where the model has events
(the registry's rectifier and brake chopper, diodes, stick/slip, breaker, sampling and time events). Agreement:
every state within :data:`STATE_TOL` (1e-6) of its range over the reference run, the same events (count, zero
function and direction, in order), their times within :data:`EVENT_TOL` (1e-9 s). The runs are tight (rtol 1e-10,
atol 1e-12; rtol 1e-11 where from 1e-10 to 1e-11 the reference itself moves an event by more than 1e-9 s, measured
at the case; fmpy's CVODE at rtol 1e-11, or 1e-10 where 1e-11 makes it give up, mxstep). A model the compiled path
cannot run is refused before integrating: ``method="CVODES"`` raises a ModelError naming the construct and the
component, and ``method="auto"`` runs the scipy path saying why in ``res.solver``; the exporter refuses it the
same way (ExportError). A model without states is evaluated algebraically at the output times whatever the method
(no integrator, no located events): there the FMU is the second backend. Measured disagreements are strict xfails
with their numbers.

The last test prints the model x backend table (``pytest -s``). Each model is compiled, exported and run once per
module (module-level caches); the module takes about 55-65 s on the two-core machine of the CI (one core: the
runs are serial; most of the time is compiling 50 models, the BDF references at tight tolerances and the C
compiler of 30 FMUs).
"""
from __future__ import annotations

import ast
import functools
import re
import time as clock
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

from acausal import ModelError, SimulationError, compile_model
from acausal.trust import UntrustedResult

STATE_TOL = 1e-6  # max |x - x_ref| over the run, per state, relative to the state's range in the reference run
EVENT_TOL = 1e-9  # s
TIGHT = dict(rtol=1e-10, atol=1e-12)
TIGHTER = dict(rtol=1e-11, atol=1e-13)
REFUSED_TOL = dict(rtol=1e-8, atol=1e-10)  # a model only the scipy path runs: nothing to compare its run with
FMU_RTOL = 1e-11  # fmpy's CVODE (its atol is rtol times the states' nominal values, 1 here)
STRIDE, PRECOMPRESSION = 1.2, 0.008  # the registry's runs: the paper's fastest stride, 8 mm
DOCS = Path(__file__).resolve().parents[1] / "docs"


@dataclass(frozen=True)
class Case:
    """One model and its run. ``build()`` gives ``(compiled model, simulate keywords)`` (params, inputs, starts);
    ``refused``: substrings the compiled path's refusal names (the construct and the component), empty when it
    takes the model; ``min_events``: the run must switch at least this often; ``state_tol``/``event_tol``/``tol``:
    loosened or tightened only with the measured reason in ``note``; ``fmu``: also export it and run the FMU
    (``"refused: ..."``: the exporter must refuse it naming these substrings, ``|``-separated); ``xfail`` /
    ``fmu_xfail``: a measured disagreement of the compiled path / the FMU (strict); ``fmu_of``: run the FMU
    of that case, this case's parameters set through FMI."""

    name: str
    group: str
    build: object
    t_end: float
    n_points: int = 101
    tol: dict = field(default_factory=lambda: dict(TIGHT))
    state_tol: float = STATE_TOL
    event_tol: float = EVENT_TOL
    min_events: int = 1
    refused: tuple = ()
    fmu: str = ""
    fmu_signals: tuple = ()
    fmu_event_tol: float = EVENT_TOL
    fmu_rtol: float = FMU_RTOL
    fmu_xfail: str = ""
    fmu_start_events: str = ""
    fmu_of: str = ""
    note: str = ""
    xfail: str = ""


# ------------------------------------------------------------------------------------------------ the models
@functools.lru_cache(maxsize=None)
def _registry(name):
    """A registered model as the protocol runs it (library preset, 8 mm, 1.2 s/stride, its condition inputs)."""
    from acausal.models.ankle.presets import preset
    from acausal.models.ankle.protocol import compiled
    from acausal.models.ankle.registry import spec

    s, cm = spec(name), compiled(name).sim
    params = {k: v for k, v in preset("library").items() if cm.has_parameter(k)}
    params.update({**s.params, "stride_time": STRIDE})
    if s.uses_precompression:
        params["P_nominal"] = PRECOMPRESSION
    values = dict(zip(cm.param_names, cm.param_vector(params)))
    return cm, dict(params=params, inputs=s.condition_inputs(values) or None)


@functools.lru_cache(maxsize=None)
def _actuator(variant):
    """The paper's Eq. (4) bench model in closed loop, as the virtual bench runs it (its truth values), with a
    hidden effect at its typical size."""
    from acausal.models.ankle.actuator import AnkleActuator
    from acausal.models.ankle.effects import effect
    from acausal.models.bench.virtual import truth_values

    effects = {"closed loop": (), "closed loop, gear backlash": ("gear_backlash",)}[variant]
    cm = compile_model(AnkleActuator.eq4(mode="closed_loop", effects=effects))
    params = {**truth_values(), "stride_time": STRIDE, "P_nominal": PRECOMPRESSION}
    params.update({effect(e).parameter: effect(e).typical for e in effects})
    return cm, dict(params=params)


@functools.lru_cache(maxsize=None)
def _servo():
    """The servo replaying the first shipped recording with BAM's M1 parameters (docs/real-data-servo.md)."""
    from importlib import resources

    from acausal.identify import load_recordings
    from acausal.models.servo import bam
    from acausal.models.servo.model import compiled
    from acausal.models.servo.recording_format import SERVO_FORMAT, inputs, rig_params, start

    folder = resources.files("acausal.models.servo").joinpath("data/xl330/recordings")
    rec = load_recordings(str(folder), SERVO_FORMAT)[0]
    m1 = bam.mapped(bam.published()["sets"]["main m1"])
    cm = compiled(("coulomb",))
    return cm, dict(params={**rig_params(rec.meta), **m1}, inputs=inputs(rec), starts=start(rec))


def _doc_nodes(chapter):
    """The top-level statements of a users' guide chapter's code blocks, in order, with their first lines."""
    from .test_docs import python_blocks

    nodes = []
    for line, code in python_blocks(DOCS / chapter):
        try:
            nodes += [(line, node) for node in ast.parse(code).body]
        except SyntaxError:
            continue
    return nodes


def _names_used(node):
    return {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}


@functools.lru_cache(maxsize=None)
def _doc_namespace(chapter):
    """A chapter's imports and class definitions, and the assignments those classes use (nothing is simulated,
    compiled or exported: the chapter's runs are tests/test_docs.py's)."""
    nodes = _doc_nodes(chapter)
    needed = set().union(*[_names_used(n) for _, n in nodes if isinstance(n, ast.ClassDef)])
    assigns = [n for _, n in nodes if isinstance(n, ast.Assign)]
    while True:  # and what those assignments use in turn
        more = set().union(set(), *[_names_used(n.value) for n in assigns
                                    if _names_used(ast.Module(n.targets, [])) & needed]) - needed
        if not more:
            break
        needed |= more
    ns = {"__name__": f"docs.{Path(chapter).stem}"}
    for line, node in nodes:
        if isinstance(node, ast.Assign) and not _names_used(ast.Module(node.targets, [])) & needed:
            continue
        if isinstance(node, (ast.Import, ast.ImportFrom, ast.ClassDef, ast.Assign)):
            exec(compile(ast.Module([node], []), f"{DOCS / chapter}:{line}", "exec"), ns)
    return ns


def _doc_models(chapter):
    """The names of the Model classes a chapter defines (from its code, without running it)."""
    models = set()
    for _, node in _doc_nodes(chapter):
        if isinstance(node, ast.ClassDef) and any(isinstance(b, ast.Name) and (b.id == "Model" or b.id in models)
                                                  for b in node.bases):
            models.add(node.name)
    return models


@functools.lru_cache(maxsize=None)
def _doc(chapter, cls, args=(), params=()):
    model = _doc_namespace(chapter)[cls](*args)
    return compile_model(model), dict(params=dict(params) or None)


@functools.lru_cache(maxsize=None)
def _msl(name):
    from .test_msl_determinism import _examples

    factory = {n: f for n, f, *_ in _examples()}[name]
    return compile_model(factory()), {}


@functools.lru_cache(maxsize=None)
def _fmu_model(name):
    """A model tests/test_fmu.py exports: from the shared modules, or from test_fmu itself (which skips on
    import without fmpy and a C compiler: so do those cases here)."""
    from importlib import import_module

    from . import circuit_models, drive_models

    for module in (drive_models, circuit_models):
        if hasattr(module, name):
            return compile_model(getattr(module, name)()), {}
    return compile_model(getattr(import_module("tests.test_fmu"), name)()), {}


def registry(name, t_end=0.05, **kw):
    return Case(name, "registry", lambda: _registry(name), t_end, **kw)


def actuator(variant, t_end=0.05, **kw):
    return Case(f"AnkleActuator.eq4: {variant}", "actuator", lambda: _actuator(variant), t_end, **kw)


def doc(chapter, cls, t_end, args=(), params=(), label="", **kw):
    return Case(f"docs/{chapter}: {label or cls}", "docs",
                lambda: _doc(chapter, cls, tuple(args), tuple(params)), t_end, **kw)


def msl(name, t_end, **kw):
    return Case(f"MSL {name}", "msl", lambda: _msl(name), t_end, **kw)


def fmu_test(name, t_end, **kw):
    return Case(f"tests/test_fmu.py: {name}", "fmu", lambda: _fmu_model(name), t_end, **kw)


#: measured disagreement (finding of this suite): the FMU of MSL DiodeBridge2Pulse (no states) switches diodes
#: n1 and p2 on at the source's zero crossing (t = 0.01000000000000012 s) but never switches p1 and n2 off: all four
#: conduct from then on, p1 and n2 backwards (rectifier.diode_p1.i = rectifier.diode_p1.s = -4.57e6 A at 0.012 s,
#: their zero functions far below zero, no event), the load current currentSensor.i is 0 (|i| < 3e-9 A) where
#: simulate() (and the MSL) has the rectified sine: 2.4036 A at 0.011 s, 7.7782 A at 0.015 s, with
#: diode_p1.off = diode_n2.off = 1. Up to 0.01 s the two agree to 1e-15 relative.
BRIDGE2_FMU = ("the FMU of DiodeBridge2Pulse never turns diodes p1 and n2 off after the zero crossing at 0.01 s: "
               "all four conduct, currentSensor.i = 0 instead of the rectified sine (7.7782 A at 0.015 s)")
#: the turn-off of a half-wave rectifier's ideal diode (its current through R || C falling through zero) is where
#: the tolerance shows most: at rtol 1e-10 CVODES and BDF put it 2.6e-9 to 3.6e-9 s apart, at 1e-11 1.6e-10 s, at
#: 1e-12 1.5e-11 s (both converge to 0.0090310791 s): these run at rtol 1e-11
HALF_WAVE = "rtol 1e-11: the diode's turn-off moves by 2.6e-9 s between rtol 1e-10 and 1e-11"
#: fmpy's CVODE at rtol 1e-11 (atol 1e-11) stops on these (mxstep: MotorGearLoad at 3.5 ms, its inverse at 2.2 ms,
#: SplineReplay at 2.2 ms, Bridge6 at 46 ns, the inductor's 0.1 ms time constant): 1e-10, as tests/test_fmu.py
FMU_1E10 = dict(fmu_rtol=1e-10, note="fmpy at rtol 1e-10: at 1e-11 its CVODE stops (mxstep)")
CASES = [
    # ---- acausal compare --list: rectifier diode and brake chopper from 14 ms on (the windings' from 0.6 ms)
    registry("replay", fmu="yes"),
    registry("closed_loop", 0.03, fmu="yes"),
    registry("direct_drive", fmu="yes"),
    registry("bench_output_motor", fmu="yes"),
    registry("sea", fmu="yes"),
    registry("parallel_elastic", fmu="yes"),
    registry("self_locking", fmu="yes"),
    registry("switch_off", tol=dict(REFUSED_TOL),
             refused=("input 'arm_ref.profile'", "HeldReference", "neither a table nor a symbolic form"),
             fmu="refused: input 'arm_ref.profile' of arm_ref|HeldReference|neither a table nor a symbolic form"),
    registry("winding_24V", 0.02, fmu="yes", fmu_of="replay"),
    registry("winding_36V", 0.02, fmu="yes", fmu_of="replay"),
    registry("battery", min_events=0, fmu="yes", fmu_signals=("P_source.P", "motor.i", "driver.d")),
    # ---- the paper's Eq. (4) bench model (the virtual bench's truth), outside the registry
    actuator("closed loop, gear backlash", min_events=0),
    # ---- the servo (smooth friction law: no events)
    Case("servo: ServoPendulum (XL330 recording, BAM M1)", "servo", _servo, 0.2, min_events=0),
    # ---- the users' guide
    doc("getting-started.md", "MotorGearLoad", 0.1, min_events=0),
    doc("energy-chain.md", "SmallDrive", 0.2, min_events=0),
    doc("fmu-export.md", "Drive", 0.5, min_events=0, fmu="yes"),
    # (docs/simulation-paths.md's HalfWave and tests/test_fmu.py's are the same circuit)
    doc("fmu-export.md", "HalfWave", 0.025, tol=dict(TIGHTER), note=HALF_WAVE, fmu="yes"),
    doc("friction-and-gears.md", "GearWindsSpring", 1.0, args=("events",), label="GearWindsSpring('events')",
        min_events=0, fmu="yes", fmu_signals=("gear.flange_a.tau", "gear.backdriven")),
    doc("friction-and-gears.md", "GearWindsSpring", 1.0, args=("smooth",), label="GearWindsSpring('smooth')",
        min_events=0),
    doc("friction-and-gears.md", "DrivenStickSlip", 0.3, tol=dict(TIGHTER),
        note="rtol 1e-11: at 1e-10 the gear's stick/slip events lie 1.2e-9 s apart"),
    doc("friction-and-gears.md", "Creep", 0.2, min_events=0),
    doc("friction-and-gears.md", "SwingArm", 1.0, min_events=0),
    doc("index-reduction.md", "Geared", 0.5, min_events=0),
    doc("index-reduction.md", "InverseDrive", 0.5, min_events=0),
    doc("index-reduction.md", "DiodeCircuit", 1e-3, min_events=0),
    doc("real-data-servo.md", "Pushed", 0.2, min_events=0),
    doc("sea-position-control.md", "SEA", 0.15),
    doc("sign-conventions.md", "SourceAndLoad", 1.0, min_events=0),
    doc("sign-conventions.md", "SwappedVoltagePath", 1.0, min_events=0),
    doc("sign-conventions.md", "DrivenDamper", 1.0, min_events=0),
    doc("simulation-paths.md", "RC", 0.04, min_events=0),
    doc("simulation-paths.md", "DiodeDischarge", 0.1, args=(4.3,), label="DiodeDischarge(guess=4.3)",
        min_events=0),
    doc("writing-components.md", "Oscillator", 0.5, min_events=0),
    doc("writing-components.md", "Powered", 1.0, min_events=0),
    doc("writing-components.md", "TripCircuit", 0.5),
    doc("writing-components.md", "Mains", 0.04),
    doc("writing-components.md", "Shaken", 1.0, min_events=0),
    # ---- the MSL conformance examples (tests/test_msl_determinism.py's runs, some shortened further)
    msl("First", 0.2, fmu="yes"),
    msl("DCPM_Start", 1.6, fmu="yes"),
    msl("CharacteristicIdealDiodes", 1.0, fmu="yes", min_events=0,
        fmu_signals=("Ideal.i", "With_Ron_Goff.i", "With_Ron_Goff_Vknee.i", "With_Ron_Goff_Vknee.off")),
    msl("Rectifier", 0.01, fmu="yes"),
    msl("DiodeBridge2Pulse", 0.02, fmu="yes", min_events=0,
        fmu_signals=("currentSensor.i", "rectifier.diode_p1.off"), fmu_xfail=BRIDGE2_FMU),
    msl("SeriesResonance", 0.05, fmu="yes", min_events=0),
    msl("LossyGearDemo1", 0.5, fmu="yes"),
    msl("LossyGearDemo2", 0.1, tol=dict(REFUSED_TOL),
        refused=("block of 'bearingFriction.sa', 'gear.sa'", "undetermined", "weighted least-norm"),
        fmu="refused: block of 'bearingFriction.sa', 'gear.sa'|StickSlipGear 'gear'|least-norm"),
    msl("LossyGearDemo3", 0.3, tol=dict(REFUSED_TOL),
        refused=("block of 'bearing_a.sa', 'bearing_b.sa', 'gear.sa'", "undetermined", "weighted least-norm"),
        fmu="refused: block of 'bearing_a.sa', 'bearing_b.sa', 'gear.sa'|StickSlipGear 'gear'|least-norm"),
    msl("LossyGearDemo3 (tau_bf2 = tau_bf1)", 1.0, fmu="yes"),
    msl("Friction", 0.7, fmu="yes", tol=dict(TIGHTER),
        note="rtol 1e-11: from 1e-10 to 1e-11 the reference's clutch events move by up to 2.4e-9 s"),
    # ---- the models tests/test_fmu.py exports (its HalfWave is docs/fmu-export.md's; its actuator runs above)
    fmu_test("MotorGearLoad", 0.5, min_events=0, fmu="yes", **FMU_1E10),
    fmu_test("MotorGearLoadInverse", 0.5, min_events=0, fmu="yes", **FMU_1E10),
    fmu_test("BoundRC", 0.1, min_events=0, fmu="yes"),
    fmu_test("SplineReplay", 0.5, min_events=0, fmu="yes", **FMU_1E10),
    fmu_test("SampledDrive", 0.4, min_events=0, fmu="yes"),
    fmu_test("Bridge6", 0.01, fmu="yes", **FMU_1E10, fmu_start_events=(
        "at t = 0 two diodes sit exactly at zero and leave it: whether one switches while the modes settle or at "
        "the start event is up to round-off (-9e-16 in the C, 0 in Python; tests/test_fmu.py)")),
]
BY_NAME = {c.name: c for c in CASES}
assert len(BY_NAME) == len(CASES)


# ------------------------------------------------------------------------------------------------ measuring
TABLE: dict = {}  # case name -> {backend: cell text}


def _cell(case, backend, text):
    TABLE.setdefault(case.name, {})[backend] = text


@functools.lru_cache(maxsize=None)
def model(name):
    return BY_NAME[name].build()


def _grid(case):
    return dict(n_points=case.n_points, dense_output=False, **case.tol)


def _state_deviation(cm, X, X_ref):
    """``(worst relative deviation, its state)``: max |X - X_ref| per state over its range in ``X_ref`` (a state
    that does not move: over its magnitude, at least 1)."""
    if not cm.state_names:
        return 0.0, ""
    span = np.ptp(X_ref, axis=1)
    span = np.where(span > 0, span, np.maximum(np.max(np.abs(X_ref), axis=1), 1.0))
    dev = np.max(np.abs(np.asarray(X) - X_ref), axis=1) / span
    k = int(np.argmax(dev))
    return float(dev[k]), cm.state_names[k]


def _event_deviation(events, ref_events):
    """``(same sequence of zero functions and directions, max |t - t_ref|)``."""
    same = len(events) == len(ref_events) and all(a[1:] == b[1:] for a, b in zip(events, ref_events))
    dt = max((abs(float(a[0]) - float(b[0])) for a, b in zip(events, ref_events)), default=0.0)
    return same, dt


@functools.lru_cache(maxsize=None)
def reference(name):
    """The scipy path's run (BDF): the reference. For a model the compiled path refuses, ``method="auto"``'s run,
    which is that (the test checks its ``res.solver``)."""
    case = BY_NAME[name]
    cm, kw = model(name)
    t0 = clock.perf_counter()
    res = cm.simulate(case.t_end, method="auto" if case.refused else "BDF", **kw, **_grid(case))
    return res, clock.perf_counter() - t0


@functools.lru_cache(maxsize=None)
def compiled_run(name):
    """``(result or None, refusal message or None, seconds)`` of ``method="CVODES"``."""
    case = BY_NAME[name]
    cm, kw = model(name)
    t0 = clock.perf_counter()
    try:
        res = cm.simulate(case.t_end, method="CVODES", **kw, **_grid(case))
    except ModelError as exc:
        return None, str(exc), clock.perf_counter() - t0
    return res, None, clock.perf_counter() - t0


def _compiled_available():
    from acausal.compiled import available

    if not available():
        pytest.skip("the compiled path is off (CasADi missing, or --scipy-path)")


def _xfail(reason):
    return [pytest.mark.xfail(strict=True, reason=reason)] if reason else []


ACCEPTED = [pytest.param(c, id=c.name, marks=_xfail(c.xfail)) for c in CASES if not c.refused]
REFUSED = [pytest.param(c, id=c.name) for c in CASES if c.refused]
EXPORTED = [pytest.param(c, id=c.name, marks=_xfail(c.fmu_xfail)) for c in CASES if c.fmu == "yes"]
EXPORT_REFUSED = [pytest.param(c, id=c.name) for c in CASES if c.fmu.startswith("refused")]


# ------------------------------------------------------------------------------------------------ the tests
def _verdict(ok, dev, same, dt, n, n_ref, what="states"):
    """A table cell: agrees or DIFFERS, with the measured deviations."""
    text = f"{'agrees' if ok else 'DIFFERS'}: {what} {dev:.1e} of range"
    if not same:
        return text + f", {n} events against {n_ref}"
    return text + (f", {n} events within {dt:.1e} s" if n else "")


@pytest.mark.parametrize("case", ACCEPTED)
def test_compiled_path_agrees_with_the_scipy_path(case):
    """The compiled path takes the model (``method="CVODES"`` runs it, ``method="auto"`` takes it: its
    ``simulation_path``), and agrees with BDF: states within ``state_tol`` of their range, the same events at
    times within ``event_tol``. A model without states is evaluated algebraically whatever the method (CVODES
    too): the same values."""
    _compiled_available()
    cm, kw = model(case.name)
    ref, _ = reference(case.name)
    _cell(case, "scipy (BDF)", f"reference: {len(ref.events)} events")
    fast, refusal, _ = compiled_run(case.name)
    assert refusal is None, refusal
    if not cm.state_names:
        _cell(case, "compiled (CasADi)", "n/a: no states (evaluated algebraically at the output times, whatever "
                                         "the method)")
        for name in cm.names()[:20] + list(case.fmu_signals):
            np.testing.assert_array_equal(fast[name], ref[name], err_msg=name)
        return
    assert fast.solver.startswith(("CVODES", "IDAS")), fast.solver  # not a failed run redone on the scipy path
    assert cm.simulation_path(kw.get("inputs")).startswith("compiled"), cm.simulation_path(kw.get("inputs"))
    dev, worst = _state_deviation(cm, fast.states, ref.states)
    same, dt = _event_deviation(fast.events, ref.events)
    ok = dev < case.state_tol and same and dt < case.event_tol
    _cell(case, "compiled (CasADi)", f"{fast.solver.split()[0]} " + _verdict(ok, dev, same, dt, len(fast.events),
                                                                              len(ref.events)))
    assert len(ref.events) >= case.min_events, f"the run does not switch: {ref.events}"
    assert np.array_equal(fast.t, ref.t)
    assert dev < case.state_tol, f"{worst}: {dev:.3g} of its range"
    assert same, (fast.events, ref.events)
    assert dt < case.event_tol, f"event times differ by {dt:.3g} s: {fast.events} vs {ref.events}"


@pytest.mark.parametrize("case", REFUSED)
def test_compiled_path_refuses_naming_the_construct_and_the_component(case):
    """``method="CVODES"`` raises a ModelError before integrating, naming what the compiled path cannot run and
    where; ``method="auto"`` runs the scipy path (BDF) and says why in ``res.solver``, as ``simulation_path``."""
    _compiled_available()
    cm, kw = model(case.name)
    fast, refusal, seconds = compiled_run(case.name)
    assert fast is None and refusal is not None
    why = refusal.split("cannot take the compiled path: ", 1)[-1]
    _cell(case, "compiled (CasADi)", f"refused: {why}")
    for part in case.refused:
        assert part in refusal, (part, refusal)
    assert seconds < 1.0  # before integrating (the run itself takes seconds on the scipy path)
    res, _ = reference(case.name)  # method="auto"
    _cell(case, "scipy (BDF)", f"reference, what method='auto' falls back to (res.solver says why): "
                               f"{len(res.events)} events")
    assert res.solver == f"BDF (scipy: {why})", res.solver
    assert cm.simulation_path(kw.get("inputs")) == f"scipy BDF: {why}"
    assert len(res.events) >= case.min_events


#: measured disagreement (finding of this suite): scipy's Radau on the half-wave rectifier (an IdealDiode into
#: R || C, docs/simulation-paths.md) finds spurious crossings of the diode's zero function while it conducts, each
#: a falling event and a rising one 1e-12 s later: at rtol 1e-11, atol 1e-13 over 0.025 s, 10 events against BDF's,
#: CVODES's and the FMU's 2, its turn-off at 0.0090425534 s instead of 0.0090310793 s (11.5 us late), C.v off by
#: 1.8e-5 of its range; at rtol 1e-8 over 0.04 s, 104 events against 4, C.v off by 0.0229 V (2.3e-3 of its range).
#: The trust checks pass it (res.trust == []).
RADAU_HALF_WAVE = ("method='Radau' on the half-wave rectifier: spurious diode off/on event pairs 1e-12 s apart while "
                   "it conducts (10 events against 2 in 0.025 s at rtol 1e-11), the turn-off 11.5 us late, C.v off "
                   "by 1.8e-5 of its range")
#: the same in the six-pulse bridge (tests/circuit_models.py): at rtol 1e-10, atol 1e-12 over 0.01 s, 24 events
#: against 8, the 16 more off/on pairs 1e-12 s apart (the first at 0.0010071056 s, diode 5), C.v off by 1.6e-6 of its
#: range (2.8e-4 V at 0.0092 s); the 8 real commutations within 4e-11 s of BDF's
RADAU_BRIDGE = ("method='Radau' on the six-pulse diode bridge: 8 spurious off/on event pairs 1e-12 s apart (24 "
                "events against 8 in 0.01 s at rtol 1e-10), C.v off by 1.6e-6 of its range")
RADAU = [pytest.param(BY_NAME["docs/fmu-export.md: HalfWave"], id="docs/fmu-export.md: HalfWave",
                      marks=_xfail(RADAU_HALF_WAVE)),
         pytest.param(BY_NAME["tests/test_fmu.py: Bridge6"], id="tests/test_fmu.py: Bridge6",
                      marks=_xfail(RADAU_BRIDGE)),
         pytest.param(BY_NAME["docs/writing-components.md: TripCircuit"], id="docs/writing-components.md: TripCircuit")]


@pytest.mark.parametrize("case", RADAU)
def test_radau_agrees_with_bdf(case):
    """The scipy path's other implicit integrator on models with diode and breaker events: states and events as
    BDF's (the same bounds)."""
    cm, kw = model(case.name)
    ref, _ = reference(case.name)
    res = cm.simulate(case.t_end, method="Radau", **kw, **_grid(case))
    dev, worst = _state_deviation(cm, res.states, ref.states)
    same, dt = _event_deviation(res.events, ref.events)
    ok = dev < case.state_tol and same and dt < case.event_tol
    _cell(case, "scipy (Radau)", _verdict(ok, dev, same, dt, len(res.events), len(ref.events)))
    assert dev < case.state_tol, f"{worst}: {dev:.3g} of its range"
    assert same, (res.events, ref.events)
    assert dt < case.event_tol


STATELESS = [pytest.param(c, id=c.name) for c in CASES if c.min_events == 0 and c.name in (
    "battery", "MSL DiodeBridge2Pulse", "MSL CharacteristicIdealDiodes", "docs/index-reduction.md: InverseDrive")]


@pytest.mark.parametrize("case", STATELESS)
def test_a_model_without_states_says_how_it_ran(case):
    """Issue 38: ``res.solver`` says which path ran. A model without states is evaluated algebraically at the
    output times, whatever the method (``method="CVODES"`` is not refused: there is nothing to integrate), and
    ``res.solver`` says so in ``cm.simulation_path()``'s words (it was '', found by this suite)."""
    cm, kw = model(case.name)
    assert not cm.state_names
    path = cm.simulation_path(kw.get("inputs"))
    assert path.startswith("algebraic")
    res, _ = reference(case.name)
    assert res.solver == path, repr(res.solver)
    fast, refusal, _ = compiled_run(case.name)
    assert refusal is None and fast.solver == path


#: models of the users' guide that no backend can run, each failing as the chapter shows: the compiled path and
#: the scipy path fail alike (the same error; an untrusted result's message the same but for its numbers)
FAILING = {"docs/fmu-export.md: Latched": ("fmu-export.md", "Latched", (), 2.0, SimulationError),
           "docs/friction-and-gears.md: DrivenGear('events')": ("friction-and-gears.md", "DrivenGear", ("events",), 0.3,
                                                               SimulationError),
           "docs/simulation-paths.md: DiodeDischarge()": ("simulation-paths.md", "DiodeDischarge", (), 0.1,
                                                         SimulationError),
           "docs/simulation-paths.md: NanoOhm": ("simulation-paths.md", "NanoOhm", (), 1.0, UntrustedResult)}
#: models of the users' guide that are not run here, and why
NOT_RUN = {"writing-components.md": {"Cable": "a composite with ports, run inside Powered",
                                     "Broken": "does not compile (StructureError, before any backend)"}}


@pytest.mark.parametrize("name", list(FAILING))
def test_a_model_that_cannot_run_fails_alike_on_both_paths(name):
    """A chattering event (no consistent mode), a Newton block that cannot start, a result the trust checks
    reject: ``method="CVODES"`` and ``method="BDF"`` raise the same error."""
    _compiled_available()
    chapter, cls, args, t_end, error = FAILING[name]
    cm, _ = _doc(chapter, cls, args)
    messages = []
    for method in ("CVODES", "BDF"):
        with pytest.raises(error) as err:
            cm.simulate(t_end, method=method, max_events=50)
        messages.append(str(err.value))
    if error is UntrustedResult:  # the path and the measured sizes differ, the verdict and its reasons not
        messages = [re.sub(r"\d[\d.e+-]*", "#", m.split("cannot be trusted: ", 1)[1]) for m in messages]
    assert messages[0] == messages[1], messages


def test_every_model_of_the_users_guide_is_a_case():
    """Every Model class a chapter defines runs here (a case, or a model that fails alike), or says why not."""
    from .test_docs import doc_files

    cased = {c.name.split(": ", 1)[1].split("(")[0] for c in CASES if c.group == "docs"}
    cased |= {name.split(": ", 1)[1].split("(")[0] for name in FAILING}
    missing = [f"{path.name}: {k}" for path in doc_files() for k in sorted(_doc_models(path.name))
               if k not in cased and k not in NOT_RUN.get(path.name, {})]
    assert not missing, missing


# ------------------------------------------------------------------------------------------------ FMU
def _export_kwargs(kw):
    return {k: v for k, v in kw.items() if k in ("params", "inputs") and v}


def _fmu_path(fmu_dir, case):
    return fmu_dir / f"{re.sub(r'[^A-Za-z0-9]+', '_', case.name).strip('_')}.fmu"


@pytest.fixture(scope="module")
def fmu_dir(tmp_path_factory):
    from .fmu_support import require_fmu_tools

    require_fmu_tools()
    return tmp_path_factory.mktemp("parity_fmu")


@functools.lru_cache(maxsize=None)
def _export(name, fmu_dir):
    """The FMU of a case's model (exported once: the windings share the replay's, their parameters set through
    FMI)."""
    from acausal.export import export_fmu

    case = BY_NAME[name]
    if case.fmu_of:
        return _export(case.fmu_of, fmu_dir)
    cm, kw = model(name)
    return export_fmu(cm, _fmu_path(fmu_dir, case), **_export_kwargs(kw))


_LOGGED = re.compile(r"t = (\S+) s: event (\d+) \(.*\) (rising|falling)$")


@pytest.mark.parametrize("case", EXPORTED)
def test_fmu_agrees_with_simulate(case, fmu_dir):
    """The exported FMU in fmpy (CVODE at rtol ``fmu_rtol``, 1e-11 unless the case says) against simulate() (the
    compiled path; the scipy path where that refuses): states within ``state_tol`` of their range, the FMU's
    logged events the same as simulate()'s (zero function, direction, order) at times within ``fmu_event_tol``.
    A model without states: the FMU locates its mode changes as events, simulate() sets the modes sample by
    sample: the signals agree at the output times, and every FMU event lies in an output interval where
    simulate()'s modes change."""
    from fmpy import simulate_fmu

    cm, kw = model(case.name)
    path = _export(case.name, fmu_dir)
    start_values = {}
    if case.fmu_of:  # the parameters in which this case differs from the one whose FMU it runs
        base = model(case.fmu_of)[1]["params"]
        start_values = {k: v for k, v in kw["params"].items() if base.get(k) != v}
        assert start_values and set(base) <= set(kw["params"])
    fast, _, _ = compiled_run(case.name)
    sim = fast if fast is not None else reference(case.name)[0]
    log = []
    res = simulate_fmu(str(path), stop_time=case.t_end, relative_tolerance=case.fmu_rtol,
                       output_interval=case.t_end / (case.n_points - 1),
                       output=list(cm.state_names) + list(case.fmu_signals), start_values=start_values,
                       record_events=False, debug_logging=True,
                       logger=lambda env, name, status, category, message: log.append(
                           message.decode() if isinstance(message, bytes) else str(message)))
    events = [(float(m[1]), int(m[2]), m[3]) for m in (_LOGGED.match(s) for s in log) if m]
    assert np.allclose(res["time"], sim.t, rtol=0, atol=1e-12 * case.t_end)
    if cm.state_names:
        X = np.array([res[n] for n in cm.state_names])
        dev, worst = _state_deviation(cm, X, sim.states)
        ref_events = sim.events
        if case.fmu_start_events:  # compared from t > 0 (the reason at the case)
            events, ref_events = [e for e in events if e[0] > 0], [e for e in sim.events if e[0] > 0]
        same, dt = _event_deviation(events, ref_events)
        ok = dev < case.state_tol and same and dt < case.fmu_event_tol
        _cell(case, "FMU (fmpy)", _verdict(ok, dev, same, dt, len(events), len(ref_events))
              + (" (from t > 0)" if case.fmu_start_events else ""))
        assert dev < case.state_tol, f"{worst}: {dev:.3g} of its range"
        assert same, (events, ref_events)
        assert dt < case.fmu_event_tol, f"event times differ by {dt:.3g} s: {events} vs {ref_events}"
        return
    dev, worst = 0.0, ""
    for n in case.fmu_signals:
        ref = np.asarray(sim[n])
        d = float(np.max(np.abs(res[n] - ref)) / max(np.ptp(ref), 1.0 if not np.any(ref) else 1e-300))
        dev, worst = max((dev, worst), (d, n))
    modes = np.asarray(sim.modes).reshape(len(cm.discrete_names), -1)
    switching = np.flatnonzero(np.any(np.diff(modes, axis=1) != 0, axis=0))
    inside = all(any(sim.t[k] <= t <= sim.t[k + 1] for k in switching) for t, _, _ in events if t > 0)
    ok = dev < case.state_tol and inside
    _cell(case, "FMU (fmpy)", f"{'agrees' if ok else 'DIFFERS'}: signals {dev:.1e} of range"
                              + (f", {len(events)} events, each in an output interval where simulate()'s modes change"
                                 if events and inside else f", {len(events)} events" if events else ""))
    assert dev < case.state_tol, f"{worst}: {dev:.3g} of its range"
    assert inside, (events, sim.t[switching])


@pytest.mark.parametrize("case", EXPORT_REFUSED)
def test_exporter_refuses_naming_the_construct_and_the_component(case, fmu_dir):
    """What the FMU's C runtime cannot run is an ExportError naming the construct and its component; no file is
    left."""
    from acausal.export import ExportError, export_fmu

    cm, kw = model(case.name)
    path = _fmu_path(fmu_dir, case)
    with pytest.raises(ExportError) as err:
        export_fmu(cm, path, **_export_kwargs(kw))
    _cell(case, "FMU (fmpy)", f"refused by the exporter: {str(err.value).split(' (equations from')[0]}")
    for part in case.fmu.split(": ", 1)[1].split("|"):
        assert part in str(err.value), (part, str(err.value))
    assert not path.exists()


# ------------------------------------------------------------------------------------------------ the table
def test_zz_table():
    """The model x backend table of the cases that ran (``pytest -s`` prints it): agrees (with the largest state
    deviation over the state's range and event-time difference measured) / DIFFERS / refused (the reason) / n/a."""
    backends = ["scipy (BDF)", "compiled (CasADi)", "FMU (fmpy)"]
    lines = ["| model | scipy | compiled (CasADi) | FMU (fmpy) |", "|---|---|---|---|"]
    for case in CASES:
        row = TABLE.get(case.name)
        if not row:
            continue
        scipy = row.get("scipy (BDF)", "-") + (f"; Radau {row['scipy (Radau)']}" if "scipy (Radau)" in row else "")
        cells = [scipy] + [row.get(b, "-") for b in backends[1:]]
        lines.append(f"| {case.name} | " + " | ".join(c.replace("|", "/") for c in cells) + " |")
    print("\n" + "\n".join(lines))
