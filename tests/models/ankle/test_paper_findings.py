"""The paper's findings, checked in our simulation of the ankle actuator, and golden values.

Replay conditions where the motor cannot follow (the required duty exceeds the driver's 0.9 at 48 V, i.e. low
precompression and fast strides) are outside what the bench could do; the findings are checked where the motor
can follow, which the tests assert first.
"""
import json
from pathlib import Path

import numpy as np
import pytest

from acausal.models.ankle.protocol import Condition, run_condition, sweep

Ps = [0.008, 0.011, 0.018]
Ts = [2.0, 2.5, 3.0]  # at 1.5 s and 18 mm the replay already needs a duty of 0.93 > 0.9


@pytest.fixture(scope="module")
def grid():
    conds = [Condition(P, T) for P in Ps for T in Ts]
    res = sweep(conds, progress=False)
    return {(r.condition.P, r.condition.stride_time): r for r in res}


@pytest.mark.slow
def test_conditions_are_feasible_and_balanced(grid):
    for r in grid.values():
        assert r.max_duty <= 0.9, r.condition  # the motor can follow at 48 V
        assert abs(r.balance_residual) < 1e-6, r.condition  # source = losses + output + stored change


def test_driver_share_of_loss_grows_with_stride_time(grid):
    """Constant quiescent draw: the slower the stride, the more of the source energy the driver burns."""
    for P in Ps:
        share = [grid[P, T].stage_loss["driver"] / grid[P, T].energy["source"] for T in Ts]
        assert np.all(np.diff(share) > 0), (P, share)


def test_motor_losses_grow_with_stride_time(grid):
    """Slower strides run the motor at low speed and high torque: its relative loss grows (2-3 s)."""
    for P in Ps:
        frac = [grid[P, T].stage_loss["motor"] / grid[P, T].energy["driver"] for T in Ts]
        assert np.all(np.diff(frac) > 0), (P, frac)


def test_motor_losses_grow_with_precompression(grid):
    """Across the range (8 -> 18 mm) the motor's relative loss grows at every stride time. Between 8 and 11 mm
    our model dips by up to 1 % (relative) instead of rising (a known difference, stated in the report): only
    the range trend is asserted."""
    for T in Ts:
        frac = {P: grid[P, T].stage_loss["motor"] / grid[P, T].energy["driver"] for P in Ps}
        assert frac[0.018] > frac[0.011] and frac[0.018] > frac[0.008], (T, frac)


def test_actuator_peak_power_well_below_direct_drive():
    """Fig. 7: the series spring lowers the peak power at the driver input by at least 30 % for about the same
    energy per stride (paper: direct drive ~40 % higher peak; 126 vs 122 J)."""
    act = run_condition(Condition(0.008, 3.0))
    dd = run_condition(Condition(0.008, 3.0, model="direct_drive"))
    assert act.peak_power["source"] <= 0.7 * dd.peak_power["source"]
    assert act.energy["source"] == pytest.approx(dd.energy["source"], rel=0.15)
    assert act.energy["output"] == pytest.approx(dd.energy["output"], rel=1e-6)  # the same joint work


def test_bench_output_motor_is_pushed_by_the_gait_moment():
    """Fig. 7's "direct drive" was the bench's output motor: it holds the joint on the gait angle while the actuator
    pushes, so its joint work is the forward direct drive's with the sign turned, it is back-driven at push-off
    (the non-regenerative rectifier returns nothing: source power never below zero) and its balance closes."""
    fwd = run_condition(Condition(0.008, 3.0, model="direct_drive"))
    out = run_condition(Condition(0.008, 3.0, model="bench_output_motor"))
    assert out.energy["output"] == pytest.approx(-fwd.energy["output"], rel=1e-6)
    assert out.energy["output"] < 0 and np.min(out.power["motor"]) < -20.0  # back-driven, tens of watts
    assert np.min(out.power["source"]) > -0.01 and abs(out.balance_residual) < 1e-6
    # with the actuator's own drive train (the guess) the output motor needs less than the actuator: the paper's
    # 1.4x peak and 126 J must come from a different output drive train (claim C9's reading)
    act = run_condition(Condition(0.008, 3.0))
    assert out.peak_power["source"] < act.peak_power["source"] and out.energy["source"] < act.energy["source"]


@pytest.mark.slow
def test_tracking_error_at_fast_strides_exceeds_slow():
    """Fig. 13: at 18 mm the arm follows the setpoint worse at 1.2 s/stride than at 3 s (the paper puts the worst
    error in push-off; the model's is in the arm's fast return after it: the figure's caption says so)."""
    fast = run_condition(Condition(0.018, 1.2, model="closed_loop", strides=3))
    slow = run_condition(Condition(0.018, 3.0, model="closed_loop", strides=3))
    assert fast.tracking_rms > 1.5 * slow.tracking_rms
    assert fast.tracking_max > slow.tracking_max
    assert abs(fast.balance_residual) < 1e-6 and abs(slow.balance_residual) < 1e-6


