"""Moment-arm planning (models/ankle/planning.py): the exact inverse, the torque-tolerant path (the paper's
fminbnd tolerance) that removes the arm-speed singularity of a soft linkage, the arm's mechanical range, and the
torque shortfall the protocol reports."""
import numpy as np
import pytest

from acausal import ModelError
from acausal.library.maccepa import torque
from acausal.models.ankle.planning import plan_moment_arm
from acausal.models.ankle.protocol import Condition, run_condition

GEOMETRY = dict(k=132e3, A=0.1, B=0.06, body_mass=60.0)


def _peak_speed(plan):
    return float(np.max(np.abs(plan.phi_profile(plan.fraction, 1))))  # rad per stride


def test_zero_tolerance_is_the_exact_inverse():
    p = plan_moment_arm(0.008, **GEOMETRY)
    assert p.shortfall < 1e-9
    np.testing.assert_allclose(torque(p.alpha, 0.008, 132e3, 0.1, 0.06), p.M, atol=1e-9)


def test_a_torque_band_slows_the_arm_of_a_soft_linkage():
    """At 2 mm the exact arm speed peaks where the gait moment crosses zero (alpha ~ M^(1/3)); a 5 N m band
    (5 % of the 98 N m peak) takes most of it away and leaves exactly the allowed error."""
    exact, banded = plan_moment_arm(0.002, **GEOMETRY), plan_moment_arm(0.002, **GEOMETRY, tolerance=5.0)
    assert _peak_speed(banded) < 0.2 * _peak_speed(exact)
    assert 4.9 < banded.shortfall <= 5.0 + 1e-9
    err = torque(banded.alpha, 0.002, 132e3, 0.1, 0.06) - banded.M
    assert np.max(np.abs(err)) <= 5.0 + 1e-9
    wider = plan_moment_arm(0.002, **GEOMETRY, tolerance=10.0)
    assert _peak_speed(wider) < _peak_speed(banded)  # a wider band, a slower arm


def test_the_arm_range_saturates_and_the_shortfall_says_so():
    limit = np.radians(15.0)
    p = plan_moment_arm(0.008, **GEOMETRY, arm_limit=limit)
    assert np.max(np.abs(p.phi)) <= limit + 1e-12
    assert p.shortfall > 10.0  # the exact plan needs 20 deg: the torque falls short where the arm is held


def test_bad_band_is_named():
    with pytest.raises(ModelError, match="tolerance"):
        plan_moment_arm(0.008, **GEOMETRY, tolerance=-1.0)
    with pytest.raises(ModelError, match="arm_limit"):
        plan_moment_arm(0.008, **GEOMETRY, arm_limit=0.0)


def test_protocol_reports_the_shortfall_and_the_band_makes_the_soft_corner_feasible():
    exact = run_condition(Condition(0.002, 1.2))
    banded = run_condition(Condition(0.002, 1.2, overrides={"torque_tolerance": 5.0}))
    assert exact.max_duty > 4.0 and exact.torque_error_max < 1e-3
    assert banded.max_duty < 0.9  # the motor can follow at 48 V
    assert 4.9 < banded.torque_error_max < 5.05 and banded.row()["torque_error_max_Nm"] == banded.torque_error_max
    assert banded.energy["output"] < exact.energy["output"]  # less joint work: the torque falls short
    assert abs(banded.balance_residual) < 1e-6


def test_taut_ring_is_the_exact_least_speed_path_in_the_band():
    """The active-set solver against a general QP solver on random periodic bands, and the analytic case of two
    pins (the path is straight between them, both ways round the ring)."""
    from scipy.optimize import minimize
    from acausal.models.ankle.planning import _least_speed_in_band

    rng = np.random.default_rng(3)
    n = 24
    for _ in range(5):
        centre = np.cumsum(rng.normal(size=n)) - np.linspace(0, 1, n) * np.sum(rng.normal(size=n))
        half = rng.uniform(0.05, 1.0, n)
        lo, hi = centre - half, centre + half
        x = _least_speed_in_band(centre, lo, hi)
        ref = minimize(lambda y: np.sum((np.roll(y, -1) - y) ** 2), centre, method="SLSQP",
                       bounds=list(zip(lo, hi)), options={"ftol": 1e-14, "maxiter": 500}).x
        assert np.all(x >= lo) and np.all(x <= hi)
        obj = lambda y: np.sum((np.roll(y, -1) - y) ** 2)  # noqa: E731
        assert obj(x) <= obj(ref) + 1e-9
    lo, hi = np.full(12, -10.0), np.full(12, 10.0)
    lo[2] = hi[2] = 1.0
    lo[8] = hi[8] = 4.0
    x = _least_speed_in_band(np.zeros(12), lo, hi)
    np.testing.assert_allclose(x[2:9], np.linspace(1.0, 4.0, 7))
    np.testing.assert_allclose(np.r_[x[8:], x[:3]], np.linspace(4.0, 1.0, 7))


def test_neighbouring_designs_start_from_each_others_active_set():
    """A map's rows are solved each from the active set of the row before (a warm start); each equals its own
    solution from the constant (the same optimum: the active set decides the path), and the planner's reach passed
    in gives the plan it finds itself."""
    from acausal.library.maccepa import max_torque
    from acausal.models.ankle.planning import _least_speed_in_band, _taut_ring, arm_angles

    rng = np.random.default_rng(7)
    n = 48
    centre = np.cumsum(rng.normal(size=n))
    centre -= np.linspace(0, 1, n) * centre[-1]
    rows = [centre + 0.05 * j * np.sin(2 * np.pi * np.arange(n) / n) for j in range(6)]  # neighbouring designs
    half = rng.uniform(0.1, 0.8, n)
    phi = np.array(rows)
    x = _least_speed_in_band(phi, phi - half, phi + half)
    for j, row in enumerate(rows):
        cold, _ = _taut_ring(row, row - half, row + half)
        np.testing.assert_allclose(x[j], cold, rtol=0, atol=1e-12)
    P, k, A, B, mass = np.array([0.004, 0.006, 0.008]), 130e3, 0.045, 0.04, 70.0
    free = arm_angles(P, k, A, B, mass, tolerance=3.0)[3]
    given = arm_angles(P, k, A, B, mass, tolerance=3.0, reach=max_torque(P, k, A, B))[3]
    np.testing.assert_array_equal(free, given)
