"""FMU export: exported FMI 2.0 Model Exchange FMUs validated and simulated by fmpy, compared with
``simulate()``. Each FMU is exported (C compiled) once per module."""
import ctypes
import re
import zipfile

import numpy as np
import pytest
import sympy as sp

from acausal import Model, Parameter, SimulationError, Start, compile_model, connect, time
from acausal.export import ExportError, export_fmu
from acausal.library.electrical import (EMF, Capacitor, ConstantVoltage, Ground, IdealDiode, Inductor,
                                        PrescribedVoltage, Resistor)
from acausal.library.rotational import Damper, Fixed, IdealGear, Inertia, Position
from acausal.model.signals import PeriodicSpline, SampledSignal, Signal

from ..circuit_models import Bridge6
from .fmu_support import require_fmu_tools
from ..drive_models import MotorGearLoad, MotorGearLoadInverse
from ..simulation.test_events_trust import _Chatter, _TripModel

require_fmu_tools()
import fmpy  # noqa: E402
from fmpy import read_model_description, simulate_fmu  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

#: these tests touch which backend integrates a run: .ci/run runs them again without the accelerators
pytestmark = pytest.mark.backend

TIGHT = dict(rtol=1e-11, atol=1e-13)


def relative_error(a, b):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / max(np.max(np.abs(b)), 1e-300))


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    cm = compile_model(MotorGearLoad())
    return cm, export_fmu(MotorGearLoad(), tmp_path_factory.mktemp("fmu") / "drive.fmu")


def test_motor_gear_load_validates_and_matches_simulate(drive):
    """fmpy finds nothing wrong with the FMU (XML schema, variable names, model structure, start values, units),
    and its CVODE run matches a tight simulate() to 1e-6 relative in the states and outputs, aliases included."""
    cm, path = drive
    assert validate_fmu(str(path)) == []
    names = ["L.i", "rotor.w", "load.phi", "gear.flange_b.tau", "load.w", "R.v", "src.p.i", "load.flange_b.tau"]
    assert {"src.p.i", "load.flange_b.tau"} <= set(cm.flat.aliases)  # eliminated aliases are outputs too
    res = simulate_fmu(str(path), stop_time=1.0, relative_tolerance=1e-10, output_interval=0.01, output=names)
    ref = cm.simulate(1.0, t_eval=res["time"], **TIGHT)
    for n in names:
        assert relative_error(res[n], ref[n]) < 1e-6, n


class BoundRC(Model):
    """An RC charger whose resistor is bound to the model's parameter R0 (R = 2 R0).

    Used to check calculated parameters in the FMU."""

    R0 = Parameter(10.0, unit="Ohm", min=0.0, doc="half the resistance")

    def build(self):
        self.src = ConstantVoltage(V=5.0)
        self.R = Resistor(R=2 * self.R0)
        self.C = Capacitor(C=1e-3, v=Start(0.0))
        self.gnd = Ground()
        connect(self.src.p, self.R.p)
        connect(self.R.n, self.C.p)
        connect(self.C.n, self.src.n, self.gnd.p)


@pytest.fixture(scope="module")
def rc(tmp_path_factory):
    return compile_model(BoundRC()), export_fmu(BoundRC(), tmp_path_factory.mktemp("fmu") / "rc.fmu")


def test_parameters_and_start_values_set_through_fmi(drive, rc):
    """A parameter and a state's start set through FMI act as simulate(params=..., starts=...) does; a bound
    parameter is a calculatedParameter computed in the FMU from the one it is bound to."""
    cm, path = drive
    res = simulate_fmu(str(path), stop_time=0.5, relative_tolerance=1e-10, output_interval=0.01,
                       output=["L.i", "rotor.w"], start_values={"R.R": 0.6, "L.i": 1.5}, record_events=False)
    ref = cm.simulate(0.5, t_eval=res["time"], params={"R.R": 0.6}, starts={"L.i": 1.5}, **TIGHT)
    assert res["L.i"][0] == 1.5
    for n in ("L.i", "rotor.w"):
        assert relative_error(res[n], ref[n]) < 1e-6, n
    cm_rc, path_rc = rc
    assert validate_fmu(str(path_rc)) == []
    kinds = {v.name: v.causality for v in read_model_description(str(path_rc)).modelVariables}
    assert kinds["R0"] == "parameter" and kinds["R.R"] == "calculatedParameter"
    res = simulate_fmu(str(path_rc), stop_time=0.1, relative_tolerance=1e-10, output_interval=0.01,
                       output=["C.v", "R.R"], start_values={"R0": 20.0}, record_events=False)
    ref = cm_rc.simulate(0.1, t_eval=res["time"], params={"R0": 20.0}, **TIGHT)
    assert np.all(res["R.R"] == 40.0)
    assert relative_error(res["C.v"], ref["C.v"]) < 1e-6


