"""The paper's electromechanical model of the ankle actuator (its Eq. 4) on the test bench, with optional effects.

::

    supply -[P_source]- rect (ideal, non-regenerative) - driver (ideal PWM) -[P_driver]- motor (R, L, k, J, b)
        -[P_motor]- gear (ideal, n = 860) -[P_link]- link (MACCEPA, Eq. 1-3) -[P_output]- torque_sensor - ankle

Eq. (4) lumps the actuator into a DC motor with resistance R, inductance L, constant k, inertia J and viscous
friction b (both referred to the motor shaft) behind an ideal gear of ratio n = 860. The driver and the
rectifier are ideal (no quiescent draw; regenerated power is burnt, never returned) and the supply is stiff, so
the baseline has exactly the parameters the paper calibrated (Table 2).

``effects`` (identifiers of :mod:`acausal.models.effects`) adds what Eq. (4) leaves out, each with library
components: ``gear_coulomb_friction`` (a BearingFriction before the gear), ``gear_load_dependent_loss`` (the
ideal gear swapped for a LossyGear), ``winding_temperature`` (the motor's heat port on its lumped thermal capacitance),
``driver_quiescent_power`` (the driver's P_q), ``torque_sensor_offset`` (a Bias block in the torque reading),
``gear_backlash`` (a Backlash between the gear output and the moment arm, whose encoder reads the arm side)
and ``precompression_error`` (the spring's actual precompression; a parameter of every variant).

Modes:

* ``"replay"``: the measured ankle angle theta(t) (``ankle.phi_ref``) and moment-arm angle phi(t)
  (``arm_target.signal``) are prescribed signals; the compiler's index reduction derives motor speed,
  acceleration, current and voltages. Without a stateful effect the model has no state at all, so a replay is
  evaluated algebraically, vectorised over samples and parameter sets (calibration, design maps).
* ``"closed_loop"``: the bench as run: the output motor moves the ankle along the gait (``stride_time``), a PID
  tracks the planned moment-arm angle (``arm_ref.profile``) through the driver within 0.9 of the bus voltage.

Measured quantities, named after the recording columns (see :mod:`acausal.models.recording_format`):
``motor.i`` (motor current), ``P_source.i`` (supply current into the driver side), ``P_source.v`` (supply
voltage), ``joint_torque`` (torque on the foot, plantarflexion positive), ``arm_angle.phi.value``, ``ankle``'s angle.
"""
from __future__ import annotations

from acausal import Eq, Model, Parameter, Variable, connect
from acausal.library.blocks import Bias, SignalSource
from acausal.library.drives import DCMotor, PWMDriver
from acausal.library.electrical import ConstantVoltage, Ground, IdealNonRegenerativeRectifier
from acausal.library.gait import AnkleAngleSource, GaitProfile, unit_cycle
from acausal.library.maccepa import Maccepa
from acausal.library.rotational import AngleSensor, Backlash, BearingFriction, IdealGear, LossyGear, Position, TorqueSensor
from acausal.library.sensors import ElectricalPowerSensor, MechanicalPowerSensor
from acausal.library.thermal import FixedTemperature, HeatCapacitor, ThermalConductor

from .effects import EFFECTS, effect
from .drive_train import add_arm_controller, add_follower
from .planning import plan_moment_arm

N_GEAR = 860.0

#: the measurement points of the chain (label, power variable), as in the component model
MEASUREMENT_POINTS = [("source", "P_source.P"), ("driver", "P_driver.P"), ("motor", "P_motor.P"),
                      ("link", "P_link.P"), ("output", "P_output.P")]

#: model variable behind each recorded column (the simulated reading of that sensor)
SIGNALS = {"motor_current_A": "motor.i", "supply_current_A": "P_source.i", "joint_torque_Nm": "joint_torque",
           "supply_voltage_V": "P_source.v"}


