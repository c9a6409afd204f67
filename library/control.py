"""Continuous-time control blocks (after MSL ``Modelica.Blocks.Continuous``/``Math``/``Nonlinear``).

Blocks are causal: :class:`~acausal.model.connectors.RealInput` s in, :class:`~acausal.model.connectors.RealOutput` s
out, each signal a plain number in whatever unit the connected quantity has (rad, A, V...). Gains therefore carry
"output unit per input unit"; the units given below are those of a normalised loop (output and input in the same
unit) and are multiplied by ``[y]/[u]`` in a real loop (a position controller commanding a voltage has ``kp`` in
V/rad).

Saturations are written with sympy ``Min``/``Max``: continuous, piecewise-smooth, no events; the generated
Jacobian uses their exact piecewise derivatives.

* :class:`PID` - PID with output limits, derivative on the filtered measurement and back-calculation anti-windup.
* :class:`PIDVariableLimit` - the same with a time-varying symmetric limit from an input (e.g. the bus voltage).
* :class:`FirstOrder`, :class:`Limiter`, :class:`Feedback`, :class:`Add` - the usual small blocks.
* :class:`VelocityAccelerationFeedForward` - a reference's rate and acceleration, weighted (a drive's feed-forward).
* :class:`DutyPositionController` - a hobby servo's P position law commanding the PWM duty.
* :class:`CascadeServo` - position -> velocity -> current cascade of a servo drive, built from the blocks above;
  :func:`cascade_gains` tunes it for a motor by loop shaping.
"""
from __future__ import annotations

import abc
import math
from numbers import Real

import sympy as sp
from sympy import Max, Min

from acausal import Component, Eq, Model, ModelError, Parameter, RealInput, RealOutput, Variable, connect, der
from acausal.model.partials import check_option

__all__ = ["PID", "PIDVariableLimit", "FirstOrder", "Limiter", "Feedback", "Add", "VelocityAccelerationFeedForward",
           "DutyPositionController",
           "DutyOutput", "CascadeServo", "cascade_gains", "clamp"]


def clamp(u, lo, hi):
    """``min(max(u, lo), hi)`` as a sympy expression (``hi`` wins if ``lo > hi``)."""
    return Min(Max(u, lo), hi)


def duty_output(u, enable, d_max):
    """A servo firmware's duty: the command ``u`` limited to ``+-d_max`` and gated by the torque ``enable``."""
    return enable * clamp(u, -d_max, d_max)


def _negated_default(kw: dict, name: str, of: str):
    """Default ``kw[name] = -kw[of]`` (a symmetric limit) when only ``of`` is given."""
    if name not in kw and of in kw and kw[of] is not None:
        kw[name] = -kw[of]


def _is_number(v) -> bool:
    return isinstance(v, Real) or (isinstance(v, sp.Basic) and v.is_number)