def _messages():
    got = []

    def logger(env, name, status, category, message):
        got.append(message.decode() if isinstance(message, bytes) else str(message))
    return got, logger


def test_refused_settings_are_errors_naming_the_parameter(drive, rc):
    """Out of bounds, bound to another parameter: fmi2SetReal fails and the FMU's log says why, as
    param_vector() does."""
    got, logger = _messages()
    with pytest.raises(Exception, match="fmi2SetReal"):
        simulate_fmu(str(drive[1]), stop_time=0.1, start_values={"R.R": -1.0}, logger=logger)
    assert any("parameter 'R.R' of R = -1 is below its minimum 0 [Ohm]" in m for m in got), got
    got, logger = _messages()  # fmpy itself refuses to set a calculatedParameter: ask the FMU directly
    md = read_model_description(str(rc[1]))
    fmu = fmpy.instantiate_fmu(fmpy.extract(str(rc[1])), md, fmi_type="ModelExchange", logger=logger)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    with pytest.raises(Exception, match="fmi2SetReal"):
        fmu.setReal([vr["R.R"]], [30.0])
    with pytest.raises(Exception, match="fmi2SetReal"):
        fmu.setReal([vr["R.loss_power"]], [1.0])
    fmu.freeInstance()
    assert any("'R.R' of R is bound to 2*R0" in m and "set 'R0'" in m for m in got), got
    assert any("R.loss_power is computed by the model" in m for m in got), got


def test_model_description_names_every_variable_with_unit_and_doc(drive):
    """Every parameter, state, unknown, alias and mode is a variable of the FMU; units and docs come along, the
    state derivatives point at their states, and the zip holds the C source and the model's documentation."""
    cm, path = drive
    md = read_model_description(str(path))
    by_name = {v.name: v for v in md.modelVariables}
    assert set(by_name) == set(cm.names(parameters=True)) | set(cm.discrete_names) | {"max_events"}
    assert {v.name for v in md.modelVariables if v.causality == "output"} == set(cm.names())
    assert by_name["R.R"].unit == "Ohm" and by_name["R.R"].start == "0.7"
    assert by_name["L.i"].unit == "A" and by_name["src.p.i"].unit == "A"
    assert by_name["der(L.i)"].derivative is by_name["L.i"]
    assert [d.variable.name for d in md.derivatives] == [f"der({s})" for s in cm.state_names]
    assert md.description.startswith("24 V source, R, L, EMF")
    assert by_name["R.loss_power"].description == cm.flat.variables["R.loss_power"].doc
    with zipfile.ZipFile(path) as zf:
        files = set(zf.namelist())
        page = zf.read("documentation/index.html").decode()
    assert {"modelDescription.xml", "sources/MotorGearLoad.c", "binaries/linux64/MotorGearLoad.so",
            "documentation/index.html"} <= files
    assert "ideal gear 860" in page and "R.R" in page and "states (3)" in page


class HalfWave(Model):
    """A half-wave rectifier: 50 Hz, 10 V through an ideal diode (state events) into R || C."""

    def build(self):
        self.src = PrescribedVoltage(v_ref=10 * sp.sin(2 * sp.pi * 50 * time))
        self.D, self.R, self.C = IdealDiode(), Resistor(R=10.0), Capacitor(C=1e-4, v=Start(0.0))
        self.gnd = Ground()
        connect(self.src.p, self.D.p)
        connect(self.D.n, self.R.p, self.C.p)
        connect(self.R.n, self.C.n, self.src.n, self.gnd.p)


