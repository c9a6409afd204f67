"""The CYBERLEGs alpha-prosthesis ankle actuator (paper sections 2-3), one model with declared options.

::

    supply -[P_source]- rectifier - PWM driver -[P_driver]- DC motor -[P_motor]- rotor - gears (planetary 86:1,
        helical 10:1) -[P_link]- MACCEPA -[P_output]- torque_sensor - ankle joint (moved along the gait)

``P_*`` are power sensors at the paper's five measurement points (Fig. 6): source (electrical, supply -> driver
side), driver output (electrical, at the motor terminals), motor (the air-gap power ``k i w``, as the paper computes
it from the motor current and speed, Eq. 6: the motor's rotor inertia and friction, ``motor.J`` and ``motor.b``,
sit behind the sensor as ``rotor`` and ``rotor_friction``), moment arm ("link") and joint ("output"), mechanical
ones positive in the direction supply -> joint. The energy accounts (losses, stored energies, the
measurement points) are found by convention from the components (:mod:`acausal.results.energy`): nothing here lists
them.

:class:`DriveTrain` is the partial model every ankle drive shares (supply to gear output); :class:`AnkleActuator`
completes it with the MACCEPA, the joint and the way the moment arm is moved. Options (constructor keywords):

* ``mode``: ``"replay"`` (the paper's Simulink approach: the moment-arm angle is imposed through an inverse
  constraint on the driver command, so index reduction derives current, voltages and every power; the driver
  does not saturate, check ``driver.d`` against ``d_max``) or ``"closed_loop"`` (a PID tracks the reference
  within the bus voltage: the motor's limits show up as tracking error, paper Fig. 13).
* ``feed_forward`` (closed loop only, default True): the PID gets the velocity and acceleration feed-forward of
  the paper's EPOS2 position mode (:meth:`DriveTrain.add_controller`); False: the PID alone.
* ``driver_limit`` (replay only, default False): the replay knows the driver's duty limit
  (:meth:`DriveTrain.add_limited_follower`): the driver gets the voltage the motor needs for the prescribed motion
  (``feed_forward``, the inverse of the motor's own equations), smoothly limited to ``d_max`` times the bus
  voltage (``limiter``), the motor current is a state of the motor's electrical equation, and a torque on the motor
  shaft (``motion_support``) holds the prescribed motion: zero while the driver is within its limit (the replay
  then predicts what the plain one does), the current the driver cannot push times ``k`` while it is saturated.
  On clean virtual-bench recordings it does not bring the replay's motor current closer to the truth (see
  ``Split`` in :mod:`acausal.models.bench.calibration`), so calibration does not use it by default.
* ``motion``: ``"gait"`` (the joint follows the healthy gait at ``stride_time``, the arm the planned trajectory)
  or ``"recorded"`` (replay only: joint and arm angles are absolute-time inputs ``ankle.phi_ref`` and
  ``arm_target.signal``, e.g. smoothed bench recordings).
* ``supply``: ``"rectifier"`` (the bench: lab supply behind the non-regenerative rectifier), ``"battery"``
  (the supply straight on the driver's bus, so regenerated energy returns) or ``"ideal"`` (Eq. 4: a stiff
  48 V source and an ideal non-regenerative rectifier).
* ``gears``: ``"paper"`` (planetary 86:1 with the catalogue's 70 % and 0.7 g cm2 input inertia, helical 10:1 at
  an assumed 90 %, smooth mesh law), ``"self_locking"`` (a self-locking 10:1 worm ``worm`` in place of the
  helical stage) or ``"ideal"`` (Eq. 4: one ideal gear ``gear`` of ratio 860).
* ``driver``: ``"paper"`` (the EPOS2 model: quiescent draw, conduction, switching) or ``"ideal"`` (lossless);
  ``driver_cls`` the driver's class (default :class:`~acausal.library.drives.EPOS2`, the paper's).
* ``linkage``: ``"lossless"`` (the paper's Eq. 1-3 MACCEPA) or ``"frictional"``
  (:class:`~acausal.library.maccepa.FrictionalMaccepa`: bar and pivot friction, ``link.r_f``, ``link.tau_0``,
  ``link.d``). The planned trajectory inverts the lossless linkage either way, so with friction the joint torque
  falls short of the gait moment by the friction torque (the protocol reports it).
* ``effects``: what Eq. (4) leaves out, as swap-in parts (:mod:`acausal.models.ankle.effects`):
  ``gear_coulomb_friction`` (a BearingFriction before the gear), ``gear_load_dependent_loss`` (the ideal gear
  swapped for a LossyGear), ``winding_temperature`` (the motor's heat port on its lumped thermal capacitance),
  ``torque_sensor_offset`` (a Bias in the torque reading), ``gear_backlash`` (a Backlash between gear output and
  moment arm, whose encoder reads the arm side); ``driver_quiescent_power`` and ``precompression_error`` are
  parameters of every variant.

:meth:`AnkleActuator.eq4` is the paper's Eq. (4) bench model (ideal supply, driver and gear; the motor's lumped
R, J, b), the truth of the virtual bench and the baseline of calibration and diagnosis.

Parameters travel through the model: the planned moment-arm angle is a :class:`~acausal.ParametricSignal` of the
run's ``P_nominal``, ``link.k``, ``link.A``, ``link.B``, ``body_mass``, ``torque_tolerance`` and ``arm_limit``, so
setting any of them (e.g. ``simulate(params={"body_mass": 90})``) replans the trajectory. The spring's actual
precompression is ``link.P = P_nominal + precompression_error``.

Assumptions (not published, ``docs/parameters.md``): lever lengths A = 0.1 m and B = 0.06 m, body mass
60 kg, supply 48 V, helical-stage efficiency 0.9.
"""
from __future__ import annotations

