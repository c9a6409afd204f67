"""Lumped 1-D heat transfer (MSL ``Modelica.Thermal.HeatTransfer`` names and sign conventions).

Every component talks through :class:`~acausal.model.connectors.HeatPort` s: temperature ``T`` [K] and heat flow
``Q_flow`` [W], **positive into the component**. The power entering a component through a heat port is simply
``port.Q_flow`` (``Result.power("name.port")``), so a thermal network balances its energy exactly: heat put in
by sources = heat stored in capacitors + heat taken up by fixed-temperature boundaries.

Defaults: temperatures default to 293.15 K (20 degC), the MSL's default start and reference temperature. Element
values (``C``, ``G``, ``R``) have no natural default; they default to 1 in SI units as placeholders (assumption,
as in :mod:`acausal.library.electrical`; MSL leaves them without default), so always give them.

Typical use, a motor winding heated by its copper loss::

    class Winding(Model):
        def build(self):
            self.heater = PrescribedHeatFlow(Q_flow=10.0)         # 10 W copper loss
            self.winding = HeatCapacitor(C=2.11 / 0.21, T=293.15)  # maxon EC-4pole 30 datasheet
            self.r_wh = ThermalResistor(R=0.21)                    # winding -> housing
            ...
            connect(self.heater.port, self.winding.port, self.r_wh.port_a)
"""
import abc

from sympy import exp

from acausal import Component, Eq, Input, Parameter, RealInput, RealOutput, Variable, der, time
from acausal.model.connectors import HeatPort

__all__ = ["HeatCapacitor", "Element1D", "ThermalConductor", "ThermalResistor", "DecayingTemperatureStep",
           "FixedTemperature",
           "PrescribedTemperature", "FixedHeatFlow", "PrescribedHeatFlow", "SignalHeatFlow", "TemperatureSensor",
           "HeatFlowSensor"]

T_DEFAULT = 293.15  # K, 20 degC: MSL's default start/reference temperature (convention, not a measurement)


# --------------------------------------------------------------------------------------------- storage
class HeatCapacitor(Component):
    """Lumped thermal element storing heat (MSL ``HeatCapacitor``)::

        C * der(T) = port.Q_flow          T = port.T
        energy     = C * (T - T_ref)      (heat stored relative to T_ref)

    ``port.Q_flow`` > 0 heats the body. ``T`` is a state; its start value is an initial condition
    (``fixed=True``): ``HeatCapacitor(C=..., T=350.0)`` starts at 350 K (default 293.15 K, MSL's default).
    ``energy`` is the heat content relative to the reference temperature ``T_ref``, so that
    ``energy(t) - energy(0) = integral of port.Q_flow``, the stored term of an energy balance.

    Parameters:
        C [J/K]: heat capacity (= c_p * m). Default 1.0: placeholder (assumption), always give it.
        T_ref [K]: reference temperature of ``energy``. Default 293.15 K (20 degC, MSL convention).
    """

    C = Parameter(1.0, unit="J/K", min=0.0, doc="heat capacity of the element (c_p * m)")
    T_ref = Parameter(T_DEFAULT, unit="K", min=0.0, doc="reference temperature of the stored energy")
    port = HeatPort(doc="heat port; Q_flow > 0 heats the element")
    T = Variable(start=T_DEFAULT, unit="K", fixed=True, min=0.0, state_select="prefer", nominal=300.0,
                 doc="temperature of the element")
    der_T = Variable(unit="K/s", doc="time derivative of the temperature")
    energy = Variable(unit="J", doc="stored heat C*(T - T_ref)")

    def equations(self):
        return [Eq(self.T, self.port.T), Eq(self.der_T, der(self.T)), Eq(self.C * self.der_T, self.port.Q_flow),
                Eq(self.energy, self.C * (self.T - self.T_ref))]


# --------------------------------------------------------------------------------------------- transport
class Element1D(Component):
    """Partial lossless 1-D heat-transfer element between two ports (MSL ``Interfaces.Element1D``)::

        dT = port_a.T - port_b.T
        port_a.Q_flow =  Q_flow        (Q_flow > 0: heat flows from port_a through the element to port_b)
        port_b.Q_flow = -Q_flow

    The element stores nothing: what enters at ``port_a`` leaves at ``port_b``. Subclasses add the law relating
    ``Q_flow`` and ``dT``.
    """

    port_a = HeatPort(doc="heat port a; Q_flow > 0 flows from here to port_b")
    port_b = HeatPort(doc="heat port b")
    dT = Variable(unit="K", doc="temperature difference port_a.T - port_b.T")
    Q_flow = Variable(unit="W", doc="heat flow from port_a to port_b")

    def equations(self):
        return [Eq(self.dT, self.port_a.T - self.port_b.T), Eq(self.port_a.Q_flow, self.Q_flow),
                Eq(self.port_b.Q_flow, -self.Q_flow)]