@pytest.fixture(scope="module")
def rectifier(tmp_path_factory):
    return compile_model(HalfWave()), export_fmu(HalfWave(), tmp_path_factory.mktemp("fmu") / "rectifier.fmu")


def test_rectifier_switches_through_its_events_as_simulate_does(rectifier):
    """The diode's zero function is the FMU's event indicator and its mode logic runs in C: fmpy's run switches
    the diode ten times in 0.1 s, at the times simulate() does (within 1e-6 s; the turn-off crosses gently), with
    the same capacitor voltage. The diode starts at rest (indicator exactly zero), which the environment's root
    finding cannot see leaving zero: the FMU asks for that event itself (fmi2CompletedIntegratorStep)."""
    cm, path = rectifier
    md = read_model_description(str(path))
    assert validate_fmu(str(path)) == [] and md.numberOfEventIndicators == 1
    assert md.modelExchange.needsCompletedIntegratorStep
    got, logger = _messages()
    res = simulate_fmu(str(path), stop_time=0.1, relative_tolerance=1e-8, output_interval=1e-4,
                       output=["C.v", "D.off", "D.i"], record_events=False, debug_logging=True, logger=logger)
    ref = cm.simulate(0.1, t_eval=res["time"], rtol=1e-10, atol=1e-12)
    events = [m for m in got if ": event " in m]
    assert len(ref.events) == 10 and len(events) == 10, events
    for text, (t_ref, i, direction) in zip(events, ref.events):
        t_fmu = float(text.split("t = ")[1].split(" s")[0])
        assert abs(t_fmu - t_ref) < 1e-6 and text.endswith(direction) and f"event {i} " in text, (text, t_ref)
    assert relative_error(res["C.v"], ref["C.v"]) < 1e-6
    differ = np.flatnonzero(res["D.off"] != ref.modes[cm.discrete_names.index("D.off")])
    assert differ.size <= 2  # at most an output sample at a switch, where the two runs' times differ by < 1e-6 s



def _logged_events(messages):
    """``(time, event index, direction)`` of the FMU's logEvents messages, as ``Result.events``."""
    found = [re.match(r"t = (\S+) s: event (\d+) \(.*\) (rising|falling)$", m) for m in messages]
    return [(float(f[1]), int(f[2]), f[3]) for f in found if f]


@pytest.mark.slow
def test_three_phase_bridge_switches_as_simulate_does(tmp_path):
    """Six ideal diodes commutate 60 times in 0.1 s; each commutation cascades (a diode turning on makes its
    neighbour's current reverse). The two diodes exactly at zero after the start are watched 1e-12 from it
    (acausal.simulation.events.knee_offsets, in Python and in the C alike), so round-off no longer sends a commutation
    through a cycle at the knee. After the start the FMU logs the same crossings as simulate()'s
    events (same events, directions and order; times within 1e-6 s), and its modes and capacitor voltage between
    the events equal simulate()'s, the modes from the start on. At t = 0 two diodes sit exactly at zero and leave
    it (the FMU switches them at t = 0 as simulate() does, not at the end of the first step); whether one of them
    already switches while the modes settle, or only at that start event, is up to round-off (-9e-16 in the C,
    exactly zero in the Python), so the events at t = 0 are not compared one by one."""
    cm = compile_model(Bridge6())
    path = export_fmu(cm, tmp_path / "bridge.fmu")
    got, logger = _messages()
    modes = list(cm.discrete_names)
    res = simulate_fmu(str(path), stop_time=0.1, relative_tolerance=1e-8, output_interval=1e-4,
                       output=["C.v", *modes], record_events=False, debug_logging=True, logger=logger)
    ref = cm.simulate(0.1, t_eval=res["time"], rtol=1e-10, atol=1e-12)
    events = [e for e in _logged_events(got) if e[0] > 0]
    assert [e for e in _logged_events(got) if e[0] == 0] == [(0.0, 0, "falling")]
    assert len(ref.events) >= 60 and [e[0] for e in ref.events[:2]] == [0.0, 0.0]
    assert len(events) == len(ref.events) - 2, (events[:12], ref.events[:12])
    for (t, i, direction), (t_ref, i_ref, d_ref) in zip(events, ref.events[2:]):
        assert (i, direction) == (i_ref, d_ref) and abs(t - t_ref) < 1e-6, ((t, i, direction), (t_ref, i_ref, d_ref))
    t_events = np.array([e[0] for e in ref.events])
    between = np.min(np.abs(res["time"][:, None] - t_events[None, :]), axis=1) > 1e-6
    for n in modes:
        assert np.array_equal(res[n][between], ref[n][between]), n
    assert relative_error(res["C.v"], ref["C.v"]) < 1e-6


