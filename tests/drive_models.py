"""The issue's reference drive train ("motor_gear_load") in its forward and inverse forms, shared by tests and
benchmarks, plus the hand-derived solutions they are checked against."""
import numpy as np
import sympy as sp

from acausal import Model, Start, compile_model, connect, time
from acausal.library.blocks import InverseBlockConstraint
from acausal.library.electrical import EMF, ConstantVoltage, Ground, Inductor, Resistor, SignalVoltage
from acausal.library.rotational import AngleSensor, Damper, Fixed, IdealGear, Inertia, LossyGear, Position

V, R, L, K = 24.0, 0.7, 6.53e-5, 0.0273
J_ROTOR, D_ROTOR, N, J_LOAD, D_LOAD = 5.68e-6, 1.3e-4, 860.0, 0.05, 2.0


class MotorGearLoad(Model):
    """24 V source, R, L, EMF, rotor inertia + damper, ideal gear 860, load inertia + damper."""

    def make_gear(self):
        return IdealGear(ratio=N)

    def build(self):
        self.src = ConstantVoltage(V=V)
        self.R = Resistor(R=R)
        self.L = Inductor(L=L, i=Start(0.0))
        self.emf = EMF(k=K)
        self.rotor = Inertia(J=J_ROTOR)
        self.damper = Damper(d=D_ROTOR)
        self.gear = self.make_gear()
        self.load = Inertia(J=J_LOAD)
        self.load_damper = Damper(d=D_LOAD)
        self.fixed = Fixed()
        self.gnd = Ground()
        connect(self.src.p, self.R.p)
        connect(self.R.n, self.L.p)
        connect(self.L.n, self.emf.p)
        connect(self.emf.n, self.src.n, self.gnd.p)
        connect(self.emf.flange, self.rotor.flange_a)
        connect(self.rotor.flange_b, self.damper.flange_b, self.gear.flange_a)
        connect(self.damper.flange_a, self.fixed.flange, self.load_damper.flange_a)
        connect(self.gear.flange_b, self.load.flange_a)
        connect(self.load.flange_b, self.load_damper.flange_b)


class MotorLossyGearLoad(MotorGearLoad):
    """The same drive with a lossy gear (smooth law, efficiency 0.8): its power-flow-dependent efficiency between
    two inertias makes a nonlinear algebraic loop (a Newton block)."""

    def make_gear(self):
        return LossyGear(ratio=N, eta=0.8, law="smooth")


class MotorGearLoadInverse(MotorGearLoad):
    """The same drive with the load angle prescribed: 0.3 sin(2 pi t) rad."""

    def build(self):
        super().build()
        self.pos = Position(phi_ref=0.3 * sp.sin(2 * sp.pi * time))
        connect(self.pos.flange, self.load.flange_b)


class VoltageForMotion(Model):
    """Inverse model: which source voltage makes the load follow 0.3 sin(2 pi t)? Needs phi''' (inductor)."""

    def build(self):
        self.src = SignalVoltage()
        self.R = Resistor(R=R)
        self.L = Inductor(L=L)
        self.emf = EMF(k=K)
        self.rotor = Inertia(J=J_ROTOR)
        self.gear = IdealGear(ratio=N)
        self.load = Inertia(J=J_LOAD)
        self.sensor = AngleSensor()
        self.inverse = InverseBlockConstraint(target=0.3 * sp.sin(2 * sp.pi * time))
        self.gnd = Ground()
        connect(self.src.p, self.R.p)
        connect(self.R.n, self.L.p)
        connect(self.L.n, self.emf.p)
        connect(self.emf.n, self.src.n, self.gnd.p)
        connect(self.emf.flange, self.rotor.flange_a)
        connect(self.rotor.flange_b, self.gear.flange_a)
        connect(self.gear.flange_b, self.load.flange_a)
        connect(self.load.flange_b, self.sensor.flange)
        connect(self.sensor.phi, self.inverse.u)
        connect(self.inverse.y, self.src.u)


def steady_state(R_=R):
    """Analytic steady state of MotorGearLoad: (load speed [rad/s], current [A])."""
    b_eff = D_ROTOR + D_LOAD / N**2  # viscous friction referred to the motor
    w_motor = V / (R_ * b_eff / K + K)
    return w_motor / N, b_eff * w_motor / K


def inverse_solution(t):
    """Exact current, motor voltage (EMF terminal) and supply power of MotorGearLoadInverse with i(0) = 0.

    L di/dt = V - R i - K w_m(t), w_m = N * 0.3 * 2 pi cos(2 pi t): a linear first-order ODE with a sinusoidal
    input, solved in closed form (particular solution + homogeneous decay).
    """
    t = np.asarray(t, dtype=float)
    w = 2 * np.pi
    A = K * N * 0.3 * w  # w_m = (A/K) cos(w t), back-EMF = A cos(w t)
    tau = L / R
    # particular: i_p = V/R - (A/L) * (a cos + b sin)/(...) ; solve L i' + R i = -A cos(wt)
    den = R**2 + (w * L) ** 2
    ip = V / R - A * (R * np.cos(w * t) + w * L * np.sin(w * t)) / den
    ip0 = V / R - A * R / den
    i = ip - ip0 * np.exp(-t / tau)
    v_emf = A * np.cos(w * t)
    di = (V - R * i - v_emf) / L
    v_motor = L * di + v_emf  # voltage across inductor + EMF (motor terminals)
    return i, v_motor, V * i


def compiled(model_cls):
    return compile_model(model_cls())