class BenchAnkle(Model):
    """The Eq. (4) ankle actuator with optional effects (see the module docstring)."""

    stride_time = Parameter(2.0, unit="s", min=0.1, doc="stride duration (closed loop)")
    P_nominal = Parameter(0.008, unit="m", min=0.0, max=0.018, doc="nominal spring precompression")
    precompression_error = Parameter(0.0, unit="m", doc="actual minus nominal precompression")
    winding_heating = Parameter(EFFECTS["winding_temperature"].typical, unit="K/J", min=1e-9,
                                doc="1 / the motor's lumped heat capacity (winding_temperature)")
    joint_torque = Variable(unit="N.m", doc="reading of the joint torque sensor (torque on the foot)")
    tracking_error = Variable(unit="rad", doc="moment-arm reference minus actual angle (closed loop)")

    def __init__(self, mode: str = "replay", effects=(), **kw):
        if mode not in ("replay", "closed_loop"):
            raise ValueError(f"BenchAnkle: mode must be 'replay' or 'closed_loop', got {mode!r}")
        self.effects = tuple(sorted({effect(e).id for e in effects}))
        super().__init__(**kw)
        self.mode = mode

    def has(self, name: str) -> bool:
        return name in self.effects

    def build(self):
        self.supply = ConstantVoltage(V=48.0)
        self.P_source = ElectricalPowerSensor()
        self.rect = IdealNonRegenerativeRectifier()
        self.driver = PWMDriver(command="voltage", saturate=self.mode == "closed_loop", R_on=0.0, k_sw=0.0, P_q=0.0)
        self.P_driver = ElectricalPowerSensor()
        self.motor = DCMotor(use_heat_port=self.has("winding_temperature"), R=0.7, J=4.07e-6, b=7.0e-6)
        self.gnd = Ground()
        connect(self.supply.p, self.P_source.pc, self.P_source.pv)
        connect(self.P_source.nc, self.rect.p_in)
        connect(self.supply.n, self.P_source.nv, self.rect.n_in, self.gnd.p)
        connect(self.rect.p_bus, self.driver.bus_p)
        connect(self.rect.n_bus, self.driver.bus_n)
        connect(self.driver.mot_p, self.P_driver.pc, self.P_driver.pv)
        connect(self.P_driver.nc, self.motor.p)
        connect(self.driver.mot_n, self.P_driver.nv, self.motor.n)
        if self.has("winding_temperature"):
            self.winding = HeatCapacitor(C=1 / self.winding_heating)
            self.cooling = ThermalConductor(G=1 / 7.61)  # winding-housing-ambient, 0.21 + 7.4 K/W (datasheet)
            self.ambient = FixedTemperature(T=self.motor.T_ref)
            connect(self.motor.heat_port, self.winding.port, self.cooling.port_a)
            connect(self.cooling.port_b, self.ambient.port)
        self.P_motor = MechanicalPowerSensor()
        connect(self.motor.flange, self.P_motor.flange_a)
        shaft = self.P_motor.flange_b
        if self.has("gear_coulomb_friction"):
            self.gear_friction = BearingFriction(tau_c=0.0, w_c=5.0)
            connect(shaft, self.gear_friction.flange_a)
            shaft = self.gear_friction.flange_b
        if self.has("gear_load_dependent_loss"):
            self.gear = LossyGear(ratio=N_GEAR, eta=1.0, law="smooth", P_s=0.5)
        else:
            self.gear = IdealGear(ratio=N_GEAR)
        connect(shaft, self.gear.flange_a)
        arm = self.gear.flange_b
        if self.has("gear_backlash"):
            self.backlash = Backlash(b=0.0, tau_s=3.0)
            connect(arm, self.backlash.flange_a)
            arm = self.backlash.flange_b
        self.P_link = MechanicalPowerSensor()
        connect(arm, self.P_link.flange_a)
        self.link = Maccepa(k=132e3, P=self.P_nominal + self.precompression_error)
        self.P_output = MechanicalPowerSensor()
        self.torque_sensor = TorqueSensor()
        connect(self.P_link.flange_b, self.link.flange_b)
        connect(self.link.flange_a, self.P_output.flange_a)
        connect(self.P_output.flange_b, self.torque_sensor.flange_a)
        self.arm_angle = AngleSensor()
        connect(arm, self.arm_angle.flange)
        if self.mode == "replay":
            self.ankle = Position(phi_ref=unit_cycle().angle_signal())
            self.arm_target = SignalSource(signal=plan_moment_arm(0.008, 132e3, 0.1, 0.06, 60.0).phi_profile)
            add_follower(self, self.arm_angle.phi, self.arm_target.y)
            reference = self.arm_target.y
        else:
            self.ankle = AnkleAngleSource(stride_time=self.stride_time)
            self.arm_ref = GaitProfile(stride_time=self.stride_time,
                                       profile=plan_moment_arm(0.008, 132e3, 0.1, 0.06, 60.0).phi_profile)
            add_arm_controller(self, self.arm_ref.y, self.arm_angle.phi)
            reference = self.arm_ref.y
        connect(self.torque_sensor.flange_b, self.ankle.flange)
        self._reference = reference
        self._reading = self.torque_sensor.tau
        if self.has("torque_sensor_offset"):
            self.torque_offset = Bias(bias=0.0)
            connect(self.torque_sensor.tau, self.torque_offset.u)
            self._reading = self.torque_offset.y

    def equations(self):
        return [Eq(self.joint_torque, self._reading.value),
                Eq(self.tracking_error, self._reference.value - self.arm_angle.phi.value)]
