"""Parallel elasticity: a torsion spring between lower leg and foot, in parallel with the drive.

What changes against the paper's actuator and why: there is no series element; the gear output drives the joint
directly (as in the direct drive) and a linear torsion spring ``parallel`` acts on the joint beside it, from
the lower leg (fixed on the bench). The spring torque on the foot is ``c (theta0 - theta)`` (plantarflexion
positive), so the drive only supplies ``M(t) - c (theta0 - theta)``. A parallel spring takes load off the motor
(torque, hence copper loss) wherever the gait moment follows the angle like a spring, but it cannot shift the
timing of the power as a series spring does, and it acts in swing too, where the drive must hold it.

Spring design by the paper's criterion (section 2): ``c`` and ``theta0`` minimise the peak mechanical power the
drive delivers to the joint, ``max |(M - c (theta0 - theta)) dtheta/dt|``, following the gait at 1.2 s per
stride with 60 kg (a scan on a grid refined by Nelder-Mead; deterministic). For the packaged gait data:
about 210 N m/rad at theta0 of about 11 deg plantarflexion (peak 60 W against the direct drive's 193 W).
``parallel.c`` and ``parallel.phi_rel0`` (= theta0) are run-time parameters.

Measurement points: source, driver output, motor (k i w) as in the paper; "link" is the drive's power into the
joint (gear output), "output" the power into the gait (drive plus spring). Over a stride the spring returns
what it stores, so link and output energies agree; their peaks differ.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.optimize import minimize

from acausal import connect
from acausal.library.gait import DEFAULT_BODY_MASS, AnkleTorqueLoad, GaitProfile, unit_cycle
from acausal.library.rotational import AngleSensor, Fixed, Spring
from acausal.library.sensors import MechanicalPowerSensor

from ..ankle.actuator import DriveTrain
from .sea import DESIGN_STRIDE_TIME

_N_DESIGN = 2000


def _gait(body_mass: float, n: int = _N_DESIGN):
    cyc = unit_cycle()
    s = np.arange(n) / n
    return body_mass * cyc.torque(s), cyc.angle(s), cyc.angle(s, 1)


def peak_drive_power(c: float, theta0: float, body_mass: float = DEFAULT_BODY_MASS,
                     stride_time: float = DESIGN_STRIDE_TIME,
                     n: int = _N_DESIGN) -> float:
    """Peak |(M - c (theta0 - theta)) dtheta/dt| [W] the drive delivers with a parallel spring (c [N m/rad],
    theta0 [rad])."""
    M, theta, dtheta = _gait(body_mass, n)
    return float(np.max(np.abs((M - c * (theta0 - theta)) * dtheta))) / stride_time


@lru_cache(maxsize=8)
def design_spring(body_mass: float = DEFAULT_BODY_MASS) -> tuple[float, float]:
    """``(c [N m/rad], theta0 [rad])`` minimising :func:`peak_drive_power` at 1.2 s/stride (c >= 0): a grid
    scan (c 0-1500 N m/rad, theta0 -25..25 deg) refined by Nelder-Mead from the best grid point."""
    M, theta, dtheta = _gait(body_mass)
    T = DESIGN_STRIDE_TIME

    def peak(c, t0):
        return np.max(np.abs((M - c * (t0 - theta)) * dtheta), axis=-1) / T

    cs = np.linspace(0.0, 1500.0, 31)
    t0s = np.radians(np.linspace(-25.0, 25.0, 26))
    pk = np.array([peak(c, t0s[:, None]) for c in cs])
    i, j = np.unravel_index(int(np.argmin(pk)), pk.shape)
    best = minimize(lambda x: float(peak(abs(x[0]) * 100.0, x[1])), x0=[cs[i] / 100.0, t0s[j]],
                    method="Nelder-Mead", options={"xatol": 1e-7, "fatol": 1e-9, "maxiter": 4000})
    if best.fun <= pk[i, j]:
        return abs(float(best.x[0])) * 100.0, float(best.x[1])
    return float(cs[i]), float(t0s[j])


class ParallelElastic(DriveTrain):
    """Motor and gears (n = 860) moving the joint along the gait angle, with a parallel torsion spring designed
    for the model's default body mass."""

    def build(self):
        gear_out = self.build_drive()
        c, theta0 = design_spring(type(self).body_mass.default)
        self.P_link = MechanicalPowerSensor()
        self.leg = Fixed()
        self.parallel = Spring(c=c, phi_rel0=theta0)
        self.P_output = MechanicalPowerSensor()
        self.load = AnkleTorqueLoad(stride_time=self.stride_time, body_mass=self.body_mass)
        connect(gear_out, self.P_link.flange_a)
        # spring from the lower leg (flange_a) to the joint (flange_b): phi_rel = theta
        connect(self.leg.flange, self.parallel.flange_a)
        connect(self.P_link.flange_b, self.parallel.flange_b, self.P_output.flange_a)
        connect(self.P_output.flange_b, self.load.flange)
        self.joint_ref = GaitProfile(stride_time=self.stride_time, profile=unit_cycle().angle_signal())
        self.joint_angle = AngleSensor()
        connect(self.load.flange, self.joint_angle.flange)
        self.add_follower(self.joint_angle.phi, self.joint_ref.y)
