"""Causal signal blocks: sources (MSL ``Modelica.Blocks.Sources``: Step, Ramp, Sine), gains and products, the
mean and RMS over a period (MSL ``Modelica.Blocks.Math.Mean``/``RootMeanSquare``), and the inverse-model
constraint.

Sources are expressions of time and of their parameters, so their parameters change per run without recompiling
and index reduction differentiates them exactly where the structure needs it. A Step's jump (and a Ramp's or a
delayed Sine's kink) is a time event: the compiler turns each relation of time into a mode switched by an event at
its threshold, so the integrator stops there exactly.
"""
import sympy as sp

from acausal import Component, Discrete, Eq, Event, Input, Parameter, RealInput, RealOutput, Variable, der, time


class SignalSource(Component):
    """Output a prescribed signal ``y = signal(t)`` (number, sympy expression of time, or Signal)."""

    signal = Input(doc="prescribed signal")
    y = RealOutput(doc="output")

    def equations(self):
        return [Eq(self.y.value, self.signal)]


class Gain(Component):
    """``y = k u``."""

    k = Parameter(1.0, doc="gain")
    u = RealInput(doc="input")
    y = RealOutput(doc="output")

    def equations(self):
        return [Eq(self.y.value, self.k * self.u.value)]


class InverseBlockConstraint(Component):
    """Inverse model (MSL ``InverseBlockConstraints``): force the signal at ``u`` (e.g. a sensor output) to
    follow ``target(t)``, and leave the signal at ``y`` (e.g. a source's command input) as an unknown that the
    compiler solves for. With a motion target this turns a forward drive into its inverse dynamics; index
    reduction differentiates the target as often as needed."""

    target = Input(doc="prescribed value of u")
    u = RealInput(doc="signal to be constrained")
    y = RealOutput(doc="signal determined by the constraint")

    def equations(self):
        return [Eq(self.u.value, self.target)]


class SignalConstraint(Component):
    """Inverse model with a signal target: force ``u`` to equal the signal at ``target`` and leave ``y`` free
    (an unknown that the compiler solves for). Like :class:`InverseBlockConstraint`, but the target comes through
    a connector (e.g. from a profile source whose time scale is a parameter)."""

    u = RealInput(doc="signal to be constrained")
    target = RealInput(doc="value u must take")
    y = RealOutput(doc="signal determined by the constraint")

    def equations(self):
        return [Eq(self.u.value, self.target.value)]


class Bias(Component):
    """``y = u + bias``: a constant offset in a signal path, e.g. the zero offset of a sensor's reading."""

    bias = Parameter(0.0, doc="offset added to the input (unit of the signal)")
    u = RealInput(doc="input")
    y = RealOutput(doc="output")

    def equations(self):
        return [Eq(self.y.value, self.u.value + self.bias)]


class Step(Component):
    """``y = offset`` before ``start_time``, ``offset + height`` from it on (MSL ``Blocks.Sources.Step``)."""

    height = Parameter(1.0, doc="height of the step (unit of the signal)")
    offset = Parameter(0.0, doc="output before the step (unit of the signal)")
    start_time = Parameter(0.0, unit="s", doc="time of the step")
    y = RealOutput(doc="output")

    def equations(self):
        return [Eq(self.y.value, self.offset + sp.Piecewise((0, time < self.start_time), (self.height, True)))]


class Ramp(Component):
    """``y`` rises linearly by ``height`` over ``duration`` from ``start_time`` (MSL ``Blocks.Sources.Ramp``)."""

    height = Parameter(1.0, doc="height of the ramp (unit of the signal)")
    duration = Parameter(1.0, unit="s", min=0.0, doc="duration of the ramp (0: a step)")
    offset = Parameter(0.0, doc="output before the ramp (unit of the signal)")
    start_time = Parameter(0.0, unit="s", doc="time the ramp starts")
    y = RealOutput(doc="output")

    def equations(self):
        t0, T = self.start_time, self.duration
        return [Eq(self.y.value, self.offset + sp.Piecewise((0, time < t0), (self.height, time >= t0 + T),
                                                            (self.height * (time - t0) / sp.Max(T, 1e-300), True)))]


class Sine(Component):
    """``y = offset + amplitude sin(2 pi f (t - start_time) + phase)`` from ``start_time`` on, ``offset`` before
    it (MSL ``Blocks.Sources.Sine``)."""

    amplitude = Parameter(1.0, doc="amplitude (unit of the signal)")
    f = Parameter(1.0, unit="Hz", min=0.0, doc="frequency")
    phase = Parameter(0.0, unit="rad", doc="phase at start_time")
    offset = Parameter(0.0, doc="offset (unit of the signal)")
    start_time = Parameter(0.0, unit="s", doc="time the sine starts")
    y = RealOutput(doc="output")

    def equations(self):
        wave = self.amplitude * sp.sin(2 * sp.pi * self.f * (time - self.start_time) + self.phase)
        return [Eq(self.y.value, self.offset + sp.Piecewise((0, time < self.start_time), (wave, True)))]