# --------------------------------------------------------------------------------------------- PID
class _PIDBase(Component, abc.ABC):
    """PID law shared by :class:`PID` and :class:`PIDVariableLimit`; subclasses give the limits ``(lo, hi)``.

    ::

        e       = setpoint - measurement
        Td * der(x_d) = measurement - x_d                 (first-order filter of the measurement)
        D       = -kd * der(x_d)                          (derivative of the filtered measurement, not of e)
        y_unsat = kp * e + I + D
        y       = clamp(y_unsat, lo, hi) = min(max(y_unsat, lo), hi)
        der(I)  = ki * e + k_aw * (y - y_unsat)           (back-calculation anti-windup)

    In Laplace terms, unsaturated: ``y = kp e + (ki/s) e - kd s/(Td s + 1) measurement``.
    """

    setpoint = RealInput(doc="reference value r")
    measurement = RealInput(doc="measured value of the controlled quantity")
    y = RealOutput(doc="limited controller output")

    kp = Parameter(1.0, unit="1", doc="proportional gain [y]/[e]")
    ki = Parameter(0.0, unit="1/s", doc="integral gain [y]/([e] s)")
    kd = Parameter(0.0, unit="s", doc="derivative gain [y] s/[e], acting on the measurement")
    Td = Parameter(1e-3, unit="s", min=0.0, doc="time constant of the derivative filter (> 0)")
    k_aw = Parameter(None, unit="1/s", min=0.0, derived="ki/kp", doc="anti-windup back-calculation gain")
    k_ff = Parameter(1.0, unit="1", doc="gain of the feed-forward input u_ff (with_feed_forward; MSL LimPID kFF)")

    e = Variable(unit="1", doc="control error setpoint - measurement")
    I = Variable(start=0.0, fixed=True, unit="1", doc="integral part (state, starts at 0)")
    x_d = Variable(unit="1", doc="filtered measurement (state of the derivative filter)")
    D = Variable(start=0.0, fixed=True, unit="1",
                 doc="derivative part; D(0) = 0 is an initial condition met by x_d(0) = measurement(0)")
    y_unsat = Variable(unit="1", doc="output before the limiter")

    def __init__(self, with_feed_forward: bool = False, **kw):
        check_option(self, "with_feed_forward", with_feed_forward, (True, False))
        if "k_aw" not in kw:
            kp, ki = kw.get("kp", 1.0), kw.get("ki", 0.0)
            if _is_number(kp) and _is_number(ki):
                kw["k_aw"] = float(ki) / float(kp) if float(kp) != 0 else 0.0
            else:  # bound to parameters of an enclosing model: keep the rule symbolic
                kw["k_aw"] = sp.sympify(ki) / sp.sympify(kp)
        td = kw.get("Td")
        if td is not None and _is_number(td) and float(td) <= 0:
            raise ModelError(f"{type(self).__name__}: the derivative filter time constant Td must be > 0, got {td}")
        super().__init__(**kw)
        self.with_feed_forward = bool(with_feed_forward)
        if self.with_feed_forward:
            self.u_ff = RealInput(doc="feed-forward signal, added to the output before the limiter (k_ff u_ff)")

    @abc.abstractmethod
    def _limits(self):
        """Lower and upper output limit ``(lo, hi)`` as expressions."""

    def equations(self):
        m = self.measurement.value
        lo, hi = self._limits()
        return [Eq(self.e, self.setpoint.value - m),
                Eq(self.Td * der(self.x_d), m - self.x_d),
                Eq(self.D, -self.kd * der(self.x_d)),
                Eq(self.y_unsat, self.kp * self.e + self.I + self.D
                   + (self.k_ff * self.u_ff.value if self.with_feed_forward else 0)),
                Eq(self.y.value, clamp(self.y_unsat, lo, hi)),
                Eq(der(self.I), self.ki * self.e + self.k_aw * (self.y.value - self.y_unsat))]


