"""What a servo's firmware and sensing do to its signals, as swap-in blocks (causal ``u`` in, ``y`` out).

Each block is the identity when its size parameter is zero, so inserting one into a signal path of
:class:`~acausal.library.servo.PositionServo` extends the model by one parameter without changing it at zero:

=====================  ==================  ===================================================================
block                  size (zero)         what it models
=====================  ==================  ===================================================================
:class:`GoalRateLimit` ``t_v`` [s/rad]     a profile-velocity / maximum-velocity limit on the goal the firmware
                                           tracks (``1 / v_max``; Feetech's ``max_velocity``, Dynamixel's
                                           Profile Velocity)
:class:`GoalAccelLimit` ``t_a`` [s2/rad] a profile-acceleration limit: the goal the firmware tracks changes its
                                           speed no faster than ``1 / t_a`` (Dynamixel's Profile Acceleration)
:class:`DeadZone`      ``uMax``            ``y = u - clamp(u, -uMax, uMax)`` (MSL ``Blocks.Nonlinear.DeadZone``,
                                           symmetric): a deadband of the position error (Dynamixel's
                                           compliance margin, Feetech's insensitive zone), or the mean effect of
                                           truncating the duty to the PWM register's step
:class:`ErrorGain`     ``c`` [1/unit]      an error-dependent gain ``y = u / (1 + c |u|)``: the duty falls short
                                           of the linear law at large errors (torque-limit protection, a current
                                           loop inside the position loop)
:class:`GainScale`     ``s`` [1]           ``y = (1 + s) u``: the firmware's gain differs from the declared
                                           error gain (BAM's ``error_gain_ratio`` of the Feetech STS3215)
:class:`Punch`         ``p``               ``y = u + p tanh(u / u_c)``: a minimum drive added as soon as the
                                           firmware drives at all (Dynamixel AX's and Feetech's punch)
:class:`LoopDelay`     ``T`` [s]           the firmware regulates a reading ``T`` old: ``y = u - T du/dt``, the
                                           first-order delay (valid while ``T`` is well below the loop's time
                                           constants; exact in its sensitivity at ``T = 0``)
=====================  ==================  ===================================================================

A zero offset of a reading is the library's :class:`~acausal.library.blocks.Bias`. Sources of the defaults:
Rhoban/bam (Apache-2.0) ``bam/feetech/actuator.py`` (the STS3215's goal rate limit and error-gain ratio),
``bam/actuator.py`` (the duty and current limits of a voltage-controlled servo); ROBOTIS e-Manual, XL330 control
table (Profile Velocity, Profile Acceleration in steps of 214.577 rev/min^2 = 0.374 rad/s^2, PWM Limit 885, position
resolution 4096 per turn).
"""
import sympy as sp

from acausal import Component, Eq, Parameter, RealInput, RealOutput, Variable, der

from .control import clamp

__all__ = ["GoalRateLimit", "GoalAccelLimit", "DeadZone", "ErrorGain", "GainScale", "Punch", "LoopDelay"]


class _SISO(Component):
    u = RealInput(doc="input")
    y = RealOutput(doc="output")


class GoalRateLimit(_SISO):
    """The goal a firmware tracks, moved no faster than ``v_max = 1 / t_v`` (a profile-velocity limit)::

        z = u - x  (lag, state, starts at 0),   v = der(x) = k z / max(1, t_v k |z|),   y = x + v / k

    ``x`` follows ``u`` at the rate ``k`` (a first-order tracker) but never faster than ``1 / t_v``; the output
    adds the tracker's own lag back (``v / k``), so ``y = u`` exactly while the limit is not reached, whatever
    ``k``: with ``t_v = 0`` the block is the identity. Limited, ``y`` runs ``v_max / k`` ahead of ``x`` (1 ms of
    travel at the default ``k``). The hard limit's sensitivity to ``t_v`` is zero where it is not reached, so the
    diagnosis probes this block at a size (``probe`` of its effect), not at zero.
    """

    t_v = Parameter(0.0, unit="s/rad", min=0.0, doc="1 / largest goal speed (0: unlimited)")
    k = Parameter(1000.0, unit="1/s", min=1e-9, doc="tracking rate of the limited goal (sharpness of the limit)")
    z = Variable(start=0.0, fixed=True, unit="rad", doc="lag of the limited goal behind the input")
    v = Variable(unit="rad/s", doc="speed of the limited goal")

    def equations(self):
        return [Eq(self.v, self.k * self.z / sp.Max(1, self.t_v * self.k * sp.Abs(self.z))),
                Eq(der(self.z), der(self.u.value) - self.v),
                Eq(self.y.value, self.u.value - self.z + self.v / self.k)]


