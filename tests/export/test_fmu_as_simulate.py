"""An exported FMU stops and solves as simulate() does: the same event limit (the Integer parameter ``max_events``,
simulate()'s default) and the same Newton rules for a nonlinear block (the start, the damped step, the
convergence test and the fallback to the start values), run in fmpy.

fmpy runs in a child process with a time limit: an FMU that does not stop is a failure that says so, not a test
run that hangs."""
import inspect
import json
import subprocess
import sys

import numpy as np
import pytest
import sympy as sp

from acausal import (Component, Discrete, Eq, Event, Model, Parameter, SimulationError, Start, Variable,
                     compile_model, connect, der, time)
from acausal.export import export_fmu
from acausal.library.electrical import Capacitor, Ground, IdealDiode, PrescribedVoltage, Resistor
from acausal.model.partials import OnePort
from acausal.simulation.simulate import simulate

from .fmu_support import require_fmu_tools

require_fmu_tools()
from fmpy import read_model_description  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

#: seconds an fmpy run may take here before it counts as hanging (each takes about a second)
FMPY_LIMIT = 120

_RUN = """
import json, sys
from fmpy import simulate_fmu
messages = []
def logger(env, name, status, category, message):
    messages.append(message.decode() if isinstance(message, bytes) else str(message))
kw = json.loads(sys.argv[2])
error, values = None, {}
try:
    res = simulate_fmu(sys.argv[1], logger=logger, **kw)
    values = {n: [float(v) for v in res[n]] for n in res.dtype.names}
except Exception as exc:
    error = str(exc)
print(json.dumps({"error": error, "messages": messages, "values": values}))
"""


def fmpy_run(path, **kw):
    """``simulate_fmu(path, **kw)`` in a child process: ``(error or None, the FMU's logged messages, the outputs
    by name with "time", as arrays)``; a run past :data:`FMPY_LIMIT` seconds fails the test, saying so."""
    try:
        done = subprocess.run([sys.executable, "-c", _RUN, str(path), json.dumps(kw)], capture_output=True,
                              text=True, timeout=FMPY_LIMIT)
    except subprocess.TimeoutExpired:
        pytest.fail(f"fmpy did not finish {path.name} within {FMPY_LIMIT} s ({kw}): the FMU does not stop")
    assert done.returncode == 0, done.stderr[-2000:]
    out = json.loads(done.stdout.strip().splitlines()[-1])
    return out["error"], out["messages"], {n: np.array(v) for n, v in out["values"].items()}


# ------------------------------------------------------------------------------------------------ event limit
class _Relay(Component):
    """An on/off relay without hysteresis driving its own input: x rises at 1/s while off and falls at 1/s while
    on, and the relay switches on when x rises through 0, off when it falls through 0. From t = 1 s every switch
    sends x back across 0 within a step (a sliding mode): the events never end."""

    x = Variable(start=-1.0, fixed=True)
    on = Discrete(start=0.0)

    def equations(self):
        return [Eq(der(self.x), 1 - 2 * self.on)]

    def events(self):
        return [Event(self.x, on_rising={self.on: 1}, on_falling={self.on: 0}, doc="relay switches")]


class _Relayed(Model):
    def build(self):
        self.relay = _Relay()


@pytest.fixture(scope="module")
def relay(tmp_path_factory):
    return compile_model(_Relayed()), export_fmu(_Relayed(), tmp_path_factory.mktemp("fmu") / "relay.fmu")


def test_the_event_limit_is_an_integer_parameter_at_simulates_default(relay):
    """modelDescription.xml declares ``max_events``: an Integer parameter starting at simulate()'s default
    max_events (10 000), its value reference one past the last Real's; fmpy finds nothing wrong with the FMU."""
    cm, path = relay
    assert validate_fmu(str(path)) == []
    md = read_model_description(str(path))
    (limit,) = [v for v in md.modelVariables if v.name == "max_events"]
    default = inspect.signature(simulate).parameters["max_events"].default
    assert default == 10_000
    assert (limit.type, limit.causality, limit.variability, int(limit.start)) == ("Integer", "parameter", "fixed",
                                                                                  default)
    assert limit.valueReference == max(v.valueReference for v in md.modelVariables if v.type == "Real") + 1


