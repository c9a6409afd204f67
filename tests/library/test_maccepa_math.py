"""Sliding-bar MACCEPA linkage math (paper section 2, Eq. 1-3) of ``acausal.library.maccepa``."""
import math

import numpy as np
import pytest
import sympy as sp

from acausal.errors import ModelError
from acausal.library import maccepa as m

K, A, B = 132000.0, 0.100, 0.060          # 132 N/mm die spring; proposed geometry (parameters.md)
MM = 1e-3
PS = [0.0, 2 * MM, 8 * MM, 18 * MM]


def paper_torque(alpha, P, k, A, B):
    """Eq. 1-3 written straight from the paper."""
    root = np.sqrt(1.0 - (B / A * np.sin(alpha)) ** 2)
    C = B * np.cos(alpha) + A * root                                  # Eq. 1
    f = k * B * (P + A + B - C) * np.sin(alpha) / (A * root)          # Eq. 2
    return C * f, C, f                                                # Eq. 3


# ------------------------------------------------------------------------------------------ forward formulas
@pytest.mark.parametrize("k,a,b", [(K, A, B), (130000.0, 0.08, 0.06), (50000.0, 0.06, 0.05), (K, 0.05, 0.07)])
@pytest.mark.parametrize("P", [0.0, 2 * MM, 7 * MM, 18 * MM])
def test_torque_equals_paper_eq_1_to_3(k, a, b, P):
    lim = min(1.4, 0.95 * m.alpha_limit(a, b))
    alpha = np.concatenate([np.linspace(-lim, -0.05, 37), np.linspace(0.05, lim, 37)])
    T, C, f = paper_torque(alpha, P, k, a, b)
    np.testing.assert_allclose(m.link_length(alpha, a, b), C, rtol=1e-13)
    np.testing.assert_allclose(m.perpendicular_force(alpha, P, k, a, b), f, rtol=1e-9)
    np.testing.assert_allclose(m.torque(alpha, P, k, a, b), T, rtol=1e-9)
    np.testing.assert_allclose(m.spring_compression(alpha, P, a, b), P + a + b - C, rtol=1e-9, atol=1e-15)
    assert np.all(m.spring_compression(alpha, P, a, b) >= P)


def test_hand_computed_values():
    # alpha = 90 deg, P = 0: W = sqrt(1 - 0.36) = 0.8, C = A W = 0.08 m, compression = 0.16 - 0.08 = 0.08 m,
    # f = k B 0.08 / (A 0.8) = 7920 N, T = 0.08 * 7920 = 633.6 N m.
    assert m.link_length(math.pi / 2, A, B) == pytest.approx(0.08, rel=1e-14)
    assert m.perpendicular_force(math.pi / 2, 0.0, K, A, B) == pytest.approx(7920.0, rel=1e-13)
    assert m.torque(math.pi / 2, 0.0, K, A, B) == pytest.approx(633.6, rel=1e-13)
    assert m.spring_energy(math.pi / 2, 0.0, K, A, B) == pytest.approx(0.5 * K * 0.08 ** 2, rel=1e-13)
    # alpha = 0: C = A + B, compression = P, T = 0, E = k P^2 / 2
    assert m.link_length(0.0, A, B) == pytest.approx(A + B, rel=1e-15)
    assert m.spring_compression(0.0, 5 * MM, A, B) == 5 * MM
    assert m.torque(0.0, 5 * MM, K, A, B) == 0.0
    assert m.spring_energy(0.0, 5 * MM, K, A, B) == pytest.approx(0.5 * K * (5 * MM) ** 2, rel=1e-15)


@pytest.mark.parametrize("P", PS)
def test_torque_is_odd(P):
    alpha = np.linspace(1e-4, 3.1, 200)
    np.testing.assert_allclose(m.torque(-alpha, P, K, A, B), -m.torque(alpha, P, K, A, B), rtol=1e-14)
    assert np.all(m.torque(alpha[alpha < 1.5], P, K, A, B) > 0.0)   # plantarflexion alpha -> plantarflexion T


@pytest.mark.parametrize("P", PS)
def test_torque_is_gradient_of_energy(P):
    alpha = np.linspace(-1.3, 1.3, 53)
    h = 1e-5
    dE = (m.spring_energy(alpha + h, P, K, A, B) - m.spring_energy(alpha - h, P, K, A, B)) / (2 * h)
    T = m.torque(alpha, P, K, A, B)
    np.testing.assert_allclose(dE, T, rtol=1e-7, atol=1e-6)
    # work done: integral of T dalpha (Gauss-Legendre, 80 nodes per piece) equals the change of stored energy
    x, w = np.polynomial.legendre.leggauss(80)
    for a0, a1 in [(0.0, 0.3), (-0.4, 0.9), (0.2, 1.5), (-1.2, -0.1)]:
        nodes = 0.5 * (a1 - a0) * x + 0.5 * (a1 + a0)
        work = 0.5 * (a1 - a0) * np.sum(w * m.torque(nodes, P, K, A, B))
        dEnergy = m.spring_energy(a1, P, K, A, B) - m.spring_energy(a0, P, K, A, B)
        assert work == pytest.approx(dEnergy, rel=1e-9)