def test_modes_with_no_consistent_value_are_an_error_naming_the_component(tmp_path):
    """At t = 1 the zero x - 1 - 2 m rises and sets m = 1, which makes it -2: the event iteration returns to the
    modes it started from through a flip far from the knee. The FMU stops with fmi2Error and the message
    simulate() raises (the component, the time, the modes), instead of keeping m = 1 silently."""
    path = export_fmu(_Chatter(), tmp_path / "chatter.fmu")
    with pytest.raises(SimulationError) as python:
        compile_model(_Chatter()).simulate(2.0)
    got, logger = _messages()
    with pytest.raises(Exception, match="fmi2NewDiscreteStates"):
        simulate_fmu(str(path), stop_time=2.0, logger=logger)
    assert str(python.value) in got, (str(python.value), got)
    assert re.search(r"do not settle after an event at t = 1 s: the events of _NoConsistentMode 'c' switch back "
                     r"and forth.*chatters\); modes c.m = 1$", str(python.value))


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:invalid value encountered")
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_a_nan_zero_function_is_an_error_naming_the_event(tmp_path):
    """sqrt(x) - 0.5 with x falling through zero: from t = 1 the zero function is NaN, which has no sign. The FMU
    reports it (fmi2Error, a message of simulate()'s form naming the event's component, its zero function, the
    time and the modes) instead of running on without events; before that it switched at t = 0.75 as simulate()
    does. fmi2GetEventIndicators fails too, but fmpy ignores errors inside CVODE's root function (the warning
    filtered here): the run stops at the step's fmi2CompletedIntegratorStep."""
    path = export_fmu(_TripModel(), tmp_path / "trip.fmu")
    got, logger = _messages()
    with pytest.raises(Exception, match="fmi2CompletedIntegratorStep failed with status 3"):
        simulate_fmu(str(path), stop_time=3.0, logger=logger, debug_logging=True)
    pattern = (r"the zero function of an event of _Trip 'trip' is nan at t = (\S+) s: sqrt\(trip.x\) - 0.5 \(modes "
               r"trip.flag = (\d)\); a NaN or infinite switching value has no sign to switch on \(a division by a "
               r"coefficient that is zero in this mode, or a function used outside its domain\)$")
    found = [f for f in (re.match(pattern, m) for m in got) if f]
    assert found and 1.0 <= float(found[0][1]) <= 1.1 and found[0][2] == "0", got
    with pytest.raises(SimulationError, match=pattern):
        compile_model(_TripModel()).simulate(3.0)
    assert _logged_events(got) == [(pytest.approx(0.75, abs=1e-9), 0, "falling")]


class SplineReplay(MotorGearLoad):
    """The reference drive with its load angle prescribed by a periodic quintic spline (a numeric signal, as the
    gait data are): index reduction needs the spline's first and second derivatives."""

    def build(self):
        super().build()
        t = np.linspace(0.0, 1.0, 40, endpoint=False)
        motion = 0.3 * np.sin(2 * np.pi * t) + 0.1 * np.cos(6 * np.pi * t)
        self.pos = Position(phi_ref=PeriodicSpline(t, motion, period=1.0, name="gait-like motion"))
        connect(self.pos.flange, self.load.flange_b)


