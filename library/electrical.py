"""Analog electrical components (MSL ``Modelica.Electrical.Analog`` names and sign conventions).

Current flows from pin ``p`` through the component to pin ``n``; power into a one-port is ``v*i``.
Also the supply side of a drive: :class:`Supply`, :class:`IdealDiode`, :class:`BrakeChopper` and the
:class:`NonRegenerativeRectifier` built from them.
"""
import sympy as sp

from acausal import (Component, Discrete, Eq, Event, Input, Model, Parameter, RealInput, RealOutput, Variable, connect,
                     der)
from acausal.model.connectors import Pin
from acausal.model.partials import OnePort, PartialElementaryRotationalToElectrical


class Ground(Component):
    """Reference potential: ``p.v = 0``."""

    p = Pin(doc="ground pin")

    def equations(self):
        return [Eq(self.p.v, 0)]


class Resistor(OnePort):
    """Ideal linear resistor, ``v = R i``; dissipates ``loss_power = v i >= 0``."""

    R = Parameter(1.0, unit="Ohm", min=0.0, doc="resistance")
    loss_power = Variable(unit="W", doc="dissipated power v*i")

    def equations(self):
        return [*super().equations(), Eq(self.v, self.R * self.i), Eq(self.loss_power, self.v * self.i)]


class Conductor(OnePort):
    """Ideal linear conductor, ``i = G v``."""

    G = Parameter(1.0, unit="S", min=0.0, doc="conductance")

    def equations(self):
        return [*super().equations(), Eq(self.i, self.G * self.v)]


class SwitchedResistor(OnePort):
    """A resistance ``R`` in series with an ideal switch that is closed while the input ``closed`` is 1 and open
    while it is 0: ``i = closed v / R`` (values in between scale the conductance). A servo's winding behind its
    torque-enable: with the torque off the bridge floats and no current flows (no back-EMF braking).
    ``loss_power = v i = closed v^2 / R >= 0``."""

    R = Parameter(1.0, unit="Ohm", min=1e-12, doc="resistance while closed")
    closed = RealInput(doc="switch state: 1 closed, 0 open")
    loss_power = Variable(unit="W", doc="dissipated power v i")

    def equations(self):
        return [*super().equations(), Eq(self.i, self.closed.value * self.v / self.R),
                Eq(self.loss_power, self.v * self.i)]


class BrakingWinding(SwitchedResistor):
    """A servo's winding behind its torque-enable that the bridge does not leave floating with the torque off: a
    fraction ``brake`` of the winding's conductance stays (``i = (closed + brake (1 - closed)) v / R``): 0 is the
    floating bridge (coast: :class:`SwitchedResistor`), 1 both low sides on (the winding shorted: dynamic braking,
    the back-EMF's current drags the back-driven rotor). H-bridge drivers offer both decay modes (coast and brake,
    e.g. TI DRV8833's IN1 = IN2 = 0 and = 1); which one a servo's torque-off uses is not in its manual.
    ``loss_power = v i >= 0``."""

    brake = Parameter(0.0, unit="1", min=0.0, max=1.0, doc="winding conductance left with the torque off, per 1/R")

    def equations(self):
        on = self.closed.value + self.brake * (1 - self.closed.value)
        return [*OnePort.equations(self), Eq(self.i, on * self.v / self.R), Eq(self.loss_power, self.v * self.i)]


class CurrentLimitedResistor(SwitchedResistor):
    """A :class:`SwitchedResistor` behind a driver that caps its current at ``i_max = 1 / inv_i_max`` (a servo's
    current limit, e.g. a Dynamixel's Current Limit register): ``i = closed (v/R) / max(1, inv_i_max |v/R|)``.
    At the cap the voltage the winding does not need is dropped here and counted in ``loss_power``; a real driver
    lowers its duty instead and draws that much less from its supply (the current and the motion are the same).
    The reciprocal keeps "no limit" at 0, so a fit can start there. ``loss_power = v i >= 0``."""

    inv_i_max = Parameter(0.0, unit="1/A", min=0.0, doc="reciprocal of the current limit (0: no limit)")

    def equations(self):
        free = self.v / self.R  # the current without a limit
        return [*OnePort.equations(self),
                Eq(self.i, self.closed.value * free / sp.Max(1, self.inv_i_max * sp.Abs(free))),
                Eq(self.loss_power, self.v * self.i)]