def test_a_chattering_relay_stops_at_the_event_limit_as_simulate_does(relay):
    """The relay slides from t = 1 s. The FMU stops at its 10 001st event with fmi2Error and the message
    simulate() raises (the limit, the time, the relay); it logged 10 001 events, all at t = 1 s to 1e-6 s. Set to
    50 through FMI, it stops at the 51st event with simulate(max_events=50)'s message."""
    cm, path = relay
    error, messages, _ = fmpy_run(path, stop_time=2.0, debug_logging=True)
    assert error is not None and "fmi2NewDiscreteStates failed with status 3" in error, error
    assert messages[-1] == "more than 10000 events by t = 1 s (last from _Relay 'relay'): the model chatters"
    events = [float(m.split("t = ")[1].split(" s")[0]) for m in messages if ": event 0 (" in m]
    assert len(events) == 10_001 and abs(events[0] - 1.0) < 1e-6 and abs(events[-1] - 1.0) < 1e-6
    with pytest.raises(SimulationError) as python:
        cm.simulate(2.0, max_events=50)
    error, messages, _ = fmpy_run(path, stop_time=2.0, start_values={"max_events": 50})
    assert error is not None and messages[-1] == str(python.value), (messages[-3:], str(python.value))
    assert str(python.value).startswith("more than 50 events by t = 1 s (last from _Relay 'relay')")


@pytest.mark.slow
def test_simulate_stops_the_relay_with_the_fmus_message(relay):
    """simulate(2.0) with its default limit stops the relay with the message the FMU logs by default."""
    cm, _ = relay
    with pytest.raises(SimulationError) as python:
        cm.simulate(2.0)
    assert str(python.value) == "more than 10000 events by t = 1 s (last from _Relay 'relay'): the model chatters"


def test_a_negative_event_limit_is_refused_naming_it(relay):
    """max_events = -1 set through FMI fails in fmi2SetInteger, naming the parameter and simulate()'s default."""
    _, path = relay
    error, messages, _ = fmpy_run(path, stop_time=2.0, start_values={"max_events": -1})
    assert error is not None and "fmi2SetInteger" in error, error
    assert any("max_events = -1 is negative" in m and "default is 10000" in m for m in messages), messages


# ------------------------------------------------------------------------------------------------ Newton blocks
class _ExpDiode(OnePort):
    """A diode by Shockley's law, i = Is (exp(v / Vt) - 1) (the users' guide's ShockleyDiode): a law sympy does not
    invert in a circuit, so the circuit has a Newton block."""

    Is = Parameter(1e-12, unit="A", min=0.0, doc="saturation current")
    Vt = Parameter(0.025, unit="V", min=0.0, doc="thermal voltage")

    def equations(self):
        return [*super().equations(), Eq(self.i, self.Is * (sp.exp(self.v / self.Vt) - 1))]


class _ClampedRectifier(Model):
    """A half-wave rectifier whose input is clamped: 10 V at 50 Hz through 1 Ohm to an ideal diode D (state events)
    into 10 Ohm || 100 uF, and an exponential diode E from ground to D's anode that conducts on the negative
    half-waves. Tearing iterates on D.s (a Newton block of D, E and the resistor)."""

    def build(self):
        self.src = PrescribedVoltage(v_ref=10 * sp.sin(2 * sp.pi * 50 * time))
        self.R1, self.E, self.D = Resistor(R=1.0), _ExpDiode(), IdealDiode()
        self.R, self.C, self.gnd = Resistor(R=10.0), Capacitor(C=1e-4, v=Start(0.0)), Ground()
        connect(self.src.p, self.R1.p)
        connect(self.R1.n, self.E.n, self.D.p)
        connect(self.D.n, self.R.p, self.C.p)
        connect(self.R.n, self.C.n, self.src.n, self.E.p, self.gnd.p)


