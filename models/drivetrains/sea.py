"""Series elastic actuator (SEA): a linear torsion spring in place of the MACCEPA.

What changes against the paper's actuator and why: the MACCEPA's nonlinear, precompression-dependent torque
``T(alpha, P)`` is replaced by a linear torsion spring ``tau = c alpha`` (``alpha = phi - theta``, the moment-arm
angle minus the joint angle, plantarflexion positive) between the same gear output and the joint. Everything
else (supply, rectifier, driver, motor, gears, bench) is the paper's. It answers: how much of the MACCEPA's
benefit is series elasticity as such, and how much its adjustable nonlinearity?

The stiffness is chosen by the criterion the paper's design used (section 2): the one that minimises the peak
mechanical power at the moment arm, ``max |M(t) dphi/dt|``, when the actuator follows the gait exactly at
1.2 s per stride (60 kg). With ``phi = theta + M / c``::

    P_arm(t) = M(t) (dtheta/dt + (dM/dt) / c)

Time scaling multiplies ``P_arm`` by ``1 / stride_time``, so the optimum does not depend on the stride time.
For the packaged gait data it is about 401 N m/rad (peak 69.5 W at 1.2 s; the direct drive needs 193 W).
A rigid link (``c -> infinity``) is the direct drive. The planned trajectory is the swappable input
``arm_ref.profile``, planned by :func:`plan_sea` from the run's ``link.c`` and ``body_mass`` (both run-time
parameters).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.optimize import minimize_scalar

from acausal import ParametricSignal, PeriodicSpline
from acausal.errors import ModelError
from acausal.library.gait import DEFAULT_BODY_MASS, unit_cycle
from acausal.library.rotational import Spring

from ..ankle.actuator import SeriesLinkAnkle
from ..ankle.planning import N_PLAN, Plan, gait_samples

DESIGN_STRIDE_TIME = 1.2  # s: the paper's design condition ("1.2 s per stride")
_N_DESIGN = 4000  # gait-fraction samples for the peak-power criterion


def _gait(body_mass: float, n: int = _N_DESIGN):
    cyc = unit_cycle()
    s = np.arange(n) / n
    return body_mass * cyc.torque(s), body_mass * cyc.torque(s, 1), cyc.angle(s, 1)


def peak_arm_power(c: float, body_mass: float = DEFAULT_BODY_MASS, stride_time: float = DESIGN_STRIDE_TIME,
                   n: int = _N_DESIGN) -> float:
    """Peak |M dphi/dt| [W] at the moment arm of a linear SEA of stiffness ``c`` [N m/rad] following the gait."""
    if not c > 0:
        raise ModelError(f"SEA: stiffness c must be > 0 N m/rad, got {c!r}")
    M, dM, dtheta = _gait(body_mass, n)
    return float(np.max(np.abs(M * (dtheta + dM / c)))) / stride_time


@lru_cache(maxsize=8)
def design_stiffness(body_mass: float = DEFAULT_BODY_MASS) -> float:
    """The stiffness [N m/rad] minimising :func:`peak_arm_power` (paper's design criterion): a log-spaced scan
    over 10-10^5 N m/rad, refined by bounded Brent minimisation around the best sample (deterministic)."""
    M, dM, dtheta = _gait(body_mass)

    def peak(c):
        return float(np.max(np.abs(M * (dtheta + dM / c)))) / DESIGN_STRIDE_TIME

    cs = np.geomspace(10.0, 1e5, 241)
    pk = np.array([peak(c) for c in cs])
    i = int(np.argmin(pk))
    lo, hi = np.log(cs[max(i - 1, 0)]), np.log(cs[min(i + 1, cs.size - 1)])
    best = minimize_scalar(lambda x: peak(float(np.exp(x))), bounds=(lo, hi), method="bounded",
                           options={"xatol": 1e-6})
    return float(np.exp(best.x)) if best.fun <= pk[i] else float(cs[i])


def plan_sea(c: float, body_mass: float = DEFAULT_BODY_MASS, n: int = N_PLAN) -> Plan:
    """The moment-arm trajectory of the linear SEA: ``alpha = M / c``, ``phi = theta + alpha`` (one stride)."""
    if not c > 0:
        raise ModelError(f"SEA: stiffness link.c must be > 0 N m/rad, got {c!r}")
    s, theta, M = gait_samples(body_mass, n)
    alpha = M / c
    phi = theta + alpha
    prof = PeriodicSpline(s, phi, period=1.0, degree=5, name=f"SEA moment-arm angle (c = {c:g} N m/rad)")
    return Plan(s, theta, M, alpha, phi, prof)


def _planned(c, body_mass):
    return plan_sea(c, body_mass).phi_profile


class SeriesElastic(SeriesLinkAnkle):
    """The paper's drive train with a linear torsion spring ``link`` (``c`` [N m/rad]) as the series element,
    designed for the model's default body mass."""

    def make_link(self):
        return Spring(c=design_stiffness(type(self).body_mass.default))

    def planned_arm(self):
        return ParametricSignal(_planned, {"c": self.link.c, "body_mass": self.body_mass},
                                name="SEA moment-arm angle", max_order=5)
