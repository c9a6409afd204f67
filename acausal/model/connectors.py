"""Connectors (ports) of the physical domains, MSL conventions, SI units.

===============  ==================  ==================  ===============================================
connector        potential           flow                sign convention
===============  ==================  ==================  ===============================================
:class:`Pin`     ``v`` [V]           ``i`` [A]           current into the component positive
:class:`Flange`  ``phi`` [rad]       ``tau`` [N m]       torque acting *on* the component positive
:class:`HeatPort` ``T`` [K]          ``Q_flow`` [W]      heat flowing into the component positive
RealInput/Output ``value`` [any]     (none)              causal signal: outputs drive connected inputs
===============  ==================  ==================  ===============================================

Connecting ports makes their potentials equal and their flows sum to zero. A port connected to nothing has
zero flow: an open pin carries no current, a free flange no torque, an unconnected heat port is adiabatic.
A causal input must be connected (:class:`RealInput` is ``required`` by default).
"""
from .components import Connector, Flow, Potential


class Pin(Connector):
    """Electrical pin: potential ``v`` [V], current ``i`` [A] into the component."""

    domain = "electrical"
    v = Potential(unit="V", doc="electric potential")
    i = Flow(unit="A", doc="current into the component")


class Flange(Connector):
    """Rotational flange: absolute angle ``phi`` [rad], cut torque ``tau`` [N m] acting on the component."""

    domain = "rotational"
    phi = Potential(unit="rad", doc="absolute rotation angle")
    tau = Flow(unit="N.m", doc="cut torque in the flange, acting on the component")


class HeatPort(Connector):
    """Thermal port: temperature ``T`` [K], heat flow ``Q_flow`` [W] into the component."""

    domain = "thermal"
    T = Potential(start=293.15, unit="K", min=0.0, doc="port temperature")
    Q_flow = Flow(unit="W", doc="heat flow into the component")


class RealInput(Connector):
    """Causal signal input (``value``); must be connected."""

    domain = "signal"
    required_default = True
    value = Potential(doc="signal value")


class RealOutput(Connector):
    """Causal signal output (``value``)."""

    domain = "signal"
    drives = True
    value = Potential(doc="signal value")