class FedDrive(Model):
    """Motor, gear and damped load fed through a prescribed voltage ``supply`` (a numeric signal)."""

    def supply(self):
        return SampledSignal([0.0, 0.1, 0.25, 0.5], [0.0, 10.0, 24.0, 18.0], name="logged supply")

    def build(self):
        self.src = PrescribedVoltage(v_ref=self.supply())
        self.R, self.L, self.emf = Resistor(R=0.7), Inductor(L=6.53e-5, i=Start(0.0)), EMF(k=0.0273)
        self.rotor, self.gear, self.load = Inertia(J=5.68e-6), IdealGear(ratio=860), Inertia(J=0.05)
        self.friction, self.housing, self.gnd = Damper(d=2.0), Fixed(), Ground()
        connect(self.src.p, self.R.p)
        connect(self.R.n, self.L.p)
        connect(self.L.n, self.emf.p)
        connect(self.emf.n, self.src.n, self.gnd.p)
        connect(self.emf.flange, self.rotor.flange_a)
        connect(self.rotor.flange_b, self.gear.flange_a)
        connect(self.gear.flange_b, self.load.flange_a)
        connect(self.load.flange_b, self.friction.flange_a)
        connect(self.friction.flange_b, self.housing.flange)


class SampledDrive(FedDrive):
    """The drive fed through a logged voltage (linear between samples, held after the last)."""


@pytest.mark.parametrize("model, t_end", [(MotorGearLoadInverse, 1.0), (SplineReplay, 2.0), (SampledDrive, 0.8)])
def test_prescribed_inputs_are_compiled_in(model, t_end, tmp_path):
    """Prescribed motion as an expression of time (MotorGearLoadInverse), as a periodic spline table (derivatives
    up to the 2nd, past its period) and a logged voltage held after its last sample: the FMU's runs match
    simulate() to 1e-6 relative."""
    cm = compile_model(model())
    path = export_fmu(cm, tmp_path / f"{model.__name__}.fmu")
    assert validate_fmu(str(path)) == []
    names = ["L.i", "src.p.i", "gear.flange_b.tau", "load.phi"]
    res = simulate_fmu(str(path), stop_time=t_end, relative_tolerance=1e-10, output_interval=0.005, output=names,
                       record_events=False)
    ref = cm.simulate(t_end, t_eval=res["time"], **TIGHT)
    for n in names:
        assert relative_error(res[n], ref[n]) < 1e-6, n


class _Opaque(Signal):
    name = "opaque"

    def evaluate(self, t, order):
        return np.sin(t) if order == 0 else np.cos(t)


def test_an_input_without_a_table_form_is_an_error_naming_it(tmp_path):
    """A numeric input with neither a table nor a closed form cannot be compiled in: the error names the input,
    its component and what to do."""
    class Opaque(FedDrive):
        def supply(self):
            return _Opaque()

    with pytest.raises(ExportError, match=r"input 'src.v_ref' of src is a _Opaque 'opaque' with neither a table "
                                          r"nor a symbolic form.*SampledSignal"):
        export_fmu(Opaque(), tmp_path / "opaque.fmu")
    assert not (tmp_path / "opaque.fmu").exists()


@pytest.fixture(scope="module")
def actuator(tmp_path_factory):
    """The paper's actuator in closed loop (rectifier with diode and brake chopper events, a Newton block of the
    two lossy gears, the gait spline and the planned arm trajectory), exported with the library preset at 8 mm
    and 1.2 s/stride."""
    from acausal.models.ankle.presets import preset
    from acausal.models.ankle.protocol import compiled

    cm = compiled("closed_loop").sim
    params = {k: v for k, v in preset("library").items() if cm.has_parameter(k)}
    params.update({"stride_time": 1.2, "P_nominal": 0.008})
    return cm, params, export_fmu(cm, tmp_path_factory.mktemp("fmu") / "actuator.fmu", params=params)


@pytest.mark.slow
def test_closed_loop_actuator_matches_simulate(actuator):
    """One stride of the closed-loop actuator in fmpy: states and outputs within 1e-4 relative of simulate(),
    from the same consistent initial states (the controller's derivative part starts at zero: the FMU solves for
    it as simulate() does), also with a parameter changed through FMI."""
    cm, params, path = actuator
    assert validate_fmu(str(path)) == []
    md = read_model_description(str(path))
    assert md.numberOfEventIndicators == 2 and md.variableNamingConvention == "flat"  # der(der(...)) names
    names = cm.state_names + ["controller.D", "link.alpha", "P_source.P", "P_motor.P", "P_output.P", "supply.p.i"]
    for extra in ({}, {"motor.R": 0.5}):
        res = simulate_fmu(str(path), stop_time=1.2, relative_tolerance=1e-9, output_interval=0.005,
                           output=names, start_values=extra, record_events=False)
        ref = cm.simulate(1.2, t_eval=res["time"], params={**params, **extra}, rtol=1e-10, atol=1e-12)
        assert ref.events  # the run switches the rectifier
        for n in cm.state_names:
            assert abs(res[n][0] - ref[n][0]) <= 1e-9 * max(1.0, abs(ref[n][0])), (n, extra)
        for n in names:
            assert relative_error(res[n], ref[n]) < 1e-4, (n, extra)


