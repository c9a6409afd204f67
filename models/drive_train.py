"""The drive train shared by the ankle models: supply -[P_source]- rectifier - PWM driver -[P_driver]- DC motor
-[P_motor]- planetary 86:1 - helical 10:1, with the paper's first three measurement points.

:func:`add_drive_train` is called inside a model's ``build`` and adds the components as attributes of that model
(``supply``, ``P_source``, ``rect``, ``driver``, ``P_driver``, ``motor``, ``gnd``, ``P_motor``, ``planetary``,
``helical``), so every model names them the same way; it returns the gear output flange.

Gears: the smooth mesh law (see ``LossyGear``): no locked mode is needed under forward dynamics (closed loop),
and in inverse replays the motor current stays continuous at motion reversals, so every joule passes through
the integrated powers. Values: planetary 86:1 with the catalogue's 70 % and 0.7 g cm2 input inertia; helical
10:1 at an assumed 90 %.
"""
from acausal import connect
from acausal.library.drives import DCMotor, PWMDriver
from acausal.library.electrical import Ground, NonRegenerativeRectifier, Supply
from acausal.library.rotational import Gearbox
from acausal.library.sensors import ElectricalPowerSensor, MechanicalPowerSensor


def add_drive_train(m, saturate: bool):
    """Add the drive train to model ``m`` (inside its ``build``); ``saturate``: the driver clamps its duty
    (closed loop) or not (inverse models, where the compiler solves for the command). Returns the output flange."""
    m.supply = Supply()
    m.P_source = ElectricalPowerSensor()
    m.rect = NonRegenerativeRectifier()
    m.driver = PWMDriver(command="voltage", saturate=saturate)
    m.P_driver = ElectricalPowerSensor()
    m.motor = DCMotor()
    m.gnd = Ground()
    connect(m.supply.p, m.P_source.pc, m.P_source.pv)
    connect(m.P_source.nc, m.rect.p_in)
    connect(m.supply.n, m.P_source.nv, m.rect.n_in, m.gnd.p)
    connect(m.rect.p_bus, m.driver.bus_p)
    connect(m.rect.n_bus, m.driver.bus_n)
    connect(m.driver.mot_p, m.P_driver.pc, m.P_driver.pv)
    connect(m.P_driver.nc, m.motor.p)
    connect(m.driver.mot_n, m.P_driver.nv, m.motor.n)
    m.P_motor = MechanicalPowerSensor()
    m.planetary = Gearbox(ratio=86.0, eta=0.7, J_a=0.7e-7, law="smooth")
    m.helical = Gearbox(ratio=10.0, eta=0.9, law="smooth")
    connect(m.motor.flange, m.P_motor.flange_a)
    connect(m.P_motor.flange_b, m.planetary.flange_a)
    connect(m.planetary.flange_b, m.helical.flange_a)
    return m.helical.flange_b
