"""Fixed-step RK4 on the compiled path (``sensitivities(..., method="RK4")``): fourth-order convergence on a
sampled input's own grid, sensitivities that are the exact derivatives of the discrete solution, one compiled
roll-out for every recording, and a clear refusal where a fixed step cannot run."""
import numpy as np
import pytest

from acausal import Model, ModelError, Start, compile_model, connect
from acausal.library.electrical import Capacitor, Ground, IdealDiode, PrescribedVoltage, Resistor
from acausal.model.signals import SampledSignal

#: these tests touch which backend integrates a run: .ci/run runs them again without the accelerators
pytestmark = pytest.mark.backend

pytest.importorskip("casadi", reason="the fixed-step path needs CasADi (pip install acausal[fast])")


class RC(Model):
    """A logged voltage (linear between samples) into R = 1 ohm and C = 0.1 F; with ``diode`` a half-wave
    rectifier in front (an event-law diode)."""

    def __init__(self, signal, diode=False, **kw):
        self.signal, self.diode = signal, diode
        super().__init__(**kw)

    def build(self):
        self.src, self.R = PrescribedVoltage(v_ref=self.signal), Resistor(R=1.0)
        self.C, self.gnd = Capacitor(C=0.1, v=Start(0.0)), Ground()
        if self.diode:
            self.D = IdealDiode()
            connect(self.src.p, self.D.p)
            connect(self.D.n, self.R.p)
        else:
            connect(self.src.p, self.R.p)
        connect(self.R.n, self.C.p)
        connect(self.C.n, self.src.n, self.gnd.p)


def _log(seed, n=120):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.004, 0.012, n))  # an uneven host clock, as in a servo log
    return t, np.sin(9 * t) + 0.3 * rng.standard_normal(n)


def _model(seed):
    t, y = _log(seed)
    return t, SampledSignal(t, y, name="logged voltage")


def test_rk4_on_the_samples_converges_at_fourth_order_to_cvodes():
    t, sig = _model(1)
    cm = compile_model(RC(sig))
    ref = cm.sensitivities(t, [], names=["C.v"], t_start=t[0], rtol=1e-12, atol=1e-14, method="CVODES")[0]["C.v"]
    err = [np.abs(cm.sensitivities(t, [], names=["C.v"], t_start=t[0], method="RK4", substeps=k)[0]["C.v"]
                  - ref).max() for k in (1, 2, 4)]
    assert err[2] < 1e-8 * np.abs(ref).max()
    # the input is linear inside every step: the kinks at the samples cost no order
    assert err[0] / err[1] > 12 and err[1] / err[2] > 12, err


def test_rk4_sensitivities_are_the_derivatives_of_the_discrete_solution():
    t, sig = _model(2)
    cm = compile_model(RC(sig))
    wrt = ["R.R", "C.C"]
    vals, sens = cm.sensitivities(t, wrt, names=["C.v", "R.i"], t_start=t[0], method="RK4", substeps=2)
    for j, w in enumerate(wrt):
        base = cm.param_vector({})[cm.param_index(w)]
        h = 1e-6 * base
        fd = {}
        for sgn in (1, -1):
            fd[sgn] = cm.sensitivities(t, [], names=["C.v", "R.i"], params={w: base + sgn * h}, t_start=t[0],
                                       method="RK4", substeps=2)[0]
        for name in ("C.v", "R.i"):
            d = (fd[1][name] - fd[-1][name]) / (2 * h)
            assert np.abs(sens[name][j] - d).max() < 1e-6 * np.abs(d).max(), (w, name)
    # and close to the continuous sensitivities (CVODES), which they approximate at the step's order
    _, exact = cm.sensitivities(t, wrt, names=["C.v"], t_start=t[0], rtol=1e-10, atol=1e-12, method="CVODES")
    assert np.abs(sens["C.v"] - exact["C.v"]).max() < 1e-5 * np.abs(exact["C.v"]).max()


def test_one_rollout_serves_every_recording():
    """The inputs are data of the call, not tables inside the function: another log of the same model reuses the
    compiled roll-out and gets its own answer."""
    from acausal.simulation.compiled.fixed_step import fixed_step
    t1, s1 = _model(3)
    cm = compile_model(RC(s1))
    a = cm.sensitivities(t1, [], names=["C.v"], t_start=t1[0], method="RK4")[0]["C.v"]
    stepper = fixed_step(cm, 4)
    t2, y2 = _log(4)
    b = cm.sensitivities(t2, [], names=["C.v"], inputs={"src.v_ref": SampledSignal(t2, y2)}, t_start=t2[0],
                         method="RK4")[0]["C.v"]
    assert fixed_step(cm, 4) is stepper
    ref = cm.sensitivities(t2, [], names=["C.v"], inputs={"src.v_ref": SampledSignal(t2, y2)}, t_start=t2[0],
                           rtol=1e-12, atol=1e-14, method="CVODES")[0]["C.v"]
    assert np.abs(b - ref).max() < 1e-7 and not np.allclose(a[:50], b[:50])


