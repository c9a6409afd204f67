"""Electromechanical drive components: the averaged PWM motor driver and the DC motor.

Sign conventions: a pin's current is positive *into* the component; power into a component through a pin pair
is ``v*i``. The motor's ``flange.tau`` is the torque acting on the motor at its shaft (so the torque the motor
delivers to its load is ``-flange.tau``).
"""
import sympy as sp

from acausal import Component, Eq, Model, ModelError, Parameter, RealInput, RealOutput, Variable, connect, der
from acausal.model.connectors import HeatPort, Pin
from acausal.model.partials import PartialElementaryRotationalToElectrical, check_option


class _OptionalHeatPort:
    """Mixin: ``use_heat_port=True`` adds ``heat_port`` through which the dissipated heat leaves."""

    def _init_heat_port(self, use_heat_port):
        self.use_heat_port = check_option(self, "use_heat_port", use_heat_port, (True, False))
        if use_heat_port:
            self.heat_port = HeatPort(doc="dissipated heat leaves here")


class PWMDriver(Component, _OptionalHeatPort):
    """Averaged four-quadrant H-bridge, duty-cycle or voltage command; lossless and unlimited by default
    (the maxon EPOS2 70/10 of the paper, with its losses and duty limit, is :class:`EPOS2`).

    Ports: DC bus ``bus_p``/``bus_n``, motor side ``mot_p``/``mot_n``, command input ``u``. With
    ``command="duty"`` the duty cycle is ``d = clamp(u, -d_max, d_max)``; with ``command="voltage"`` it is
    ``d = clamp(u / v_bus, -d_max, d_max)`` (``u`` in volts). ``saturate=False`` drops the clamp (for inverse
    models, where the compiler solves for the command; check ``d`` against ``d_max`` afterwards). Equations (``i_m``
    motor current, out of ``mot_p``; ``i_bus`` into ``bus_p``)::

        v_m   = d v_bus - R_on i_m                                    (averaged bridge + conduction drop)
        v_bus i_bus = d v_bus i_m + P_q + k_sw |i_m| v_bus            (power balance)
        loss_power  = P_q + R_on i_m^2 + k_sw |i_m| v_bus  >= 0

    so ``v_bus i_bus = v_m i_m + loss_power`` holds exactly. ``ideal=True`` is the lossless bridge written
    linearly (``v_m = d v_bus``, ``i_bus = d i_m``): the same for the defaults, but a resistance in series with
    its bus is then solved in closed form instead of by Newton iterations. The motor terminals are referenced to the bus
    as in a bridge with symmetric PWM (``mot_n.v = bus_n.v + (v_bus - v_m)/2``) and the four terminal currents sum to
    zero, so the motor circuit needs no ground of its own (do not ground it separately). The defaults are
    neutral: no quiescent draw, no conduction or switching loss, the full duty range (``d_max`` = 1). Set them
    for your driver, or use a subclass holding one device's values (:class:`EPOS2`). The bridge passes power
    both ways; whether the supply can take it back is decided upstream (see ``NonRegenerativeRectifier``).
    """

    P_q = Parameter(0.0, unit="W", min=0.0, doc="quiescent consumption")
    R_on = Parameter(0.0, unit="Ohm", min=0.0, doc="bridge conduction resistance")
    k_sw = Parameter(0.0, unit="1", min=0.0, doc="switching loss coefficient, P_sw = k_sw |i_m| v_bus")
    d_max = Parameter(1.0, unit="1", min=0.0, max=1.0, doc="largest duty cycle magnitude")
    bus_p = Pin(doc="DC bus +")
    bus_n = Pin(doc="DC bus -")
    mot_p = Pin(doc="motor +")
    mot_n = Pin(doc="motor -")
    u = RealInput(doc="command: duty cycle [1] or voltage [V]")
    d = Variable(unit="1", doc="duty cycle after saturation")
    v_bus = Variable(start=48.0, unit="V", doc="bus voltage")
    i_bus = Variable(unit="A", doc="current drawn from the bus")
    v_m = Variable(unit="V", doc="motor terminal voltage")
    i_m = Variable(unit="A", doc="motor current (out of mot_p)")
    loss_power = Variable(unit="W", doc="dissipated power (quiescent + conduction + switching)")
    bus_power = Variable(unit="W", doc="power drawn from the bus v_bus*i_bus")
    motor_power = Variable(unit="W", doc="power delivered to the motor v_m*i_m")

    def __init__(self, command: str = "duty", saturate: bool = True, use_heat_port: bool = False,
                 ideal: bool = False, **kw):
        super().__init__(**kw)
        self.command = check_option(self, "command", command, ("duty", "voltage"))
        self.saturate = check_option(self, "saturate", saturate, (True, False))
        self.ideal = check_option(self, "ideal", ideal, (True, False))
        if ideal and any(kw.get(k, 0.0) != 0.0 for k in ("P_q", "R_on", "k_sw")):
            raise ModelError(f"{type(self).__name__}(ideal=True) has no losses; P_q, R_on and k_sw are not used")
        self._init_heat_port(use_heat_port)

    def equations(self):
        raw = self.u.value if self.command == "duty" else self.u.value / self.v_bus
        d_eq = Eq(self.d, sp.Max(-self.d_max, sp.Min(self.d_max, raw))) if self.saturate else Eq(self.d, raw)
        eqs = [Eq(self.v_bus, self.bus_p.v - self.bus_n.v), Eq(self.i_bus, self.bus_p.i),
               Eq(0, self.bus_p.i + self.bus_n.i + self.mot_p.i + self.mot_n.i),
               Eq(self.v_m, self.mot_p.v - self.mot_n.v), Eq(self.i_m, -self.mot_p.i),
               Eq(self.mot_n.v, self.bus_n.v + (self.v_bus - self.v_m) / 2),
               d_eq,
               Eq(self.bus_power, self.v_bus * self.i_bus), Eq(self.motor_power, self.v_m * self.i_m)]
        if self.ideal:  # linear in the currents and voltages: a bus resistance is solved in closed form
            eqs += [Eq(self.v_m, self.d * self.v_bus), Eq(self.loss_power, 0), Eq(self.i_bus, self.d * self.i_m)]
        else:
            eqs += [Eq(self.v_m, self.d * self.v_bus - self.R_on * self.i_m),
                    Eq(self.loss_power, self.P_q + self.R_on * self.i_m**2
                       + self.k_sw * sp.Abs(self.i_m) * self.v_bus),
                    Eq(self.v_bus * self.i_bus, self.d * self.v_bus * self.i_m + self.P_q
                       + self.k_sw * sp.Abs(self.i_m) * self.v_bus)]
        if self.use_heat_port:
            eqs.append(Eq(self.heat_port.Q_flow, -self.loss_power))
        return eqs