class PID(_PIDBase):
    """PID controller with output limits and anti-windup (after MSL ``LimPID``, back-calculation form).

    ::

                    +-----------------------------------------------+
        setpoint -->| e = setpoint - measurement                    |
                    | y_unsat = kp*e + I + D                        |--> y = min(max(y_unsat, y_min), y_max)
     measurement -->| D = -kd * d/dt [measurement filtered by Td]   |
                    | der(I) = ki*e + k_aw*(y - y_unsat),  I(0) = 0 |
                    +-----------------------------------------------+

    Design choices (standard practice, Astrom & Hagglund, *Advanced PID Control*, ch. 3):

    * The derivative acts on the measurement, not on the error, so a setpoint step gives no derivative kick.
      The measurement passes a first-order filter ``1/(Td s + 1)`` first, limiting the derivative's
      high-frequency gain to ``kd/Td``. At t = 0 the filter starts at the measurement (``D(0) = 0``, met by the
      initialisation adjusting the filter state ``x_d``; keep the plant's own states fixed, else the minimum-norm
      initialisation may move them too).
    * Anti-windup by back-calculation: while the output saturates, ``k_aw * (y - y_unsat)`` bleeds the integrator
      so that ``y_unsat`` stays near the limit instead of winding up; ``k_aw = 0`` disables it. When unsaturated,
      ``y = y_unsat`` and the law is the plain PID.
    * The limiter is ``min(max(., y_min), y_max)``: continuous, no events.

    Parameters (the units are those of a normalised loop; multiply by [y]/[e]):
        kp [1]: proportional gain. Default 1 (MSL ``LimPID.k``).
        ki [1/s]: integral gain (= kp/Ti). Default 0: no integral action (assumption).
        kd [s]: derivative gain (= kp*Td_pid). Default 0: no derivative action (assumption).
        Td [s]: derivative filter time constant, > 0. Default 1 ms (assumption: fast against mechanical loops).
        y_max: upper output limit; no default, as MSL ``LimPID.yMax``: a limit must be chosen.
        y_min: lower output limit. Default ``-y_max`` (MSL).
        k_aw [1/s]: back-calculation gain. Default ``ki/kp`` (tracking time constant equal to the integral time,
            Astrom & Hagglund's rule of thumb), 0 when ``kp = 0``.
    """

    y_max = Parameter(None, unit="1", doc="upper output limit")
    y_min = Parameter(None, unit="1", derived="-y_max", doc="lower output limit")

    def __init__(self, **kw):
        _negated_default(kw, "y_min", "y_max")
        super().__init__(**kw)

    def _limits(self):
        return self.y_min, self.y_max

    def assertions(self):
        return [(self.y_max >= self.y_min, "the upper output limit y_max must not be below the lower limit y_min")]


class PIDVariableLimit(_PIDBase):
    """:class:`PID` whose output limit comes from a signal: ``y = clamp(y_unsat, -limit, +limit)``.

    For a controller whose authority changes over time, e.g. a current loop commanding a voltage that cannot
    exceed the available bus voltage (``limit`` = 0.9 * supply voltage for a PWM bridge). ``limit`` must be
    >= 0. Same law, parameters and defaults as :class:`PID` otherwise (the anti-windup term sees the moving limit).
    """

    limit = RealInput(doc="symmetric output limit, >= 0 (same unit as y)")

    def _limits(self):
        return -self.limit.value, self.limit.value


# --------------------------------------------------------------------------------------------- small blocks
class FirstOrder(Component):
    """First-order lag (MSL ``Continuous.FirstOrder``): ``T * der(x) = k * u - x``, ``y = x``.

    ``y(s) = k / (T s + 1) u(s)``. The state ``x`` starts at 0 (fixed); give ``FirstOrder(..., x=1.0)`` for
    another initial output.

    Parameters:
        k [1]: static gain [y]/[u]. Default 1 (MSL).
        T [s]: time constant, > 0. No default (MSL has none).
    """

    k = Parameter(1.0, unit="1", doc="gain")
    T = Parameter(None, unit="s", min=0.0, doc="time constant")
    u = RealInput(doc="input")
    y = RealOutput(doc="output")
    x = Variable(start=0.0, fixed=True, doc="state (= output)")

    def equations(self):
        return [Eq(self.T * der(self.x), self.k * self.u.value - self.x), Eq(self.y.value, self.x)]


class Limiter(Component):
    """Static saturation (MSL ``Nonlinear.Limiter``): ``y = min(max(u, u_min), u_max)``.

    Parameters:
        u_max: upper limit; no default (MSL ``uMax`` has none).
        u_min: lower limit. Default ``-u_max`` (MSL).
    """

    u_max = Parameter(None, unit="1", doc="upper limit of the output")
    u_min = Parameter(None, unit="1", doc="lower limit of the output (default -u_max)")
    u = RealInput(doc="input")
    y = RealOutput(doc="limited output")

    def __init__(self, **kw):
        _negated_default(kw, "u_min", "u_max")
        super().__init__(**kw)

    def equations(self):
        return [Eq(self.y.value, clamp(self.u.value, self.u_min, self.u_max))]

    def assertions(self):
        return [(self.u_max >= self.u_min, "the upper limit u_max must not be below the lower limit u_min")]


