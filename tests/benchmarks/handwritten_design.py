"""Hand-vectorised numpy reference for the design map: the Eq. (4) replay equations of AnkleActuator.eq4 written out by
hand (ideal driver, non-regenerative rectifier, ideal gear n, lossless MACCEPA), evaluated on the same planned
trajectories as the compiled chain with the Eq. (4) preset ``paper_datasheet`` and the virtual bench's lumped motor
values (:data:`PRESET`, :data:`OVERRIDES`: ideal gears, driver and linkage, so the same equations); planning and
spline evaluation are shared, so the ratio measures the generated code."""
import numpy as np

from acausal.library.maccepa import stiffness, torque
from acausal.models.bench import design
from acausal.models.bench.virtual import TRUTH

N_GEAR = 860.0
PRESET, OVERRIDES = "paper_datasheet", dict(TRUTH)


def evaluate_designs(ks, Ps, T):
    values = design.design_params(PRESET, OVERRIDES)[1]
    R, L, kt, J, b = (values[f"motor.{x}"] for x in "RLkJb")
    A, B = values["link.A"], values["link.B"]
    d = design.plan_designs(ks, Ps, T, values)
    theta_s = design.PeriodicSplineBatch(d.t, d.theta[:, None], T)
    phi_s = design.PeriodicSplineBatch(d.t, d.phi.T, T)
    th, th1 = theta_s.evaluate(d.t, 0), theta_s.evaluate(d.t, 1)
    ph, ph1, ph2, ph3 = (phi_s.evaluate(d.t, o) for o in range(4))
    ks_f, Ps_f = d.k[d.feasible], d.P[d.feasible]
    alpha = ph - th
    Tl = np.empty_like(alpha)
    Tl1 = np.empty_like(alpha)
    for k in np.unique(ks_f):
        sel = ks_f == k
        a, P = alpha[sel], Ps_f[sel][:, None]
        Tl[sel] = torque(a, P, k, A, B)
        Tl1[sel] = stiffness(a, P, k, A, B) * (ph1[sel] - th1)
    w, w1, w2 = N_GEAR * ph1, N_GEAR * ph2, N_GEAR * ph3
    i = (J * w1 + b * w + Tl / N_GEAR) / kt
    di = (J * w2 + b * w1 + Tl1 / N_GEAR) / kt
    v = R * i + L * di + kt * w
    P_bus = v * i
    E_source = np.mean(np.maximum(P_bus, 0.0), axis=-1) * T
    E_output = np.mean(Tl * th1, axis=-1) * T
    eff = np.full(len(d.k), np.nan)
    eff[d.feasible] = E_output / E_source
    return eff
