"""Trajectory planning for the MACCEPA ankle (paper section 3): the moment-arm angle that makes the linkage
torque equal the biomechanical ankle torque.

For a precompression ``P`` and stiffness ``k`` the linkage must deliver ``T(alpha, P) = M(t)`` (Eq. 3 = the gait
moment times body mass), so ``alpha(t) = T^-1(M(t), P)`` and ``phi(t) = theta(t) + alpha(t)``. The paper solved
this per sample with MATLAB's fminbnd; here the library's vectorised inverse solves all samples at once. The
result is a periodic quintic spline over the gait fraction, so the replay's index reduction can take up to
five derivatives of it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from acausal import PeriodicSpline
from acausal.library.gait import unit_cycle
from acausal.library.maccepa import inverse_torque

N_PLAN = 400  # samples of the gait fraction for the planned trajectory


@dataclass
class Plan:
    fraction: np.ndarray  # gait fraction samples [0, 1)
    theta: np.ndarray  # ankle angle [rad], plantarflexion positive
    M: np.ndarray  # biomechanical ankle torque [N m]
    alpha: np.ndarray  # linkage deflection [rad]
    phi: np.ndarray  # moment-arm angle [rad]
    phi_profile: PeriodicSpline  # phi over the gait fraction (period 1)


def plan_moment_arm(P: float, k: float, A: float, B: float, body_mass: float, n: int = N_PLAN) -> Plan:
    """The moment-arm trajectory for one stride (independent of the stride time: the profile is stretched)."""
    cyc = unit_cycle()
    s = np.arange(n) / n
    theta = cyc.angle(s)
    M = body_mass * cyc.torque(s)
    alpha = inverse_torque(M, P, k, A, B)
    phi = theta + alpha
    prof = PeriodicSpline(s, phi, period=1.0, degree=5, name=f"planned moment-arm angle (P = {P * 1e3:g} mm)")
    return Plan(s, theta, M, alpha, phi, prof)


def planned_arm_angle(P: float, k: float, A: float, B: float, body_mass: float) -> PeriodicSpline:
    """The planned moment-arm angle over the gait fraction (period 1) for precompression ``P`` [m], stiffness
    ``k`` [N/m], lever lengths ``A``, ``B`` [m] and ``body_mass`` [kg]: what the actuator's
    :class:`~acausal.ParametricSignal` builds from a run's parameters."""
    return plan_moment_arm(P, k, A, B, body_mass).phi_profile