import abc

from acausal import Eq, Model, ModelError, ParametricSignal, Parameter, Variable, connect
from acausal.model.partials import check_option
from acausal.library.blocks import Bias, Gain, SignalConstraint, SignalSource, SmoothLimiter
from acausal.library.control import PIDVariableLimit, VelocityAccelerationFeedForward
from acausal.library.drives import EPOS2, DCMotor, MotorFeedForward
from acausal.library.electrical import (ConstantVoltage, Ground, IdealNonRegenerativeRectifier,
                                        NonRegenerativeRectifier, Supply, VoltageSensor)
from acausal.library.gait import DEFAULT_BODY_MASS, AnkleAngleSource, GaitProfile, unit_cycle
from acausal.library.maccepa import FrictionalMaccepa, Maccepa
from acausal.library.rotational import (AngleSensor, Backlash, BearingFriction, Gearbox, IdealGear, LossyGear,
                                        Position, SelfLockingGear, SignalTorque, TorqueSensor)
from acausal.library.sensors import ElectricalPowerSensor, MechanicalPowerSensor
from acausal.library.thermal import DecayingTemperatureStep, FixedTemperature, HeatCapacitor, ThermalConductor

from .effects import EFFECTS, effect
from .planning import ARM_LIMIT, planned_arm_angle
from .presets import EQ4_LUMPED, N_TOTAL  # N_TOTAL: planetary 86:1 x helical 10:1


#: the constructor options and their choices
OPTIONS = {"mode": ("replay", "closed_loop"), "motion": ("gait", "recorded"),
           "supply": ("rectifier", "battery", "ideal"), "gears": ("paper", "self_locking", "ideal"),
           "driver": ("paper", "ideal"), "linkage": ("lossless", "frictional")}


