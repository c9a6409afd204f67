"""The compiled path against the scipy path on the models the fits and diagnoses repeat, both
measured in the same run:

* the Eq. 4 ankle actuator in closed loop (5 states, the gait spline and the planned moment-arm spline as inputs),
  6 s of gait: the default ``simulate()`` vs scipy's BDF (the previous default);
* the same model's exact sensitivities of the motor current and speed to three parameters over 2 s;
* the whole chain in closed loop (``AnkleActuator(mode="closed_loop")``: rectifier, EPOS2 driver, motor,
  lossy gears, MACCEPA; 6 s of gait at 2 s/stride, 3001 outputs), the default ``simulate()``, in units of the
  hand-written 1-s scipy LSODA run of ``handwritten.py`` (goal: at most 50 of them), the two interleaved (four
  hand-written runs before each run of the chain, each side's fastest).

Ratios go to ``extra_info`` and the README; the assertions are loose regression guards on ratios only.
"""

import time

import numpy as np
import pytest

from acausal import compile_model
from acausal.models.ankle.actuator import AnkleActuator
from .timing import best_of

pytest.importorskip("casadi", reason="the compiled path needs CasADi")


@pytest.fixture(scope="module")
def eq4():
    return compile_model(AnkleActuator.eq4(mode="closed_loop", effects=()))


def _report(benchmark, what, ref):
    if benchmark.disabled or benchmark.stats is None:
        return None
    t = benchmark.stats.stats.min
    benchmark.extra_info.update(scipy_s=ref, ratio=t / ref)
    print(f"\n{what}: compiled {t * 1e3:.1f} ms, scipy BDF {ref * 1e3:.1f} ms, ratio {t / ref:.3f}")
    return t / ref


def test_closed_loop_ankle_compiled_vs_scipy(benchmark, eq4):
    run = dict(n_points=3001, rtol=1e-6, atol=1e-9)
    fast = eq4.simulate(6.0, **run)
    ref = eq4.simulate(6.0, method="BDF", **run)
    assert fast.solver.startswith("CVODES")
    assert np.max(np.abs(fast["motor.i"] - ref["motor.i"])) < 1e-3 * np.max(np.abs(ref["motor.i"]))
    assert abs(fast.energy_balance().residual) < 1e-6
    t_ref = best_of(lambda: eq4.simulate(6.0, method="BDF", **run), 2)
    benchmark.pedantic(lambda: eq4.simulate(6.0, **run), rounds=5, iterations=1)
    ratio = _report(benchmark, "closed-loop Eq. 4 ankle, 6 s", t_ref)
    assert ratio is None or ratio < 0.5  # regression guard (measured about 0.1)


def test_closed_loop_ankle_sensitivities_compiled_vs_scipy(benchmark, eq4):
    t = np.linspace(0.0, 2.0, 401)
    wrt = ["motor.R", "motor.k", "link.k"]
    args = dict(names=["motor.i", "motor.w"], rtol=1e-8, atol=1e-10)
    v1, s1 = eq4.sensitivities(t, wrt, **args)
    v2, s2 = eq4.sensitivities(t, wrt, method="BDF", **args)
    for n in s1:
        scale = np.max(np.abs(s2[n]), axis=1, keepdims=True) + 1e-300
        assert np.all(np.abs(s1[n] - s2[n]) <= 1e-4 * scale), n
    t_ref = best_of(lambda: eq4.sensitivities(t, wrt, method="BDF", **args), 1)
    benchmark.pedantic(lambda: eq4.sensitivities(t, wrt, **args), rounds=3, iterations=1)
    ratio = _report(benchmark, "sensitivities to 3 parameters, 2 s", t_ref)
    assert ratio is None or ratio < 0.5


def test_lossy_gear_drive_on_idas_vs_scipy(benchmark):
    """The reference drive with a lossy gear (a Newton block on the scipy path; algebraic variables of IDAS on the
    compiled path), 0.3 s."""
    from ..drive_models import MotorLossyGearLoad
    cm = compile_model(MotorLossyGearLoad())
    run = dict(n_points=301, rtol=1e-6, atol=1e-9)
    fast, ref = cm.simulate(0.3, **run), cm.simulate(0.3, method="BDF", **run)
    assert fast.solver.startswith("IDAS")
    assert np.max(np.abs(fast["load.w"] - ref["load.w"])) < 1e-4 * np.max(np.abs(ref["load.w"]))
    t_ref = best_of(lambda: cm.simulate(0.3, method="BDF", **run), 3)
    benchmark.pedantic(lambda: cm.simulate(0.3, **run), rounds=5, iterations=1)
    ratio = _report(benchmark, "drive with a lossy gear, 0.3 s", t_ref)
    assert ratio is None or ratio < 0.5


def test_whole_chain_closed_loop_ankle_in_hand_written_runs(benchmark):
    from .handwritten import simulate as hand_written
    cm = compile_model(AnkleActuator(mode="closed_loop"))
    run = dict(n_points=3001)
    res = cm.simulate(6.0, **run)
    assert res.trust == [] and abs(res.energy_balance().residual) < 1e-6
    hand = []

    def hand_block():  # the round's untimed set-up: the reference timed beside each run of the chain
        for _ in range(4):
            t0 = time.perf_counter()
            hand_written()
            hand.append(time.perf_counter() - t0)
    benchmark.pedantic(lambda: cm.simulate(6.0, **run), setup=hand_block, rounds=8, iterations=1)
    if benchmark.disabled or benchmark.stats is None:
        return
    t, t_hand = benchmark.stats.stats.min, min(hand)
    # the goal is the native loop's; where it is not built (or switched off) the run takes CasADi's event path,
    # whose own figure guards it (docs/benchmarks.md: 193-225 runs with ACAUSAL_NATIVE=0, 2026-12-02, idle)
    native = "native" in res.solver
    guard = 150 if native else 700  # regression guards only: 3x the goal, and 3x the CasADi path's figure
    benchmark.extra_info.update(hand_s=t_hand, hand_runs=t / t_hand, goal_hand_runs=50, solver=res.solver)
    print(f"\nwhole chain, closed loop, 6 s: {t * 1e3:.0f} ms = {t / t_hand:.0f} hand-written 1-s runs "
          f"({t_hand * 1e3:.2f} ms each; goal <= 50 on the native loop; this run: {res.solver})")
    assert t / t_hand < guard, res.solver
