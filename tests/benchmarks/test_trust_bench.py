"""What the trust checks cost against the run they check (at most a quarter of a run on either
path), on the 1-s ``motor_gear_load`` at rtol 1e-6 / atol 1e-9 with 1001 outputs and dense output (the default):
the check (non-finite values, poles, conditioning, the energy balance) timed on fresh results, the run without it
measured in the same session.

Ratios are stored in ``extra_info`` and printed; the only assertion on time is a loose regression guard on the
ratio (3x the goal), never an absolute time.
"""
import pytest

from acausal import compile_model
from acausal.results import trust

from ..drive_models import MotorGearLoad
from .timing import best_of, min_time

RUN = dict(rtol=1e-6, atol=1e-9, n_points=1001)
GOAL = 0.25


@pytest.fixture(scope="module")
def cm():
    return compile_model(MotorGearLoad())


@pytest.mark.parametrize("method", ["auto", "LSODA"])
def test_trust_check_share_of_a_run(benchmark, cm, method):
    def run():
        return cm.simulate(1.0, trust="off", method=method, **RUN)

    def check(res):
        trust.check(res, RUN["rtol"], RUN["atol"], "raise", True)
        return res

    res = check(run())
    assert res.trust == []  # a sane run: the check finds nothing
    reference = best_of(run, 30)
    benchmark.pedantic(check, setup=lambda: ((run(),), {}), rounds=60, iterations=1)
    t = min_time(benchmark)
    if t is None:
        return
    ratio = t / reference
    benchmark.extra_info.update(reference_s=reference, ratio=ratio, goal_ratio=GOAL, solver=res.solver)
    print(f"\n{benchmark.name}: check {t * 1e3:.3f} ms, run {reference * 1e3:.3f} ms ({res.solver}), "
          f"share {ratio:.2f} (goal <= {GOAL})")
    assert ratio < 3 * GOAL
