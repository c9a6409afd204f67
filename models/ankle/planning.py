"""Trajectory planning for the MACCEPA ankle (paper section 3): the moment-arm angle that makes the linkage
torque equal (or close to) the biomechanical ankle torque.

For a precompression ``P`` and stiffness ``k`` the linkage must deliver ``T(alpha, P) = M(t)`` (Eq. 3 = the gait
moment times body mass), so ``alpha(t) = T^-1(M(t), P)`` and ``phi(t) = theta(t) + alpha(t)``. The library's
vectorised inverse solves all samples at once. The result is a periodic quintic spline over the gait fraction,
so the replay's index reduction can take up to five derivatives of it.

The exact inverse has a weak spot: near zero precompression the linkage is soft at alpha = 0 (``T ~ alpha^3``),
so ``alpha ~ M^(1/3)`` has an infinite slope wherever the gait moment crosses zero, and the planned arm speed
explodes (at 2 mm the arm would need 10 rad per stride, about 7000 rad/s at the motor at 1.2 s/stride, while
its range stays within 25 deg). The paper solved the inverse per sample with MATLAB's fminbnd, a bounded
minimisation of the torque error with a finite tolerance. Here that is ``tolerance`` [N m]: the arm may leave a
torque error up to ``tolerance`` and takes the path of least squared speed inside that band (the obstacle
problem of a taut periodic string, solved exactly by a primal-dual active-set iteration from the exact plan);
``arm_limit`` [rad] bounds the arm's mechanical range (the band is clipped to ``|phi| <= arm_limit``; where that
leaves no torque within tolerance, the arm saturates and the shortfall grows). ``tolerance = 0`` and an arm that
stays inside its range give the exact plan. :attr:`Plan.shortfall` is the largest torque error the plan leaves [N m].
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from acausal import ModelError, PeriodicSpline
from acausal.library.gait import unit_cycle
from acausal.library.maccepa import inverse_torque, max_torque, torque

N_PLAN = 400  # samples of the gait fraction for the planned trajectory
ARM_LIMIT = np.pi  # rad: default mechanical range of the moment arm (no bound: the planned arm stays within 25 deg)
_ITER_MAX = 1000  # active-set steps at most (about 40 in practice from the constant)
_WARM_MAX = 100  # ... from a neighbouring design's active set, before starting again from the constant


@dataclass
class Plan:
    fraction: np.ndarray  # gait fraction samples [0, 1)
    theta: np.ndarray  # ankle angle [rad], plantarflexion positive
    M: np.ndarray  # biomechanical ankle torque [N m]
    alpha: np.ndarray  # linkage deflection [rad]
    phi: np.ndarray  # moment-arm angle [rad]
    phi_profile: PeriodicSpline  # phi over the gait fraction (period 1)
    shortfall: float = 0.0  # N m: largest |T(alpha) - M| the plan leaves


def gait_samples(body_mass: float, n: int = N_PLAN):
    """``(s, theta, M)``: ``n`` gait fractions over one stride, the ankle angle [rad] and the biomechanical moment
    [N m] for ``body_mass`` [kg] there (the packaged Winter data)."""
    cyc = unit_cycle()
    s = np.arange(n) / n
    return s, cyc.angle(s), body_mass * cyc.torque(s)


def _taut_ring(start, lo, hi, active=None):
    """The periodic path within ``[lo, hi]`` of least sum of squared differences, exactly: a primal-dual active-set
    iteration (Hintermueller, Ito and Kunisch 2002; for this M-matrix problem it converges in finitely many steps
    from any start). Between the samples held at a bound the optimal path is straight (the discrete Laplacian
    vanishes there), so each step interpolates linearly around the ring between the active samples, then moves to
    the active set the multipliers ``2 x_i - x_(i-1) - x_(i+1)`` call for; it stops when the active set repeats.
    Starts from ``active`` (``(at lo, at hi)`` masks: a neighbouring design's solution, a few steps from this one's)
    when given, else from the unconstrained optimum, a constant (the mean of ``start``): the samples where it leaves
    the band. Returns the path and its active set."""
    n = start.size
    i = np.arange(n)
    before, after = np.roll(i, 1), np.roll(i, -1)  # neighbours around the ring
    flat = np.full(n, np.mean(start))
    if active is None:
        x, (on_lo, on_hi), steps = flat, (flat < lo, flat > hi), _ITER_MAX
    else:
        x, (on_lo, on_hi), steps = None, active, _WARM_MAX
    for _ in range(steps):
        on = on_lo | on_hi
        act = np.flatnonzero(on)
        if act.size == 0:  # the constant lies in every band: optimal
            if active is None:
                return x, (on_lo, on_hi)
            if ((flat >= lo) & (flat <= hi)).all():
                return flat, (on_lo, on_hi)
            break  # a warm start that lost its bounds: start again from the constant
        v = np.where(on_lo, lo, hi)[act]
        x = np.interp(np.where(i < act[0], i + n, i), np.append(act, act[0] + n), np.append(v, v[0]))
        lam = np.where(on, 2 * x - x[before] - x[after], 0.0)
        new_lo, new_hi = lam + (lo - x) > 0, lam + (hi - x) < 0
        if np.array_equal(new_lo, on_lo) and np.array_equal(new_hi, on_hi):
            return x, (on_lo, on_hi)
        on_lo, on_hi = new_lo, new_hi
    if active is not None:
        return _taut_ring(start, lo, hi)
    raise ModelError(f"planning: the path within the torque band did not settle in {_ITER_MAX} active-set steps")


def _least_speed_in_band(phi, lo, hi):
    """:func:`_taut_ring` for each path along the last axis (leading axes: independent paths, each started from the
    active set of the one before: neighbouring designs of a map differ by a few samples)."""
    phi, lo, hi = np.broadcast_arrays(np.asarray(phi, float), lo, hi)
    out = np.empty(phi.shape)
    active = None
    for idx in np.ndindex(phi.shape[:-1]):
        out[idx], active = _taut_ring(phi[idx], lo[idx], hi[idx], active)
    return out


def arm_angles(P, k: float, A: float, B: float, body_mass: float, tolerance: float = 0.0,
               arm_limit: float = ARM_LIMIT, n: int = N_PLAN, reach=None):
    """``(s, theta, M, phi)``: the gait samples and the planned moment-arm angle [rad] of one stride for
    precompression ``P`` [m], a scalar or a 1-D array of designs sharing the stiffness ``k`` (``phi`` then has a
    row per design); ``tolerance`` and ``arm_limit`` as in the module docstring. ``reach``: the linkage's
    :func:`~acausal.library.maccepa.max_torque` at these ``P``, ``k``, ``A``, ``B`` when the caller has it."""
    if not tolerance >= 0:
        raise ModelError(f"planning: torque tolerance must be >= 0 N m, got {tolerance!r}")
    if not arm_limit > 0:
        raise ModelError(f"planning: arm_limit must be > 0 rad, got {arm_limit!r}")
    s, theta, M = gait_samples(body_mass, n)
    Pc = np.asarray(P, dtype=float)[..., None]
    most = max_torque(Pc, k, A, B) if reach is None else tuple(np.asarray(r, dtype=float)[..., None] for r in reach)
    # the linkage's reach, for each inversion below
    phi = theta + inverse_torque(M, Pc, k, A, B, reach=most)
    if tolerance > 0 or np.max(np.abs(phi)) > arm_limit:
        reach = np.max(np.abs(M))  # the band's ends stay within the gait's torques
        lo = theta + inverse_torque(np.clip(M - tolerance, -reach, reach), Pc, k, A, B, reach=most)
        hi = theta + inverse_torque(np.clip(M + tolerance, -reach, reach), Pc, k, A, B, reach=most)
        lo, hi = np.clip(lo, -arm_limit, arm_limit), np.clip(hi, -arm_limit, arm_limit)
        phi = _least_speed_in_band(phi, lo, hi)
    return s, theta, M, phi


def plan_moment_arm(P: float, k: float, A: float, B: float, body_mass: float, tolerance: float = 0.0,
                    arm_limit: float = ARM_LIMIT, n: int = N_PLAN) -> Plan:
    """The moment-arm trajectory for one stride (independent of the stride time: the profile is stretched);
    ``tolerance`` [N m] and ``arm_limit`` [rad] as in the module docstring."""
    s, theta, M, phi = arm_angles(P, k, A, B, body_mass, tolerance, arm_limit, n)
    alpha = phi - theta
    shortfall = float(np.max(np.abs(torque(alpha, P, k, A, B) - M)))
    name = f"planned moment-arm angle (P = {P * 1e3:g} mm" + (f", within {tolerance:g} N m)" if tolerance else ")")
    prof = PeriodicSpline(s, phi, period=1.0, degree=5, name=name)
    return Plan(s, theta, M, alpha, phi, prof, shortfall)


def planned_arm_angle(P: float, k: float, A: float, B: float, body_mass: float, tolerance: float = 0.0,
                      arm_limit: float = ARM_LIMIT) -> PeriodicSpline:
    """The planned moment-arm angle over the gait fraction (period 1) for precompression ``P`` [m], stiffness
    ``k`` [N/m], lever lengths ``A``, ``B`` [m], ``body_mass`` [kg], torque ``tolerance`` [N m] and ``arm_limit``
    [rad]: what the actuator's :class:`~acausal.ParametricSignal` builds from a run's parameters."""
    return plan_moment_arm(P, k, A, B, body_mass, tolerance, arm_limit).phi_profile