class Capacitor(OnePort):
    """Ideal capacitor, ``i = C dv/dt``; stores ``energy = C v^2 / 2``."""

    C = Parameter(1.0, unit="F", min=0.0, doc="capacitance")
    energy = Variable(unit="J", doc="stored energy C v^2/2")

    def equations(self):
        return [*super().equations(), Eq(self.i, self.C * der(self.v)), Eq(self.energy, self.C * self.v**2 / 2)]


class Inductor(OnePort):
    """Ideal inductor, ``v = L di/dt``; stores ``energy = L i^2 / 2``."""

    L = Parameter(1.0, unit="H", min=0.0, doc="inductance")
    energy = Variable(unit="J", doc="stored energy L i^2/2")

    def equations(self):
        return [*super().equations(), Eq(self.v, self.L * der(self.i)), Eq(self.energy, self.L * self.i**2 / 2)]


class ConstantVoltage(OnePort):
    """Ideal constant voltage source, ``v = V`` (p is the + terminal). The power it delivers is ``-v*i``."""

    V = Parameter(1.0, unit="V", doc="source voltage")

    def equations(self):
        return [*super().equations(), Eq(self.v, self.V)]


class PrescribedVoltage(OnePort):
    """Voltage source following a prescribed signal ``v_ref(t)`` (number, sympy expression or Signal)."""

    v_ref = Input(unit="V", doc="prescribed voltage")

    def equations(self):
        return [*super().equations(), Eq(self.v, self.v_ref)]


class SignalVoltage(OnePort):
    """Voltage source driven by a causal input: ``v = u.value`` (MSL ``SignalVoltage``)."""

    u = RealInput(doc="voltage command [V]")

    def equations(self):
        return [*super().equations(), Eq(self.v, self.u.value)]


class SineVoltageVariableFrequencyAndAmplitude(OnePort):
    """Sine voltage source whose amplitude ``V`` and frequency ``f`` are causal inputs (MSL
    ``Analog.Sources.SineVoltageVariableFrequencyAndAmplitude``); p is the + terminal. The phase is integrated
    from the frequency, so a frequency that changes moves the wave on without a jump::

        v = offset + V sin(phi)          der(phi) = 2 pi f

    ``phi`` is a state starting at 0 (MSL's start value); ``phi=Start(x)`` starts the wave at phase ``x``.
    ``source_power = -v i`` is the power the source delivers to the circuit. Default: ``offset`` = 0 (MSL's).
    MSL's options to replace ``V`` or ``f`` by a constant are not here: connect a constant signal instead.
    """

    offset = Parameter(0.0, unit="V", doc="offset of the sine wave")
    V = RealInput(doc="amplitude [V]")
    f = RealInput(doc="frequency [Hz]")
    phi = Variable(start=0.0, fixed=True, unit="rad", doc="phase of the sine wave")
    source_power = Variable(unit="W", doc="power delivered to the circuit, -v*i")

    def equations(self):
        return [*super().equations(), Eq(der(self.phi), 2 * sp.pi * self.f.value),
                Eq(self.v, self.offset + self.V.value * sp.sin(self.phi)), Eq(self.source_power, -self.v * self.i)]


class ConstantCurrent(OnePort):
    """Ideal constant current source: ``i = I`` flows from p to n through the source."""

    I = Parameter(1.0, unit="A", doc="source current")

    def equations(self):
        return [*super().equations(), Eq(self.i, self.I)]


class SignalCurrent(OnePort):
    """Current source driven by a causal input: ``i = u.value``."""

    u = RealInput(doc="current command [A]")

    def equations(self):
        return [*super().equations(), Eq(self.i, self.u.value)]


class CurrentSensor(OnePort):
    """Ideal ammeter in series: ``v = 0``, output ``i_out = i`` (current p -> n)."""

    i_out = RealOutput(doc="measured current [A]")

    def equations(self):
        return [*super().equations(), Eq(self.v, 0), Eq(self.i_out.value, self.i)]


class VoltageSensor(Component):
    """Ideal voltmeter: no current, output ``v_out = p.v - n.v``."""

    p = Pin(doc="positive pin")
    n = Pin(doc="negative pin")
    v_out = RealOutput(doc="measured voltage [V]")

    def equations(self):
        return [Eq(self.p.i, 0), Eq(self.n.i, 0), Eq(self.v_out.value, self.p.v - self.n.v)]


