"""The drive train shared by the ankle models: supply -[P_source]- rectifier - PWM driver -[P_driver]- DC motor
-[P_motor]- planetary 86:1 - helical 10:1, with the paper's first three measurement points.

:func:`add_drive_train` is called inside a model's ``build`` and adds the components as attributes of that model
(``supply``, ``P_source``, ``rect``, ``driver``, ``P_driver``, ``motor``, ``gnd``, ``P_motor``, ``planetary``,
``helical``), so every model names them the same way; it returns the gear output flange.

Gears: the smooth mesh law (see ``LossyGear``): no locked mode is needed under forward dynamics (closed loop),
and in inverse replays the motor current stays continuous at motion reversals, so every joule passes through
the integrated powers. Values: planetary 86:1 with the catalogue's 70 % and 0.7 g cm2 input inertia; helical
10:1 at an assumed 90 %.

Options for the alternative actuators (the defaults are the paper's drive train):

* ``supply="battery"``: the supply is connected straight to the driver's bus, without the non-regenerative
  rectifier, so energy fed back by the driver charges it (a battery with internal resistance, ``Supply``
  accepts negative current). No ``rect`` component then.
* ``output_stage="self_locking"``: the helical 10:1 stage is replaced by a self-locking 10:1 stage ``worm``
  (:class:`~acausal.library.rotational.SelfLockingGear`); the total ratio stays 860. No ``helical`` then.
* ``driver_cls``: the driver class (default :class:`~acausal.library.drives.PWMDriver`), e.g. one that can be
  switched off.

:func:`drive_train_accounts` lists the loss powers and stored energies the chosen drive train contributes to a
model's energy balance.
"""
from acausal import connect
from acausal.library.drives import DCMotor, PWMDriver
from acausal.library.electrical import Ground, NonRegenerativeRectifier, Supply
from acausal.library.rotational import Gearbox, SelfLockingGear
from acausal.library.sensors import ElectricalPowerSensor, MechanicalPowerSensor

SUPPLIES = ("rectifier", "battery")
OUTPUT_STAGES = ("helical", "self_locking")


def _check(supply: str, output_stage: str):
    if supply not in SUPPLIES:
        raise ValueError(f"add_drive_train: supply must be one of {SUPPLIES}, got {supply!r}")
    if output_stage not in OUTPUT_STAGES:
        raise ValueError(f"add_drive_train: output_stage must be one of {OUTPUT_STAGES}, got {output_stage!r}")


def add_drive_train(m, saturate: bool, supply: str = "rectifier", output_stage: str = "helical",
                    driver_cls=PWMDriver):
    """Add the drive train to model ``m`` (inside its ``build``); ``saturate``: the driver clamps its duty
    (closed loop) or not (inverse models, where the compiler solves for the command). Returns the output flange.
    ``supply``, ``output_stage``, ``driver_cls``: see the module docstring."""
    _check(supply, output_stage)
    m.supply = Supply()
    m.P_source = ElectricalPowerSensor()
    if supply == "rectifier":
        m.rect = NonRegenerativeRectifier()
    m.driver = driver_cls(command="voltage", saturate=saturate)
    m.P_driver = ElectricalPowerSensor()
    m.motor = DCMotor()
    m.gnd = Ground()
    connect(m.supply.p, m.P_source.pc, m.P_source.pv)
    if supply == "rectifier":
        connect(m.P_source.nc, m.rect.p_in)
        connect(m.supply.n, m.P_source.nv, m.rect.n_in, m.gnd.p)
        connect(m.rect.p_bus, m.driver.bus_p)
        connect(m.rect.n_bus, m.driver.bus_n)
    else:
        connect(m.P_source.nc, m.driver.bus_p)
        connect(m.supply.n, m.P_source.nv, m.driver.bus_n, m.gnd.p)
    connect(m.driver.mot_p, m.P_driver.pc, m.P_driver.pv)
    connect(m.P_driver.nc, m.motor.p)
    connect(m.driver.mot_n, m.P_driver.nv, m.motor.n)
    m.P_motor = MechanicalPowerSensor()
    m.planetary = Gearbox(ratio=86.0, eta=0.7, J_a=0.7e-7, law="smooth")
    connect(m.motor.flange, m.P_motor.flange_a)
    connect(m.P_motor.flange_b, m.planetary.flange_a)
    if output_stage == "helical":
        m.helical = Gearbox(ratio=10.0, eta=0.9, law="smooth")
        connect(m.planetary.flange_b, m.helical.flange_a)
        return m.helical.flange_b
    m.worm = SelfLockingGear(ratio=10.0)
    connect(m.planetary.flange_b, m.worm.flange_a)
    return m.worm.flange_b


def drive_train_accounts(supply: str = "rectifier", output_stage: str = "helical") -> dict:
    """The drive train's share of a model's energy balance: loss powers grouped by stage (``driver``: supply
    side up to the driver output, ``motor``, ``gearing``) and stored energies."""
    _check(supply, output_stage)
    front = ["supply.loss_power"] + (["rect.loss_power"] if supply == "rectifier" else []) + ["driver.loss_power"]
    last = "helical" if output_stage == "helical" else "worm"
    stored = (["rect.bus_energy"] if supply == "rectifier" else []) + ["motor.energy", "planetary.energy"]
    if output_stage == "helical":
        stored.append("helical.energy")
    return {"loss_groups": {"driver": front, "motor": ["motor.loss_power"],
                            "gearing": ["planetary.loss_power", f"{last}.loss_power"]},
            "stored": stored}


def add_follower(m, measured, target):
    """Inverse model: the driver command ``m.follow`` makes ``measured`` (a RealOutput) equal ``target`` (the
    compiler solves for the command)."""
    from acausal.library.blocks import SignalConstraint
    m.follow = SignalConstraint()
    connect(measured, m.follow.u)
    connect(target, m.follow.target)
    connect(m.follow.y, m.driver.u)


def add_arm_controller(m, reference, measured):
    """Closed loop: ``m.controller`` (PID with anti-windup) drives ``m.driver`` so that ``measured`` follows
    ``reference``, within the largest motor voltage the bridge can make from the present bus
    (``m.bus_voltage`` times ``d_max``, ``m.available``)."""
    from acausal.library.blocks import Gain
    from acausal.library.control import PIDVariableLimit
    from acausal.library.electrical import VoltageSensor
    m.controller = PIDVariableLimit(kp=400.0, ki=2000.0, kd=2.0, Td=0.002, k_aw=1.0)
    connect(reference, m.controller.setpoint)
    connect(measured, m.controller.measurement)
    connect(m.controller.y, m.driver.u)
    m.bus_voltage = VoltageSensor()
    m.available = Gain(k=m.driver.d_max)
    connect(m.rect.p_bus, m.bus_voltage.p)
    connect(m.rect.n_bus, m.bus_voltage.n)
    connect(m.bus_voltage.v_out, m.available.u)
    connect(m.available.y, m.controller.limit)
