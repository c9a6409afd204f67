"""Residual statistics (acausal.identify.residuals): each one separates a systematic error from white noise."""
import numpy as np
import pytest

from acausal import DataError
from acausal.identify.residuals import (autocorrelation, block_length, cross_correlations, leave_one_group_out,
                                        phase_profile, structure_test, whiteness)


def test_phase_profile_recovers_a_repeating_error_under_noise():
    rng = np.random.default_rng(0)
    T = 1.2
    t = np.arange(0, 10 * T, 1e-3)
    err = 0.5 * np.sin(2 * np.pi * t / T)
    p = phase_profile(t, err + 0.3 * rng.standard_normal(t.size), T, bins=40)
    assert np.all(p.count > 0) and p.count.sum() == t.size
    assert np.max(np.abs(p.mean - 0.5 * np.sin(2 * np.pi * p.phase))) < 0.06  # bin width + noise / sqrt(300)
    assert np.allclose(p.std, 0.3, rtol=0.15)


def test_whiteness_tells_white_noise_from_a_smooth_residual():
    rng = np.random.default_rng(1)
    e = rng.standard_normal(5000)
    w = whiteness(e, 40)
    assert w.white and w.fraction_outside < 0.15 and w.acf[0] == 1.0
    ar = np.zeros_like(e)
    for k in range(1, e.size):
        ar[k] = 0.9 * ar[k - 1] + e[k]
    w2 = whiteness(ar, 40)
    assert not w2.white and w2.fraction_outside > 0.9
    assert w2.acf[1] == pytest.approx(0.9, abs=0.03)


def test_autocorrelation_matches_the_definition():
    x = np.random.default_rng(2).standard_normal(300)
    y = x - x.mean()
    direct = [np.sum(y[: y.size - k] * y[k:]) / np.sum(y * y) for k in range(6)]
    assert np.allclose(autocorrelation(x, 5), direct)


def test_cross_correlation_names_the_regressor_behind_the_residual():
    rng = np.random.default_rng(3)
    t = np.linspace(0, 6, 6000)
    w = np.sin(2 * np.pi * t / 1.2) * 300
    residual = 0.2 * np.tanh(w / 5) + 0.05 * rng.standard_normal(t.size)  # a Coulomb friction left out
    cc = cross_correlations(residual, {"speed": w, "sign(speed)": np.tanh(w / 5), "time": t})
    assert cc[0].name == "sign(speed)" and cc[0].significant and cc[0].r > 0.9
    time_corr = next(c for c in cc if c.name == "time")
    assert not time_corr.significant
    with pytest.raises(DataError, match="regressor 'bad'"):
        cross_correlations(residual, {"bad": t[:10]})


def test_leave_one_group_out_equals_refitting_without_the_group():
    rng = np.random.default_rng(4)
    n, groups = 120, np.repeat(np.arange(6), 20)
    J = np.column_stack([np.ones(n), rng.standard_normal(n), np.linspace(0, 1, n)])
    y = J @ [1.0, 2.0, -0.5] + 0.1 * rng.standard_normal(n)
    beta = np.linalg.lstsq(J, y, rcond=None)[0]
    r = y - J @ beta
    loo = leave_one_group_out(J, r, groups)
    for g in range(6):
        m = groups == g
        b_g = np.linalg.lstsq(J[~m], y[~m], rcond=None)[0]
        assert np.allclose(loo[m], y[m] - J[m] @ b_g)
    assert np.sum(loo**2) > np.sum(r**2)


def _first_order(x, fc, rate=1000.0):
    """x through a first-order low-pass at fc [Hz] (unit DC gain), as a filtering current sensor does."""
    a = np.exp(-2 * np.pi * fc / rate)
    y = np.empty_like(x)
    acc = 0.0
    for k, v in enumerate(x):
        acc = a * acc + (1 - a) * v
        y[k] = acc
    return y


def _stride_recording(seed, strides=3, T=1.2, rate=1000.0):
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(strides * T * rate))) / rate
    return t, rng


