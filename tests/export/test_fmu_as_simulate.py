"""An exported FMU stops and solves as simulate() does: the same event limit (the Integer parameter ``max_events``,
simulate()'s default) and the same Newton rules for a nonlinear block (the start, the damped step, the
convergence test and the fallback to the start values), run in fmpy.

fmpy runs in a child process with a time limit: an FMU that does not stop is a failure that says so, not a test
run that hangs."""
import inspect
import json
import subprocess
import sys
import time as clock

import numpy as np
import pytest

from acausal import Component, Discrete, Eq, Event, Model, SimulationError, Variable, compile_model, der
from acausal.export import export_fmu
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
error = None
try:
    res = simulate_fmu(sys.argv[1], logger=logger, **kw)
    times = [float(t) for t in res["time"]]
except Exception as exc:
    error, times = str(exc), []
print(json.dumps({"error": error, "messages": messages, "times": times}))
"""


def fmpy_run(path, **kw):
    """``simulate_fmu(path, **kw)`` in a child process: ``(error or None, the FMU's logged messages, output times,
    seconds taken)``; a run past :data:`FMPY_LIMIT` seconds fails the test, saying so."""
    start = clock.perf_counter()
    try:
        done = subprocess.run([sys.executable, "-c", _RUN, str(path), json.dumps(kw)], capture_output=True,
                              text=True, timeout=FMPY_LIMIT)
    except subprocess.TimeoutExpired:
        pytest.fail(f"fmpy did not finish {path.name} within {FMPY_LIMIT} s ({kw}): the FMU does not stop")
    assert done.returncode == 0, done.stderr[-2000:]
    out = json.loads(done.stdout.strip().splitlines()[-1])
    return out["error"], out["messages"], out["times"], clock.perf_counter() - start


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
    error, messages, _, seconds = fmpy_run(path, stop_time=2.0, debug_logging=True)
    assert error is not None and "fmi2NewDiscreteStates failed with status 3" in error, error
    assert messages[-1] == "more than 10000 events by t = 1 s (last from _Relay 'relay'): the model chatters"
    events = [float(m.split("t = ")[1].split(" s")[0]) for m in messages if ": event 0 (" in m]
    assert len(events) == 10_001 and abs(events[0] - 1.0) < 1e-6 and abs(events[-1] - 1.0) < 1e-6
    with pytest.raises(SimulationError) as python:
        cm.simulate(2.0, max_events=50)
    error, messages, _, _ = fmpy_run(path, stop_time=2.0, start_values={"max_events": 50})
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
    error, messages, _, _ = fmpy_run(path, stop_time=2.0, start_values={"max_events": -1})
    assert error is not None and "fmi2SetInteger" in error, error
    assert any("max_events = -1 is negative" in m and "default is 10000" in m for m in messages), messages