def test_a_long_log_is_crossed_in_pieces_as_by_one_roll():
    """Logs of any length share a few cached rolls (whole chunks, then the rest's binary digits); the pieces give
    what one roll over the whole grid gives, states and sensitivities."""
    from acausal.simulation.compiled.fixed_step import CHUNK, fixed_step
    t, sig = _log(6, n=2 * CHUNK + 45)
    cm = compile_model(RC(SampledSignal(t, sig)))
    from acausal.simulation.compiled.fixed_step import FixedStep
    vals, sens = cm.sensitivities(t, ["R.R"], names=["C.v"], t_start=t[0], method="RK4", substeps=2)
    stepper = fixed_step(cm, 2, ("R.R",))
    bindings = {}
    on_vm = FixedStep(cm, 2, ("R.R",), bindings, native=False)  # the pieces are CasADi's (the C loop has none)
    assert on_vm.backend == "CasADi" and on_vm.pieces(t.size - 1) == [CHUNK, CHUNK, 32, 8, 4]
    u = [SampledSignal(t, sig)]
    grid = np.asarray(t, dtype=float)
    y0 = np.concatenate([[0.0], np.zeros(1)])
    pd = np.concatenate([cm.param_vector({}), np.zeros(len(cm.discrete_names))])
    X, S = on_vm.run(t[0], y0[:1], t, cm.param_vector({}), np.zeros(len(cm.discrete_names)), u)
    assert sorted(on_vm._rolls) == [4, 8, 32, CHUNK]
    assert np.abs(X[0, 1:] - vals["C.v"][1:]).max() < 1e-14
    whole = np.asarray(stepper.step.mapaccum("whole", t.size - 1)(y0, stepper.stage_values(grid, u), pd))
    i = cm.state_names.index("C.v")
    assert np.abs(vals["C.v"][1:] - whole[i]).max() < 1e-14
    assert np.abs(sens["C.v"][0][1:] - whole[1 + i]).max() < 1e-12 * np.abs(whole[1 + i]).max()


def test_fixed_step_refuses_what_it_cannot_run():
    t, sig = _model(5)
    with pytest.raises(ModelError, match="substeps must be a positive integer"):
        compile_model(RC(sig)).sensitivities(t, [], t_start=t[0], method="RK4", substeps=0)
    rectifier = compile_model(RC(sig, diode=True))
    with pytest.raises(ModelError, match="events"):
        rectifier.sensitivities(t, [], t_start=t[0], method="RK4")
    from acausal.simulation.compiled.fixed_step import fixed_step
    from acausal.backends.casadi import Unsupported
    with pytest.raises(Unsupported, match="event zero functions"):
        fixed_step(rectifier, 4)


def test_the_native_loop_takes_the_same_steps_as_casadi():
    """Where a C compiler is found, the steps run in compiled C (:mod:`acausal.simulation.compiled.native`): the same
    numbers as CasADi's unrolled step, states and sensitivities, on an uneven log of any length and any substep count;
    without a compiler the fixed step stays on CasADi and says so."""
    from acausal.backends.ccompiler import which_compiler
    from acausal.simulation.compiled.fixed_step import FixedStep, fixed_step
    if which_compiler()[0] is None:
        pytest.skip("no C compiler on this machine")
    t, sig = _log(7, n=300)
    cm = compile_model(RC(SampledSignal(t, sig)))
    p, d, u = cm.param_vector({"R.R": 1.7}), np.zeros(len(cm.discrete_names)), [SampledSignal(t, sig)]
    for k in (1, 3, 8):
        c, vm = FixedStep(cm, k, ("R.R", "C.C"), {}), FixedStep(cm, k, ("R.R", "C.C"), {}, native=False)
        assert c.backend == "C" and vm.backend == "CasADi"
        (Xc, Sc), (Xv, Sv) = c.run(t[0], [0.2], t, p, d, u), vm.run(t[0], [0.2], t, p, d, u)
        assert np.abs(Xc - Xv).max() <= 1e-14 * np.abs(Xv).max()
        assert np.abs(Sc - Sv).max() <= 1e-14 * np.abs(Sv).max() and np.abs(Sv).max() > 0
    assert fixed_step(cm, 3).backend == "C"