@pytest.mark.parametrize("P", PS)
def test_stiffness_is_derivative_of_torque(P):
    alpha = np.linspace(-2.5, 2.5, 71)
    h = 1e-6
    fd = (m.torque(alpha + h, P, K, A, B) - m.torque(alpha - h, P, K, A, B)) / (2 * h)
    np.testing.assert_allclose(m.stiffness(alpha, P, K, A, B), fd, rtol=1e-6, atol=1e-4)


@pytest.mark.parametrize("P", [0.0, 2 * MM, 7 * MM, 18 * MM])
@pytest.mark.parametrize("k,a,b", [(K, A, B), (80000.0, 0.07, 0.09)])
def test_stiffness_at_zero(P, k, a, b):
    assert m.stiffness(0.0, P, k, a, b) == pytest.approx(k * b * (a + b) * P / a, rel=1e-13, abs=1e-12)


def test_stiffness_at_zero_design_point():
    # P = 7 mm (paper's design optimum): 132000 * 0.06 * 0.16 * 0.007 / 0.1 = 88.704 N m/rad
    assert m.stiffness(0.0, 7 * MM, K, A, B) == pytest.approx(88.704, rel=1e-13)


# ------------------------------------------------------------------------------------------ reach
def test_max_torque_values_and_location():
    # Found: T_max = 633.600, 649.481, 697.594, 779.195 N m for P = 0, 2, 8, 18 mm,
    # at alpha = 90.00, 89.61, 88.48, 86.78 deg. P = 0 peaks exactly at 90 deg with 633.6 N m (hand value above).
    P = np.array(PS)
    tmax, amax = m.max_torque(P, K, A, B)
    assert tmax.shape == amax.shape == (4,)
    np.testing.assert_allclose(tmax, [633.6, 649.48097, 697.59363, 779.19550], rtol=1e-6)
    assert amax[0] == pytest.approx(math.pi / 2, abs=1e-7)
    np.testing.assert_allclose(m.stiffness(amax, P, K, A, B), 0.0, atol=1e-5)
    grid = np.linspace(0.0, math.pi, 100001)
    for p, t, a in zip(P, tmax, amax):
        T = m.torque(grid, p, K, A, B)
        assert T.max() <= t * (1 + 1e-12)                     # nothing larger anywhere, first max is global
        assert np.all(np.diff(T[grid <= a]) > 0)              # monotonic up to the maximum
        assert np.all(np.diff(T[grid >= a + 1e-3]) < 0)       # then falling (not monotonic for large alpha)
    t_scalar, a_scalar = m.max_torque(8 * MM, K, A, B)
    assert np.ndim(t_scalar) == 0 and t_scalar == pytest.approx(tmax[2], rel=1e-14)


def test_peak_gait_torque_reachable_at_60kg():
    # Winter natural cadence peak plantarflexor moment 1.628 N m/kg -> 97.7 N m at 60 kg (parameters.md: ~98 N m).
    # Max torques found for P = 0, 2, 8, 18 mm: 633.6, 649.5, 697.6, 779.2 N m (A = 0.1 m, B = 0.06 m,
    # k = 132000 N/m): the peak is reachable with a wide margin over P in [0, 18 mm].
    P = np.linspace(0.0, 18 * MM, 37)
    tmax, _ = m.max_torque(P, K, A, B)
    assert np.all(tmax > 98.0)
    # alpha at 98 N m matches the ranges of parameters.md: 32.7 deg at P = 0, 19.5 deg at P = 18 mm
    alpha = np.degrees(m.inverse_torque(98.0, np.array([0.0, 18 * MM]), K, A, B))
    np.testing.assert_allclose(alpha, [32.72, 19.52], atol=0.01)


