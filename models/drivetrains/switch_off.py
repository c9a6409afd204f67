"""The MACCEPA actuator with a non-backdrivable (self-locking) transmission, and the driver switched off while
little torque is needed (the paper's discussion, section 5).

What changes against the paper's actuator and why: the paper found the driver's constant consumption (10-15 W)
to be a large share of the loss and proposed "switching off the motor when not providing significant torque, in
combination with a non-backdriveable transmission", expecting more mechanical loss but perhaps less in total.
Here the helical 10:1 stage is replaced by a self-locking 10:1 stage
(:class:`~acausal.library.rotational.SelfLockingGear`, default the most efficient self-locking worm: 49.5 %
forward, nothing backward; the total ratio stays 860), so the gear holds the moment arm with the motor
unpowered, and the driver is switched off (:class:`SwitchedPWMDriver`: no quiescent draw, no current) in the
stretch of the gait cycle chosen by the switching rule below. Two registered models share the components:
``self_locking`` (driver always on: the cost of the transmission alone) and ``switch_off`` (with the rule).

Switching rule (:func:`switch_plan`), evaluated on the planned trajectory of the condition: the driver is
switched off over the longest stretch of the gait cycle in which

1. the gait needs little torque: ``|M(s)| <= M_off`` (default 3 N m, 3 % of the 98 N m peak), and
2. the MACCEPA with its moment arm held still keeps the joint torque within ``M_off`` of the gait moment:
   ``|T(phi_hold - theta(s), P) - M(s)| <= M_off`` with ``phi_hold`` the planned arm angle where the hold
   begins.

Within that stretch: the arm is brought to rest on ``phi_hold`` over ``blend`` (default 5 % of the stride,
driver on), the driver's enable ramps down over ``ramp`` (1 %) while the locked gear takes over the torque,
stays off, ramps up again (``ramp``) before the end, and the arm returns onto the plan over ``blend``. The
arm stands still whenever the driver is not fully on. If no stretch leaves the driver fully off for more than
2 % of the stride, it stays on.
The energy at the five measurement points changes through the saved quiescent draw (driver), the lower
forward efficiency and the overhauling loss of the worm (gearing), and the joint torque's small deviation from
the gait moment while the arm is held (output).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from math import comb

import numpy as np

from acausal import Constant, Parameter, RealInput, Signal, connect
from acausal.errors import ModelError
from acausal.library.drives import EPOS2
from acausal.library.gait import GaitProfile, unit_cycle
from acausal.library.maccepa import Maccepa
from acausal.library.maccepa import torque as maccepa_torque

from ..ankle.actuator import AnkleActuator
from ..ankle.planning import ARM_LIMIT, plan_moment_arm

M_OFF = 3.0  # N m: "little torque" threshold of the switching rule
BLEND = 0.05  # stride fractions: arm brought to rest / back onto the plan
RAMP = 0.01  # stride fractions: enable ramp of the driver (locked gear takes / hands back the torque)
_N_RULE = 1000  # gait-fraction samples on which the rule is evaluated


class SwitchedPWMDriver(EPOS2):
    """The paper's PWM driver with an ``enable`` input (1 on, 0 off) that switches its quiescent draw:
    ``P_q_eff = P_off + enable (P_q - P_off)``; everything else as the paper's
    :class:`~acausal.library.drives.EPOS2`. Switched off, the bridge makes no voltage: use ``enable < 1`` only while the motor stands still with no current (the model ensures
    it). Defined here, not in the library, because only this alternative needs it (``P_off`` = 0 W: the whole
    measured draw is taken to stop with the driver, an assumption)."""

    P_off = Parameter(0.0, unit="W", min=0.0, doc="draw while switched off (assumption: 0 W)")
    enable = RealInput(doc="1: driver on, 0: switched off (values in between while switching)")

    def equations(self):
        P_q = self.P_off + self.enable.value * (self.P_q - self.P_off)
        return [eq.xreplace({self.P_q: P_q}) for eq in super().equations()]


# -------------------------------------------------------------------------------------------- smooth windows
@lru_cache(maxsize=None)
def _step_coefs(m: int = 4):
    """Smoothstep S(x) on [0, 1] with m continuous derivatives at both ends: coefficients of S and derivatives."""
    base = np.polynomial.Polynomial([0.0, 1.0]) ** m * np.polynomial.Polynomial([1.0, -1.0]) ** m
    S = base.integ()
    S = S / S(1.0)
    out = [S]
    for _ in range(2 * m + 2):
        out.append(out[-1].deriv())
    return out


def _step(x: float, order: int) -> float:
    polys = _step_coefs()
    if order >= len(polys):
        return 0.0
    return float(polys[order](x))


class Window(Signal):
    """1-periodic window over the gait fraction: 0, rising over ``[a, a + rise]``, 1, falling over
    ``[b, b + fall]``, 0 (``a``, ``b`` taken modulo 1; smooth steps with 4 continuous derivatives)."""

    def __init__(self, a: float, rise: float, b: float, fall: float, name: str = "window"):
        self.a, self.rise, self.fall = a % 1.0, rise, fall
        self.top = (b - a) % 1.0  # where the fall starts, measured from a
        if not (rise > 0 and fall > 0 and rise <= self.top and self.top + fall < 1.0):
            raise ModelError(f"window {name!r}: inconsistent rise {rise}, fall {fall} at {a}..{b}")
        self.name = name

    def _scalar(self, s: float, order: int) -> float:
        u = (s - self.a) % 1.0
        if u < self.rise:
            return _step(u / self.rise, order) / self.rise ** order
        if u < self.top:
            return 1.0 if order == 0 else 0.0
        if u < self.top + self.fall:
            v = -_step((u - self.top) / self.fall, order) / self.fall ** order
            return 1.0 + v if order == 0 else v
        return 0.0

    def evaluate(self, t, order):
        if np.ndim(t) == 0:
            return np.float64(self._scalar(float(t), order))
        return np.vectorize(lambda x: self._scalar(x, order), otypes=[float])(t)


class Complement(Signal):
    """``1 - w`` for a signal ``w`` (the enable that goes with a hold window)."""

    def __init__(self, w: Signal, name: str = "complement"):
        self.w, self.name = w, name

    def evaluate(self, t, order):
        y = -np.asarray(self.w(t, order), dtype=float)
        return y + 1.0 if order == 0 else y


class HeldReference(Signal):
    """``phi(s) = plan(s) + h(s) (phi_hold - plan(s))``: the plan, held at ``phi_hold`` where the window ``h``
    is 1 (exactly still there), with derivatives by Leibniz's rule."""

    def __init__(self, plan: Signal, h: Signal, phi_hold: float, name: str = "held moment-arm angle"):
        self.plan, self.h, self.phi_hold, self.name = plan, h, float(phi_hold), name
        self.max_order = getattr(plan, "max_order", None)

    def evaluate(self, t, order):
        y = self.plan(t, order)
        for j in range(order + 1):
            hj = self.h(t, j)
            rest = (self.phi_hold - self.plan(t, 0)) if j == order else -self.plan(t, order - j)
            y = y + comb(order, j) * hj * rest
        return y