def test_without_a_compiler_the_fixed_step_stays_on_casadi(monkeypatch, tmp_path):
    from acausal.backends.ccompiler import BuildError, shared_library
    from acausal.simulation.compiled.fixed_step import FixedStep
    monkeypatch.setenv("CC", "no-such-compiler-here")
    monkeypatch.setenv("ACAUSAL_CACHE_DIR", str(tmp_path))
    with pytest.raises(BuildError, match="no C compiler found.*CC environment variable"):
        shared_library("int f(void) { return 1; }")
    t, sig = _log(8, n=60)
    cm = compile_model(RC(SampledSignal(t, sig)))
    stepper = FixedStep(cm, 2, ("R.R",), {})
    assert stepper.backend == "CasADi"
    X, S = stepper.run(t[0], [0.0], t, cm.param_vector({}), np.zeros(len(cm.discrete_names)), [SampledSignal(t, sig)])
    assert np.isfinite(X).all() and np.abs(S).max() > 0


def test_a_library_is_built_once_per_source_and_a_refused_source_says_why(tmp_path, monkeypatch):
    from acausal.backends.ccompiler import BuildError, shared_library, which_compiler
    if which_compiler()[0] is None:
        pytest.skip("no C compiler on this machine")
    monkeypatch.setenv("ACAUSAL_CACHE_DIR", str(tmp_path))
    first = shared_library("int acausal_probe(void) { return 7; }\n")
    assert first.parent == tmp_path / "native" and first.exists()
    stamp = first.stat().st_mtime_ns
    assert shared_library("int acausal_probe(void) { return 7; }\n") == first and first.stat().st_mtime_ns == stamp
    import ctypes
    assert ctypes.CDLL(str(first)).acausal_probe() == 7
    with pytest.raises(BuildError, match="failed"):
        shared_library("int broken(void) { return }\n")
    assert sorted(p.suffix for p in (tmp_path / "native").iterdir()) == [first.suffix]  # no leftovers


# ------------------------------------------------------------------------------------------ substep control
def _grids(cm, seeds=(0, 1, 2)):
    """The control's ``run`` over logged RC grids: the capacitor voltage of grid j at k substeps, and the count of
    runs asked for."""
    logs = [_log(s, n=60) for s in seeds]
    calls = []

    def run(pairs):
        calls.append(list(pairs))
        out = []
        for j, k in pairs:
            t, y = logs[j]
            out.append(cm.sensitivities(t, [], names=["C.v"], inputs={"src.v_ref": SampledSignal(t, y)},
                                        t_start=t[0], method="RK4", substeps=k)[0]["C.v"])
        return out
    return logs, run, calls


def test_the_substep_control_doubles_each_grid_until_twice_the_substeps_agree_within_its_tolerance():
    from acausal.simulation.compiled.substep_control import SubstepControl
    t, y = _log(0, n=60)
    cm = compile_model(RC(SampledSignal(t, y)))
    logs, run, calls = _grids(cm)
    tol = 1e-9
    control = SubstepControl(cm, tol, {j: 1 for j in range(len(logs))})
    chosen = control.choose(run)
    assert set(chosen) == {0, 1, 2} and all(k is not None and k > 1 for k in chosen.values())
    for j, k in chosen.items():  # what it chose meets the tolerance, and half of it would not have
        coarse, fine = run([(j, k), (j, 2 * k)])
        assert np.max(np.abs(coarse - fine)) <= tol
        half, same = run([(j, k // 2), (j, k)])
        assert np.max(np.abs(half - same)) > tol
    assert control.choose(run) is chosen  # chosen once: a second call runs nothing
    j = control.nearest_limit([0, 1, 2])
    assert control.errors[j] == max(control.errors.values())
    coarse, fine = run([(j, chosen[j]), (j, 2 * chosen[j])])
    assert control.accepts(j, coarse, fine)
    assert not control.accepts(j, coarse, coarse + 10 * tol)


def test_the_substep_control_sends_a_grid_beyond_its_most_substeps_to_the_error_controlled_integrator():
    from acausal.simulation.compiled.substep_control import MAX_SUBSTEPS, SubstepControl
    t, y = _log(0, n=60)
    cm = compile_model(RC(SampledSignal(t, y)))
    _, run, _ = _grids(cm, seeds=(0,))
    control = SubstepControl(cm, 0.0, {0: 1})  # nothing meets a zero tolerance
    assert control.most in MAX_SUBSTEPS.values()
    assert control.choose(run) == {0: None}


def test_a_model_the_fixed_step_cannot_run_has_every_grid_on_the_error_controlled_integrator():
    from acausal.simulation.compiled.substep_control import SubstepControl
    t, y = _log(0, n=60)
    rectifier = compile_model(RC(SampledSignal(t, y), diode=True))  # an event-law diode: zero functions
    control = SubstepControl(rectifier, 1e-6, {0: 4, 1: 4})
    assert not control.possible
    assert control.choose(lambda pairs: pytest.fail("nothing may run on the fixed step")) == {0: None, 1: None}