class ThermalConductor(Element1D):
    """Lumped thermal conduction without storage (MSL ``ThermalConductor``): ``Q_flow = G * dT``.

    Parameters:
        G [W/K]: thermal conductance (e.g. k*A/L for a wall). Default 1.0: placeholder (assumption).
    """

    G = Parameter(1.0, unit="W/K", min=0.0, doc="constant thermal conductance")

    def equations(self):
        return [*super().equations(), Eq(self.Q_flow, self.G * self.dT)]


class ThermalResistor(Element1D):
    """Lumped thermal resistance without storage (MSL ``ThermalResistor``): ``dT = R * Q_flow``.

    Written in this form so that ``R = 0`` (a perfect thermal contact) is allowed. Datasheet thermal resistances
    (maxon's "thermal resistance housing-ambient", K/W) plug in directly.

    Parameters:
        R [K/W]: thermal resistance (= 1/G). Default 1.0: placeholder (assumption).
    """

    R = Parameter(1.0, unit="K/W", min=0.0, doc="constant thermal resistance")

    def equations(self):
        return [*super().equations(), Eq(self.dT, self.R * self.Q_flow)]


class DecayingTemperatureStep(Element1D):
    """A temperature step across a heat path that decays exponentially, lossless: the initial excess temperature
    of a first-order thermal body made a *parameter* (no MSL counterpart)::

        port_a.T - port_b.T = dT0 * exp(-(time - t0) / tau)         port_a.Q_flow = -port_b.Q_flow

    Use: a body of capacity C cooled to a fixed ambient through a conductance G whose temperature starts ``dT0``
    above where its state starts (a winding still warm from the previous recording of a session). Put the step
    between the heat source (port_a) and the body with its cooling (port_b), with ``tau = C / G``, and start the
    body at ambient: by superposition (the body's equation is linear in its temperature) the source then sees
    exactly the temperature of a body started ``dT0`` warmer, also when the heat it makes depends on that
    temperature. The start value becomes a parameter, with exact parameter sensitivities (start values of
    states are numbers). The heat stored in the initial excess is not in the body's ``energy`` (it leaves to
    ambient outside the model); what enters the step leaves it, so energy balances are unchanged.

    Parameters:
        dT0 [K]: the step at ``time = t0`` (the initial excess temperature). Default 0: no step.
        t0 [s]: when the step is ``dT0`` (the run's start). Default 0.
        tau [s]: decay time constant (``C / G`` of the body). Default 1.0: placeholder (assumption), always give it.
    """

    dT0 = Parameter(0.0, unit="K", doc="temperature step port_a.T - port_b.T at time t0")
    t0 = Parameter(0.0, unit="s", doc="time at which the step is dT0")
    tau = Parameter(1.0, unit="s", min=0.0, doc="decay time constant of the step (C / G of the body)")

    def equations(self):
        return [*super().equations(), Eq(self.dT, self.dT0 * exp(-(time - self.t0) / self.tau))]


# --------------------------------------------------------------------------------------------- boundaries
class FixedTemperature(Component):
    """Fixed-temperature boundary, an ideal heat sink/source (MSL ``FixedTemperature``): ``port.T = T``.

    It supplies whatever heat flow the network asks; ``port.Q_flow`` > 0 means heat flows *into* the boundary
    (e.g. the heat a motor housing gives to the ambient).

    Parameters:
        T [K]: boundary temperature. Default 293.15 K (20 degC, MSL default; maxon datasheets rate at 25 degC).
    """

    T = Parameter(T_DEFAULT, unit="K", min=0.0, doc="fixed temperature at the port")
    port = HeatPort(doc="heat port; Q_flow > 0 is heat absorbed by the boundary")

    def equations(self):
        return [Eq(self.port.T, self.T)]


class PrescribedTemperature(Component):
    """Temperature boundary following a prescribed signal (MSL ``PrescribedTemperature``): ``port.T = T(t)``.

    ``T`` is a number, a sympy expression of :data:`acausal.time` or a :class:`acausal.Signal` [K]; it has no
    default (a signal must be given).
    """

    T = Input(unit="K", doc="prescribed port temperature")
    port = HeatPort(doc="heat port; Q_flow > 0 is heat absorbed by the boundary")

    def equations(self):
        return [Eq(self.port.T, self.T)]


