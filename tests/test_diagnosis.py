"""``acausal diagnose``: hide an effect in virtual-bench recordings and require the diagnosis to find it.

Every dataset is recorded by the virtual bench (closed loop, the paper's protocol, realistic seeded sensors) on
seeds the thresholds were not tuned on (they were tuned on seeds 0-2)."""
import json

import numpy as np
import pytest

from acausal.cli import main
from acausal.models import diagnosis
from acausal.models.bench import BenchCondition, Sensors, run_bench
from acausal.models.effects import EFFECTS

#: 2 precompressions x 2 stride times, 3 strides each (every third stride held out)
CONDITIONS = [BenchCondition(P, T, strides=3) for P in (0.005, 0.011) for T in (1.2, 2.0)]
#: a smaller set for the runs that must answer "none"
SMALL = [BenchCondition(0.008, T, strides=3) for T in (1.2, 2.0)]
#: winding heating needs long runs and a precise supply-current sensor to show at all (see EFFECTS' doc)
LONG = [BenchCondition(P, 2.5, strides=16) for P in (0.011, 0.015)]
PRECISE_SUPPLY = Sensors(supply_current_noise=0.002)

#: the size each effect is hidden at (typical sizes, except winding heating: see above)
SIZES = {e.id: e.typical for e in EFFECTS.values()} | {"winding_temperature": 1.0}


def _record(tmp_path_factory, name, conditions, effects, seed, sensors=Sensors()):
    out = tmp_path_factory.mktemp(name)
    run_bench(out, conditions, effects, sensors=sensors, seed=seed)
    return out


DETECTABLE = sorted(set(EFFECTS) - {"winding_temperature"})


@pytest.mark.parametrize("eid", DETECTABLE + [pytest.param("winding_temperature", marks=pytest.mark.xfail(
    strict=True, reason="winding heating changes the supply current by a few mA over a recording: the refit does not "
                        "yet recover it (issue 7 note)"))])
def test_each_hidden_effect_is_named_and_measured(eid, tmp_path_factory):
    size = SIZES[eid]
    if eid == "winding_temperature":
        data = _record(tmp_path_factory, eid, LONG, {eid: size}, seed=11, sensors=PRECISE_SUPPLY)
    else:
        data = _record(tmp_path_factory, eid, CONDITIONS, {eid: size}, seed=11)
    d, _ = diagnosis.run(data, max_effects=1)
    assert d.cause == eid, [(s.id, s.heldout_rmse_gain, s.significant) for s in d.candidates]
    e = EFFECTS[eid]
    before, after = d.baseline.test_rmse[e.signal], d.final.test_rmse[e.signal]
    assert after <= 0.7 * before, (e.signal, before, after)
    fitted = d.final.values[e.parameter]
    assert fitted == pytest.approx(size, rel=0.2), (e.parameter, fitted, size)
    # once extended, the baseline parameters are back at the truth (R, J, b of the bench)
    assert d.final.values["motor.R"] == pytest.approx(0.7, rel=0.05)
    assert d.final.values["motor.J"] == pytest.approx(4.07e-6, rel=0.05)


@pytest.mark.parametrize("seed", [3, 4, 5, 6, 7])
def test_noise_and_quantisation_alone_give_none(seed, tmp_path_factory):
    data = _record(tmp_path_factory, f"noisy{seed}", SMALL, {}, seed=seed)
    d, _ = diagnosis.run(data, max_effects=1)
    assert d.cause == "none", [(s.id, s.heldout_rmse_gain, s.t_stat, s.delta_bic) for s in d.candidates]
    assert max(s.heldout_rmse_gain for s in d.candidates) < 0.5 * d.thresholds.min_gain


@pytest.mark.parametrize("seed", [3, 4, 5, 6, 7])
def test_clean_recordings_give_none(seed, tmp_path_factory):
    """A high-grade bench: a tenth of the sensor noise, 16-bit encoders, nothing hidden."""
    clean = Sensors(encoder_bits=16, motor_current_noise=0.003, supply_current_noise=0.002,
                    supply_voltage_noise=0.002, torque_noise=0.04)
    data = _record(tmp_path_factory, f"clean{seed}", SMALL, {}, seed=seed, sensors=clean)
    d, _ = diagnosis.run(data, max_effects=1)
    assert d.cause == "none", [(s.id, s.heldout_rmse_gain, s.t_stat, s.delta_bic) for s in d.candidates]


def test_two_hidden_effects_are_both_named(tmp_path_factory):
    effects = {"gear_coulomb_friction": 0.012, "driver_quiescent_power": 12.5}
    data = _record(tmp_path_factory, "two", CONDITIONS, effects, seed=12)
    d, _ = diagnosis.run(data, max_effects=3)
    assert set(d.causes) == set(effects), d.causes
    assert d.final.values["gear_friction.tau_c"] == pytest.approx(0.012, rel=0.2)
    assert d.final.values["driver.P_q"] == pytest.approx(12.5, rel=0.2)


def test_cli_writes_report_figures_and_json(tmp_path, capsys):
    data = tmp_path / "data"
    run_bench(data, SMALL, {"torque_sensor_offset": 1.5}, seed=13)
    out, js = tmp_path / "out", tmp_path / "verdict.json"
    assert main(["diagnose", str(data), "--out", str(out), "--json", str(js), "--no-progress"]) == 0
    assert "cause: torque_sensor_offset" in capsys.readouterr().out
    verdict = json.loads(js.read_text())
    assert verdict["cause"] == "torque_sensor_offset" and verdict["causes"][0] == verdict["cause"]
    ids = [c["id"] for c in verdict["candidates"]]
    assert sorted(ids) == sorted(EFFECTS)
    for c in verdict["candidates"]:
        assert set(c) >= {"id", "heldout_rmse_gain", "delta_bic", "params"}
        assert np.isfinite(c["heldout_rmse_gain"]) and np.isfinite(c["delta_bic"])
    best = verdict["candidates"][0]
    assert best["id"] == "torque_sensor_offset" and best["params"]["torque_offset.bias"] == pytest.approx(1.5, rel=0.2)
    report = (out / "report.md").read_text()
    assert "Verdict: `torque_sensor_offset`" in report and "thresholds were tuned" in report
    for png in ("diagnosis_residual_phase.png", "diagnosis_autocorrelation.png"):
        assert (out / png).stat().st_size > 10_000 and png in report


def test_unknown_candidate_is_a_clear_error(tmp_path):
    data = tmp_path / "data"
    run_bench(data, SMALL[:1], {}, seed=14)
    with pytest.raises(Exception, match="unknown candidate 'gear_wear'.*gear_backlash"):
        diagnosis.run(data, candidates=["gear_wear"])
