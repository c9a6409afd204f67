"""The cases of the backend parity suite (``tests/simulation/test_parity.py``): each model, how it is built
and run, what the compiled path and the exporter must say when they refuse it, and the tolerances (see that
module's docstring for what agreement means)."""
from __future__ import annotations

import ast
import functools
from dataclasses import dataclass, field
from pathlib import Path

from acausal import compile_model

STATE_TOL = 1e-6  # max |x - x_ref| over the run, per state, relative to the state's range in the reference run
EVENT_TOL = 1e-9  # s
TIGHT = dict(rtol=1e-10, atol=1e-12)
TIGHTER = dict(rtol=1e-11, atol=1e-13)
REFUSED_TOL = dict(rtol=1e-8, atol=1e-10)  # a model only the scipy path runs: nothing to compare its run with
FMU_RTOL = 1e-11  # fmpy's CVODE (its atol is rtol times the states' nominal values, 1 here)
STRIDE, PRECOMPRESSION = 1.2, 0.008  # the registry's runs: the paper's fastest stride, 8 mm
DOCS = Path(__file__).resolve().parents[2] / "docs"


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
    from ..docs.test_docs import python_blocks

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
    compiled or exported: the chapter's runs are tests/docs/test_docs.py's)."""
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


def doc_models(chapter):
    """The names of the Model classes a chapter defines (from its code, without running it)."""
    models = set()
    for _, node in _doc_nodes(chapter):
        if isinstance(node, ast.ClassDef) and any(isinstance(b, ast.Name) and (b.id == "Model" or b.id in models)
                                                  for b in node.bases):
            models.add(node.name)
    return models


@functools.lru_cache(maxsize=None)
def doc_model(chapter, cls, args=(), params=()):
    model = _doc_namespace(chapter)[cls](*args)
    return compile_model(model), dict(params=dict(params) or None)


@functools.lru_cache(maxsize=None)
def _msl(name):
    from ..msl.test_msl_determinism import _examples

    factory = {n: f for n, f, *_ in _examples()}[name]
    return compile_model(factory()), {}


@functools.lru_cache(maxsize=None)
def _fmu_model(name):
    """A model tests/export/test_fmu.py exports: from the shared modules, or from test_fmu itself (which skips on
    import without fmpy and a C compiler: so do those cases here)."""
    from importlib import import_module

    from .. import circuit_models, drive_models

    for module in (drive_models, circuit_models):
        if hasattr(module, name):
            return compile_model(getattr(module, name)()), {}
    return compile_model(getattr(import_module("tests.export.test_fmu"), name)()), {}


def registry(name, t_end=0.05, **kw):
    return Case(name, "registry", lambda: _registry(name), t_end, **kw)


def actuator(variant, t_end=0.05, **kw):
    return Case(f"AnkleActuator.eq4: {variant}", "actuator", lambda: _actuator(variant), t_end, **kw)


def doc(chapter, cls, t_end, args=(), params=(), label="", **kw):
    return Case(f"docs/{chapter}: {label or cls}", "docs",
                lambda: doc_model(chapter, cls, tuple(args), tuple(params)), t_end, **kw)


def msl(name, t_end, **kw):
    return Case(f"MSL {name}", "msl", lambda: _msl(name), t_end, **kw)


def fmu_test(name, t_end, **kw):
    return Case(f"tests/export/test_fmu.py: {name}", "fmu", lambda: _fmu_model(name), t_end, **kw)


#: MSL DiodeBridge2Pulse (no states) guards the knee rule in the FMU: at the source's zero crossing (0.01 s) the
#: current of diodes p1 and n2 turns by round-off (-2.9e-7 A), within the knee of zero on the side that says switch
#: off; watched at zero it would never cross again (all four diodes on, 0 A load current where the MSL has the
#: rectified sine), so it is watched as the knee rule's kept indicators are (modes.knee_offsets, fmi2_events.c)
#: the turn-off of a half-wave rectifier's ideal diode (its current through R || C falling through zero) is where
#: the tolerance shows most: at rtol 1e-10 CVODES and BDF put it 2.6e-9 to 3.6e-9 s apart, at 1e-11 1.6e-10 s, at
#: 1e-12 1.5e-11 s (both converge to 0.0090310791 s): these run at rtol 1e-11
HALF_WAVE = "rtol 1e-11: the diode's turn-off moves by 2.6e-9 s between rtol 1e-10 and 1e-11"
#: fmpy's CVODE at rtol 1e-11 (atol 1e-11) stops on these (mxstep: MotorGearLoad at 3.5 ms, its inverse at 2.2 ms,
#: SplineReplay at 2.2 ms, Bridge6 at 46 ns, the inductor's 0.1 ms time constant): 1e-10, as tests/export/test_fmu.py
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
    # (docs/simulation-paths.md's HalfWave and tests/export/test_fmu.py's are the same circuit)
    doc("fmu-export.md", "HalfWave", 0.025, tol=dict(TIGHTER), note=HALF_WAVE, fmu="yes"),
    doc("friction-and-gears.md", "GearWindsSpring", 1.0, args=("events",), label="GearWindsSpring('events')",
        min_events=0, fmu="yes", fmu_signals=("gear.flange_a.tau", "gear.backdriven")),
    doc("friction-and-gears.md", "GearWindsSpring", 1.0, args=("smooth",), label="GearWindsSpring('smooth')",
        min_events=0),
    doc("friction-and-gears.md", "DrivenStickSlip", 0.3, tol=dict(TIGHTER),
        note="rtol 1e-11: at 1e-10 the gear's stick/slip events lie 1.2e-9 s apart"),
    doc("friction-and-gears.md", "Creep", 0.2, min_events=0),
    doc("friction-and-gears.md", "SwingArm", 1.0, min_events=0),
    doc("html-pages.md", "SensedDrive", 0.5, min_events=0),
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
    doc("simulation-paths.md", "LoggedRC", 0.2, min_events=0),
    doc("writing-components.md", "Oscillator", 0.5, min_events=0),
    doc("writing-components.md", "Powered", 1.0, min_events=0),
    doc("writing-components.md", "TripCircuit", 0.5),
    doc("writing-components.md", "Mains", 0.04),
    doc("writing-components.md", "Banded", 1.0, min_events=0),
    doc("writing-components.md", "Shaken", 1.0, min_events=0),
    # ---- the MSL conformance examples (tests/msl/test_msl_determinism.py's runs, some shortened further)
    msl("First", 0.2, fmu="yes"),
    msl("DCPM_Start", 1.6, fmu="yes"),
    msl("CharacteristicIdealDiodes", 1.0, fmu="yes", min_events=0,
        fmu_signals=("Ideal.i", "With_Ron_Goff.i", "With_Ron_Goff_Vknee.i", "With_Ron_Goff_Vknee.off")),
    msl("Rectifier", 0.01, fmu="yes"),
    msl("DiodeBridge2Pulse", 0.02, fmu="yes", min_events=0,
        fmu_signals=("currentSensor.i", "rectifier.diode_p1.off")),
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
    # ---- the models tests/export/test_fmu.py exports (its HalfWave is docs/fmu-export.md's; its actuator runs above)
    fmu_test("MotorGearLoad", 0.5, min_events=0, fmu="yes", **FMU_1E10),
    fmu_test("MotorGearLoadInverse", 0.5, min_events=0, fmu="yes", **FMU_1E10),
    fmu_test("BoundRC", 0.1, min_events=0, fmu="yes"),
    fmu_test("SplineReplay", 0.5, min_events=0, fmu="yes", **FMU_1E10),
    fmu_test("SampledDrive", 0.4, min_events=0, fmu="yes"),
    fmu_test("Bridge6", 0.01, fmu="yes", **FMU_1E10, fmu_start_events=(
        "at t = 0 two diodes sit exactly at zero and leave it: whether one switches while the modes settle or at "
        "the start event is up to round-off (-9e-16 in the C, 0 in Python; tests/export/test_fmu.py)")),
]
BY_NAME = {c.name: c for c in CASES}
assert len(BY_NAME) == len(CASES)  # every case has its own name