class _HeatFlowSource(Component, abc.ABC):
    """Shared law of the heat-flow sources (MSL ``FixedHeatFlow``/``PrescribedHeatFlow``)::

        port.Q_flow = -Q * (1 + alpha * (port.T - T_ref))

    ``Q`` > 0 heats the connected component (flow *into* the source is ``-Q``). ``alpha`` [1/K] models a heat flow
    that depends on the port temperature, e.g. copper loss at constant current with the temperature coefficient
    of copper resistance 0.00393 1/K; default 0 (MSL default: a pure heat-flow source).
    ``T_ref`` [K] is the temperature at which the heat flow equals ``Q``; default 293.15 K (MSL default).
    """

    T_ref = Parameter(T_DEFAULT, unit="K", min=0.0, doc="reference temperature of alpha")
    alpha = Parameter(0.0, unit="1/K", doc="temperature coefficient of the heat flow")
    port = HeatPort(doc="heat port; the source pushes heat out of it into the network")

    @abc.abstractmethod
    def _heat(self):
        """The heat flow ``Q`` [W] the source pushes out of its port at ``T_ref``."""

    def equations(self):
        return [Eq(self.port.Q_flow, -self._heat() * (1 + self.alpha * (self.port.T - self.T_ref)))]


class FixedHeatFlow(_HeatFlowSource):
    """Constant heat-flow source (MSL ``FixedHeatFlow``): ``port.Q_flow = -Q_flow * (1 + alpha*(port.T - T_ref))``.

    Parameters:
        Q_flow [W]: heat flow into the connected component at ``T_ref``. Default 0 W (MSL has none; an idle
            source is the neutral choice - assumption).
        alpha [1/K], T_ref [K]: see :class:`_HeatFlowSource` (defaults 0 and 293.15 K, MSL).
    """

    Q_flow = Parameter(0.0, unit="W", doc="heat flow into the connected component at T_ref")

    def _heat(self):
        return self.Q_flow


class PrescribedHeatFlow(_HeatFlowSource):
    """Heat-flow source following a prescribed signal (MSL ``PrescribedHeatFlow``)::

        port.Q_flow = -Q_flow(t) * (1 + alpha * (port.T - T_ref))

    ``Q_flow`` is a number, a sympy expression of :data:`acausal.time` or a :class:`acausal.Signal` [W], the heat
    flow *into* the connected component (positive heats it); it has no default. ``alpha``/``T_ref`` as in
    :class:`_HeatFlowSource` (defaults 0 and 293.15 K, MSL).
    """

    Q_flow = Input(unit="W", doc="heat flow into the connected component at T_ref")

    def _heat(self):
        return self.Q_flow


class SignalHeatFlow(_HeatFlowSource):
    """Heat-flow source driven by a causal input (MSL ``PrescribedHeatFlow`` with its RealInput):
    ``port.Q_flow = -u.value * (1 + alpha * (port.T - T_ref))``, ``u`` in W, positive heats the network.
    ``alpha``/``T_ref`` as in :class:`_HeatFlowSource` (defaults 0 and 293.15 K, MSL)."""

    u = RealInput(doc="heat flow into the connected component [W]")

    def _heat(self):
        return self.u.value


# --------------------------------------------------------------------------------------------- sensors
class TemperatureSensor(Component):
    """Ideal absolute temperature sensor (MSL ``TemperatureSensor``): ``T.value = port.T`` [K], no heat flow
    (``port.Q_flow = 0``)."""

    port = HeatPort(doc="measured heat port")
    T = RealOutput(doc="absolute temperature [K]")

    def equations(self):
        return [Eq(self.port.Q_flow, 0), Eq(self.T.value, self.port.T)]


class HeatFlowSensor(Component):
    """Ideal heat-flow sensor in series (MSL ``HeatFlowSensor``)::

        port_a.T = port_b.T          (no temperature drop)
        port_a.Q_flow + port_b.Q_flow = 0
        Q_flow.value = port_a.Q_flow (heat flowing from port_a through the sensor to port_b) [W]
    """

    port_a = HeatPort(doc="heat port a (heat enters here when Q_flow > 0)")
    port_b = HeatPort(doc="heat port b")
    Q_flow = RealOutput(doc="heat flow from port_a to port_b [W]")

    def equations(self):
        return [Eq(self.port_a.T, self.port_b.T), Eq(self.port_a.Q_flow + self.port_b.Q_flow, 0),
                Eq(self.Q_flow.value, self.port_a.Q_flow)]