class GoalAccelLimit(_SISO):
    """The goal a firmware tracks, its speed changed no faster than ``a_max = 1 / t_a`` (a profile-acceleration
    limit: Dynamixel's Profile Acceleration shapes a goal step into a ramp of speed up and down)::

        z = u - x, v = der(x)                        (lag and speed of the limited goal, start 0)
        w = (k/4) z / sqrt(max(1, (k/4)^2 t_a |z| / 2))  (closing speed: at most what can stop within z)
        a = der(v) = a_f / max(1, t_a |a_f|),          a_f = k (du/dt + w - v)
        y = u - z + z_f                              (z_f: the same follower without the limit)

    ``x`` follows ``u`` (its speed fed forward) as a critically damped second-order follower (poles at ``-k/2``),
    closing the lag no faster than the speed it can still brake from at ``a_max`` (``sqrt(2 a_max |z|)``), with
    its acceleration clamped smoothly at ``a_max``: a goal step becomes a speed ramp up, a cruise and a ramp down,
    without overshoot. A follower lags a goal that turns within ``1 / k`` (a sampled step of goal is a ramp over one
    sample); the output adds the lag of the same follower without the limit back (``z_f``), so ``y = u`` exactly
    while the limit is not reached: with ``t_a = 0`` the block is the identity. The limit has no first-order effect
    at zero, so the diagnosis probes it at a size.
    """

    t_a = Parameter(0.0, unit="s2/rad", min=0.0, doc="1 / largest goal acceleration (0: unlimited)")
    k = Parameter(1000.0, unit="1/s", min=1e-9, doc="tracking rate of the goal followers")
    z = Variable(start=0.0, fixed=True, unit="rad", doc="lag of the limited goal behind the input")
    v = Variable(start=0.0, fixed=True, unit="rad/s", doc="speed of the limited goal")
    a = Variable(unit="rad/s2", doc="acceleration of the limited goal")
    z_f = Variable(start=0.0, fixed=True, unit="rad", doc="lag of the unlimited follower")
    v_f = Variable(start=0.0, fixed=True, unit="rad/s", doc="speed of the unlimited follower")

    def equations(self):
        du, q = der(self.u.value), self.k / 4
        w = q * self.z / sp.sqrt(sp.Max(1, q**2 * self.t_a * sp.Abs(self.z) / 2))  # smooth where z = 0
        a_lim = self.k * (du + w - self.v)
        return [Eq(der(self.z), du - self.v), Eq(self.a, a_lim / sp.Max(1, self.t_a * sp.Abs(a_lim))),
                Eq(der(self.v), self.a),
                Eq(der(self.z_f), du - self.v_f), Eq(der(self.v_f), self.k * (du + q * self.z_f - self.v_f)),
                Eq(self.y.value, self.u.value - self.z + self.z_f)]


class DeadZone(_SISO):
    """``y = u - clamp(u, -uMax, uMax)`` (MSL ``Blocks.Nonlinear.DeadZone`` with ``uMin = -uMax``): nothing
    passes within ``|u| <= uMax``, the rest passes shifted by ``uMax``. ``uMax = 0`` is the identity; the
    sensitivity there is ``-sign(u)``."""

    uMax = Parameter(0.0, min=0.0, doc="half width of the dead zone (unit of the signal)")

    def equations(self):
        return [Eq(self.y.value, self.u.value - clamp(self.u.value, -self.uMax, self.uMax))]


class ErrorGain(_SISO):
    """``y = u / (1 + c |u|)``: a gain that falls with the size of the signal (``c >= 0``), e.g. a firmware that
    drives less than its linear law at large position errors. ``c = 0`` is the identity."""

    c = Parameter(0.0, min=0.0, doc="fall of the gain per unit of |u| (1/unit of the signal)")

    def equations(self):
        return [Eq(self.y.value, self.u.value / (1 + self.c * sp.Abs(self.u.value)))]


class GainScale(_SISO):
    """``y = (1 + s) u``: a gain off its declared value by the fraction ``s`` (``s = 0``: the identity)."""

    s = Parameter(0.0, min=-0.99, doc="relative gain error")

    def equations(self):
        return [Eq(self.y.value, (1 + self.s) * self.u.value)]


class Punch(_SISO):
    """``y = u + p tanh(u / u_c)``: a minimum drive ``p`` added in the direction of ``u`` once ``|u|`` exceeds
    a few ``u_c`` (smoothed so the closed loop has no switching at rest). ``p = 0`` is the identity."""

    p = Parameter(0.0, min=0.0, doc="punch (unit of the signal)")
    u_c = Parameter(0.005, min=1e-12, doc="signal over which the punch comes in (unit of the signal)")

    def equations(self):
        return [Eq(self.y.value, self.u.value + self.p * sp.tanh(self.u.value / self.u_c))]


class LoopDelay(_SISO):
    """A reading ``T`` seconds old, to first order: ``y = u(t - T) ~ u - T du/dt``. Exact in value and
    sensitivity as ``T -> 0``; its error is ``T^2/2 d2u/dt2`` (below a tenth of an encoder step for a few ms
    of delay at the accelerations of a servo on a pendulum). ``T = 0`` is the identity."""

    T = Parameter(0.0, unit="s", min=0.0, doc="delay")

    def equations(self):
        return [Eq(self.y.value, self.u.value - self.T * der(self.u.value))]
