"""Efficiency-optimal spring design (paper section 4.4, Figs. 16-17).

For a spring stiffness k and precompression P the moment-arm trajectory is planned so that the MACCEPA delivers the
gait torque (paper section 3, :func:`~acausal.models.ankle.planning.arm_angles`, with the preset's body mass,
lever lengths, torque tolerance and arm range), and the paper's actuator is evaluated over one stride with a
preset's parameters (default ``paper_fit``: the same chain as every other figure, gear, driver and linkage losses
included). The chain runs on a stiff 48 V supply behind an ideal non-regenerative rectifier (:func:`chain_model`):
without the lab supply's bus capacitor the replay has no states, so it is algebraic. At the Table 1 point its
source energy is within about 1 % of the protocol's (the lab supply's internal resistance; tests/test_measured_data).
The overall efficiency per stride is the joint energy over the source energy (the rectifier returns nothing, so
the source energy is the integral of the positive bus power).

All designs of a map are evaluated in one vectorised call: their planned trajectories are stacked into one
:class:`PeriodicSplineBatch` (a signal whose value is an array over designs) and their parameters into a
parameter batch, so the generated code runs over (designs x samples) arrays. A design the linkage cannot serve
(gait torque above the MACCEPA's maximum at that k, P) is infeasible (NaN); one that needs more than the driver's
0.9 duty is kept and flagged (the motor could not follow it: its energy is a lower bound) and is no candidate for
the optimum.

The original design criterion (minimum peak mechanical power of the moment arm at 1.2 s per stride; paper:
130 N/mm and 7 mm) is evaluated on the same map for comparison, and a continuous optimiser
(:func:`refine`, bounded Nelder-Mead on the model itself) refines the efficiency optimum of the grid.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import make_interp_spline
from scipy.optimize import minimize

from acausal import Signal, compile_once
from acausal.library.maccepa import max_torque
from acausal.simulation.sweep import chunks, sweep

from ..ankle.actuator import AnkleActuator
from ..ankle.planning import arm_angles, gait_samples
from ..ankle.presets import preset
from ..ankle.protocol import D_MAX, POINTS

N_STRIDE = 400  # samples per stride
COPPER = "motor.loss_power"  # the winding's R i^2 [W]: the map's copper loss per stride, E_copper_J
#: what the non-regenerative rectifier burns [W] (the motor's returned energy, which a regenerating supply would take
#: back: E_source less it is the driver's bus energy): the map's E_rectifier_J
RECTIFIER = "rect.loss_power"
K_GRID = np.linspace(40e3, 280e3, 25)  # N/m (10 N/mm steps)
P_GRID = np.linspace(0.001, 0.018, 18)  # m


class PeriodicSplineBatch(Signal):
    """B periodic quintic interpolating splines sharing sample times: ``evaluate(t, order)`` has shape
    ``(B, len(t))`` (one row per member), so a compiled model evaluates all members at once."""

    max_order = 5

    def __init__(self, t, Y, period: float, name: str = "spline batch"):
        t = np.asarray(t, dtype=float)
        Y = np.asarray(Y, dtype=float)  # (len(t), B)
        tt = np.append(t, t[0] + period)
        yy = np.vstack([Y, Y[:1]])
        self._pp = [make_interp_spline(tt, yy, k=5, bc_type="periodic", axis=0)]
        for _ in range(self.max_order):
            self._pp.append(self._pp[-1].derivative())
        self.t0, self.period, self.name = float(t[0]), float(period), name

    def evaluate(self, t, order):
        tau = self.t0 + np.mod(np.asarray(t, dtype=float) - self.t0, self.period)
        return np.moveaxis(self._pp[order](tau), -1, 0) if np.ndim(t) else self._pp[order](tau)


def chain_model():
    """The paper's actuator (frictional linkage, lossy gears, the EPOS2 driver) replayed along given joint and
    moment-arm angles (inputs ``ankle.phi_ref``, ``arm_target.signal``) on a stiff supply: compiled once per
    process."""
    return compile_once(("ankle_design_chain",), lambda: AnkleActuator(mode="replay", motion="recorded",
                                                                        supply="ideal", linkage="frictional"))


def design_params(preset_name: str = "paper_fit", overrides: dict | None = None) -> tuple[dict, dict]:
    """``(given, values)`` for a preset with ``overrides`` on top: the run-time parameters to set (keys of parts
    the stiff-supply chain lacks, the lab supply's, do not apply) and every parameter's resulting value by name
    (what the planning reads). Set only ``given``: ``values`` holds dependent parameters (``link.P``) evaluated
    for the preset's precompression."""
    sim = chain_model()
    given = {k: v for k, v in {**preset(preset_name), **(overrides or {})}.items() if sim.has_parameter(k)}
    return given, dict(zip(sim.param_names, sim.param_vector(given)))


@dataclass
class Designs:
    """Planned trajectories of a list of designs at one stride time."""

    k: np.ndarray
    P: np.ndarray
    stride_time: float
    feasible: np.ndarray
    t: np.ndarray
    theta: np.ndarray  # (N,)
    phi: np.ndarray  # (B_feasible, N)


def plan_designs(ks, Ps, stride_time: float, values: dict, n: int = N_STRIDE) -> Designs:
    """The moment-arm trajectory of every (k, P) pair (vectorised over P for each k), planned with the run's
    parameter ``values`` (body mass, lever lengths, torque tolerance, arm range)."""
    ks, Ps = np.asarray(ks, float), np.asarray(Ps, float)
    A, B = values["link.A"], values["link.B"]
    s, theta, M = gait_samples(values["body_mass"], n)
    feasible = np.zeros(len(ks), dtype=bool)
    reach = np.zeros((2, len(ks)))  # the linkage's largest torque and its angle, per design
    for k in np.unique(ks):
        sel = ks == k
        reach[:, sel] = max_torque(Ps[sel], k, A, B)
        feasible[sel] = reach[0, sel] >= np.max(np.abs(M))
    phi = []
    for k in np.unique(ks[feasible]):
        sel = feasible & (ks == k)
        phi.append((sel, arm_angles(Ps[sel], k, A, B, values["body_mass"], values["torque_tolerance"],
                                    values["arm_limit"], n, reach=reach[:, sel])[3]))
    rows = np.empty((int(feasible.sum()), n))
    index = np.cumsum(feasible) - 1
    for sel, ph in phi:
        rows[index[sel]] = ph
    return Designs(ks, Ps, stride_time, feasible, s * stride_time, theta, rows)


def evaluate_designs(ks, Ps, stride_time: float, preset_name: str = "paper_fit", overrides: dict | None = None,
                     n: int = N_STRIDE) -> dict:
    """Energy per stride at the measurement points (and what the rectifier burns, ``E_rectifier_J``), efficiency,
    peak powers and the largest duty of every
    design (arrays over designs; NaN where infeasible) with a preset's parameters and ``overrides``."""
    given, values = design_params(preset_name, overrides)
    d = plan_designs(ks, Ps, stride_time, values, n)
    B = len(d.k)
    out = {key: np.full(B, np.nan) for key in
           ["efficiency", "peak_link_W", "peak_motor_W", "max_duty", "E_copper_J", "E_rectifier_J"]
           + [f"E_{p}_J" for p in POINTS]}
    out.update(k=d.k, P=d.P, feasible=d.feasible)
    if not d.feasible.any():
        return out
    T = stride_time
    sim = chain_model()
    theta = PeriodicSplineBatch(d.t, d.theta[:, None], T, "gait angle")
    phi = PeriodicSplineBatch(d.t, d.phi.T, T, "planned moment-arm angles")
    base = {**given, "stride_time": T}
    pb = sim.param_batch([{**base, "link.k": k, "P_nominal": P} for k, P in zip(d.k[d.feasible], d.P[d.feasible])])
    points = dict(zip(POINTS, sim.accounts.sensors))  # the model's power sensors, in chain order
    vals = sim.evaluate(d.t, params=pb, names=list(points.values()) + ["driver.d", COPPER, RECTIFIER],
                        inputs={"ankle.phi_ref": theta, "arm_target.signal": phi})
    E = {p: np.mean(vals[v], axis=-1) * T for p, v in points.items()}  # periodic: the rectangle rule
    f = d.feasible
    for p in POINTS:
        out[f"E_{p}_J"][f] = E[p]
    out["efficiency"][f] = E["output"] / E["source"]
    out["peak_link_W"][f] = np.max(np.abs(vals[points["link"]]), axis=-1)
    out["peak_motor_W"][f] = np.max(np.abs(vals[points["motor"]]), axis=-1)
    out["max_duty"][f] = np.max(np.abs(vals["driver.d"]), axis=-1)
    out["E_copper_J"][f] = np.mean(vals[COPPER], axis=-1) * T
    out["E_rectifier_J"][f] = np.mean(vals[RECTIFIER], axis=-1) * T
    return out


def _map_chunk(args):
    ks, Ps, T, preset_name, overrides = args
    return evaluate_designs(ks, Ps, T, preset_name, overrides)


@dataclass
class DesignMap:
    stride_time: float
    k: np.ndarray  # grid axes
    P: np.ndarray
    values: dict  # name -> (len(k), len(P)) arrays
    preset: str = "paper_fit"  # the parameters it was evaluated with
    overrides: dict | None = None  # on top of the preset (e.g. another body mass)
    duty_limited: bool = True  # optima only among designs within the driver's duty (False: a model without one)

    def optimum(self, key: str = "efficiency", maximise: bool = True, duty_limited: bool | None = None) -> tuple:
        """The best grid design ``(k, P, value)``; if ``duty_limited`` (default: the map's) among those the motor
        can follow (required duty <= 0.9). NaNs where no design qualifies."""
        g = self.values[key]
        ok = np.isfinite(g)
        if self.duty_limited if duty_limited is None else duty_limited:
            ok &= self.values["max_duty"] <= D_MAX
        if not ok.any():
            return math.nan, math.nan, math.nan
        i = np.nanargmax(np.where(ok, g, -np.inf)) if maximise else np.nanargmin(np.where(ok, g, np.inf))
        a, b = np.unravel_index(i, g.shape)
        return float(self.k[a]), float(self.P[b]), float(g[a, b])

    def at(self, k: float, P: float, key: str = "efficiency") -> float:
        a, b = np.argmin(np.abs(self.k - k)), np.argmin(np.abs(self.P - P))
        return float(self.values[key][a, b])


def efficiency_map(stride_time: float, preset_name: str = "paper_fit", overrides: dict | None = None, ks=K_GRID,
                   Ps=P_GRID, executor=None, tasks: int | None = None, duty_limited: bool = True) -> DesignMap:
    """The (k x P) map at one stride time, in ``tasks`` chunks through ``executor`` (default: a process pool on
    all cores; ``"serial"`` for this process; any ``concurrent.futures.Executor``, e.g. a dask client's).
    ``duty_limited=False`` for a model without a driver limit (the paper's Eq. 4 drives the motor from an ideal
    voltage): its optima are taken over every feasible design."""
    import os
    K, P = np.meshgrid(np.asarray(ks, float), np.asarray(Ps, float), indexing="ij")
    pairs = list(zip(K.ravel(), P.ravel()))
    parts = chunks(pairs, tasks or (1 if executor == "serial" else (os.cpu_count() or 1)))
    jobs = [(np.array([a for a, _ in c]), np.array([b for _, b in c]), stride_time, preset_name, overrides)
            for c in parts]
    results = sweep(_map_chunk, jobs, executor=executor)
    merged = {key: np.concatenate([r[key] for r in results]) for key in results[0]}
    values = {key: v.reshape(K.shape) for key, v in merged.items() if key not in ("k", "P")}
    return DesignMap(stride_time, np.asarray(ks, float), np.asarray(Ps, float), values, preset_name, overrides,
                     duty_limited)


def refine(dmap: DesignMap, overrides: dict | None = None, key: str = "efficiency", value=None) -> tuple:
    """Continuous optimum of ``key`` (default the efficiency) among designs the motor can follow, started at the
    map's grid optimum of ``key`` (bounded Nelder-Mead in mm and N/mm), with the map's preset and overrides unless
    ``overrides`` are given. ``value`` computes ``key`` from :func:`evaluate_designs`' output where it is no column
    of it (a reading derived from the energies); default: the column ``key``."""
    overrides = dmap.overrides if overrides is None else overrides
    value = value or (lambda v: v[key])
    k0, P0, _ = dmap.optimum(key)
    if not np.isfinite(k0):
        return math.nan, math.nan, math.nan
    lo = np.array([dmap.k.min() / 1e3, dmap.P.min() * 1e3])
    hi = np.array([dmap.k.max() / 1e3, dmap.P.max() * 1e3])

    def neg(z):
        r = evaluate_designs(np.array([z[0] * 1e3]), np.array([z[1] * 1e-3]), dmap.stride_time, dmap.preset,
                             overrides)
        e = value(r)[0]
        return -e if np.isfinite(e) and (r["max_duty"][0] <= D_MAX or not dmap.duty_limited) else 1.0

    sol = minimize(neg, [k0 / 1e3, P0 * 1e3], method="Nelder-Mead", bounds=list(zip(lo, hi)),
                   options={"xatol": 0.1, "fatol": 1e-5, "maxiter": 200})
    return float(sol.x[0] * 1e3), float(sol.x[1] * 1e-3), float(-sol.fun)