class EPOS2(PWMDriver):
    """The maxon EPOS2 70/10 of the paper's bench as a :class:`PWMDriver`: its losses and its duty limit.

    ``P_q`` is the constant quiescent consumption the paper measured (10-15 W, section 4.2.1; default 12.5 W).
    ``R_on`` (0.05 ohm) and ``k_sw`` (0.004, switching loss per unit of ``|i_m| v_bus``) are assumptions of the
    order that gives the EPOS2's ~94 % peak efficiency. ``d_max`` = 0.9: the EPOS2's output voltage is at most
    about 0.9 of its supply (docs/parameters.md).
    """

    P_q = Parameter(12.5, unit="W", min=0.0, doc="quiescent consumption (paper: 10-15 W measured)",
                    device="maxon EPOS2 70/10")
    R_on = Parameter(0.05, unit="Ohm", min=0.0, doc="bridge conduction resistance (assumption)",
                     device="maxon EPOS2 70/10")
    k_sw = Parameter(0.004, unit="1", min=0.0, doc="switching loss coefficient, P_sw = k_sw |i_m| v_bus (assumption)",
                     device="maxon EPOS2 70/10")
    d_max = Parameter(0.9, unit="1", min=0.0, max=1.0, doc="largest duty cycle magnitude (EPOS2: ~0.9)",
                      device="maxon EPOS2 70/10")


