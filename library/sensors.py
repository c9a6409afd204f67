"""Ideal power sensors (MSL ``Modelica.Electrical.Analog.Sensors.PowerSensor`` and
``Modelica.Mechanics.Rotational.Sensors.PowerSensor``).

Both are lossless and invisible to the circuit or drive they measure: they carry no current through a voltage
path, drop no voltage across a current path, and transmit torque and motion rigidly. Each gives its reading twice:
as a causal :class:`~acausal.model.connectors.RealOutput` ``power`` (to feed a controller or a signal block) and as a
plain variable ``P`` [W] to read by name from a result (``res["sensor.P"]``). Sign conventions follow the MSL
(flow into a component positive), spelled out with a sketch in each class.
"""
from acausal import Component, Eq, RealOutput, Variable, der
from acausal.model.connectors import Flange, Pin

__all__ = ["ElectricalPowerSensor", "MechanicalPowerSensor"]


class ElectricalPowerSensor(Component):
    """Ideal electrical power meter (MSL ``Analog.Sensors.PowerSensor``): a series ammeter plus a voltmeter.

    ::

              current path (in series with the load, no voltage drop)
          ---->  pc o-----[ A ]-----o nc  ---->  to the load
                 i = pc.i
                                                      P = (pv.v - nv.v) * pc.i
          voltage path (in parallel with the load, no current)
                 pv o-----[ V ]-----o nv
                 v = pv.v - nv.v

    Equations::

        pc.v = nc.v,  pc.i + nc.i = 0       (ideal ammeter: no voltage drop, current passes through)
        pv.i = 0,     nv.i = 0              (ideal voltmeter: no current)
        i = pc.i,  v = pv.v - nv.v
        P = power.value = v * i

    What is measured: with the current path in series between a source (at ``pc``) and a load (at ``nc``) and
    the voltage path across the load (``pv`` at the load's positive pin, ``nv`` at its negative pin), ``P`` is the
    power flowing into the load, ``v * i`` in the load's own convention, positive when the load absorbs power.
    Reversing the current path (current entering at ``nc``) or swapping ``pv``/``nv`` flips the sign.
    The sensor itself absorbs no power (``pc.v*pc.i + nc.v*nc.i = 0`` and its voltage path carries no current).
    No parameters.
    """

    pc = Pin(doc="positive pin of the current path (current enters here when i > 0)")
    nc = Pin(doc="negative pin of the current path")
    pv = Pin(doc="positive pin of the voltage path")
    nv = Pin(doc="negative pin of the voltage path")
    power = RealOutput(doc="measured power (pv.v - nv.v) * pc.i [W]")
    P = Variable(unit="W", doc="measured power (pv.v - nv.v) * pc.i")
    i = Variable(unit="A", doc="current through the current path, pc -> nc")
    v = Variable(unit="V", doc="voltage across the voltage path, pv.v - nv.v")

    def equations(self):
        return [Eq(self.pc.v, self.nc.v), Eq(self.pc.i + self.nc.i, 0), Eq(self.pv.i, 0), Eq(self.nv.i, 0),
                Eq(self.i, self.pc.i), Eq(self.v, self.pv.v - self.nv.v), Eq(self.P, self.v * self.i),
                Eq(self.power.value, self.P)]


class MechanicalPowerSensor(Component):
    """Ideal rotational power meter (MSL ``Rotational.Sensors.PowerSensor``): a rigid, massless shaft piece
    between two flanges that reads torque, speed and their product.

    ::

          driving side                                     driven side
          ======|=======[ flange_a  ||  flange_b ]=======|======
                         tau = flange_a.tau  ------>  P = tau * w  (power passing a -> b)
                         w   = der(flange_a.phi)

    Equations::

        flange_a.phi = flange_b.phi                 (rigid)
        flange_a.tau + flange_b.tau = 0             (massless: the torque passes through)
        tau = flange_a.tau                          (cut torque acting on the sensor at flange_a)
        w = der(flange_a.phi)
        P = power.value = tau * w

    What is measured: ``tau * w`` is the power flowing *into* the sensor through ``flange_a``; the sensor is
    lossless, so the same power leaves through ``flange_b`` into whatever is connected there. ``P`` > 0 means
    power is transmitted from the ``flange_a`` side to the ``flange_b`` side (a motor at ``flange_a`` driving a
    load at ``flange_b``); mounting the sensor the other way round flips the sign. ``tau`` is the torque the
    ``flange_a`` side exerts on the ``flange_b`` side (``TorqueSensor``'s reading). No parameters.
    """

    flange_a = Flange(doc="flange on the driving side (power enters here when P > 0)")
    flange_b = Flange(doc="flange on the driven side")
    power = RealOutput(doc="power transmitted from flange_a to flange_b [W]")
    P = Variable(unit="W", doc="power transmitted from flange_a to flange_b, tau * w")
    tau = Variable(unit="N.m", doc="torque transmitted from flange_a to flange_b (= flange_a.tau)")
    w = Variable(unit="rad/s", doc="angular velocity of the shaft, der(flange_a.phi)")

    def equations(self):
        return [Eq(self.flange_a.phi, self.flange_b.phi), Eq(self.flange_a.tau + self.flange_b.tau, 0),
                Eq(self.tau, self.flange_a.tau), Eq(self.w, der(self.flange_a.phi)), Eq(self.P, self.tau * self.w),
                Eq(self.power.value, self.P)]