def test_a_replanning_parameter_set_in_the_fmu_is_flagged(actuator):
    """The planned arm trajectory is tabulated at export: setting a parameter it was planned from (the
    precompression) logs a warning saying that the FMU does not replan, and its description says so."""
    cm, params, path = actuator
    md = read_model_description(str(path))
    desc = {v.name: v.description or "" for v in md.modelVariables}
    assert "does not rebuild (replan)" in desc["P_nominal"] and "arm_ref.profile" in desc["P_nominal"]
    got, logger = _messages()
    simulate_fmu(str(path), stop_time=0.01, start_values={"P_nominal": 0.010}, logger=logger)
    assert any("P_nominal = 0.01 differs from the value 0.008" in m and "not rebuilt" in m for m in got), got


@pytest.mark.slow
def test_cli_exports_a_model_class_and_a_registered_model(actuator, tmp_path, capsys):
    """``acausal export MODEL --fmu FILE`` for a MODULE:CLASS (with a parameter set) and for a registered model
    (the closed-loop actuator, library preset); a misspelt parameter is refused with suggestions."""
    from acausal import cli

    out = tmp_path / "drive.fmu"
    assert cli.main(["export", "tests.drive_models:MotorGearLoad", "--fmu", str(out), "--set", "R.R=0.6"]) == 0
    assert "3 states, 10 parameters" in capsys.readouterr().out
    assert validate_fmu(str(out)) == []
    start = {v.name: v.start for v in read_model_description(str(out)).modelVariables}
    assert float(start["R.R"]) == 0.6
    out = tmp_path / "actuator.fmu"
    assert cli.main(["export", "closed_loop", "--fmu", str(out), "--set", "motor.R=0.5"]) == 0
    md = read_model_description(str(out))
    start = {v.name: v.start for v in md.modelVariables}
    assert float(start["motor.R"]) == 0.5 and md.description.startswith("the paper's actuator under PID control")
    assert cli.main(["export", "closed_loop", "--fmu", str(out), "--set", "motor.RR=0.5"]) == 2
    assert "unknown parameter 'motor.RR'" in capsys.readouterr().err
    assert cli.main(["export", "tests.drive_models:Nothing", "--fmu", str(out)]) == 2
    assert "has no Model class 'Nothing'" in capsys.readouterr().err


def test_without_a_c_compiler_the_error_says_what_to_install(monkeypatch, tmp_path):
    """No compiler on the PATH: an ExportError that says what to install; a source-only FMU still exports."""
    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(ExportError, match=r"no C compiler found .*apt-get install gcc"):
        export_fmu(compile_model(MotorGearLoad()), tmp_path / "drive.fmu")
    path = export_fmu(compile_model(MotorGearLoad()), tmp_path / "drive.fmu", binary=False)
    with zipfile.ZipFile(path) as zf:
        assert not [n for n in zf.namelist() if n.startswith("binaries/")]
    assert validate_fmu(str(path)) == []
    with pytest.raises(ExportError, match=r"the C compiler 'tcc' \(compiler=\) was not found"):
        export_fmu(compile_model(MotorGearLoad()), tmp_path / "drive.fmu", compiler="tcc")