def _logged_times(messages, marker):
    return [float(m.split("t = ")[1].split(" s")[0]) for m in messages if marker in m]


#: output times away from the clamped rectifier's events (D switches off at 9.12 ms and on at 20 ms in each period):
#: charging, clamped (E conducting, where the FMU stopped at t = 0.0107 s at every tolerance), discharged
CLAMP_TIMES = [0.005, 0.0125, 0.015, 0.025, 0.0375, 0.0625, 0.0875]
CLAMP_NAMES = ["C.v", "D.s", "D.i", "E.i", "R1.i"]


def test_a_newton_block_with_events_runs_as_simulate_does(tmp_path):
    """The clamped rectifier: simulate(0.1, rtol=1e-10) runs it (IDAS, the Newton block's variable carried from
    step to step). So does the FMU in fmpy at every relative tolerance from 1e-4 to 1e-10, its Newton iteration
    damped and started as simulate()'s (it stopped at t = 0.0107 s, the clamp turning on, with 'did not
    converge'). At the seven times away from the events every variable of the block is within max(30 rtol, 1e-8)
    of its largest value of simulate()'s (measured: 3e-4 at rtol 1e-4, 1.5e-9 at 1e-10); at rtol 1e-10 the
    FMU logs simulate()'s ten events, each within 1e-6 s."""
    cm = compile_model(_ClampedRectifier())
    assert "Newton on ['D.s']" in cm.report() and len(cm.event_zeros) == 1
    path = export_fmu(cm, tmp_path / "clamped.fmu")
    ref = cm.simulate(0.1, rtol=1e-10, atol=1e-12)
    at = cm.simulate(0.1, rtol=1e-10, atol=1e-12, t_eval=CLAMP_TIMES)
    assert len(ref.events) == 10
    for tol in (1e-4, 1e-6, 1e-8, 1e-10):
        error, messages, values = fmpy_run(path, stop_time=0.1, relative_tolerance=tol, output_interval=2.5e-4,
                                           output=CLAMP_NAMES, record_events=False, debug_logging=True)
        assert error is None, (tol, error, [m for m in messages if "Newton" in m][:1])
        for n in CLAMP_NAMES:
            scale = np.max(np.abs(ref[n]))
            got = np.interp(CLAMP_TIMES, values["time"], values[n])
            assert np.max(np.abs(got - at[n])) <= max(30 * tol, 1e-8) * scale, (tol, n, got, at[n])
        if tol == 1e-10:
            logged = _logged_times(messages, ": event 0 (")
            assert len(logged) == 10 and np.max(np.abs(np.array(logged) - [e[0] for e in ref.events])) < 1e-6


class _Recharged(Capacitor):
    """A capacitor recharged to 5 V whenever it has discharged to 0.65 V (Event.reinit of its voltage)."""

    def events(self):
        return [Event(0.65 - self.v, reinit={self.v: 5.0}, doc="recharged")]


class _PulsedDischarge(Model):
    """The users' guide's DiodeDischarge (100 uF, 100 Ohm, the exponential diode; the resistor's voltage, the tear
    variable, starts its iteration at 4.3 V) recharged by pulses: after a recharge the last solution (0.13 V) is
    far from the new one (4.3 V), on the diode's steep side, where Newton gains 25 mV per iteration."""

    def build(self):
        self.C, self.D, self.gnd = _Recharged(C=1e-4, v=Start(5.0)), _ExpDiode(), Ground()
        self.R = Resistor(R=100.0, v=Start(4.3, fixed=False))
        connect(self.C.p, self.R.p)
        connect(self.R.n, self.D.p)
        connect(self.D.n, self.C.n, self.gnd.p)


