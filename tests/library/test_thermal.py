"""Thermal library: a capacitor cooling through a conductor (analytic exponential) and the maxon EC-4pole 30
two-node winding/housing network (steady state, analytic transient, energy balance)."""
import numpy as np
import pytest
from scipy.linalg import expm

from acausal import Model, compile_model, connect
from acausal import Component, Eq, Parameter
from acausal.model.connectors import HeatPort
from acausal.library.thermal import (DecayingTemperatureStep, FixedHeatFlow, FixedTemperature, HeatCapacitor, HeatFlowSensor,
                                     PrescribedHeatFlow, PrescribedTemperature, TemperatureSensor,
                                     ThermalConductor, ThermalResistor)

# maxon EC-4pole 30 (305013/305014 datasheet, docs/parameters.md)
R_WH, R_HA = 0.21, 7.4  # K/W, winding-housing and housing-ambient thermal resistances
TAU_W, TAU_M = 2.11, 1180.0  # s, winding and motor thermal time constants
C_W, C_H = TAU_W / R_WH, TAU_M / R_HA  # J/K, usual lumped reading of the datasheet (tau = R C per node)
T_AMB = 298.15  # K, 25 degC: maxon's rating ambient
P_LOSS = 10.0  # W


class Cooling(Model):
    """A body at 350 K cooling through a conductor to a 300 K ambient."""

    def build(self):
        self.body = HeatCapacitor(C=10.0, T=350.0)
        self.cond = ThermalConductor(G=2.0)
        self.amb = FixedTemperature(T=300.0)
        self.sensor = TemperatureSensor()
        connect(self.body.port, self.cond.port_a, self.sensor.port)
        connect(self.cond.port_b, self.amb.port)


class MotorThermal(Model):
    """Two-node motor thermal network heated by a constant loss in the winding."""

    def build(self):
        self.loss = PrescribedHeatFlow(Q_flow=P_LOSS)
        self.winding = HeatCapacitor(C=C_W, T=T_AMB, T_ref=T_AMB)
        self.r_wh = ThermalResistor(R=R_WH)
        self.housing = HeatCapacitor(C=C_H, T=T_AMB, T_ref=T_AMB)
        self.r_ha = ThermalResistor(R=R_HA)
        self.ambient = FixedTemperature(T=T_AMB)
        self.to_ambient = HeatFlowSensor()
        connect(self.loss.port, self.winding.port, self.r_wh.port_a)
        connect(self.r_wh.port_b, self.housing.port, self.r_ha.port_a)
        connect(self.r_ha.port_b, self.to_ambient.port_a)
        connect(self.to_ambient.port_b, self.ambient.port)


def two_node_solution(t):
    """Exact temperature rises (winding, housing) over ambient from x' = A x + b, x(0) = 0."""
    A = np.array([[-1 / (R_WH * C_W), 1 / (R_WH * C_W)],
                  [1 / (R_WH * C_H), -1 / (R_WH * C_H) - 1 / (R_HA * C_H)]])
    b = np.array([P_LOSS / C_W, 0.0])
    x_inf = -np.linalg.solve(A, b)
    return np.array([x_inf - expm(A * tk) @ x_inf for tk in np.atleast_1d(t)]).T


def test_capacitor_cools_exponentially():
    sim = compile_model(Cooling())
    assert sim.state_names == ["body.T"]
    res = sim.simulate(20.0, rtol=1e-11, atol=1e-11, n_points=201)
    exact = 300.0 + 50.0 * np.exp(-2.0 / 10.0 * res.t)
    assert np.allclose(res["body.T"], exact, rtol=1e-6, atol=0)
    assert np.allclose(res["sensor.T.value"], res["body.T"])
    # sign conventions: heat leaves the body (into its port negative), enters the conductor at port_a and the
    # ambient at its port
    q = 2.0 * (res["body.T"] - 300.0)
    assert np.allclose(res["cond.Q_flow"], q)
    assert np.allclose(res["cond.port_a.Q_flow"], q)
    assert np.allclose(res["body.port.Q_flow"], -q)
    assert np.allclose(res["amb.port.Q_flow"], q)
    # stored energy relative to T_ref = 293.15 K; what it lost went to the ambient
    assert res["body.energy"][0] == pytest.approx(10.0 * (350.0 - 293.15))
    lost = res["body.energy"][0] - res["body.energy"][-1]
    assert lost == pytest.approx(res.energy("amb.port")[-1], rel=1e-6)


def test_motor_two_node_steady_state_and_transient():
    sim = compile_model(MotorThermal())
    assert sorted(sim.state_names) == ["housing.T", "winding.T"]
    t = np.concatenate([np.linspace(0, 20, 201), np.linspace(25, 25000, 200)])
    res = sim.simulate(25000.0, rtol=1e-10, atol=1e-10, t_eval=t)
    rise = two_node_solution(res.t)
    assert np.max(np.abs(res["winding.T"] - T_AMB - rise[0])) < 1e-6 * rise[0, -1]
    assert np.max(np.abs(res["housing.T"] - T_AMB - rise[1])) < 1e-6 * rise[1, -1]
    # steady state (21 motor time constants): the whole loss crosses both resistances in series
    assert res["winding.T"][-1] - T_AMB == pytest.approx(P_LOSS * (R_WH + R_HA), rel=1e-6)
    assert res["housing.T"][-1] - T_AMB == pytest.approx(P_LOSS * R_HA, rel=1e-6)
    assert res["to_ambient.Q_flow.value"][-1] == pytest.approx(P_LOSS, rel=1e-6)
    # the winding heats with its own short time constant first: after 10 s it is ~ P*R_wh above the housing
    k = np.searchsorted(res.t, 10.0)
    assert res["winding.T"][k] - res["housing.T"][k] == pytest.approx(P_LOSS * R_WH, rel=0.1)


