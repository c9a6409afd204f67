"""Residual statistics (acausal.identify.residuals): each one separates a systematic error from white noise."""
import numpy as np
import pytest

from acausal import DataError
from acausal.identify.residuals import (autocorrelation, cross_correlations, leave_one_group_out, phase_profile,
                                        whiteness)


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