class ServoDriver(Model):
    """A current-limited servo amplifier: a position -> velocity -> current cascade driving an averaged H-bridge
    from a DC bus, the motor current measured inside.

    ::

        position_ref, position, velocity --> [CascadeServo] --voltage--> [PWMDriver, voltage command] --> mot_p/mot_n
                                                ^ current (ammeter in mot_p)    ^ |v| <= d_max v_bus (bus_p/bus_n)

    ``ctrl`` is a :class:`~acausal.library.control.CascadeServo` whose voltage limit is the bridge's
    ``d_max v_bus``, read from the bus (so a sagging supply limits the command, and the current loop's
    anti-windup knows it); ``bridge`` a :class:`PWMDriver` with its losses (neutral by default); ``ammeter`` the
    current sensor in series with ``mot_p``. The current limit ``i_max`` bounds the current reference, so the
    motor current stays within it (up to the current loop's overshoot). The gains and limits have no neutral
    value and no default: tune them for your motor with :func:`~acausal.library.control.cascade_gains` and set
    the limits of your device. ``position`` and ``velocity`` are in the motor's units (rad, rad/s at its shaft);
    measure them where the loop should close (collocated at the motor, or at a load scaled by the ratio).
    Sign: a positive position error drives current out of ``mot_p`` through the motor.
    """

    kp_pos = Parameter(None, unit="1/s", min=0.0, doc="position P gain (rad/s per rad)")
    w_max = Parameter(None, unit="rad/s", min=0.0, doc="speed limit of the position loop's output")
    kp_vel = Parameter(None, unit="A.s/rad", min=1e-12, doc="velocity P gain")
    ki_vel = Parameter(None, unit="A/rad", min=0.0, doc="velocity I gain")
    i_max = Parameter(None, unit="A", min=0.0, doc="current limit")
    kp_cur = Parameter(None, unit="V/A", min=1e-12, doc="current P gain")
    ki_cur = Parameter(None, unit="V/(A.s)", min=0.0, doc="current I gain")
    # the bridge's parameters are the PWMDriver's declarations (one home for their defaults and bounds)
    P_q, R_on, k_sw, d_max = PWMDriver.P_q, PWMDriver.R_on, PWMDriver.k_sw, PWMDriver.d_max
    bus_p = Pin(doc="DC bus +")
    bus_n = Pin(doc="DC bus -")
    mot_p = Pin(doc="motor +")
    mot_n = Pin(doc="motor -")
    position_ref = RealInput(doc="commanded position [rad]")
    position = RealInput(doc="measured position [rad]")
    velocity = RealInput(doc="measured velocity [rad/s]")

    def build(self):
        from .blocks import Gain
        from .control import CascadeServo
        from .electrical import CurrentSensor, VoltageSensor
        self.bridge = PWMDriver(command="voltage", P_q=self.P_q, R_on=self.R_on, k_sw=self.k_sw, d_max=self.d_max)
        self.ctrl = CascadeServo(use_voltage_limit_input=True, kp_pos=self.kp_pos, w_max=self.w_max,
                                 kp_vel=self.kp_vel, ki_vel=self.ki_vel, i_max=self.i_max, kp_cur=self.kp_cur,
                                 ki_cur=self.ki_cur, v_max=0.0)  # v_max unused: the limit comes from the bus
        self.ammeter = CurrentSensor()
        self.bus_meter = VoltageSensor()
        self.available = Gain(k=self.d_max)
        connect(self.bus_p, self.bridge.bus_p, self.bus_meter.p)
        connect(self.bus_n, self.bridge.bus_n, self.bus_meter.n)
        connect(self.bridge.mot_p, self.ammeter.p)
        connect(self.ammeter.n, self.mot_p)
        connect(self.bridge.mot_n, self.mot_n)
        connect(self.bus_meter.v_out, self.available.u)
        connect(self.available.y, self.ctrl.v_limit)
        connect(self.position_ref, self.ctrl.position_ref)
        connect(self.position, self.ctrl.position)
        connect(self.velocity, self.ctrl.velocity)
        connect(self.ammeter.i_out, self.ctrl.current)
        connect(self.ctrl.voltage, self.bridge.u)