class EMF(PartialElementaryRotationalToElectrical):
    """Ideal electromechanical converter (MSL ``EMF``): ``v = k w``, ``flange.tau = -k i``.

    ``k`` [N m/A = V s/rad] is both the torque and the back-EMF constant, so the converter is lossless:
    electrical power in ``v i`` equals mechanical power out ``-flange.tau w``. With ``use_support=True`` the
    reaction torque acts on the ``support`` flange; otherwise the housing is fixed.
    """

    k = Parameter(1.0, unit="N.m/A", doc="transformation coefficient (torque and back-EMF constant)")

    def equations(self):
        return [*super().equations(), Eq(self.v, self.k * self.w), Eq(self.flange.tau, -self.k * self.i)]


class Supply(OnePort):
    """DC supply: ideal voltage ``V`` behind an internal resistance ``R_int`` (p is the + terminal).

    With the OnePort convention (``i`` from p through the supply to n) a supply that delivers current has
    ``i < 0``: ``v = V + R_int i``. ``power`` is the power delivered to the circuit, ``-v i``; ``loss_power`` the
    internal dissipation ``R_int i^2``; ``source_power`` the power of the ideal source ``-V i``.
    Defaults: 48 V (the motor's nominal voltage; the paper does not state the bench supply voltage, the EPOS2
    70/10 accepts 11-70 V) and 0.05 ohm (assumption: a laboratory supply plus leads).
    """

    V = Parameter(48.0, unit="V", min=0.0, doc="no-load voltage (assumption: motor nominal 48 V)",
                  device="the paper's 48 V bench supply")
    R_int = Parameter(0.05, unit="Ohm", min=0.0, doc="internal resistance (assumption)",
                      device="the paper's 48 V bench supply")
    power = Variable(unit="W", doc="power delivered at the terminals")
    source_power = Variable(unit="W", doc="power of the ideal internal source")
    loss_power = Variable(unit="W", doc="dissipated in the internal resistance")

    def equations(self):
        return [*super().equations(), Eq(self.v, self.V + self.R_int * self.i), Eq(self.power, -self.v * self.i),
                Eq(self.source_power, -self.V * self.i), Eq(self.loss_power, self.R_int * self.i**2)]


class IdealDiode(OnePort):
    """Ideal diode with state events (MSL ``IdealDiode``), conducting from p to n above the knee voltage.

    Written with the curve parameter ``s`` (the position on the characteristic, 0 at the knee) so that both modes
    have the same structure::

        v = s * (off + (1 - off) R_on) + V_knee       i = s * (off G_off + (1 - off)) + G_off V_knee

    ``off`` switches when ``s`` crosses zero: falling -> blocking (off = 1), rising -> conducting (off = 0).
    ``loss_power = v i >= 0`` in both modes (conducting: ``s >= 0``; blocking: ``v i = G_off (s + V_knee)^2``).
    R_on and G_off are small leakage values (MSL's defaults, 1e-5); V_knee = 0 by default (MSL's).
    """

    R_on = Parameter(1e-5, unit="Ohm", min=0.0, doc="forward state-on resistance")
    G_off = Parameter(1e-5, unit="S", min=0.0, doc="backward state-off conductance")
    V_knee = Parameter(0.0, unit="V", min=0.0, doc="forward threshold voltage")
    s = Variable(doc="curve parameter: current (on) or voltage (off) above the knee")
    loss_power = Variable(unit="W", doc="dissipated power v*i")
    off = Discrete(start=0.0, doc="1 while blocking")

    def equations(self):
        return [*super().equations(), Eq(self.v, self.s * (self.off + (1 - self.off) * self.R_on) + self.V_knee),
                Eq(self.i, self.s * (self.off * self.G_off + (1 - self.off)) + self.G_off * self.V_knee),
                Eq(self.loss_power, self.v * self.i)]

    def events(self):
        return [Event(self.s, on_rising={self.off: 0}, on_falling={self.off: 1}, doc="diode switches")]


class BrakeChopper(OnePort):
    """Averaged brake chopper across a DC bus: above the threshold ``V_on`` it conducts ``i = G (v - V_on)``
    (the average current of a chopper whose duty grows with the over-voltage), below it nothing. The switch is
    a state event on ``v - V_on``; the current is continuous there. ``loss_power = v i >= 0``.
    Defaults (assumptions): 50 V threshold for a 48 V bus, G = 2 S (50 W at 0.5 V over-voltage)."""

    V_on = Parameter(50.0, unit="V", min=0.0, doc="bus voltage where braking starts")
    G = Parameter(2.0, unit="S", min=0.0, doc="braking conductance above the threshold")
    loss_power = Variable(unit="W", doc="dissipated power v*i")
    on = Discrete(start=0.0, doc="1 while braking")

    def equations(self):
        return [*super().equations(), Eq(self.i, self.on * self.G * (self.v - self.V_on)),
                Eq(self.loss_power, self.v * self.i)]

    def events(self):
        return [Event(self.v - self.V_on, on_rising={self.on: 1}, on_falling={self.on: 0}, doc="chopper switches")]