class Feedback(Component):
    """Difference of two signals (MSL ``Math.Feedback``): ``y = u1 - u2`` (reference minus feedback)."""

    u1 = RealInput(doc="commanded value (reference)")
    u2 = RealInput(doc="feedback value (subtracted)")
    y = RealOutput(doc="u1 - u2")

    def equations(self):
        return [Eq(self.y.value, self.u1.value - self.u2.value)]


class Add(Component):
    """Weighted sum of two signals (MSL ``Math.Add``): ``y = k1 * u1 + k2 * u2``.

    Parameters:
        k1, k2 [1]: weights. Default +1 each (MSL).
    """

    k1 = Parameter(1.0, unit="1", doc="weight of u1")
    k2 = Parameter(1.0, unit="1", doc="weight of u2")
    u1 = RealInput(doc="first input")
    u2 = RealInput(doc="second input")
    y = RealOutput(doc="k1*u1 + k2*u2")

    def equations(self):
        return [Eq(self.y.value, self.k1 * self.u1.value + self.k2 * self.u2.value)]


class VelocityAccelerationFeedForward(Component):
    """Feed-forward of a smooth reference's rate and acceleration (the velocity and acceleration feed-forward of
    a drive's position mode, e.g. maxon EPOS2)::

        y = k_v der(u) + k_a der(der(u))

    ``u`` must be a signal the compiler can differentiate twice (a profile of time, e.g. a ``GaitProfile``): the
    derivatives are those of the reference, not of a measurement. For a DC motor behind a gear of ratio ``n``
    commanding a voltage, ``k_v = n (k + R b / k)`` and ``k_a = n R J / k`` are the voltage the unloaded motor
    needs to follow the reference (back-EMF and viscous friction; the inertia's current through the winding)."""

    u = RealInput(doc="reference")
    y = RealOutput(doc="feed-forward [y]")
    k_v = Parameter(0.0, unit="1", doc="gain on the reference's rate [y] s/[u]")
    k_a = Parameter(0.0, unit="1", doc="gain on the reference's acceleration [y] s2/[u]")
    rate = Variable(unit="1", doc="der(u) [u]/s")

    def equations(self):
        return [Eq(self.rate, der(self.u.value)),
                Eq(self.y.value, self.k_v * self.rate + self.k_a * der(self.rate))]


class DutyPositionController(Component):
    """Proportional position controller of a hobby servo's firmware, commanding the PWM duty directly::

        y = enable * clamp(kp * error_gain * (position_ref - position), -d_max, d_max)

    ``kp`` is the firmware's gain register (dimensionless count), ``error_gain`` [1/rad] turns ``kp`` times the
    position error into a duty (Dynamixel XL330: (4096 / 2 pi) / (256 * 885) = 0.0028774 per rad, Rhoban/bam
    ``dynamixel/actuator.py``, confirmed on the logged duty). ``enable`` (0/1) is the torque-enable input.
    """

    kp = Parameter(None, unit="1", min=0.0, doc="position gain (firmware register value)")
    error_gain = Parameter(None, unit="1/rad", min=0.0, doc="duty per rad of error per unit of kp")
    d_max = Parameter(1.0, unit="1", min=0.0, max=1.0, doc="largest duty magnitude (XL330: PWM limit 885/885)")
    position_ref = RealInput(doc="commanded position [rad]")
    position = RealInput(doc="measured position [rad]")
    enable = RealInput(doc="torque enable (1 on, 0 off)")
    y = RealOutput(doc="duty command [1]")

    def equations(self):
        raw = self.kp * self.error_gain * (self.position_ref.value - self.position.value)
        return [Eq(self.y.value, duty_output(raw, self.enable.value, self.d_max))]


class DutyOutput(Component):
    """The last stage of a servo firmware's duty law: the duty command limited and gated by the torque enable,
    ``y = enable * clamp(u, -d_max, d_max)`` (:class:`DutyPositionController` is this stage after
    ``u = kp * error_gain * (position_ref - position)``)."""

    d_max = Parameter(1.0, unit="1", min=0.0, max=1.0, doc="largest duty magnitude (XL330: PWM limit 885/885)")
    u = RealInput(doc="duty command before the limit [1]")
    enable = RealInput(doc="torque enable (1 on, 0 off)")
    y = RealOutput(doc="duty command [1]")

    def equations(self):
        return [Eq(self.y.value, duty_output(self.u.value, self.enable.value, self.d_max))]