class DriveTrain(Model):
    """Supply -[P_source]- (rectifier) - driver -[P_driver]- motor -[P_motor]- gears: the partial model every
    ankle drive extends (MSL style: a subclass's ``build`` calls :meth:`build_drive` and connects the returned gear
    output). Options ``supply``, ``gears``, ``driver``, ``driver_cls`` and ``saturate`` (the driver clamps its
    duty: closed loop) as in the module docstring. ``shared_points``: measurement points that are the same sensor
    as another (a drive without a series link: ``{"link": "output"}``)."""

    body_mass = Parameter(DEFAULT_BODY_MASS, unit="kg", min=1.0, doc="body mass scaling the gait torque "
                          "(assumption, library/gait)")
    stride_time = Parameter(2.0, unit="s", min=0.1, doc="stride duration (paper: 1.2-3 s)")

    shared_points: dict = {}

    def __init__(self, supply: str = "rectifier", gears: str = "paper", driver: str = "paper",
                 driver_cls=EPOS2, saturate: bool = False, **kw):
        self.options = {k: check_option(self, k, v, OPTIONS[k])
                        for k, v in (("supply", supply), ("gears", gears), ("driver", driver))}
        super().__init__(**kw)
        self.driver_cls, self.saturate = driver_cls, saturate

    def motor_options(self) -> dict:
        """Keywords of the DC motor (the Eq. 4 variant sets its lumped values)."""
        return {}

    def build_drive(self):
        """Add the drive to this model and return the gear output flange."""
        o = self.options
        if o["supply"] == "ideal":
            self.supply = ConstantVoltage(V=Supply.V.default)
        else:
            self.supply = Supply()
        self.P_source = ElectricalPowerSensor()
        if o["supply"] == "rectifier":
            self.rect = NonRegenerativeRectifier()
        elif o["supply"] == "ideal":
            self.rect = IdealNonRegenerativeRectifier()
        lossless = dict(R_on=0.0, k_sw=0.0, P_q=0.0) if o["driver"] == "ideal" else {}
        self.driver = self.driver_cls(command="voltage", saturate=self.saturate, **lossless)
        self.P_driver = ElectricalPowerSensor()
        self.motor = DCMotor(rotor="external", **self.motor_options())
        self.gnd = Ground()
        connect(self.supply.p, self.P_source.pc, self.P_source.pv)
        if o["supply"] == "battery":
            connect(self.P_source.nc, self.driver.bus_p)
            connect(self.supply.n, self.P_source.nv, self.driver.bus_n, self.gnd.p)
        else:
            connect(self.P_source.nc, self.rect.p_in)
            connect(self.supply.n, self.P_source.nv, self.rect.n_in, self.gnd.p)
            connect(self.rect.p_bus, self.driver.bus_p)
            connect(self.rect.n_bus, self.driver.bus_n)
        connect(self.driver.mot_p, self.P_driver.pc, self.P_driver.pv)
        connect(self.P_driver.nc, self.motor.p)
        connect(self.driver.mot_n, self.P_driver.nv, self.motor.n)
        # the motor point as the paper computes it (Eq. 6, Fig. 6: from the motor current and speed, k i w; there
        # is no torque sensor on the motor shaft): between the air gap and the rotor, whose inertia and friction
        # (the motor's J, b) are on the far side with the gears
        self.P_motor = MechanicalPowerSensor()
        connect(self.motor.flange, self.P_motor.flange_a)
        return self.build_gears(self.motor.add_rotor(self, self.P_motor.flange_b))

    def build_gears(self, shaft):
        """The transmission from the motor-side flange ``shaft``; returns its output flange."""
        if self.options["gears"] == "ideal":
            self.gear = IdealGear(ratio=N_TOTAL)
            connect(shaft, self.gear.flange_a)
            return self.gear.flange_b
        planetary = 86.0  # the planetary gearhead's ratio; the output stage makes up the rest of N_TOTAL
        # the drag at the planetary's output (planetary.tau_c, inferred in paper_fit) turns smoothly over 0.1 rad/s
        # (a fraction of a percent of the output's peak speed, about 25 rad/s), so the replay's derivatives stay bounded
        self.planetary = Gearbox(ratio=planetary, eta=0.7, J_a=0.7e-7, law="smooth", w_c=0.1)
        connect(shaft, self.planetary.flange_a)
        if self.options["gears"] == "paper":
            self.helical = Gearbox(ratio=N_TOTAL / planetary, eta=0.9, law="smooth")
            connect(self.planetary.flange_b, self.helical.flange_a)
            return self.helical.flange_b
        self.worm = SelfLockingGear(ratio=N_TOTAL / planetary)
        connect(self.planetary.flange_b, self.worm.flange_a)
        return self.worm.flange_b

    def add_follower(self, measured, target):
        """Inverse model: the driver command ``follow`` makes ``measured`` (a RealOutput) equal ``target`` (the
        compiler solves for the command)."""
        self.follow = SignalConstraint()
        connect(measured, self.follow.u)
        connect(target, self.follow.target)
        connect(self.follow.y, self.driver.u)

    def add_limited_follower(self, measured, target, band: float = 0.05):
        """Inverse model within the driver's duty limit: the driver is commanded with the voltage the motor needs
        for the prescribed motion (``feed_forward``, the inverse of the motor's own equations), limited to what the
        bridge can make from the present bus (``limiter``, ``d_max`` times the bus voltage, corners rounded over
        ``band`` volts); the motor current then follows the motor's electrical equation, and ``motion_support``,
        a torque on the motor shaft (after ``P_motor``), holds the prescribed motion (the compiler solves for
        it). It is zero while the driver is within its limit and takes ``k`` times the current the driver cannot
        push while it is saturated: the part of the prescribed motion the recording's smoothing could not
        resolve (in the truth, the motion itself follows the voltage-limited current). The limit is smooth rather
        than a clamp with events: the motor current is now a state, and exact parameter sensitivities
        (:meth:`CompiledModel.sensitivities <acausal.compiled_model.CompiledModel.sensitivities>`) take models with
        states or events, not both."""
        self.follow = SignalConstraint()
        self.motion_support = SignalTorque()
        self.feed_forward = MotorFeedForward(self.motor)
        self.limiter = SmoothLimiter(band=band)
        connect(measured, self.follow.u)
        connect(target, self.follow.target)
        connect(self.follow.y, self.motion_support.u, self.feed_forward.tau)
        connect(self.motion_support.flange, self.P_motor.flange_b)
        connect(self.feed_forward.v, self.limiter.u)
        connect(self.available_voltage(), self.limiter.limit)
        connect(self.limiter.y, self.driver.u)

    def available_voltage(self):
        """The largest motor voltage the bridge can make from the present bus: ``bus_voltage`` (a voltage sensor
        on the driver's bus) times ``d_max`` (``available``); returns its output."""
        self.bus_voltage = VoltageSensor()
        self.available = Gain(k=self.driver.d_max)
        bus = (self.driver.bus_p, self.driver.bus_n) if self.options["supply"] == "battery" else \
            (self.rect.p_bus, self.rect.n_bus)
        connect(bus[0], self.bus_voltage.p)
        connect(bus[1], self.bus_voltage.n)
        connect(self.bus_voltage.v_out, self.available.u)
        return self.available.y

    def add_controller(self, reference, measured, feed_forward: bool = True):
        """Closed loop: ``controller`` (PID with anti-windup, assumed gains) drives the driver so that
        ``measured`` follows ``reference``, within the largest motor voltage the bridge can make from the
        present bus (:meth:`available_voltage`). With ``feed_forward`` (the paper's EPOS2 runs its position loop
        with velocity and acceleration feed-forward, 4.2.1), ``reference_ff`` adds the voltage the unloaded motor
        needs to follow the reference through the gears: ``n (k + R b / k)`` per rad/s of the reference, plus the
        PID's ``kd`` (its derivative acts on the measurement and would brake the moving arm by ``kd`` times its
        speed), and ``n R J / k`` per rad/s2, with J the rotor's and the gearhead input's inertia, bound to the
        motor's parameters (a drive tuned on its motor; the load torque is left to the PID's integral). The
        controller's ``k_ff`` scales both (the drive's tuning: ``paper_fit`` infers it)."""
        self.controller = PIDVariableLimit(kp=400.0, ki=2000.0, kd=2.0, Td=0.002, k_aw=1.0,
                                           with_feed_forward=feed_forward)
        connect(reference, self.controller.setpoint)
        connect(measured, self.controller.measurement)
        connect(self.controller.y, self.driver.u)
        connect(self.available_voltage(), self.controller.limit)
        if feed_forward:
            m = self.motor
            J = m.J + (self.planetary.J_a if self.options["gears"] != "ideal" else 0)  # the gearhead's input
            self.reference_ff = VelocityAccelerationFeedForward(k_v=N_TOTAL * (m.k + m.R * m.b / m.k)
                                                                + self.controller.kd,
                                                                k_a=N_TOTAL * m.R * J / m.k)
            connect(reference, self.reference_ff.u)
            connect(self.reference_ff.y, self.controller.u_ff)