def test_motor_thermal_energy_balance():
    sim = compile_model(MotorThermal())
    res = sim.simulate(3000.0, rtol=1e-11, atol=1e-11, n_points=3001)
    heat_in = -res.energy("loss.port")  # power into the source's port is -Q_flow
    assert heat_in[-1] == pytest.approx(P_LOSS * 3000.0, rel=1e-9)
    stored = (res["winding.energy"] - res["winding.energy"][0]) + (res["housing.energy"] - res["housing.energy"][0])
    out = res.energy("ambient.port")
    assert out[-1] > 0.1 * heat_in[-1] and stored[-1] > 0.1 * heat_in[-1]  # both terms matter
    assert np.allclose(heat_in[1:], stored[1:] + out[1:], rtol=1e-6, atol=0)
    # the resistors and the sensor store nothing: what enters one port leaves the other
    for name in ("r_wh", "r_ha", "to_ambient"):
        assert np.allclose(res.power(f"{name}.port_a") + res.power(f"{name}.port_b"), 0, atol=1e-9)


def test_fixed_heat_flow_with_temperature_coefficient_and_prescribed_temperature():
    """FixedHeatFlow with alpha: the steady state of Q (1 + alpha (T - T_ref)) = (T - T_amb)/R, solved by hand."""
    Q, alpha, T_ref, R, T_amb = 5.0, 0.00393, 293.15, 4.0, 310.0

    class Heated(Model):
        def build(self):
            self.src = FixedHeatFlow(Q_flow=Q, alpha=alpha, T_ref=T_ref)
            self.body = HeatCapacitor(C=3.0, T=T_amb)
            self.res = ThermalResistor(R=R)
            self.amb = PrescribedTemperature(T=T_amb)
            connect(self.src.port, self.body.port, self.res.port_a)
            connect(self.res.port_b, self.amb.port)

    res = compile_model(Heated()).simulate(600.0, rtol=1e-11, atol=1e-11, n_points=11)
    # T - T_amb = R Q (1 + alpha (T - T_ref))  ->  T = (T_amb + R Q (1 - alpha T_ref)) / (1 - R Q alpha)
    T_ss = (T_amb + R * Q * (1 - alpha * T_ref)) / (1 - R * Q * alpha)
    assert res["body.T"][-1] == pytest.approx(T_ss, rel=1e-9)
    assert -res["src.port.Q_flow"][-1] == pytest.approx(Q * (1 + alpha * (T_ss - T_ref)), rel=1e-9)


class _TemperatureDependentHeater(Component):
    """Heat ``P0 (1 + a (T - 300 K))`` into its port (a resistive heater whose resistance rises with T)."""

    P0 = Parameter(10.0, unit="W")
    a = Parameter(0.004, unit="1/K")
    port = HeatPort()

    def equations(self):
        return [Eq(self.port.Q_flow, -self.P0 * (1 + self.a * (self.port.T - 300.0)))]


class HeatedBody(Model):
    """A body heated by a power that grows with its temperature (a copper winding: P = P0 (1 + a (T - 300))),
    cooled through G to 300 K; ``step``: a DecayingTemperatureStep between heater and body (body started at 300 K)."""

    def __init__(self, step: bool, T0: float = 300.0):
        self.step, self.T0 = step, T0
        super().__init__()

    def build(self):
        self.body = HeatCapacitor(C=50.0, T=self.T0)
        self.cond = ThermalConductor(G=0.5)
        self.amb = FixedTemperature(T=300.0)
        self.heater = _TemperatureDependentHeater()
        if self.step:
            self.warm = DecayingTemperatureStep(dT0=20.0, t0=3.0, tau=50.0 / 0.5)
            connect(self.heater.port, self.warm.port_a)
            connect(self.warm.port_b, self.body.port, self.cond.port_a)
        else:
            connect(self.heater.port, self.body.port, self.cond.port_a)
        connect(self.cond.port_b, self.amb.port)


def test_decaying_temperature_step_equals_a_warmer_start_with_temperature_dependent_heating():
    """Superposition: the heater behind the step sees exactly the temperature of a body started 20 K warmer, even
    though the heat it makes depends on that temperature; the step's start time t0 is honoured (run from 3 s)."""
    a = compile_model(HeatedBody(step=True)).simulate(300.0, t_start=3.0, n_points=61)
    b = compile_model(HeatedBody(step=False, T0=320.0)).simulate(300.0, t_start=3.0, n_points=61)
    assert np.allclose(a["heater.port.T"], b["heater.port.T"], atol=1e-5)
    assert a["heater.port.T"][0] == pytest.approx(320.0) and a["body.T"][0] == pytest.approx(300.0)
    assert np.allclose(a["warm.port_a.Q_flow"], -a["warm.port_b.Q_flow"])  # lossless: what enters leaves