# --------------------------------------------------------------------------------------------- cascade
def cascade_gains(R: float, L: float, k: float, J: float, f_current: float = 1000.0, speed_ratio: float = 10.0,
                  position_ratio: float = 10.0) -> dict:
    """Gains of :class:`CascadeServo` (and :class:`~acausal.library.drives.ServoDriver`) by loop shaping for a
    motor with terminal resistance ``R`` [ohm], inductance ``L`` [H], torque constant ``k`` [N m/A] and the
    inertia ``J`` [kg m2] its velocity loop moves (rotor plus what is rigidly coupled to it, reflected to the
    motor shaft).

    Current loop: crossover ``wc = 2 pi f_current`` with the PI zero on the electrical pole R/L
    (``kp_cur = L wc``, ``ki_cur = R wc``). Velocity loop: crossover ``wv = wc / speed_ratio``
    (``kp_vel = J wv / k``) with its PI zero at ``wv / 4`` (``ki_vel = kp_vel wv / 4``). Position loop: bandwidth
    ``wv / position_ratio`` (``kp_pos``). Each loop is several times slower than the one inside it, so each sees
    the inner one as ideal. The limits (``i_max``, ``w_max``) are the device's and not set here. A compliant
    load (a series spring) has a resonance the position loop must stay below: lower ``kp_pos`` (see the users'
    guide chapter on an SEA under position control).
    """
    for name, v in (("R", R), ("L", L), ("k", k), ("J", J), ("f_current", f_current), ("speed_ratio", speed_ratio),
                    ("position_ratio", position_ratio)):
        if not (isinstance(v, Real) and v > 0):
            raise ModelError(f"cascade_gains: {name} must be a number > 0, got {v!r}")
    wc = 2 * math.pi * f_current
    wv = wc / speed_ratio
    kp_vel = J * wv / k
    return {"kp_cur": float(L * wc), "ki_cur": float(R * wc), "kp_vel": kp_vel, "ki_vel": kp_vel * wv / 4,
            "kp_pos": wv / position_ratio}