class SeriesLinkAnkle(DriveTrain, abc.ABC):
    """A :class:`DriveTrain` whose gear output moves a moment arm that drives the joint through a series
    elastic link: ``-[P_link]- link -[P_output]- torque_sensor - ankle``, with the moment arm following a planned
    angle (``mode``, ``motion``: module docstring). Extensions say what the link is (:meth:`make_link`) and how
    the arm angle is planned (:meth:`planned_arm`)."""

    joint_torque = Variable(unit="N.m", doc="reading of the joint torque sensor (torque on the foot)")
    tracking_error = Variable(unit="rad", doc="moment-arm reference minus actual angle")

    def __init__(self, mode: str = "replay", motion: str = "gait", driver_limit: bool = False,
                 feed_forward: bool | None = None, **kw):
        self.mode = check_option(self, "mode", mode, OPTIONS["mode"])
        self.feed_forward = check_option(self, "feed_forward", mode == "closed_loop" if feed_forward is None
                                         else feed_forward, (True, False))
        if self.feed_forward and mode != "closed_loop":
            raise ModelError(f"{type(self).__name__}: feed_forward is a closed-loop option (a replay imposes the "
                             "motion)")
        self.motion = check_option(self, "motion", motion, OPTIONS["motion"])
        self.driver_limit = check_option(self, "driver_limit", driver_limit, (True, False))
        if motion == "recorded" and mode != "replay":
            raise ModelError(f"{type(self).__name__}: motion 'recorded' needs mode 'replay' (closed loop follows "
                             "the gait)")
        if driver_limit and mode != "replay":
            raise ModelError(f"{type(self).__name__}: driver_limit is a replay option (closed loop always "
                             "limits the driver's duty)")
        super().__init__(saturate=mode == "closed_loop", **kw)

    @abc.abstractmethod
    def make_link(self):
        """The elastic element between moment arm (``flange_b``) and joint (``flange_a``)."""

    @abc.abstractmethod
    def planned_arm(self):
        """The planned moment-arm angle over the gait fraction (a Signal of period 1)."""

    def build_extras(self):
        """Parts added to the drive before the link (none here)."""

    def reading(self, tau):
        """The joint-torque reading from the sensor's output ``tau`` (a RealOutput)."""
        return tau

    def build(self):
        arm = self.build_drive()
        self.build_extras()
        self.P_link = MechanicalPowerSensor()
        self.link = self.make_link()
        self.P_output = MechanicalPowerSensor()
        self.torque_sensor = TorqueSensor()
        connect(arm, self.P_link.flange_a)
        connect(self.P_link.flange_b, self.link.flange_b)
        # the output sensor measures power from the link into the joint (link.flange_a side is the foot)
        connect(self.link.flange_a, self.P_output.flange_a)
        connect(self.P_output.flange_b, self.torque_sensor.flange_a)
        self.arm_angle = AngleSensor()
        connect(arm, self.arm_angle.flange)
        if self.motion == "recorded":
            self.ankle = Position(phi_ref=unit_cycle().angle_signal())
            self.arm_target = SignalSource(signal=self.planned_arm())
            reference = self.arm_target.y
        else:
            self.ankle = AnkleAngleSource(stride_time=self.stride_time)
            self.arm_ref = GaitProfile(stride_time=self.stride_time, profile=self.planned_arm())
            reference = self.arm_ref.y
        connect(self.torque_sensor.flange_b, self.ankle.flange)
        if self.mode == "replay" and self.driver_limit:
            self.add_limited_follower(self.arm_angle.phi, reference)
        elif self.mode == "replay":
            self.add_follower(self.arm_angle.phi, reference)
        else:
            self.add_controller(reference, self.arm_angle.phi, self.feed_forward)
        self._reference = reference
        self._reading = self.reading(self.torque_sensor.tau)

    def equations(self):
        return [Eq(self.joint_torque, self._reading.value),
                Eq(self.tracking_error, self._reference.value - self.arm_angle.phi.value)]


