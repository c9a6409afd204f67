"""Hand-written scipy references for the core benchmarks: the motor_gear_load equations reduced by hand to
two states (current, motor speed), as an engineer would write them for solve_ivp."""
import numpy as np
from scipy.integrate import solve_ivp

from ..drive_models import D_LOAD, D_ROTOR, J_LOAD, J_ROTOR, K, L, N, V

J_EFF = J_ROTOR + J_LOAD / N**2
B_EFF = D_ROTOR + D_LOAD / N**2


def simulate(R=0.7, method="LSODA", t_end=1.0, rtol=1e-6, atol=1e-9, n_points=101):
    def rhs(t, x):
        i, w = x
        return np.array([(V - R * i - K * w) / L, (K * i - B_EFF * w) / J_EFF])

    jac_m = np.array([[-R / L, -K / L], [K / J_EFF, -B_EFF / J_EFF]])

    def jac(t, x):
        return jac_m

    t_eval = np.linspace(0.0, t_end, n_points)
    return solve_ivp(rhs, (0.0, t_end), [0.0, 0.0], method=method, jac=jac, rtol=rtol, atol=atol, t_eval=t_eval)


def casadi_cvodes(R=0.7, t_end=1.0, rtol=1e-6, atol=1e-9, n_points=101):
    """The same two equations written by hand for CasADi's CVODES (its defaults otherwise: BDF, the Jacobian by
    automatic differentiation), as a CasADi user would: the integrator built once, then ``run()`` integrates from
    rest and returns the states at the outputs, shape ``(2, n_points)``."""
    import casadi as ca

    x = ca.SX.sym("x", 2)
    i, w = x[0], x[1]
    ode = ca.vertcat((V - R * i - K * w) / L, (K * i - B_EFF * w) / J_EFF)
    t = np.linspace(0.0, t_end, n_points)
    F = ca.integrator("hand_written", "cvodes", {"x": x, "ode": ode}, 0.0, t[1:], {"reltol": rtol, "abstol": atol})
    x0 = np.zeros(2)

    def run():
        return np.hstack([x0[:, None], np.asarray(F(x0=x0)["xf"])])
    return run