def test_dead_point_geometry():
    # B > A: the linkage folds at asin(A/B); T grows without bound before it, so max torque is inf
    a, b = 0.05, 0.08
    lim = m.alpha_limit(a, b)
    assert lim == pytest.approx(math.asin(a / b))
    tmax, amax = m.max_torque([0.0, 10 * MM], K, a, b)
    assert np.all(np.isinf(tmax)) and np.allclose(amax, lim)
    alpha = m.inverse_torque([100.0, -1e4], 10 * MM, K, a, b)
    np.testing.assert_allclose(m.torque(alpha, 10 * MM, K, a, b), [100.0, -1e4], rtol=1e-9)
    with pytest.raises(ModelError, match="dead point"):
        m.torque(lim + 0.01, 0.0, K, a, b)


# ------------------------------------------------------------------------------------------ inverse
@pytest.mark.parametrize("P", PS)
def test_inverse_round_trip(P):
    rng = np.random.default_rng(int(P * 1e6) + 1)
    tmax, amax = m.max_torque(P, K, A, B)
    T = np.concatenate([rng.uniform(-tmax, tmax, 2000), [0.0, tmax, -tmax, 1e-6, -1e-9, 98.0, 0.999999 * tmax]])
    alpha = m.inverse_torque(T, P, K, A, B)
    assert alpha.shape == T.shape
    assert np.all(np.abs(alpha) <= amax * (1 + 1e-12))
    assert np.all(np.sign(alpha) == np.sign(T))
    back = m.torque(alpha, P, K, A, B)
    np.testing.assert_allclose(back, T, rtol=1e-9, atol=1e-15)
    # and the angle itself comes back where the branch is well conditioned
    a0 = rng.uniform(-0.9, 0.9, 500) * amax
    np.testing.assert_allclose(m.inverse_torque(m.torque(a0, P, K, A, B), P, K, A, B), a0, rtol=1e-8, atol=1e-10)


def test_inverse_with_the_reach_given_is_the_same_and_still_refuses_what_is_out_of_it():
    """Several inversions at the same precompressions (the planner's torque and its band's two ends) may pass the
    linkage's reach once (``reach=``): the same angles, the same error past it."""
    P = np.array([[0.0], [8 * MM], [18 * MM]])
    reach = m.max_torque(P, K, A, B)
    T = np.linspace(-1.0, 1.0, 7) * 0.99 * reach[0]
    np.testing.assert_array_equal(m.inverse_torque(T, P, K, A, B, reach=reach), m.inverse_torque(T, P, K, A, B))
    with pytest.raises(ModelError, match="out of reach"):
        m.inverse_torque(1.01 * reach[0], P, K, A, B, reach=reach)


def test_inverse_small_torque_without_precompression():
    # P = 0: T ~ c alpha^3 with c = k B^2 (A + B)^2 / (2 A^2); no stiffness at 0, still solved
    c = K * B ** 2 * (A + B) ** 2 / (2 * A ** 2)
    T = np.array([1e-9, -1e-6, 1e-3])
    alpha = m.inverse_torque(T, 0.0, K, A, B)
    np.testing.assert_allclose(alpha, np.cbrt(T / c), rtol=1e-4)
    np.testing.assert_allclose(m.torque(alpha, 0.0, K, A, B), T, rtol=1e-9)


def test_vectorised_shapes_and_broadcasting():
    rng = np.random.default_rng(7)
    P = np.array(PS)
    tmax, _ = m.max_torque(P, K, A, B)
    # (N,) torque with (N,) precompression, each its own P
    Pn = rng.choice(P, 300)
    Tn = rng.uniform(-1, 1, 300) * m.max_torque(Pn, K, A, B)[0]
    an = m.inverse_torque(Tn, Pn, K, A, B)
    assert an.shape == (300,)
    np.testing.assert_allclose(m.torque(an, Pn, K, A, B), Tn, rtol=1e-9, atol=1e-15)
    # (N, 1) torque against (4,) precompressions -> (N, 4), same as solving column by column
    T = rng.uniform(-0.99, 0.99, (50, 1)) * tmax.min()
    grid = m.inverse_torque(T, P, K, A, B)
    assert grid.shape == (50, 4)
    for j, p in enumerate(P):
        np.testing.assert_allclose(grid[:, j], m.inverse_torque(T[:, 0], p, K, A, B), rtol=1e-12, atol=1e-15)
    # forward functions broadcast alpha (N, 1) against P (4,)
    alpha = np.linspace(-1, 1, 9)[:, None]
    for fn in (m.torque, m.perpendicular_force, m.spring_energy, m.stiffness):
        out = fn(alpha, P, K, A, B)
        assert out.shape == (9, 4)
        np.testing.assert_allclose(out[:, 2], fn(alpha[:, 0], P[2], K, A, B), rtol=1e-15)
    assert m.spring_compression(alpha, P, A, B).shape == (9, 4)
    assert np.ndim(m.torque(0.3, 2 * MM, K, A, B)) == 0
    assert np.ndim(m.inverse_torque(10.0, 2 * MM, K, A, B)) == 0