# -------------------------------------------------------------------------------------------- switching rule
@dataclass
class SwitchPlan:
    """The switching rule's result for one condition (gait fractions in [0, 1))."""

    hold_start: float  # arm at rest on phi_hold from here (blend before it)
    hold_end: float  # arm released here (blend after it)
    phi_hold: float  # rad
    off_fraction: float  # share of the stride with the driver fully off
    max_torque_error: float  # N m, largest |T - M| over the window
    reference: Signal
    enable: Signal
    hold: Signal


def switch_plan(P: float, k: float | None = None, A: float | None = None, B: float | None = None,
                body_mass: float | None = None, M_off: float = M_OFF, blend: float = BLEND,
                ramp: float = RAMP, tolerance: float = 0.0, arm_limit: float = ARM_LIMIT) -> SwitchPlan | None:
    """Apply the switching rule (module docstring) to the planned trajectory of precompression ``P`` [m] (``k``
    [N/m], ``A``, ``B`` [m], ``body_mass`` [kg]; None: the model's defaults); ``M_off`` [N m], ``blend`` and
    ``ramp`` [stride fractions]; ``tolerance`` [N m] and ``arm_limit`` [rad] of the planning
    (:mod:`acausal.models.ankle.planning`). Candidate hold starts are the samples with little torque; the longest
    window wins (the earliest on a tie). ``None`` if the driver would be fully off for no more than 2 % of the
    stride."""
    if not M_off > 0:
        raise ModelError(f"switch_off: threshold M_off must be > 0 N m, got {M_off!r}")
    k, A, B = (Maccepa.k.default if k is None else k, Maccepa.A.default if A is None else A,
               Maccepa.B.default if B is None else B)
    body_mass = AnkleActuator.body_mass.default if body_mass is None else body_mass
    if not (0 < blend < 0.2 and 0 < ramp < 0.1):
        raise ModelError(f"switch_off: blend {blend!r} and ramp {ramp!r} must be small positive stride fractions")
    plan = plan_moment_arm(P, k, A, B, body_mass, tolerance, arm_limit)
    cyc = unit_cycle()
    n = _N_RULE
    s = np.arange(n) / n
    theta, M = cyc.angle(s), body_mass * cyc.torque(s)
    phi = plan.phi_profile(s)
    little = np.abs(M) <= M_off
    nb = int(np.ceil(blend * n))
    best = None
    for i in np.flatnonzero(little):
        order = (i - nb + np.arange(n)) % n  # the cycle from the start of the blend-in
        T_held = maccepa_torque(phi[i] - theta[order], P, k, A, B)
        ok = little[order] & (np.abs(T_held - M[order]) <= M_off)
        if not ok[:nb + 1].all():
            continue
        bad = np.flatnonzero(~ok)
        last = (bad[0] if bad.size else n) - 1  # last ok sample, counted from the blend-in start
        length = (last - nb - nb) / n  # hold_start .. hold_end
        if best is None or length > best[0]:
            err = float(np.max(np.abs(T_held[:last + 1] - M[order][:last + 1])))
            best = (length, i, err)
    if best is None or best[0] - 2 * ramp <= 0.02:
        return None
    length, i, err = best
    a = s[i]
    b = (a + length) % 1.0
    h = Window(a - blend, blend, b, blend, name="arm hold")
    hold = Window(a, ramp, b - ramp, ramp, name="gear holds")
    return SwitchPlan(a, b, float(phi[i]), length - 2 * ramp, err,
                      HeldReference(plan.phi_profile, h, phi[i]), Complement(hold, name="driver enable"), hold)


