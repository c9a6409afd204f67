"""Causal signal blocks: sources, gains, and the inverse-model constraint."""
from sympy import Eq

from acausal import Component, Input, Parameter, RealInput, RealOutput


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