#: W/K: the motor's winding-housing-ambient conductance, 1 / (0.21 + 7.4 K/W) (datasheet, parameters.md)
WINDING_G = 1 / 7.61


class AnkleActuator(SeriesLinkAnkle):
    """The paper's ankle actuator: :class:`DriveTrain`, MACCEPA, joint, and the moment arm moved by ``mode``
    (see the module docstring for every option)."""

    P_nominal = Parameter(Maccepa.P.default, unit="m", min=0.0, max=0.018,
                          doc="nominal spring precompression (the paper's 0-18 mm; the trajectory is planned for it)")
    precompression_error = Parameter(0.0, unit="m", doc="actual minus nominal precompression")
    torque_tolerance = Parameter(0.0, unit="N.m", min=0.0,
                                 doc="torque error the planned trajectory may leave for a slower arm (the paper's "
                                     "fminbnd tolerance; 0: the exact inverse; see planning)")
    arm_limit = Parameter(ARM_LIMIT, unit="rad", min=1e-3,
                          doc="mechanical range of the moment arm, |phi| <= arm_limit (default: no bound)")
    winding_heating = Parameter(EFFECTS["winding_temperature"].typical, unit="K/J", min=1e-9,
                                doc="1 / the motor's lumped heat capacity (effect winding_temperature)")
    winding_excess = Parameter(0.0, unit="K", doc="the winding's temperature above ambient at winding_t0 (effect "
                                                  "winding_temperature: still warm from a session's earlier recording)")
    winding_t0 = Parameter(0.0, unit="s", doc="when the winding is winding_excess above ambient (the run's start)")
    winding_G = Parameter(WINDING_G, unit="W/K", min=1e-9,
                          doc="the lumped motor's conductance to ambient (effect winding_temperature; datasheet "
                              "1 / (0.21 + 7.4 K/W), parameters.md)")

    def __init__(self, mode: str = "replay", effects=(), linkage: str = "lossless", **kw):
        self.linkage = check_option(self, "linkage", linkage, OPTIONS["linkage"])
        self.effects = tuple(sorted({effect(e).id for e in effects}))
        if "gear_load_dependent_loss" in self.effects and kw.get("gears", "paper") != "ideal":
            raise ModelError(f"{type(self).__name__}: effect gear_load_dependent_loss swaps the ideal gear "
                             "(gears='ideal')")
        super().__init__(mode=mode, **kw)

    @classmethod
    def eq4(cls, mode: str = "replay", effects=(), **kw) -> "AnkleActuator":
        """The paper's Eq. (4) bench model: stiff 48 V supply, ideal rectifier and driver, ideal gear of ratio
        860, the motor's lumped R, J, b (:data:`~acausal.models.ankle.presets.EQ4_LUMPED`); a replay takes
        recorded angles. In closed loop (the virtual bench, :mod:`acausal.models.bench.virtual`) its controller is
        the PID alone unless ``feed_forward=True``: the virtual bench is the project's own rig, not the paper's."""
        kw.setdefault("motion", "recorded" if mode == "replay" else "gait")
        if mode == "closed_loop":
            kw.setdefault("feed_forward", False)
        return cls(mode=mode, effects=effects, supply="ideal", gears="ideal", driver="ideal", **kw)

    def has(self, name: str) -> bool:
        return name in self.effects

    def motor_options(self) -> dict:
        opts = {"use_heat_port": self.has("winding_temperature")}
        if self.options["gears"] == "ideal":
            opts.update({k.split(".", 1)[1]: v for k, v in EQ4_LUMPED.items()})
        return opts

    def build_gears(self, shaft):
        if self.has("gear_coulomb_friction"):
            self.gear_friction = BearingFriction(tau_c=0.0, w_c=5.0)
            connect(shaft, self.gear_friction.flange_a)
            shaft = self.gear_friction.flange_b
        if self.has("gear_load_dependent_loss"):
            self.gear = LossyGear(ratio=N_TOTAL, eta=1.0, law="smooth", P_s=0.5)
            connect(shaft, self.gear.flange_a)
            out = self.gear.flange_b
        else:
            out = super().build_gears(shaft)
        if self.has("gear_backlash"):
            self.backlash = Backlash(b=0.0, tau_s=3.0)
            connect(out, self.backlash.flange_a)
            out = self.backlash.flange_b
        return out

    def build_extras(self):
        if self.has("winding_temperature"):
            # the winding starts at ambient (the motor's reference temperature), so zero heating is the baseline;
            # a winding still warm from an earlier recording starts winding_excess above it (the step decays as the
            # lumped motor cools, exactly as a warmer start would: DecayingTemperatureStep)
            self.winding = HeatCapacitor(C=1 / self.winding_heating, T=DCMotor.T_ref.default)
            self.cooling = ThermalConductor(G=self.winding_G)
            self.ambient = FixedTemperature(T=self.motor.T_ref)
            self.warm_start = DecayingTemperatureStep(dT0=self.winding_excess, t0=self.winding_t0,
                                                      tau=1 / (self.winding_heating * self.winding_G))
            connect(self.motor.heat_port, self.warm_start.port_a)
            connect(self.warm_start.port_b, self.winding.port, self.cooling.port_a)
            connect(self.cooling.port_b, self.ambient.port)

    def make_link(self):
        cls = FrictionalMaccepa if self.linkage == "frictional" else Maccepa
        return cls(P=self.P_nominal + self.precompression_error)

    def planned_arm(self) -> ParametricSignal:
        """The planned moment-arm angle over the gait fraction, from this run's parameters."""
        depends = {"P": self.P_nominal, "k": self.link.k, "A": self.link.A, "B": self.link.B,
                   "body_mass": self.body_mass, "tolerance": self.torque_tolerance, "arm_limit": self.arm_limit}
        return ParametricSignal(planned_arm_angle, depends, name="planned moment-arm angle", max_order=5)

    def reading(self, tau):
        if self.has("torque_sensor_offset"):
            self.torque_offset = Bias(bias=0.0)
            connect(tau, self.torque_offset.u)
            return self.torque_offset.y
        return tau