def test_a_newton_block_that_fails_from_its_last_solution_is_solved_from_its_start_values(tmp_path):
    """After each of the 26 recharges in 1 s, the iteration from the block's last solution does not converge in
    60 iterations; the FMU solves it from its start values, as simulate() falls back to them, and logs so
    (logNewton) at each recharge (simulate()'s event times, within 1e-6 s). Away from the recharges C.v and R.v
    are within 1e-6 of their largest value of simulate()'s (measured 1.8e-7). The recharge adds charge no
    component supplies, so simulate()'s energy balance does not close: its trust checks are off here."""
    cm = compile_model(_PulsedDischarge())
    path = export_fmu(cm, tmp_path / "pulsed.fmu")
    ref = cm.simulate(1.0, rtol=1e-10, atol=1e-12, trust="off")
    t_events = np.array([e[0] for e in ref.events])
    assert len(t_events) == 26
    error, messages, values = fmpy_run(path, stop_time=1.0, relative_tolerance=1e-10, output_interval=1e-3,
                                       output=["C.v", "R.v"], record_events=False, debug_logging=True)
    assert error is None, error
    fallbacks = [m for m in messages if "from the start values" in m]
    assert len(fallbacks) == 26 and all("from the last solution 'R.v' = " in m and ": did not converge in 60 "
                                        "iterations" in m for m in fallbacks), fallbacks[:2]
    assert np.max(np.abs(np.array(_logged_times(fallbacks, "Newton")) - t_events)) < 1e-6
    t = values["time"]
    far = np.min(np.abs(t[:, None] - t_events[None, :]), axis=1) > 2e-3
    times = np.unique(t[far])
    at = cm.simulate(1.0, rtol=1e-10, atol=1e-12, trust="off", t_eval=times)
    for n in ("C.v", "R.v"):
        got = np.interp(times, t[far], values[n][far])
        assert np.max(np.abs(got - at[n])) <= 1e-6 * np.max(np.abs(ref[n])), n


class _Discharge(Model):
    """The users' guide's DiodeDischarge without a start value for the tear variable R.v: from 0 V (5 V across
    the diode) Newton creeps and does not converge at t = 0."""

    def build(self):
        self.C, self.D, self.gnd = Capacitor(C=1e-3, v=Start(5.0)), _ExpDiode(), Ground()
        self.R = Resistor(R=100.0)
        connect(self.C.p, self.R.p)
        connect(self.R.n, self.D.p)
        connect(self.D.n, self.C.n, self.gnd.p)


def test_a_newton_block_that_cannot_start_fails_with_simulates_last_iterate(tmp_path):
    """The FMU's initialisation fails (fmi2Error) with the reason, the last iterate beside the start value and the
    residual simulate() reports, word for word (the same damped iteration from the same start), and the hint."""
    cm = compile_model(_Discharge())
    with pytest.raises(SimulationError) as python:
        cm.simulate(0.1, method="BDF")
    error, messages, _ = fmpy_run(export_fmu(cm, tmp_path / "discharge.fmu"), stop_time=0.1)
    assert error is not None and "fmi2ExitInitializationMode" in error, error
    said = str(python.value)
    what = said.split(" at t = 0 s: ")[1].split("; last iterate")[0]
    iterate = said.split("; last iterate ")[1].split(". Hint")[0]
    assert what.startswith("did not converge in 60 iterations (residual ") and "(start 0)" in iterate, said
    assert messages[-1] == ("at t = 0 s: Newton iteration for the nonlinear block of 'R.v' (equations from "
                            f"Resistor 'R', _ExpDiode 'D'): {what}; last iterate {iterate}. "
                            "Hint: give 'R.v' a start value near the solution (Start(value) where the component is "
                            "made, or Variable(start=...) in its class) and export again; if the importing tool's "
                            "integrator stepped far (a trial state), try a smaller step"), (messages[-1], said)