class DCMotor(PartialElementaryRotationalToElectrical, _OptionalHeatPort):
    """Permanent-magnet DC motor (a brushless EC motor driven as a DC machine), paper Eq. (4) per component::

        v = R(T) i + L di/dt + k w                       R(T) = R (1 + alpha_R (T - T_ref))
        J dw/dt = k i - b w - tau_c tanh(w / w_c) + flange.tau

    ``k`` is both the torque and the back-EMF constant (SI units). Coulomb (no-load) friction uses the smooth law
    ``tau_c tanh(w / w_c)``: it opposes motion, dissipates ``tau_c tanh(w/w_c) w >= 0``, and differs from the
    ideal sign law only for ``|w| <~ 3 w_c`` (w_c = 1 rad/s, against speeds of ~10^3 rad/s here).
    ``loss_power`` = copper ``R(T) i^2`` + friction. With ``use_heat_port=True`` the winding temperature is the
    port's temperature and the copper loss leaves through it (friction heat is not routed); otherwise the
    winding stays at ``T_ref``. ``energy`` = ``L i^2/2 + J w^2/2``. With ``use_support=True`` the housing
    (``support``) takes the reaction of the air-gap and friction torques, ``support.tau = tau_e - tau_f``, so
    ``flange.tau + support.tau = J dw/dt``.

    ``rotor="external"``: the component is the winding and the air gap only (MSL's ``AirGapDC``): the flange
    carries the air-gap torque, ``flange.tau = -k i``, so the power it delivers is ``k i w``, and ``tau_f``,
    ``friction_loss`` and the rotor's kinetic energy are zero here. ``J``, ``b``, ``tau_c`` and ``w_c`` stay
    this motor's parameters for the rotor the enclosing model puts on the shaft (:meth:`add_rotor`: an
    ``Inertia`` and a ``BearingFriction`` of the same law). A power sensor between the two then reads what a
    bench computes from the motor current and speed (paper Eq. 6, Fig. 6: no torque sensor on the motor shaft),
    and the rotor's friction counts in the stage after it.

    Defaults: maxon EC-4pole 30, 200 W, 48 V winding (part 305015): R = 0.386 ohm and L = 6.53e-5 H (paper,
    Table 2), k = 0.0274 N m/A (derived from the 24 V/36 V windings, docs/parameters.md), J = 3.33e-6
    kg m2 rotor inertia (datasheet; Table 2 lists it swapped with friction), b = 5.66e-6 N m s/rad (no-load
    friction 9.9 mN m / no-load speed 1749 rad/s), tau_c = 0 (all no-load friction is put in b by default),
    alpha_R = 0.00393 1/K (copper), T_ref = 298.15 K (datasheet values at 25 C). Fit ranges (``fit_range``,
    ``nominal``: what a calibration searches) span small DC motors, from a few watts to a few hundred.
    """

    R = Parameter(0.386, unit="Ohm", min=0.0, doc="terminal resistance at T_ref (paper Table 2)",
                  device="maxon EC-4pole 30, 48 V winding", fit_range=(0.01, 20.0), nominal=0.5)
    L = Parameter(6.53e-5, unit="H", min=0.0, doc="terminal inductance (paper Table 2)",
                  device="maxon EC-4pole 30, 48 V winding", fit_range=(1e-7, 1e-2), nominal=1e-4)
    k = Parameter(0.0274, unit="N.m/A", min=0.0, doc="torque = back-EMF constant (derived, parameters.md)",
                  device="maxon EC-4pole 30, 48 V winding", fit_range=(0.005, 0.2), nominal=0.03)
    J = Parameter(3.33e-6, unit="kg.m2", min=0.0, doc="rotor inertia (datasheet)",
                  device="maxon EC-4pole 30, 48 V winding", fit_range=(1e-8, 1e-1), nominal=1e-5)
    b = Parameter(5.66e-6, unit="N.m.s/rad", min=0.0, doc="viscous friction (no-load torque / no-load speed)",
                  device="maxon EC-4pole 30, 48 V winding", fit_range=(0.0, 1e-1), nominal=1e-5)
    tau_c = Parameter(0.0, unit="N.m", min=0.0, doc="Coulomb friction torque")
    w_c = Parameter(1.0, unit="rad/s", min=1e-12, doc="speed scale of the smooth Coulomb law")
    alpha_R = Parameter(0.00393, unit="1/K", doc="resistance temperature coefficient (copper)")
    T_ref = Parameter(298.15, unit="K", min=0.0, doc="reference temperature of R")
    w = Variable(unit="rad/s", doc="shaft speed relative to the housing", state_select="prefer")
    tau_e = Variable(unit="N.m", doc="electromagnetic torque k i")
    tau_f = Variable(unit="N.m", doc="friction torque (viscous + Coulomb), opposing w")
    R_T = Variable(unit="Ohm", doc="winding resistance at the winding temperature")
    copper_loss = Variable(unit="W", doc="R(T) i^2")
    friction_loss = Variable(unit="W", doc="tau_f w >= 0")
    loss_power = Variable(unit="W", doc="copper + friction loss")
    shaft_power = Variable(unit="W", doc="mechanical power delivered at the shaft, -flange.tau * w")
    energy = Variable(unit="J", doc="stored energy L i^2/2 + J w^2/2")

    def __init__(self, use_support: bool = False, use_heat_port: bool = False, rotor: str = "internal", **kw):
        self.rotor = check_option(self, "rotor", rotor, ("internal", "external"))
        super().__init__(use_support=use_support, **kw)
        self._init_heat_port(use_heat_port)

    def add_rotor(self, model: Model, shaft, name: str = "rotor"):
        """For ``rotor="external"``: add this motor's rotor to ``model`` on the flange ``shaft`` (the motor's
        flange, or a sensor behind it): ``<name>`` (Inertia ``J``) and ``<name>_friction`` (BearingFriction,
        ``tau_c tanh(w / w_c) + b w``), their parameters bound to this motor's. Returns the rotor's far flange."""
        if self.rotor != "external":
            raise ModelError(f"{self.path or type(self).__name__}: add_rotor needs rotor='external' (this motor "
                             "keeps its rotor inside)")
        from .rotational import BearingFriction, Inertia  # rotational imports nothing from here
        inertia = Inertia(J=self.J)
        friction = BearingFriction(tau_c=self.tau_c, d=self.b, w_c=self.w_c)
        setattr(model, name, inertia)
        setattr(model, f"{name}_friction", friction)
        connect(shaft, inertia.flange_a)
        connect(inertia.flange_b, friction.flange_a)
        return friction.flange_b

    def support_torque(self):
        """The housing takes the reaction of the air-gap and friction torques (the rotor's inertia makes the
        motor non-elementary: ``flange.tau + support.tau = J dw/dt``)."""
        return self.tau_e - self.tau_f

    def equations(self):
        T = self.heat_port.T if self.use_heat_port else self.T_ref
        eqs = [*super().equations(),
               Eq(self.R_T, self.R * (1 + self.alpha_R * (T - self.T_ref))),
               Eq(self.v, self.R_T * self.i + self.L * der(self.i) + self.k * self.w),
               Eq(self.tau_e, self.k * self.i),
               Eq(self.copper_loss, self.R_T * self.i**2), Eq(self.friction_loss, self.tau_f * self.w),
               Eq(self.loss_power, self.copper_loss + self.friction_loss),
               Eq(self.shaft_power, -self.flange.tau * self.w)]
        if self.rotor == "external":  # the air gap alone: the rotor is the enclosing model's (add_rotor)
            eqs += [Eq(self.tau_f, 0), Eq(self.tau_e + self.flange.tau, 0),
                    Eq(self.energy, self.L * self.i**2 / 2)]
        else:
            eqs += [Eq(self.tau_f, self.b * self.w + self.tau_c * sp.tanh(self.w / self.w_c)),
                    Eq(self.J * der(self.w), self.tau_e - self.tau_f + self.flange.tau),
                    Eq(self.energy, self.L * self.i**2 / 2 + self.J * self.w**2 / 2)]
        if self.use_heat_port:
            eqs.append(Eq(self.heat_port.Q_flow, -self.copper_loss))
        return eqs