@pytest.mark.slow
@pytest.mark.parametrize("name", ["replay", "battery"])
def test_registered_replays_export(name, tmp_path):
    """The paper's replay (the planned arm prescribed up to its third derivative, rectifier events) and the
    battery-fed replay (no states at all) run in fmpy within 1e-4 relative of simulate() at the five points'
    powers."""
    from acausal.models.ankle.presets import preset
    from acausal.models.ankle.protocol import compiled
    from acausal.models.ankle.registry import spec

    c, s = compiled(name), spec(name)
    cm = c.sim
    params = {k: v for k, v in preset("library").items() if cm.has_parameter(k)}
    params.update({**s.params, "stride_time": 1.2, "P_nominal": 0.008})
    path = export_fmu(cm, tmp_path / f"{name}.fmu", params=params)
    assert validate_fmu(str(path)) == []
    names = cm.state_names + sorted(set(c.points.values()))
    res = simulate_fmu(str(path), stop_time=1.2, relative_tolerance=1e-9, output_interval=0.005, output=names,
                       record_events=False)
    ref = cm.simulate(1.2, t_eval=res["time"], params=params, rtol=1e-10, atol=1e-12)
    for n in names:
        assert relative_error(res[n], ref[n]) < 1e-4, n


def _instance(path):
    """An initialised Model Exchange instance of the FMU at ``path`` (fmpy's low-level API), in continuous-time
    mode at t = 0, and its variables' value references by name."""
    md = read_model_description(str(path))
    fmu = fmpy.instantiate_fmu(fmpy.extract(str(path)), md, fmi_type="ModelExchange")
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    while fmu.newDiscreteStates()[0]:
        pass
    fmu.enterContinuousTimeMode()
    return fmu, md, {v.name: v.valueReference for v in md.modelVariables}


def test_derivatives_and_indicators_equal_the_python_functions_anywhere(actuator):
    """At arbitrary times and states (not only along a solution), fmi2GetDerivatives and fmi2GetEventIndicators
    of the closed-loop actuator's FMU equal the generated Python functions (Newton block, spline and plan tables)
    to 1e-10 relative: the C is the same equations, not an approximation of them."""
    cm, params, path = actuator
    fmu, md, vr = _instance(path)
    p = cm.param_vector(params)
    u = cm.input_tuple(None, p)
    x0 = np.array(fmu.getReal([vr[n] for n in cm.state_names]))
    rng = np.random.default_rng(3)
    for k in range(20):
        t = float(rng.uniform(0.0, 2.4))
        x = x0 + rng.normal(size=x0.size) * np.maximum(np.abs(x0), 1.0) * 0.05
        fmu.setTime(t)
        fmu.setContinuousStates((ctypes.c_double * x.size)(*x), x.size)
        d = np.array(fmu.getReal([vr[n] for n in cm.discrete_names]))
        dx = np.zeros(x.size)
        fmu.getDerivatives((ctypes.c_double * x.size).from_buffer(dx), x.size)
        z = np.zeros(len(cm.event_zeros))
        fmu.getEventIndicators((ctypes.c_double * z.size).from_buffer(z), z.size)
        ref_dx = np.asarray(cm.funcs["rhs"](t, x.tolist(), p.tolist(), d.tolist(), u), dtype=float)
        ref_z = np.array([float(v) for v in cm.funcs["zeros"](t, x.tolist(), p.tolist(), d.tolist(), u)])
        assert np.allclose(dx, ref_dx, rtol=1e-10, atol=1e-10 * np.max(np.abs(ref_dx))), (t, dx, ref_dx)
        assert np.allclose(z, ref_z, rtol=1e-10, atol=1e-12), (t, z, ref_z)
    fmu.terminate()
    fmu.freeInstance()


def test_fmu_state_is_saved_and_restored(drive):
    """fmi2GetFMUstate / fmi2SetFMUstate (canGetAndSetFMUstate): states, time and values come back."""
    cm, path = drive
    fmu, md, vr = _instance(path)
    saved = fmu.getFMUState()
    before = fmu.getReal([vr["L.i"], vr["der(L.i)"]])
    fmu.setTime(0.3)
    fmu.setContinuousStates((ctypes.c_double * 3)(1.0, 2.0, 3.0), 3)
    assert fmu.getReal([vr["L.i"], vr["der(L.i)"]]) != before
    fmu.setFMUState(saved)
    assert fmu.getReal([vr["L.i"], vr["der(L.i)"]]) == before
    fmu.freeFMUState(saved)
    fmu.terminate()
    fmu.freeInstance()
