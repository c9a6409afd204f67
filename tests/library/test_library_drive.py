"""Drive-train library: defining equations at operating points, losses >= 0, energy balances, the rectifier,
the lossy gear's direction-dependent loss, and the stages composed."""
import numpy as np
import pytest
import sympy as sp

from acausal import Model, compile_model, connect, time
from acausal.library.blocks import SignalSource
from acausal.library.electrical import Ground, NonRegenerativeRectifier, Resistor, Supply
from acausal.library.drives import EPOS2, DCMotor
from acausal.library.rotational import Gearbox, Inertia, LossyGear, Position, TorqueSource


def test_supply_terminal_voltage_and_losses():
    class M(Model):
        def build(self):
            self.s = Supply(V=48.0, R_int=0.5)
            self.load = Resistor(R=11.5)
            self.g = Ground()
            connect(self.s.p, self.load.p)
            connect(self.s.n, self.load.n, self.g.p)

    res = compile_model(M()).simulate(1.0, n_points=3)
    i = 48.0 / 12.0
    assert res["s.v"][0] == pytest.approx(48.0 - 0.5 * i)
    assert res["s.power"][0] == pytest.approx((48.0 - 0.5 * i) * i)
    assert res["s.loss_power"][0] == pytest.approx(0.5 * i**2)
    assert res["s.source_power"][0] == pytest.approx(48.0 * i)


class _DriverBench(Model):
    """Supply -> rectifier -> PWM driver (duty command) -> DC motor whose shaft follows a prescribed motion."""

    def __init__(self, duty, motion, **kw):
        super().__init__(**kw)
        self._duty, self._motion = duty, motion

    def build(self):
        self.supply = Supply(V=48.0)
        self.rect = NonRegenerativeRectifier()
        self.driver = EPOS2()
        self.cmd = SignalSource(signal=self._duty)
        self.motor = DCMotor()
        self.pos = Position(phi_ref=self._motion)
        self.gnd = Ground()
        connect(self.supply.p, self.rect.p_in)
        connect(self.supply.n, self.rect.n_in, self.gnd.p)
        connect(self.rect.p_bus, self.driver.bus_p)
        connect(self.rect.n_bus, self.driver.bus_n)
        connect(self.cmd.y, self.driver.u)
        connect(self.driver.mot_p, self.motor.p)
        connect(self.driver.mot_n, self.motor.n)
        connect(self.motor.flange, self.pos.flange)


@pytest.fixture(scope="module")
def backdriven():
    """The motion drives the motor as a generator half of the time: the driver feeds power back to the bus."""
    sim = compile_model(_DriverBench(0.5, -300 * sp.sin(2 * sp.pi * time)))
    return sim.simulate(2.0, n_points=4001, rtol=1e-8, atol=1e-10)


def test_rectifier_blocks_returned_power(backdriven):
    res = backdriven
    assert res["driver.bus_power"].min() < -500.0  # the driver really returns power
    # the supply never takes power back: only the blocking diode's leakage (G_off * v) remains
    assert res["supply.power"].min() > -48.0**2 * 1e-5 * 1.01
    assert res["rect.chopper.on"].max() == 1.0
    # the returned energy shows up in the rectifier's dissipation
    returned = -np.trapezoid(np.minimum(res["driver.bus_power"], 0.0), res.t)  # energy the driver fed back
    assert res.energy("rect.loss_power")[-1] > 0.5 * returned
    assert len(res.events) < 50  # diode and chopper switch cleanly, no chattering


def test_drive_energy_balance_and_losses_nonnegative(backdriven):
    res = backdriven
    for name in ("supply.loss_power", "rect.loss_power", "driver.loss_power", "motor.loss_power",
                 "motor.copper_loss", "motor.friction_loss"):
        assert res[name].min() >= -1e-9 * max(1.0, res[name].max()), name
    e_src = res.energy("supply.source_power")[-1]
    e_loss = sum(res.energy(n)[-1] for n in ("supply.loss_power", "rect.loss_power", "driver.loss_power",
                                                "motor.loss_power"))
    e_out = res.energy("pos.flange")[-1]  # mechanical power into the motion source
    stored = sum(res[n][-1] - res[n][0] for n in ("rect.bus_energy", "motor.energy"))
    assert e_src == pytest.approx(e_loss + e_out + stored, rel=1e-6)