class SelfLockingMaccepa(AnkleActuator):
    """The paper's actuator (replayed) with a self-locking 10:1 stage ``worm`` and a switchable driver; the
    driver's enable and the gear's hold come from the 1-periodic inputs ``enable_ref.profile`` and
    ``hold_ref.profile`` (defaults: always on, never held)."""

    def __init__(self, **kw):
        super().__init__(gears="self_locking", driver_cls=SwitchedPWMDriver, **kw)

    def build(self):
        super().build()
        self.enable_ref = GaitProfile(stride_time=self.stride_time, profile=Constant(1.0, name="driver enable"))
        self.hold_ref = GaitProfile(stride_time=self.stride_time, profile=Constant(0.0, name="gear holds"))
        connect(self.enable_ref.y, self.driver.enable)
        connect(self.hold_ref.y, self.worm.hold)


def condition_inputs(spec, values: dict) -> dict:
    """Inputs of registered model ``spec`` for a run with parameter values ``values`` (the model's own, every
    parameter by name): ``switch_off`` applies the switching rule to the run's planned trajectory (the driver
    stays on where the rule finds no stretch); ``self_locking`` keeps the driver on."""
    args = (values["P_nominal"], values["link.k"], values["link.A"], values["link.B"], values["body_mass"])
    band = dict(tolerance=values["torque_tolerance"], arm_limit=values["arm_limit"])
    sp_ = switch_plan(*args, **band) if spec.name == "switch_off" else None
    if sp_ is None:
        return {"arm_ref.profile": plan_moment_arm(*args, **band).phi_profile,
                "enable_ref.profile": Constant(1.0, name="driver enable"),
                "hold_ref.profile": Constant(0.0, name="gear holds")}
    return {"arm_ref.profile": sp_.reference, "enable_ref.profile": sp_.enable, "hold_ref.profile": sp_.hold}