def test_out_of_reach_error_names_sample():
    P = 2 * MM
    tmax, _ = m.max_torque(P, K, A, B)          # 649.481 N m
    T = np.linspace(-100.0, 100.0, 30)
    T[17], T[20], T[25] = 700.0, -800.0, 650.0
    with pytest.raises(ModelError) as err:
        m.inverse_torque(T, P, K, A, B)
    msg = str(err.value)
    assert "3 samples out of reach" in msg
    assert "index 17" in msg and "T = 700 N m" in msg
    assert f"maximum {tmax:.6g} N m" in msg and "649.481" in msg
    assert "P = 0.002 m" in msg and "k = 132000 N/m" in msg and "A = 0.1 m" in msg and "B = 0.06 m" in msg
    # broadcast case: the index is the position in the broadcast shape, with that sample's P
    with pytest.raises(ModelError, match=r"1 sample out of reach; first at index \(1, 0\): T = -700 N m exceeds "
                                         r"the maximum 649\.481 N m reachable at P = 0\.002 m"):
        m.inverse_torque([[10.0], [-700.0]], [2 * MM, 18 * MM], K, A, B)


@pytest.mark.parametrize("name,kw", [("k", dict(k=0.0)), ("k", dict(k=-5.0)), ("A", dict(A=-0.1)),
                                     ("B", dict(B=float("nan"))), ("A", dict(A=0.0)), ("k", dict(k=np.inf))])
def test_invalid_parameters_named(name, kw):
    args = dict(k=K, A=A, B=B)
    args.update(kw)
    for call in (lambda: m.torque(0.1, 0.0, **args), lambda: m.inverse_torque(1.0, 0.0, **args),
                 lambda: m.max_torque(0.0, **args), lambda: m.stiffness(0.0, 0.0, **args),
                 lambda: m.torque_expr(sp.Symbol("alpha"), 0, **args)):
        with pytest.raises(ModelError, match=rf"parameter {name} must"):
            call()


def test_invalid_precompression_named():
    with pytest.raises(ModelError, match=r"parameter P \(precompression\) must .* P = -0\.001 m at index 2"):
        m.inverse_torque(1.0, [0.0, 1e-3, -1e-3], K, A, B)
    with pytest.raises(ModelError, match=r"parameter P"):
        m.torque(0.2, -1e-3, K, A, B)
    with pytest.raises(ModelError, match=r"parameter P"):
        m.energy_expr(sp.Symbol("alpha"), -0.002, K, A, B)
    with pytest.raises(ModelError, match=r"not finite"):
        m.inverse_torque([1.0, np.nan], 0.0, K, A, B)


# ------------------------------------------------------------------------------------------ sympy forms
def test_sympy_expressions_match_numpy():
    alpha, P, k, a, b = sp.symbols("alpha P k A B", real=True)
    T = sp.lambdify((alpha, P, k, a, b), m.torque_expr(alpha, P, k, a, b), "numpy")
    E = sp.lambdify((alpha, P, k, a, b), m.energy_expr(alpha, P, k, a, b), "numpy")
    x = np.linspace(-1.4, 1.4, 41)[:, None]
    p = np.array(PS)
    np.testing.assert_allclose(T(x, p, K, A, B), m.torque(x, p, K, A, B), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(E(x, p, K, A, B), m.spring_energy(x, p, K, A, B), rtol=1e-12)
    np.testing.assert_allclose(T(x, p, K, A, B), paper_torque(x, p, K, A, B)[0], rtol=1e-9, atol=1e-9)


@pytest.mark.slow
def test_sympy_energy_derivative_is_torque():
    alpha = sp.Symbol("alpha", real=True)
    P, k, a, b = sp.symbols("P k A B", positive=True)
    dE = sp.diff(m.energy_expr(alpha, P, k, a, b), alpha)
    T = m.torque_expr(alpha, P, k, a, b)
    assert sp.simplify(dE - T) == 0
    # and numerically, at the library's numbers (exact rationals for A, B)
    num = {P: sp.Rational(7, 1000), k: 132000, a: sp.Rational(1, 10), b: sp.Rational(6, 100)}
    for v in (-1.2, -0.3, 0.01, 0.7, 1.5):
        d = (dE - T).subs(num).subs(alpha, sp.Rational(str(v))).evalf(30)
        assert abs(d) < 1e-20
        assert float(T.subs(num).subs(alpha, v)) == pytest.approx(m.torque(v, 7 * MM, K, A, B), rel=1e-12)
