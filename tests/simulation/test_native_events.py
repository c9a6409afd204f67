"""The native loop (acausal/simulation/compiled/native_loop.py, native_dae.c) with state events: runs integrated by
SUNDIALS in C, their crossings found in its steps. Its agreement with the scipy path on every shipped model
is in tests/simulation/test_parity.py (and the CasADi event path's own tests ask for that path); here what is its own: table
inputs evaluated in C from numbers passed per run, negative start times with energy quadratures, the fallback to
the CasADi event path where the library cannot be built, and that it is what runs by default."""
import numpy as np
import pytest

from acausal import Model, Start, compile_model, connect
from acausal.backends import ccompiler
from acausal.simulation.compiled import native_loop
from acausal.library.electrical import Capacitor, Ground, IdealDiode, PrescribedVoltage, Resistor
from acausal.model.signals import PeriodicSpline, SampledSignal

#: these tests touch which backend integrates a run: .ci/run runs them again without the accelerators
pytestmark = pytest.mark.backend

pytest.importorskip("casadi", reason="the compiled path needs CasADi")

TIGHT = dict(rtol=1e-10, atol=1e-12)


def _recording(amplitude, phase):
    t = np.linspace(0.0, 0.02, 41, endpoint=False)
    return PeriodicSpline(t, amplitude * np.sin(2 * np.pi * 50 * t + phase), period=0.02)


class _Rectifier(Model):
    """A half-wave rectifier (ideal diode into R || C) whose source follows an input signal."""

    def build(self):
        self.src = PrescribedVoltage(v_ref=_recording(10.0, 0.0))  # a numeric input: runs may replace it
        self.D, self.R, self.C = IdealDiode(), Resistor(R=10.0), Capacitor(C=1e-4, v=Start(0.0))
        self.gnd = Ground()
        connect(self.src.p, self.D.p)
        connect(self.D.n, self.R.p, self.C.p)
        connect(self.R.n, self.C.n, self.src.n, self.gnd.p)


def _native_or_skip(cm, inputs=None):
    res = cm.simulate(0.01, n_points=3, inputs=inputs, trust="off")
    if "compiled path, native" not in res.solver:
        pytest.skip(f"the native event loop is not built here (no C compiler or no libsundials-dev): {res.solver}")
    return res


def test_one_library_serves_every_recording_of_a_model():
    """Two recordings (different numbers, same table layout) run on one compiled library: the tables' numbers go
    to the C loop per run. Each run's switches and capacitor voltage agree with the scipy path's on the same
    recording."""
    cm = compile_model(_Rectifier())
    _native_or_skip(cm, {"src.v_ref": _recording(10.0, 0.0)})
    for amplitude, phase in ((10.0, 0.0), (7.0, 0.4)):
        inputs = {"src.v_ref": _recording(amplitude, phase)}
        fast = cm.simulate(0.06, n_points=121, inputs=inputs, **TIGHT)
        ref = cm.simulate(0.06, n_points=121, inputs=inputs, method="BDF", trust="off", **TIGHT)
        assert fast.solver.startswith("CVODES (compiled path, native"), fast.solver  # an ODE: CVODES
        assert [e[1:] for e in fast.events] == [e[1:] for e in ref.events] and len(ref.events) >= 4
        assert np.allclose([e[0] for e in fast.events], [e[0] for e in ref.events], atol=1e-8)
        assert np.max(np.abs(fast["C.v"] - ref["C.v"])) < 1e-6 * np.ptp(ref["C.v"])
    assert len(cm.compiled_path._native) == 1  # one layout (and one set of quadratures): one library


def test_a_run_from_a_negative_start_keeps_its_energy_integrals():
    """IDAS 6's dense output of the quadratures takes its round-off fuzz from tn + h without the absolute value:
    at negative times, right after a first step of a few ulps, it refused every time. The loop integrates in the
    time since the segment's start; a replay that starts before 0 closes its energy balance."""
    cm = compile_model(_Rectifier())
    _native_or_skip(cm)
    res = cm.simulate(0.04, t_start=-0.02, n_points=81, rtol=1e-9, atol=1e-11, trust="off")
    assert "compiled path, native" in res.solver, res.solver
    assert res.events and abs(res.energy_balance().residual) < 1e-6
    ref = cm.simulate(0.04, t_start=-0.02, n_points=81, method="BDF", trust="off", rtol=1e-9, atol=1e-11)
    assert res.energy("R.loss_power")[-1] == pytest.approx(ref.energy("R.loss_power")[-1], rel=1e-5)


@pytest.mark.slow
def test_without_the_library_the_casadi_event_path_runs_it(monkeypatch):
    """Where the library cannot be built (here: a SUNDIALS library the linker cannot find), the run takes the
    CasADi event path, with the same switches; the refusal is kept (not tried again per run)."""
    cm = compile_model(_Rectifier())
    monkeypatch.setattr(native_loop, "LIBS", ("-lacausal_no_such_library",))
    monkeypatch.setattr(ccompiler, "_REFUSED", {})
    monkeypatch.setattr(native_loop, "_LOOP", {})  # the loop as this process would first build it
    res = cm.simulate(0.06, n_points=121, **TIGHT)
    assert res.solver.startswith("CVODES (compiled path, CasADi"), res.solver
    runner, why = native_loop.segment_runner(cm, res.inputs, [])
    assert runner is None and "could not be built" in why
    ref = cm.simulate(0.06, n_points=121, method="BDF", trust="off", **TIGHT)
    assert [e[1:] for e in res.events] == [e[1:] for e in ref.events]


def test_a_sampled_recording_and_its_slope_in_c():
    """A SampledSignal (linear between samples, held outside them) drives the source: the C evaluation of the
    table (the piece by binary search, held beyond the last sample) gives the scipy path's switches."""
    cm = compile_model(_Rectifier())
    t = np.linspace(0.0, 0.05, 501)
    inputs = {"src.v_ref": SampledSignal(t, 10 * np.sin(2 * np.pi * 50 * t) * (1 - t / 0.1))}
    _native_or_skip(cm, inputs)
    fast = cm.simulate(0.07, n_points=71, inputs=inputs, **TIGHT)  # past the last sample: held
    ref = cm.simulate(0.07, n_points=71, inputs=inputs, method="BDF", trust="off", **TIGHT)
    assert [e[1:] for e in fast.events] == [e[1:] for e in ref.events]
    assert np.allclose([e[0] for e in fast.events], [e[0] for e in ref.events], atol=1e-8)
    assert np.max(np.abs(fast["C.v"] - ref["C.v"])) < 1e-6 * np.ptp(ref["C.v"])