class CascadeServo(Model):
    """Cascaded position -> velocity -> current controller of a servo drive, commanding the motor voltage.

    ::

        position_ref --> [P  pos] --w_ref--> [PI vel] --i_ref--> [PI cur] --> voltage  (to a SignalVoltage)
                           ^  |w_ref|<=w_max   ^ |i_ref|<=i_max   ^ |v| <= v_max (or <= v_limit input)
        position --------- +                   |                  |
        velocity ------------------------------+                  |
        current ---------------------------------------------------+

    ``pos`` is a :class:`PID` used as a P controller (kp_pos, limited to +-w_max: the profile speed limit),
    ``vel`` a PI controller (kp_vel, ki_vel, limited to +-i_max: the drive's current limit) and ``cur`` a PI
    controller (kp_cur, ki_cur, limited to +-v_max, or with ``use_voltage_limit_input=True`` to the
    ``v_limit`` input, e.g. 0.9 times a varying supply voltage). Each PI has back-calculation anti-windup with
    ``k_aw = ki/kp``, so a saturated inner loop does not wind up the outer one's integrator.

    This is the classic cascade of industrial servo drives, each loop several times slower than the one inside
    it. maxon's EPOS2 position mode differs: its PID position controller (with velocity/acceleration
    feed-forward) commands the current loop directly, without a velocity loop in between. The controllers here
    are continuous; a real drive samples them (EPOS2: about 10 kHz for the current loop, 1 kHz for the outer
    loops), which this model neglects. ``kp_vel`` and ``kp_cur`` must be > 0 (the anti-windup gains ki/kp of
    the inner loops divide by them).

    Signals: ``position_ref``, ``position`` [rad], ``velocity`` [rad/s], ``current`` [A] in, ``voltage`` [V] out;
    also ``w_ref`` and ``i_ref`` are readable as ``pos.y.value`` and ``vel.y.value``.

    Parameter defaults: limits from the EPOS2 70/10 and maxon EC-4pole 30 datasheets
    (docs/parameters.md); gains are assumptions from loop shaping for the bare motor (48 V winding:
    R = 0.386 ohm, L = 0.0653 mH, k = 0.0274 N m/A, rotor J = 3.33e-6 kg m2): current-loop crossover
    wc = 2 pi 1 kHz with the PI zero on the electrical pole (kp_cur = L wc, ki_cur = R wc); velocity crossover
    wc/10 (kp_vel = J wv / k, PI zero at wv/4); position bandwidth wv/10. With a load, retune vel and pos.
    """

    kp_pos = Parameter(62.8, unit="1/s", min=0.0, doc="position P gain (rad/s per rad)",
                       device="maxon EC-4pole 30 on an EPOS2 70/10")
    w_max = Parameter(2618.0, unit="rad/s", min=0.0, doc="speed limit (25 000 rpm, motor datasheet maximum)",
                      device="maxon EC-4pole 30 on an EPOS2 70/10")
    kp_vel = Parameter(0.0763, unit="A.s/rad", min=0.0, doc="velocity P gain",
                       device="maxon EC-4pole 30 on an EPOS2 70/10")
    ki_vel = Parameter(12.0, unit="A/rad", min=0.0, doc="velocity I gain", device="maxon EC-4pole 30 on an EPOS2 70/10")
    i_max = Parameter(10.0, unit="A", min=0.0, doc="current limit (EPOS2 70/10: 10 A continuous)",
                      device="maxon EC-4pole 30 on an EPOS2 70/10")
    kp_cur = Parameter(0.41, unit="V/A", min=0.0, doc="current P gain (L * 2 pi 1 kHz)",
                       device="maxon EC-4pole 30 on an EPOS2 70/10")
    ki_cur = Parameter(2425.0, unit="V/(A.s)", min=0.0, doc="current I gain (R * 2 pi 1 kHz)",
                       device="maxon EC-4pole 30 on an EPOS2 70/10")
    v_max = Parameter(43.2, unit="V", min=0.0, doc="voltage limit (0.9 * 48 V supply, EPOS2 output stage)",
                      device="maxon EC-4pole 30 on an EPOS2 70/10")

    position_ref = RealInput(doc="commanded position [rad]")
    position = RealInput(doc="measured position [rad]")
    velocity = RealInput(doc="measured velocity [rad/s]")
    current = RealInput(doc="measured motor current [A]")
    voltage = RealOutput(doc="commanded motor voltage [V]")

    def __init__(self, use_voltage_limit_input: bool = False, **kw):
        super().__init__(**kw)
        self.use_voltage_limit_input = check_option(self, "use_voltage_limit_input", use_voltage_limit_input,
                                                    (True, False))
        if use_voltage_limit_input:
            self.v_limit = RealInput(doc="available voltage magnitude [V] (replaces v_max)")

    def build(self):
        self.pos = PID(kp=self.kp_pos, ki=0.0, kd=0.0, y_max=self.w_max)
        self.vel = PID(kp=self.kp_vel, ki=self.ki_vel, kd=0.0, y_max=self.i_max)
        if self.use_voltage_limit_input:
            self.cur = PIDVariableLimit(kp=self.kp_cur, ki=self.ki_cur, kd=0.0)
            connect(self.v_limit, self.cur.limit)
        else:
            self.cur = PID(kp=self.kp_cur, ki=self.ki_cur, kd=0.0, y_max=self.v_max)
        connect(self.position_ref, self.pos.setpoint)
        connect(self.position, self.pos.measurement)
        connect(self.pos.y, self.vel.setpoint)
        connect(self.velocity, self.vel.measurement)
        connect(self.vel.y, self.cur.setpoint)
        connect(self.current, self.cur.measurement)
        connect(self.cur.y, self.voltage)