class MotorFeedForward(Component):
    """The voltage a :class:`DCMotor` ``motor`` needs to make, at its present speed, the torque it makes plus
    ``tau``: the inverse of its own equations (its parameters, its winding resistance at the winding temperature)
    evaluated at the current ``i = motor.i + tau / motor.k``::

        v = R(T) i + L di/dt + k w

    With ``tau`` the torque something else adds to the motor's shaft to hold a prescribed motion, ``v`` is the
    command a perfect feed-forward gives the driver: where the driver delivers it, ``motor.i`` carries all of
    ``i`` and ``tau`` decays with the winding's ``L / R`` (0.1 ms here) to zero. A signal block (no port carries
    power): it reads the motor's variables."""

    tau = RealInput(doc="torque [N m] the motor would have to make in addition to k i (same sense)")
    v = RealOutput(doc="motor voltage [V] that makes it")
    i = Variable(unit="A", doc="motor current that makes the motor's and the extra torque")

    def __init__(self, motor: DCMotor, **kw):
        super().__init__(**kw)
        self._motor = motor

    def equations(self):
        m = self._motor
        return [Eq(m.k * self.i, m.k * m.i + self.tau.value),
                Eq(self.v.value, m.R_T * self.i + m.L * der(self.i) + m.k * m.w)]
