"""Cluster-robust standard errors: honest when residuals are correlated within a stride."""
import numpy as np
import pytest
from scipy.optimize import least_squares

from acausal.identify.calibrate import Experiment, Free, calibrate
from acausal.identify.uncertainty import cluster_covariance, groups_of, loss_derivatives

N_STRIDES, PER_STRIDE = 40, 200


def _data(rng, slope=2.0, offset=1.0):
    """A line sampled over 40 strides whose error is a random smooth wave per stride (correlated within a stride,
    independent between strides) plus white noise."""
    t = np.arange(N_STRIDES * PER_STRIDE) / PER_STRIDE
    x = np.sin(2 * np.pi * t) + 0.3 * t / N_STRIDES
    stride = (t // 1).astype(int)
    wave = rng.standard_normal(N_STRIDES)[stride] * (0.3 * np.sin(2 * np.pi * t) + 0.3 * np.sin(np.pi * (t % 1)))
    return t, x, stride, slope * x + offset + wave + 0.05 * rng.standard_normal(t.size)


@pytest.mark.slow
@pytest.mark.parametrize("loss", ["linear", "soft_l1"])
def test_cluster_robust_errors_match_the_spread_over_repeated_experiments(loss):
    """Over 200 repeated data sets the spread of the fitted slope equals the cluster-robust standard error (within
    20 %), while the textbook white-noise error is several times too small."""
    rng = np.random.default_rng(7)
    fitted, robust, white = [], [], []
    for _ in range(200):
        t, x, stride, y = _data(rng)
        sol = least_squares(lambda p: p[0] * x + p[1] - y, [0.0, 0.0], loss=loss, f_scale=3.0)
        cov, G = cluster_covariance(sol.jac, sol.fun, stride, loss, 3.0)
        J = sol.jac
        s2 = 2 * sol.cost / (t.size - 2)
        fitted.append(sol.x[0])
        robust.append(np.sqrt(cov[0, 0]))
        white.append(np.sqrt(s2 * np.linalg.inv(J.T @ J)[0, 0]))
    assert G == N_STRIDES
    spread = np.std(fitted, ddof=1)
    assert np.median(robust) == pytest.approx(spread, rel=0.2), (np.median(robust), spread)
    assert np.median(white) < spread / 3, (np.median(white), spread)


def test_calibrate_reports_cluster_robust_errors_and_the_textbook_ones():
    rng = np.random.default_rng(3)
    t, x, stride, y = _data(rng)
    train = np.ones(t.size, bool)
    exp = Experiment("line", t, {"y": y}, lambda v: {"y": v["a"] * x + v["b"]}, train, ~train, stride)
    cal = calibrate([exp], [Free("a", 1.0), Free("b", 0.0)], ["y"], scales={"y": 1.0}, loss="linear")
    assert cal.clusters == N_STRIDES and "cluster-robust" in cal.std_method
    assert cal.std["a"] > 3 * cal.std_white["a"]
    assert abs(cal.values["a"] - 2.0) < 3 * cal.std["a"]


def test_groups_follow_the_residual_vector_order():
    t = np.arange(10.0)
    m1 = np.array([True] * 8 + [False] * 2)
    e1 = Experiment("a", t, {"s": t, "u": t}, None, m1, ~m1, stride=(t // 4).astype(int))
    e2 = Experiment("b", t, {"s": t, "u": t}, None, np.ones(10, bool), np.zeros(10, bool), period=5.0)
    g = groups_of([e1, e2], ["s", "u"])
    # e1: strides 0, 1 over 8 samples, twice (two signals); e2: two cycles of 5 samples, twice
    assert g.tolist() == [0] * 4 + [1] * 4 + [0] * 4 + [1] * 4 + [2] * 5 + [3] * 5 + [2] * 5 + [3] * 5


def test_loss_derivatives_match_finite_differences():
    f = np.linspace(-10, 10, 41)
    C = 3.0
    rho0 = {"linear": lambda z: z, "soft_l1": lambda z: 2 * ((1 + z) ** 0.5 - 1), "cauchy": np.log1p,
            "arctan": np.arctan, "huber": lambda z: np.where(z <= 1, z, 2 * np.sqrt(np.abs(z)) - 1)}
    for loss, r0 in rho0.items():
        z = (f / C) ** 2
        h = 1e-4
        d1 = (r0(z + h) - r0(z - h)) / (2 * h)
        d2 = (r0(z + h) - 2 * r0(z) + r0(z - h)) / h**2
        rho1, rho2 = loss_derivatives(f, loss, C)
        away = np.abs(z - 1) > 1e-3  # huber's kink
        assert np.allclose(rho1[away], d1[away], rtol=1e-5, atol=1e-7), loss
        assert np.allclose(rho2[away] * C**2, d2[away], rtol=1e-3, atol=1e-4), loss