def test_pwm_driver_and_motor_equations_at_operating_points(backdriven):
    res = backdriven
    k = slice(100, 4000, 450)
    d, vb, im = res["driver.d"][k], res["driver.v_bus"][k], res["driver.i_m"][k]
    assert np.allclose(res["driver.v_m"][k], d * vb - 0.05 * im)
    assert np.allclose(res["driver.loss_power"][k], 12.5 + 0.05 * im**2 + 0.004 * np.abs(im) * vb)
    assert np.allclose(res["driver.bus_power"][k], res["driver.motor_power"][k] + res["driver.loss_power"][k])
    w = res["motor.w"][k]
    assert np.allclose(w, -300 * 2 * np.pi * np.cos(2 * np.pi * res.t[k]))
    assert np.allclose(res["motor.v"][k], 0.386 * im + 6.53e-5 * res.der("motor.i")[k] + 0.0274 * w, rtol=1e-6,
                       atol=1e-6)
    tau_on_shaft = res["motor.flange.tau"][k]
    # J dw/dt = k i - b w + flange.tau
    assert np.allclose(tau_on_shaft, 3.33e-6 * res.der("motor.w")[k] - 0.0274 * im + 5.66e-6 * w, rtol=1e-6,
                       atol=1e-9)


def test_motor_winding_heats_resistance():
    from acausal.library.electrical import ConstantVoltage
    from acausal.library.rotational import Fixed

    class Hot(Model):
        def build(self):
            self.src = ConstantVoltage(V=1.0)
            self.motor = DCMotor(use_heat_port=True)
            self.fix = Fixed()
            self.g = Ground()
            self.temp = _FixedT()
            connect(self.src.p, self.motor.p)
            connect(self.src.n, self.motor.n, self.g.p)
            connect(self.motor.flange, self.fix.flange)
            connect(self.motor.heat_port, self.temp.port)

    res = compile_model(Hot()).simulate(0.05, n_points=3)
    R_hot = 0.386 * (1 + 0.00393 * (373.15 - 298.15))
    assert res["motor.R_T"][-1] == pytest.approx(R_hot)
    assert res["motor.i"][-1] == pytest.approx(1.0 / R_hot, rel=1e-6)
    assert res["motor.heat_port.Q_flow"][-1] == pytest.approx(-R_hot * (1 / R_hot) ** 2, rel=1e-6)


from acausal import Component, Eq  # noqa: E402
from acausal.model.connectors import HeatPort  # noqa: E402


class _FixedT(Component):
    port = HeatPort()

    def equations(self):
        return [Eq(self.port.T, 373.15)]


# ------------------------------------------------------------------------------------------------ lossy gear
class _GearBench(Model):
    def build(self):
        self.pos = Position(phi_ref=sp.sin(2 * sp.pi * time))
        self.gear = LossyGear(ratio=10, eta=0.7)
        self.load = TorqueSource(tau=-2.0 + 3 * sp.sin(np.pi * time + 0.3))
        connect(self.pos.flange, self.gear.flange_a)
        connect(self.gear.flange_b, self.load.flange)


def test_lossy_gear_driving_and_backdriven_fractions():
    res = compile_model(_GearBench()).simulate(2.0, n_points=2001)
    p_a = res["gear.input_power"]  # into the mesh at the input (motor) side
    p_b = res.power("gear.flange_b")  # into the mesh at the output side
    loss = res["gear.loss_power"]
    assert loss.min() >= 0.0
    drv, back = p_a > 1e-9, p_a < -1e-9
    assert drv.sum() > 100 and back.sum() > 100  # both directions occur
    assert np.allclose(loss[drv], 0.3 * p_a[drv])  # driven: loses (1 - eta) of its input
    assert np.allclose(loss[back], (1 / 0.7 - 1) * (-p_a[back]))  # back-driven: (1/eta - 1) of its output
    assert np.allclose(loss, p_a + p_b)  # the balance of the mesh itself


def test_lossy_gear_switches_by_events_without_chattering():
    class Dynamic(Model):
        """Forward dynamics: a torque-driven input inertia, the gear, a spring-like sinusoidal load."""

        def build(self):
            self.drive = TorqueSource(tau=0.3 * sp.sin(2 * sp.pi * time))
            self.J_in = Inertia(J=1e-3)
            self.gear = LossyGear(ratio=10, eta=0.7)
            self.J_out = Inertia(J=0.05)
            self.load = TorqueSource(tau=1.0 * sp.sin(2 * sp.pi * 0.7 * time + 1.0))
            connect(self.drive.flange, self.J_in.flange_a)
            connect(self.J_in.flange_b, self.gear.flange_a)
            connect(self.gear.flange_b, self.J_out.flange_a)
            connect(self.J_out.flange_b, self.load.flange)

    res = compile_model(Dynamic()).simulate(3.0, n_points=3001, rtol=1e-9, atol=1e-11)
    loss = res["gear.loss_power"]
    assert loss.min() >= -1e-9
    # every sign change of input speed or input torque is one event, no more
    n_w = np.sum(np.diff(np.sign(res["gear.w_a"])) != 0)
    n_tau = np.sum(np.diff(np.sign(res["gear.flange_a.tau"])) != 0)
    assert 0 < len(res.events) <= n_w + n_tau + 2
    e_in = res.energy("drive.flange")[-1] + res.energy("load.flange")[-1]
    stored = res["J_in.energy"][-1] + res["J_out.energy"][-1]
    assert -e_in == pytest.approx(res.energy("gear.loss_power")[-1] + stored, rel=1e-6)


