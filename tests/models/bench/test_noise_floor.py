"""On clean recordings (nothing hidden) the calibrated Eq. (4) baseline predicts the held-out
currents to within the sensor noise, because the replay's smoothing is chosen from the data
(:func:`acausal.identify.smoothing.derivative_spacing`) rather than fixed at 80 knots per stride.

The motor current the replay predicts is ``n J / k`` times the smoothed moment-arm angle's second derivative
(``n = 860``): with 14-bit encoders and the fixed 80 knots per stride, the smoothing's quantisation noise alone
added about 0.025 A (RMS) to it, and the held-out RMSE sat 15 % above the 0.03 A sensor noise.

The conditions are those where the driver stays below its voltage limit (P >= 5 mm, stride times >= 2 s): at
faster strides the motor current jumps within ~4 ms when the driver saturates, which no smoothing of the angles
can follow (see ``Split`` in models/bench/calibration.py). Seeds 201 and 202 are used nowhere else."""
import numpy as np
import pytest

from acausal.identify import load_recordings
from acausal.models.bench.calibration import fit
from acausal.models.bench.recording_format import ANKLE_FORMAT
from acausal.models.bench.virtual import BenchCondition, Sensors, run_bench

CONDITIONS = [BenchCondition(P, T, strides=3) for P in (0.005, 0.011) for T in (2.0, 2.5)]
#: the virtual bench's defaults, and another recipe: half the sample rate, noisier current sensors
RECIPES = {"default": (Sensors(), 201),
           "500 Hz, noisy currents": (Sensors(rate=500.0, motor_current_noise=0.05, supply_current_noise=0.03), 202)}


@pytest.mark.slow
@pytest.mark.parametrize("recipe", sorted(RECIPES))
def test_clean_baseline_is_at_the_noise_floor(recipe, tmp_path):
    sensors, seed = RECIPES[recipe]
    run_bench(tmp_path, CONDITIONS, {}, sensors=sensors, seed=seed, executor="serial")
    recs = load_recordings(tmp_path, ANKLE_FORMAT)
    assert len(recs[0].t) == round(2.0 * 3 * sensors.rate)  # the recipe's rate is what was recorded
    cal, _ = fit(recs)
    floor = sensors.noise_floor()
    ratios = {s: cal.rmse(s) / floor[s] for s in ("motor_current_A", "supply_current_A")}
    assert all(r <= 1.10 for r in ratios.values()), ratios
    assert cal.values["motor.J"] == pytest.approx(4.07e-6, rel=0.02)
    assert cal.values["motor.R"] == pytest.approx(0.7, rel=0.02)


def test_current_filter_of_the_virtual_bench():
    """The first-order current filter: white noise comes out at the level ``noise_floor`` says, a step rises with
    the time constant 1 / (2 pi f), and no filter leaves the reading untouched."""
    s = Sensors(rate=1000.0, current_filter_hz=50.0)
    noise = np.random.default_rng(0).standard_normal(200_000) * s.motor_current_noise
    assert np.std(s.filtered(noise)) == pytest.approx(s.noise_floor()["motor_current_A"], rel=0.02)
    step = s.filtered(np.r_[0.0, np.ones(100)])
    t = np.arange(step.size) / s.rate  # the step arrives at sample 1: after time t it has reached 1 - exp(-t / tau)
    assert np.allclose(step, 1 - np.exp(-t * 2 * np.pi * s.current_filter_hz), atol=1e-12)
    x = np.arange(5.0)
    assert Sensors().filtered(x) is x and Sensors().noise_floor()["motor_current_A"] == Sensors().motor_current_noise
