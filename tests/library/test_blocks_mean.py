"""Mean and RMS over a period (MSL Modelica.Blocks.Math.Mean / RootMeanSquare): sampled at the end of
every period by an event that cannot be missed, on both simulation paths and in an exported FMU."""
import numpy as np
import pytest
import sympy as sp

from acausal import Model, compile_model, connect, time
from acausal.library.blocks import RMS, Mean, SignalSource

F, A = 50.0, 2.0  # Hz, amplitude of the sine


class Signals(Model):
    """u = 1 + t + 2 sin(2 pi 50 t) into a Mean and an RMS over 1/50 s."""

    def build(self):
        self.src = SignalSource(signal=1.0 + time + A * sp.sin(2 * np.pi * F * time))
        self.mean = Mean(f=F, y_start=-1.0)
        self.rms = RMS(f=F)
        connect(self.src.y, self.mean.u, self.rms.u)


def closed_forms(k):
    """Mean and RMS of u over period k (from k T to (k + 1) T), exactly."""
    T = 1 / F
    a, b = k * T, (k + 1) * T
    mean = 1 + (a + b) / 2  # the sine averages out
    # mean of (1 + t)^2 + A^2 sin^2 + 2 A (1 + t) sin over the period
    sq = ((1 + b) ** 3 - (1 + a) ** 3) / (3 * T) + A**2 / 2 - 2 * A / (2 * np.pi * F)
    return mean, np.sqrt(sq)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["auto", "BDF"])
def test_mean_and_rms_of_each_period(method):
    cm = compile_model(Signals())
    periods = 10
    T = 1 / F
    t_eval = (np.arange(periods) + 1.5) * T  # mid-period: the value sampled at the end of the period before
    res = cm.simulate(periods * T + 0.5 * T, t_eval=np.r_[0.5 * T, t_eval], method=method, rtol=1e-9, atol=1e-12)
    assert res["mean.y.value"][0] == -1.0 and res["rms.y.value"][0] == 0.0  # before the first period ends
    for j, k in enumerate(range(periods)):
        mean, rms = closed_forms(k)
        assert res["mean.y.value"][j + 1] == pytest.approx(mean, rel=1e-6), k
        assert res["rms.y.value"][j + 1] == pytest.approx(rms, rel=1e-6), k
    times = sorted({round(t, 12) for t, _, _ in res.events})
    assert np.allclose(times, (np.arange(periods) + 1) * T, atol=1e-12)



@pytest.mark.parametrize("method", ["auto", "BDF"])
def test_a_sample_at_t_end_shows_in_the_value_at_t_end(method):
    """The run ends on a sample (3 periods); the value at t_end is the one after that event, the
    final value a Modelica tool reports (the mean of the third period), not the left limit (the second's). An
    output at an earlier sample keeps the value before it."""
    cm = compile_model(Signals())
    T = 1 / F
    res = cm.simulate(3 * T, n_points=7, method=method, rtol=1e-9, atol=1e-12)
    assert res["mean.y.value"][-1] == pytest.approx(closed_forms(2)[0], rel=1e-6)
    assert res["rms.y.value"][-1] == pytest.approx(closed_forms(2)[1], rel=1e-6)
    assert res["mean.y.value"][4] == pytest.approx(closed_forms(0)[0], rel=1e-6)  # t = 2 T: before that sample

class Sine(Model):
    """u = 1 + 2 sin(2 pi 50 t) into an RMS over 1/50 s."""

    def build(self):
        self.src = SignalSource(signal=1.0 + A * sp.sin(2 * np.pi * F * time))
        self.rms = RMS(f=F)
        connect(self.src.y, self.rms.u)


@pytest.mark.slow
def test_the_integral_restarts_so_long_runs_stay_accurate():
    """500 periods at the default tolerances: the last period's RMS is as accurate as the first's, since the
    integral restarts at every sample (reinit). Integrated on without a restart it would have grown to 30 and
    carried its 1e-6 relative error into every later period (5e-4 of the last one's 0.06)."""
    res = compile_model(Sine()).simulate(500.5 / F, t_eval=np.array([1.5, 499.5]) / F)
    want = np.sqrt(1 + A**2 / 2)
    assert np.allclose(res["rms.y.value"], want, rtol=2e-5), res["rms.y.value"] / want - 1
    assert abs(res["rms.x"][-1]) < 2 * want**2 / F  # restarted at the last sample


class Steady(Model):
    """A constant input: nothing for the solver to resolve, so its steps grow long."""

    def build(self):
        self.src = SignalSource(signal=3.0)
        self.mean = Mean(f=10.0)
        connect(self.src.y, self.mean.u)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["auto", "BDF", "LSODA"])
def test_no_sample_is_missed_with_long_steps(method):
    """200 periods of a constant: every period's end is an event (the zero function is linear in time and jumps
    back by a period at each), even where the solver would step over many periods."""
    res = compile_model(Steady()).simulate(20.0, n_points=3, method=method)
    assert len(res.events) == 200
    assert np.allclose([t for t, _, _ in res.events], np.arange(1, 201) / 10.0, atol=1e-9)
    assert res["mean.y.value"][-1] == pytest.approx(3.0, rel=1e-9)


def test_mean_in_an_exported_fmu(tmp_path):
    from ..export.fmu_support import require_fmu_tools

    require_fmu_tools()
    from fmpy import simulate_fmu

    from acausal.export import export_fmu

    path = export_fmu(Signals(), tmp_path / "mean.fmu")
    T = 1 / F
    res = simulate_fmu(str(path), stop_time=5.5 * T, output_interval=T / 2, relative_tolerance=1e-9,
                       output=["mean.y.value", "rms.y.value"])
    mid = np.isclose((res["time"] / T) % 1, 0.5) & (res["time"] > T)
    for t, m, r in zip(res["time"][mid], res["mean.y.value"][mid], res["rms.y.value"][mid]):
        mean, rms = closed_forms(int(t / T) - 1)
        assert m == pytest.approx(mean, rel=1e-6) and r == pytest.approx(rms, rel=1e-6), t


def test_reinit_of_a_variable_that_is_no_state_is_an_error_naming_it():
    from acausal import Component, Event, ModelError, Variable
    from sympy import Eq

    class Bad(Component):
        y = Variable(doc="algebraic")

        def equations(self):
            return [Eq(self.y, 2 * time)]

        def events(self):
            return [Event(time - 1.0, reinit={self.y: 0.0})]

    class M(Model):
        def build(self):
            self.bad = Bad()

    with pytest.raises(ModelError, match=r"event of Bad 'bad' reinitialises 'bad.y', which is not a state"):
        compile_model(M())
