"""Backend parity: every shipped model and the MSL conformance examples run on every backend
that accepts them, and the backends agree.

Backends: the scipy path (``method="BDF"``, the reference; ``method="Radau"`` on three models with diode and breaker
events), the compiled path (``method="CVODES"``: CVODES, or IDAS for a model with a Newton block) as it runs by
default (the native loop where it is built) and on CasADi's integrators (``ACAUSAL_NATIVE=0``: what runs without
SUNDIALS's library or a C compiler), and an exported FMI 2.0 Model Exchange FMU run by fmpy (its CVODE and the FMU's C
event iteration). Models:

* every model of ``acausal compare --list`` (:mod:`acausal.models.ankle.registry`), as the protocol runs it
  (library preset, 8 mm, 1.2 s/stride, the model's condition inputs); the windings run the replay's FMU with
  their parameters set through FMI;
* the paper's Eq. (4) bench model in closed loop with gear backlash (the virtual bench's truth, outside the
  registry);
* the servo on a pendulum (:mod:`acausal.models.servo.model`) replaying a shipped recording;
* every model of the users' guide (``docs/*.md``: the chapters' imports, classes and the assignments those use,
  nothing of their runs), those that no backend can run checked to fail alike on both paths;
* the ten MSL conformance examples (``tests/msl/test_msl_determinism.py``'s list, eleven runs);
* the models ``tests/export/test_fmu.py`` exports.

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
The cases, their builders and tolerances are in ``tests/simulation/parity_cases.py``.
"""
from __future__ import annotations

import functools
import re
import time as clock

import numpy as np
import pytest

from acausal import ModelError, SimulationError
from acausal.results.trust import UntrustedResult

from .parity_cases import BY_NAME, CASES, doc_model, doc_models

#: these tests touch which backend integrates a run: .ci/run runs them again without the accelerators
pytestmark = pytest.mark.backend


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
    from acausal.simulation.compiled import available

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


def _agrees(case, cm, fast, ref, column, solver_ok) -> None:
    """``fast`` agrees with the reference ``ref``, its cell of the table in ``column``: a model without states has
    the reference's values (evaluated algebraically whatever the method); one with states ran on the compiled path
    (``solver_ok(fast.solver)``), its states within ``state_tol`` of their range, the same events at times within
    ``event_tol``."""
    if not cm.state_names:
        _cell(case, column, "n/a: no states (evaluated algebraically at the output times, whatever the method)")
        for name in cm.names()[:20] + list(case.fmu_signals):
            np.testing.assert_array_equal(fast[name], ref[name], err_msg=name)
        return
    assert solver_ok(fast.solver), fast.solver  # not a failed run redone on the scipy path, nor the other backend
    dev, worst = _state_deviation(cm, fast.states, ref.states)
    same, dt = _event_deviation(fast.events, ref.events)
    ok = dev < case.state_tol and same and dt < case.event_tol
    where = "native" if "native" in fast.solver else "CasADi"
    _cell(case, column, f"{fast.solver.split()[0]} ({where}) " + _verdict(ok, dev, same, dt, len(fast.events),
                                                                           len(ref.events)))
    assert len(ref.events) >= case.min_events, f"the run does not switch: {ref.events}"
    assert np.array_equal(fast.t, ref.t)
    assert dev < case.state_tol, f"{worst}: {dev:.3g} of its range"
    assert same, (fast.events, ref.events)
    assert dt < case.event_tol, f"event times differ by {dt:.3g} s: {fast.events} vs {ref.events}"


@pytest.mark.slow
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
    if cm.state_names:
        assert cm.simulation_path(kw.get("inputs")).startswith("compiled"), cm.simulation_path(kw.get("inputs"))
    _agrees(case, cm, fast, ref, "compiled", lambda solver: solver.startswith(("CVODES", "IDAS")))


@pytest.mark.slow
@pytest.mark.parametrize("case", ACCEPTED)
def test_casadi_integrator_agrees_with_the_scipy_path(case, monkeypatch):
    """The compiled path on CasADi's integrators (what runs without SUNDIALS's library or a C compiler, and a run the
    native loop fails on; ``ACAUSAL_NATIVE=0`` here) agrees with BDF as the native loop does."""
    _compiled_available()
    monkeypatch.setenv("ACAUSAL_NATIVE", "0")
    cm, kw = model(case.name)
    ref, _ = reference(case.name)
    fast = cm.simulate(case.t_end, method="CVODES", **kw, **_grid(case))
    _agrees(case, cm, fast, ref, "compiled (CasADi)",
            lambda solver: solver.startswith(("CVODES", "IDAS")) and "CasADi" in solver)


