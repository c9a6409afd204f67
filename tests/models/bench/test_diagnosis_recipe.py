"""The diagnosis on recordings made by another recipe than the virtual bench's defaults.

The recipe: half the sample rate (500 Hz), 16-bit encoders, noisier current and torque sensors, current readings
through a 100 Hz first-order filter (which the model does not know), other stride times (1.4 and 2.2 s), seeds
301-304 (used nowhere else, and never for tuning). Each effect is hidden alone at its
typical size (the winding time-compressed and carried across a six-recording session, as in
test_diagnosis_limits), then two together, then none. Required: every effect named, the pair named, ``none`` on
clean data with a detection limit for every candidate, and the truth within 3 reported (cluster-robust) standard
errors in at least 6 of the 7 single-effect cases.

Known miss: the Coulomb friction comes out about 1 % low with a viscous b 2 % high, 5-7 standard errors away: the
replay's smoothed motor speed is slightly off near the speed reversals where the smooth sign law changes fastest,
a bias no standard error covers."""
import numpy as np
import pytest

from acausal.models.ankle.effects import EFFECTS
from acausal.models.bench import diagnosis
from acausal.models.bench.virtual import BenchCondition, Sensors, run_bench, run_session

#: each test here takes seconds (its simulations or its shared fixture): out of the quick lane
pytestmark = pytest.mark.slow

RECIPE = Sensors(rate=500.0, encoder_bits=16, motor_current_noise=0.05, supply_current_noise=0.03, torque_noise=0.6,
                 current_filter_hz=100.0)
CONDITIONS = [BenchCondition(P, T, strides=3) for P in (0.005, 0.011) for T in (1.4, 2.2)]
SESSION = [BenchCondition(P, 1.6, strides=5, body_mass=100.0, settle=0) for P in (0.008, 0.011, 0.005) * 2]
WINDING = 0.1  # K/J, time-compressed (see test_diagnosis.ENDURANCE)


def _size(eid):
    return WINDING if eid == "winding_temperature" else EFFECTS[eid].typical


@pytest.fixture(scope="module")
def single(tmp_path_factory):
    """Each effect hidden alone: id -> Diagnosis."""
    out = {}
    for eid in sorted(EFFECTS):
        folder = tmp_path_factory.mktemp(eid)
        if eid == "winding_temperature":
            run_session(folder, SESSION, {eid: WINDING}, sensors=RECIPE, seed=301, pause=5.0)
        else:
            run_bench(folder, CONDITIONS, {eid: _size(eid)}, sensors=RECIPE, seed=301, executor="serial")
        out[eid] = diagnosis.run(folder, max_effects=1)[0]
    return out


@pytest.mark.parametrize("eid", sorted(EFFECTS))
def test_each_effect_is_named(single, eid):
    d = single[eid]
    assert d.causes == [eid], [(s.id, s.heldout_rmse_gain, s.significant) for s in d.candidates]
    assert d.to_dict()["standard_errors"]["method"].startswith("cluster-robust")


def test_the_truth_lies_within_three_standard_errors_in_six_of_seven_cases(single):
    z = {}
    for eid, d in single.items():
        p = EFFECTS[eid].parameter
        z[eid] = (d.final.values[p] - _size(eid)) / d.final.cal.std[p]
    assert sum(abs(v) <= 3 for v in z.values()) >= 6, z
    # the textbook errors would not do: they assume white residuals
    assert all(np.isfinite(v) for v in z.values()), z


def test_two_hidden_effects_are_both_named(tmp_path):
    effects = {"gear_coulomb_friction": 0.012, "driver_quiescent_power": 12.5}
    run_bench(tmp_path, CONDITIONS, effects, sensors=RECIPE, seed=302, executor="serial")
    d = diagnosis.run(tmp_path, max_effects=3)[0]
    assert set(d.causes) == set(effects), d.causes


@pytest.mark.parametrize("seed", [303, 304])
def test_clean_recordings_give_none_with_detection_limits(seed, tmp_path):
    run_bench(tmp_path, CONDITIONS, {}, sensors=RECIPE, seed=seed, executor="serial")
    d = diagnosis.run(tmp_path, max_effects=1)[0]
    assert d.cause == "none", [(s.id, s.heldout_rmse_gain, s.significant) for s in d.candidates]
    lims = d.to_dict()["detection_limits"]
    assert set(lims) == set(EFFECTS)
    for eid, lim in lims.items():
        assert lim["unit"] == EFFECTS[eid].unit and (lim["size"] is None or lim["size"] > 0), (eid, lim)
    # an effect of its typical size is above its limit (each is named above), except the winding, which needs a
    # session: its limit in these short, separate recordings is beyond its fitting range
    assert all(lims[e]["size"] < EFFECTS[e].typical for e in EFFECTS if e != "winding_temperature"), lims
    assert lims["winding_temperature"]["value"] is None