@pytest.mark.slow
def test_bench_losses_grow_where_the_arm_lags():
    """4.2.3: on the bench (closed loop) the losses of the gearing and the linkage grow at high precompression and
    short strides, where the motor cannot follow the plan and the arm lags; at 3 s/stride the bench and the replay
    of the same plan agree closely."""
    def both(T):
        return [run_condition(Condition(0.018, T, model=m, preset="paper_fit")) for m in ("closed_loop", "replay")]
    (bench, plan), (bench_slow, plan_slow) = both(1.2), both(3.0)
    assert plan.max_duty > 0.9 >= plan_slow.max_duty  # the plan needs more than the driver gives at 1.2 s only
    assert bench.loss_fraction["link"] > plan.loss_fraction["link"] + 0.10  # gearing (motor -> link)
    assert bench.loss_fraction["output"] > plan.loss_fraction["output"] + 0.20  # linkage (link -> output)
    assert bench.energy["output"] < 0.5 * plan.energy["output"]  # the lagging arm does less joint work
    assert abs(bench_slow.loss_fraction["link"] - plan_slow.loss_fraction["link"]) < 0.05
    assert abs(bench_slow.energy["output"] / plan_slow.energy["output"] - 1) < 0.15
    for r in (bench, plan, bench_slow, plan_slow):
        assert abs(r.balance_residual) < 1e-6, r.condition


def test_motor_point_is_the_power_computed_from_current_and_speed():
    """Fig. 6, Eq. 6: the paper's motor power is k i w (no torque sensor on the motor shaft); the rotor's friction
    is in the gearing stage."""
    r = run_condition(Condition(0.008, 2.0, preset="paper_fit"), traces=("motor.i", "motor.w", "P_motor.P"))
    k = r.params["motor.k"]
    assert np.allclose(r.traces["P_motor.P"], k * r.traces["motor.i"] * r.traces["motor.w"], rtol=1e-9, atol=1e-9)
    assert r.stages["motor"] == ["motor.loss_power"]
    assert r.stages["gearing"][0] == "rotor_friction.loss_power"
    assert r.loss_energy["rotor_friction.loss_power"] > 0.5  # J per stride: not negligible against the 9 J motor loss


GOLDEN = json.loads((Path(__file__).parents[2] / "golden" / "paper_golden.json").read_text())


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(GOLDEN))
def test_golden_values(name):
    """Our own outputs, pinned (regenerate with `python -m tests.golden.regenerate` after intended changes)."""
    from ...golden.regenerate import CASES

    r = run_condition(CASES[name])
    want = GOLDEN[name]
    tol = 1e-5 if CASES[name].model != "closed_loop" else 1e-3
    for k, v in want["energy"].items():
        assert r.energy[k] == pytest.approx(v, rel=tol, abs=1e-6), (name, k)
    for k, v in want["peak_power"].items():
        assert r.peak_power[k] == pytest.approx(v, rel=tol), (name, k)
    assert r.tracking_rms == pytest.approx(want["tracking_rms"], rel=10 * tol, abs=1e-9)


# ----------------------------------------------------- what opposes the claims that fail (README's claims table)
@pytest.mark.slow
def test_the_driver_loss_bowl_is_the_burnt_regenerated_energy():
    """C3/C4: on the bench the non-regenerative front end burns what the motor sends back (rect.loss_power); it grows
    towards short strides and with precompression, against the constant draw growing towards long strides. At the
    tuned 8 mm the draw wins from 1.5 s/stride on by far; at 18 mm the burnt energy falls from 1.5 to 2 s/stride by
    about what the draw adds over the extra half second: there C3's long-stride branch holds only by the balance the
    inference found (its target C3.long is active there, against C10's dip through the inertia)."""
    def bench(P, T):
        return run_condition(Condition(P, T, model="closed_loop", preset="paper_fit"))
    r = {(P, T): bench(P, T) for P in (0.008, 0.018) for T in (1.2, 1.5, 2.0)}
    burnt = {k: v.loss_energy["rect.loss_power"] for k, v in r.items()}
    lost = {k: v.energy["source"] - v.energy["driver"] for k, v in r.items()}
    half = 0.5 * r[(0.008, 2.0)].params["driver.P_q"]  # what the draw adds from 1.5 to 2 s/stride [J]
    for P in (0.008, 0.018):
        assert burnt[(P, 1.2)] > burnt[(P, 1.5)] > burnt[(P, 2.0)] >= 0.0, (P, burnt)
    assert burnt[(0.018, 1.2)] > 1.5 * burnt[(0.008, 1.2)]  # grows with precompression at short strides (C4)
    assert burnt[(0.008, 1.5)] - burnt[(0.008, 2.0)] < 0.6 * half  # the tuned 8 mm: the bowl, by far
    assert 0.9 * half < burnt[(0.018, 1.5)] - burnt[(0.018, 2.0)] < 1.1 * half  # 18 mm: a balance
    assert lost[(0.018, 2.0)] >= lost[(0.018, 1.5)] - 1e-2  # ... that C3 reads as holding (its 0.01 J slack)
    assert lost[(0.008, 2.0)] > lost[(0.008, 1.5)] + 0.5 * half