@pytest.mark.slow
@pytest.mark.parametrize("case", REFUSED)
def test_compiled_path_refuses_naming_the_construct_and_the_component(case):
    """``method="CVODES"`` raises a ModelError before integrating, naming what the compiled path cannot run and
    where; ``method="auto"`` runs the scipy path (BDF) and says why in ``res.solver``, as ``simulation_path``."""
    _compiled_available()
    cm, kw = model(case.name)
    fast, refusal, seconds = compiled_run(case.name)
    assert fast is None and refusal is not None
    why = refusal.split("cannot take the compiled path: ", 1)[-1]
    _cell(case, "compiled", f"refused: {why}")
    _cell(case, "compiled (CasADi)", "refused, the same")
    for part in case.refused:
        assert part in refusal, (part, refusal)
    assert seconds < 1.0  # before integrating (the run itself takes seconds on the scipy path)
    res, _ = reference(case.name)  # method="auto"
    _cell(case, "scipy (BDF)", f"reference, what method='auto' falls back to (res.solver says why): "
                               f"{len(res.events)} events")
    assert res.solver == f"BDF (scipy: {why})", res.solver
    assert cm.simulation_path(kw.get("inputs")) == f"scipy BDF: {why}"
    assert len(res.events) >= case.min_events


#: Radau's long steps over a conducting diode: its order-3 interpolant dips below zero where the solution does not
#: (read off the interpolant: 10 events against 2 on the half-wave rectifier, 24 against 8 on the six-pulse bridge,
#: C.v off by 1.8e-5 of its range); the scipy driver locates Radau's crossings and takes its outputs on the solution
RADAU = [pytest.param(BY_NAME["docs/fmu-export.md: HalfWave"], id="docs/fmu-export.md: HalfWave"),
         pytest.param(BY_NAME["tests/export/test_fmu.py: Bridge6"], id="tests/export/test_fmu.py: Bridge6"),
         pytest.param(BY_NAME["docs/writing-components.md: TripCircuit"], id="docs/writing-components.md: TripCircuit")]


@pytest.mark.slow
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
    """``res.solver`` says which path ran. A model without states is evaluated algebraically at the
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
    cm, _ = doc_model(chapter, cls, args)
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
    from ..docs.test_docs import doc_files

    cased = {c.name.split(": ", 1)[1].split("(")[0] for c in CASES if c.group == "docs"}
    cased |= {name.split(": ", 1)[1].split("(")[0] for name in FAILING}
    missing = [f"{path.name}: {k}" for path in doc_files() for k in sorted(doc_models(path.name))
               if k not in cased and k not in NOT_RUN.get(path.name, {})]
    assert not missing, missing


# ------------------------------------------------------------------------------------------------ FMU
def _export_kwargs(kw):
    return {k: v for k, v in kw.items() if k in ("params", "inputs") and v}


def _fmu_path(fmu_dir, case):
    return fmu_dir / f"{re.sub(r'[^A-Za-z0-9]+', '_', case.name).strip('_')}.fmu"


@pytest.fixture(scope="module")
def fmu_dir(tmp_path_factory):
    from ..export.fmu_support import require_fmu_tools

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


@pytest.mark.slow
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
    backends = ["scipy (BDF)", "compiled", "compiled (CasADi)", "FMU (fmpy)"]
    lines = ["| model | scipy | compiled (default: the native loop) | compiled on CasADi's integrators | FMU (fmpy) |",
             "|---|---|---|---|---|"]
    for case in CASES:
        row = TABLE.get(case.name)
        if not row:
            continue
        scipy = row.get("scipy (BDF)", "-") + (f"; Radau {row['scipy (Radau)']}" if "scipy (Radau)" in row else "")
        cells = [scipy] + [row.get(b, "-") for b in backends[1:]]
        lines.append(f"| {case.name} | " + " | ".join(c.replace("|", "/") for c in cells) + " |")
    print("\n" + "\n".join(lines))