def test_structure_test_passes_white_noise_and_reports_its_scale():
    t, rng = _stride_recording(10)
    s = structure_test(rng.standard_normal(t.size), period=1.2, rate=1000.0)
    assert s.white and s.block == 60 and s.fine == 15 and s.n_eff == 60  # 3600 samples, 1/20 of the 1.2 s cycle
    assert s.excess == pytest.approx(1.0, abs=0.45) and s.noise_std == pytest.approx(1.0, rel=0.1)
    assert s.describe().startswith("no structure at 60-sample blocks") and "60 blocks" in s.describe()
    assert block_length(2.0, 1000.0) == 100 and block_length(1.2, 1000.0, per_cycle=10) == 120


def test_structure_test_holds_its_level_on_white_and_filtered_noise():
    rng = np.random.default_rng(11)
    for filt in (None, 100.0):
        p = []
        for _ in range(300):
            e = rng.standard_normal(3000)
            p.append(structure_test(e if filt is None else _first_order(e, filt), 50).p_value)
        rate = np.mean(np.array(p) < 0.05)
        assert 0.005 < rate < 0.09, (filt, rate)  # nominal 5 %


def test_structure_test_passes_coloured_short_scale_error_that_whiteness_rejects():
    """Sensor noise through a 150 Hz filter plus a replay-like error: band-limited around 25-40 Hz (a spline with
    knots 15 ms apart, differentiated), three times the noise's variance. Smooth at the sample scale, nothing at the
    scale of the gait."""
    t, rng = _stride_recording(12)
    noise = _first_order(rng.standard_normal(t.size), 150.0)
    white = rng.standard_normal(t.size + 400)
    f = np.fft.rfftfreq(white.size, 1e-3)
    band = np.fft.irfft(np.fft.rfft(white) * ((f > 25) & (f < 40)), white.size)[200:-200]
    r = noise + band * np.sqrt(3) * noise.std() / band.std()
    assert not whiteness(r, 50).white  # at 1 kHz it looks anything but white
    s = structure_test(r, period=1.2, rate=1000.0)
    assert s.white, s.describe()
    assert s.excess < 1.5


def test_structure_test_finds_a_small_error_repeating_with_the_gait():
    t, rng = _stride_recording(13)
    noise = rng.standard_normal(t.size)
    err = 0.3 * np.tanh(np.sin(2 * np.pi * t / 1.2) / 0.2)  # a Coulomb-like torque left out, 0.3 noise levels
    assert whiteness(noise, 50).white
    s = structure_test(noise + err, period=1.2, rate=1000.0)
    assert not s.white and s.p_value < 1e-6 and s.excess > 3
    assert s.structure_rms == pytest.approx(np.sqrt(np.mean(err**2)), rel=0.25)
    assert s.describe().startswith("structure at 60-sample blocks")
    assert structure_test(noise, period=1.2, rate=1000.0).white  # the same noise alone passes


def test_structure_test_finds_a_slow_drift_and_an_offset():
    t, rng = _stride_recording(14)
    noise = rng.standard_normal(t.size)
    drift = 0.6 * (t / t[-1] - 0.5)  # -0.3 .. +0.3 noise levels, e.g. a resistance heating up
    assert not structure_test(noise + drift, period=1.2, rate=1000.0).white
    offset = structure_test(noise + 0.15, period=1.2, rate=1000.0)  # a sensor offset: Ljung-Box removes the mean
    assert not offset.white and whiteness(noise + 0.15, 50).white
    assert structure_test(noise, period=1.2, rate=1000.0).white


def test_structure_test_rejects_unusable_input():
    with pytest.raises(DataError, match="give block"):
        structure_test(np.zeros(100))
    with pytest.raises(DataError, match="fewer than two blocks"):
        structure_test(np.ones(100), 60)
    with pytest.raises(DataError, match="NaN"):
        structure_test(np.r_[np.zeros(99), np.nan], 10)
    with pytest.raises(DataError, match="block must be an integer"):
        structure_test(np.zeros(100), 0)
    assert structure_test(np.zeros(100), 10).white  # a perfect model: nothing to find
    assert not structure_test(np.full(100, 0.1), 10).white  # a pure offset has no noise to hide in