def test_softer_springs_cost_more_copper_on_both_models():
    """C11: the copper loss is not the same for every spring (1.2 s/stride, 130/7 against 60/7 and 60/4 N/mm/mm),
    on the fitted chain and on the paper's own Eq. 4, planned alike."""
    from acausal.models.ankle.presets import PAPER_EQ4
    from acausal.models.bench import design
    ks, Ps_ = np.array([60e3, 130e3]), np.array([0.004, 0.007])
    plan = {k: v for k, v in design.design_params("paper_fit")[1].items() if k in ("body_mass", "torque_tolerance")}
    for preset, over in (("paper_fit", None), (PAPER_EQ4, plan)):
        m = design.efficiency_map(1.2, preset, overrides=over, ks=ks, Ps=Ps_, executor="serial")
        cu = {(k, P): m.at(k, P, "E_copper_J") for k in ks for P in Ps_}
        assert cu[(130e3, 0.007)] < cu[(60e3, 0.007)] < cu[(60e3, 0.004)], (preset, cu)


@pytest.mark.slow
def test_motor_loss_falls_from_2_to_5_mm_whatever_the_planners_band():
    """C5: at 2 mm the MACCEPA is soft (T ~ alpha^3): with a tight torque band (1 N m) the plan moves the arm far and
    fast there, the motor runs faster than at 5 mm and draws more current (its inertia torque); the fitted 6 N m band
    takes the slowest arm path in the band, the motor then runs slower than at 5 mm, at a lower efficiency, as the
    paper's own explanation has it (4.2.2). Either way the motor loss at 2 mm is above that at 5 mm (2 s/stride)."""
    def run(P, tol):
        r = run_condition(Condition(P, 2.0, model="closed_loop", preset="paper_fit",
                                    overrides={"torque_tolerance": tol}), traces=("motor.i", "motor.w"))
        return (r.loss_fraction["motor"], np.mean(np.abs(r.traces["motor.w"])),
                np.sqrt(np.mean(r.traces["motor.i"] ** 2)))
    for tol in (1.0, 6.0):
        (loss2, w2, i2), (loss5, w5, i5) = run(0.002, tol), run(0.005, tol)
        assert loss2 > loss5 + 0.01 and i2 > i5, (tol, loss2, loss5, i2, i5)
        assert (w2 > 1.05 * w5) if tol == 1.0 else (w2 < w5), (tol, w2, w5)


@pytest.mark.slow
def test_motor_loss_falls_from_2_to_5_mm_with_the_rotors_inertia_alone():
    """C5's fall from 2 to 5 mm is not the inertia the fit infers for C3 and C10 (near its upper bound): with the
    motor's inertia at its a-priori value (the datasheet rotor's) the loss at 2 mm stays above that at 5 mm, the mean
    motor speed below (the paper's own mechanism, read on the model), at the shortest and the Table 1 stride."""
    from acausal.models.ankle.inference import UNKNOWNS
    J = next(u for u in UNKNOWNS if u.name == "motor.J")
    for T in (1.2, 2.0):
        r2, r5 = (run_condition(Condition(P, T, model="closed_loop", preset="paper_fit",
                                          overrides={"motor.J": J.start})) for P in (0.002, 0.005))
        assert r2.params["motor.J"] == J.start
        assert r2.loss_fraction["motor"] > r5.loss_fraction["motor"] + 0.005, T
        assert r2.mean_motor_speed < r5.mean_motor_speed, T

@pytest.mark.slow
def test_r_inflation_is_the_drivers_losses(tmp_path):
    """C13: Eq. 4 (ideal driver and gears) calibrated on recordings of the fitted chain inflates R by about 4x,
    beyond the paper's 2.86x; with the chain's driver made lossless (no constant draw, conduction or switching
    loss), the same calibration gives about 3x, within the claim's 25 %: the rest of the inflation is the driver's
    losses, which show in the supply current that makes R identifiable."""
    from acausal.models.ankle.published import PAPER
    from acausal.models.bench import calibration
    from acausal.models.bench.virtual import BenchCondition, run_bench, truth_body_mass
    conds = [BenchCondition(P, T, strides=3, body_mass=truth_body_mass("paper_fit"))
             for P in (0.005, 0.015) for T in (1.2, 2.0)]
    paper = PAPER["table2_R"][1] / PAPER["table2_R"][0]
    ratio = {}
    for name, truth in (("fitted", None), ("lossless", {"driver.P_q": 0.0, "driver.R_on": 0.0, "driver.k_sw": 0.0})):
        run_bench(tmp_path / name, conds, seed=2014, chain="paper_fit", truth=truth, executor="serial")
        ratio[name] = calibration.fit(tmp_path / name, "R,J,b")[0].values["motor.R"] / PAPER["table2_R"][0]
    assert ratio["fitted"] > 1.25 * paper and abs(ratio["lossless"] / paper - 1) <= 0.25, ratio
    assert ratio["fitted"] - ratio["lossless"] > 0.5, ratio