class NonRegenerativeRectifier(Model):
    """Supply front end that cannot return energy to the supply (paper Fig. 8: while the driver power dips to
    -50 W the source power only drops to about 0 W).

    ::

        p_in ->|- p_bus ---+-----------+
              diode        |           |
                         C_bus    brake chopper
                           |           |
        n_in ------------ n_bus -------+

    Energy fed back by the driver charges the bus capacitor; above ``V_brake`` the chopper burns it. So the
    returned energy shows up as ``loss_power`` (diode + chopper) or as stored bus energy, never vanishes.
    ``bus_energy`` is the capacitor's stored energy. Defaults (assumptions): 470 uF bus capacitance, brake
    threshold 50 V.
    """

    C_bus = Parameter(470e-6, unit="F", min=0.0, doc="bus capacitance (assumption)",
                      device="the paper's bench rectifier")
    V_brake = Parameter(50.0, unit="V", min=0.0, doc="brake chopper threshold (assumption)",
                        device="the paper's bench rectifier")
    G_brake = Parameter(2.0, unit="S", min=0.0, doc="brake chopper conductance above threshold (assumption)",
                        device="the paper's bench rectifier")
    p_in = Pin(doc="+ from the supply")
    n_in = Pin(doc="- from the supply")
    p_bus = Pin(doc="+ of the DC bus (to the driver)")
    n_bus = Pin(doc="- of the DC bus")
    loss_power = Variable(unit="W", doc="diode + brake chopper dissipation")
    bus_energy = Variable(unit="J", doc="energy stored in the bus capacitor")

    def build(self):
        self.diode = IdealDiode()
        self.capacitor = Capacitor(C=self.C_bus)
        self.chopper = BrakeChopper(V_on=self.V_brake, G=self.G_brake)
        connect(self.p_in, self.diode.p)
        connect(self.diode.n, self.capacitor.p, self.chopper.p, self.p_bus)
        connect(self.n_in, self.capacitor.n, self.chopper.n, self.n_bus)

    def equations(self):
        return [Eq(self.loss_power, self.diode.loss_power + self.chopper.loss_power),
                Eq(self.bus_energy, self.capacitor.energy)]


class IdealNonRegenerativeRectifier(Component):
    """Averaged, stateless supply front end that never returns energy to the supply: an ideal diode into a bus
    held at the supply voltage by an ideal brake chopper (the limit of :class:`NonRegenerativeRectifier` with
    no bus capacitance and a stiff chopper). It is the "non-regenerative rectifier" of the paper's Eq. 4 model.

    ::

        p_in ->|- p_bus        v_bus = v_in
                               i_in  = max(i_bus, 0)           (i_bus: current the driver draws from p_bus)
        n_in ---- n_bus        loss_power = v_bus (i_in - i_bus) >= 0   (regenerated power burnt in the chopper)

    Having no state, it keeps an inverse (replay) model purely algebraic, so a replay is evaluated without an
    integrator and vectorised over parameter sets. ``max`` is written ``(x + |x|) / 2``.
    """

    p_in = Pin(doc="+ from the supply")
    n_in = Pin(doc="- from the supply")
    p_bus = Pin(doc="+ of the DC bus (to the driver)")
    n_bus = Pin(doc="- of the DC bus")
    i_bus = Variable(unit="A", doc="current drawn by the driver from p_bus (negative while regenerating)")
    loss_power = Variable(unit="W", doc="regenerated power dumped in the brake chopper")

    def equations(self):
        v_bus = self.p_bus.v - self.n_bus.v
        return [Eq(v_bus, self.p_in.v - self.n_in.v), Eq(self.n_bus.v, self.n_in.v),
                Eq(self.i_bus, -self.p_bus.i), Eq(self.p_bus.i + self.n_bus.i, 0), Eq(self.p_in.i + self.n_in.i, 0),
                Eq(self.p_in.i, (self.i_bus + sp.Abs(self.i_bus)) / 2),
                Eq(self.loss_power, v_bus * (self.p_in.i - self.i_bus))]