def test_gearbox_stages_compose():
    """Planetary 86:1 (eta 0.7, input inertia 0.7 g cm2) + helical 10:1 (eta 0.9): torque and speed ratios."""

    class Train(Model):
        def build(self):
            self.pos = Position(phi_ref=100.0 * time)  # constant input speed
            self.planetary = Gearbox(ratio=86, eta=0.7, J_a=0.7e-7)
            self.helical = Gearbox(ratio=10, eta=0.9)
            self.load = TorqueSource(tau=-5.0)  # 5 N m resisting at the output
            connect(self.pos.flange, self.planetary.flange_a)
            connect(self.planetary.flange_b, self.helical.flange_a)
            connect(self.helical.flange_b, self.load.flange)

    res = compile_model(Train()).simulate(1.0, n_points=5)
    assert np.allclose(res.der("helical.flange_b.phi"), 100.0 / 860)
    # input torque needed = 5 / (860 * 0.7 * 0.9)
    assert np.allclose(-res["pos.flange.tau"], 5.0 / (860 * 0.63))
    p_in = 100.0 * 5.0 / (860 * 0.63)
    assert np.allclose(res["planetary.loss_power"] + res["helical.loss_power"], p_in * (1 - 0.63))


# ------------------------------------------------------------------------------------------------ air gap point
class _RotorBench(Model):
    """A voltage-driven motor spinning up against a load torque, its rotor inside or on the shaft behind a power
    sensor (the motor point as a bench computes it from current and speed, paper Eq. 6)."""

    def __init__(self, rotor, **kw):
        super().__init__(**kw)
        self._rotor = rotor

    def build(self):
        from acausal.library.electrical import ConstantVoltage
        from acausal.library.sensors import MechanicalPowerSensor
        self.src = ConstantVoltage(V=24.0)
        self.gnd = Ground()
        self.motor = DCMotor(rotor=self._rotor, tau_c=2e-3, w_c=5.0)
        self.load = TorqueSource(tau=-0.05 * sp.sin(3 * time) - 0.02)
        connect(self.src.p, self.motor.p)
        connect(self.src.n, self.motor.n, self.gnd.p)
        self.P_motor = MechanicalPowerSensor()
        connect(self.motor.flange, self.P_motor.flange_a)
        shaft = self.P_motor.flange_b
        if self._rotor == "external":
            shaft = self.motor.add_rotor(self, shaft)
        connect(shaft, self.load.flange)


def test_motor_with_its_rotor_outside_moves_alike_and_reads_the_air_gap_power():
    from acausal.results.energy import balance
    runs = {r: compile_model(_RotorBench(r)) for r in ("internal", "external")}
    res = {r: sim.simulate(0.5, n_points=501, rtol=1e-10, atol=1e-12) for r, sim in runs.items()}
    inside, outside = res["internal"], res["external"]
    for name in ("motor.i", "motor.w"):
        assert np.allclose(outside[name], inside[name], rtol=1e-6, atol=1e-6 * np.max(np.abs(inside[name])))
    k = DCMotor.k.default
    air_gap = k * outside["motor.i"] * outside["motor.w"]
    assert np.allclose(outside["P_motor.P"], air_gap, rtol=1e-9, atol=1e-9 * np.max(np.abs(air_gap)))
    # the shaft reading of the internal rotor is the air-gap power less the rotor's friction and kinetic power
    assert np.max(np.abs(inside["P_motor.P"] - air_gap)) > 1e-3 * np.max(np.abs(air_gap))
    # the friction moved out of the motor's account into the rotor's, the balance closes either way
    assert np.allclose(outside["motor.loss_power"], outside["motor.copper_loss"])
    assert np.allclose(outside["rotor_friction.loss_power"], inside["motor.friction_loss"], rtol=1e-6,
                       atol=1e-9)
    for r, sim in runs.items():
        assert abs(balance(res[r], sim.accounts).residual) < 1e-7
    acc = runs["external"].accounts
    assert acc.stages["P_motor.P"] == ["motor.loss_power"]
    assert "rotor_friction.loss_power" in acc.stages[""]


def test_motor_keeping_its_rotor_refuses_add_rotor():
    from acausal import ModelError
    with pytest.raises(ModelError, match="add_rotor needs rotor='external'"):
        DCMotor().add_rotor(Model(), None)
    with pytest.raises(ModelError, match="rotor"):
        DCMotor(rotor="outside")