class Product(Component):
    """``y = u1 u2`` (MSL ``Blocks.Math.Product``)."""

    u1 = RealInput(doc="first factor")
    u2 = RealInput(doc="second factor")
    y = RealOutput(doc="product")

    def equations(self):
        return [Eq(self.y.value, self.u1.value * self.u2.value)]


class SmoothLimiter(Component):
    """``y = u`` within ``|u| < limit``, ``y = +-limit`` beyond, with the corners rounded over ``band``: a limiter
    whose output is smooth in ``u`` and ``limit`` (no event, so exact parameter sensitivities and an implicit
    integrator see one smooth law)::

        y = (sabs(u + limit) - sabs(u - limit)) / 2          sabs(x) = x tanh(x / band)

    ``sabs`` is ``|x|`` up to ``2 |x| exp(-2 |x| / band)``: ``y`` equals ``u`` to round-off once ``u`` is about
    20 ``band`` inside the limit, equals the limit as far outside it, and differs from the sharp clamp by at most
    ``0.14 band`` (``0.65 band`` from the corner, on either side). ``limit`` comes through a connector (e.g. the
    largest voltage a bridge can make from its present bus)."""

    band = Parameter(0.05, min=1e-12, doc="width of the rounded corners (unit of the signal)")
    u = RealInput(doc="input")
    limit = RealInput(doc="largest output magnitude (> 0, unit of the signal)")
    y = RealOutput(doc="limited output")

    def equations(self):
        def sabs(x):
            return x * sp.tanh(x / self.band)
        u, lim = self.u.value, self.limit.value
        return [Eq(self.y.value, (sabs(u + lim) - sabs(u - lim)) / 2)]


class _PeriodMean(Component):
    """Partial: ``y`` holds the mean of ``g(u)`` over the last full period ``1 / f``, updated at the end of every
    period (MSL ``Modelica.Blocks.Math.Mean``'s sampling)::

        der(x) = g(u)
        at time = t0 + k / f  (k = 1, 2, ...):   y := out(x f),   reinit(x, 0)

    ``y`` is ``y_start`` before the first period has ended. The integral restarts at every sample (as the MSL's
    ``reinit``), so its error is that of one period, however long the run. The sample instants are events of a
    zero function linear in time, ``time - t0 - (n + 1) / f`` (``n``: periods ended so far), which jumps back by
    a period at each: located to round-off on both simulation paths and in an FMU, and never missed, however long
    the solver's steps (it crosses once per period, monotonically)."""

    f = Parameter(50.0, unit="Hz", min=1e-12, doc="base frequency: the mean is over one period 1 / f "
                                                  "(MSL default 50 Hz)")
    t0 = Parameter(0.0, unit="s", doc="start of the first period (the simulation's start time)")
    y_start = Parameter(0.0, doc="output before the first period has ended (MSL x0 / f; unit of the output)")
    u = RealInput(doc="input")
    y = RealOutput(doc="mean of the last full period (held between samples)")
    x = Variable(start=0.0, fixed=True, state_select="always", doc="integral of g(u) since the last sample")
    n = Discrete(start=0.0, doc="periods ended so far")
    y_held = Discrete(start=0.0, doc="the output held since the last sample (before the first: y_start)")
    started = Discrete(start=0.0, doc="1 once a period has ended")

    def g(self, u):
        return u

    def out(self, mean):
        return mean

    def equations(self):
        return [Eq(der(self.x), self.g(self.u.value)),
                Eq(self.y.value, self.started * self.y_held + (1 - self.started) * self.y_start)]

    def events(self):
        return [Event(time - self.t0 - (self.n + 1) / self.f,
                      on_rising={self.n: self.n + 1, self.started: 1, self.y_held: self.out(self.x * self.f)},
                      reinit={self.x: 0.0}, doc="end of a period: sample the mean, restart the integral")]


class Mean(_PeriodMean):
    """Mean of ``u`` over each period ``1 / f`` (MSL ``Modelica.Blocks.Math.Mean``), held until the next: the
    average of a 50 Hz current over one cycle, a DC component, the mean power of an AC load. See
    :class:`_PeriodMean` for the sampling."""


class RMS(_PeriodMean):
    """Root mean square of ``u`` over each period ``1 / f`` (MSL ``Modelica.Blocks.Math.RootMeanSquare``), held
    until the next: ``sqrt(mean(u^2))`` (``A / sqrt 2`` for a sine of amplitude ``A`` whose period divides
    ``1 / f``). See :class:`_PeriodMean` for the sampling."""

    def g(self, u):
        return u**2

    def out(self, mean):
        return sp.sqrt(sp.Max(mean, 0))
