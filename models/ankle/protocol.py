"""The paper's bench protocol (section 4): energy per stride at the five measurement points over precompression x
stride time, stage efficiencies and losses (Table 1 layout), peak powers, tracking error, energy balance.

One condition = one compiled model simulated over ``strides`` strides with that condition's run-time parameters;
the last stride is evaluated (what comes before lets the bus and, in closed loop, the controller settle). Sweeps run
conditions through any ``concurrent.futures.Executor`` (:func:`acausal.simulation.sweep.sweep`; default: a process pool
on all cores); each worker process compiles each model once.

Any model of the registry (:mod:`acausal.models.ankle.registry`: the paper's actuator in replay and closed
loop, the direct drive and the alternative actuators) runs through the same protocol. Its measurement points,
losses and stored energies are found from its components (:attr:`acausal.CompiledModel.accounts`: the power
sensors in build order are the points of :data:`POINTS`), so the energy balance is
checked for every model the same way and no list of them is kept by hand.
"""
from __future__ import annotations

import math
from concurrent.futures import Executor
from dataclasses import dataclass, field

import numpy as np

from acausal import ModelError, compile_once
from acausal.library.drives import EPOS2
from acausal.library.gait import unit_cycle
from acausal.results.energy import balance
from acausal.simulation.sweep import sweep as run_sweep

from .registry import spec
from .presets import preset

PRECOMPRESSIONS = [0.002, 0.005, 0.008, 0.011, 0.015, 0.018]  # m (paper section 4)
STRIDE_TIMES = [1.2, 1.3, 1.5, 2.0, 2.5, 3.0]  # s per stride (paper section 4)
#: the driver's largest duty cycle: a replay needing more means the motor cannot follow at the bus voltage
D_MAX = EPOS2.d_max.default

#: C8 (paper 4.2.3, Fig. 13): the motor cannot follow at 18 mm and 1.2 s/stride, follows there at 3 s, and the
#: paper ran every condition, so it follows in (nearly) all: read as at least 30 of the 36
FOLLOWS_AT_LEAST = 30


#: the high-precompression, short-stride corner of Figs. 11-12 (4.2.3: "both high precompression and low walking
#: duration"): precompression at least 15 mm [mm], stride time at most 1.3 s [s]
CORNER = (15.0, 1.3)


def in_corner(P_mm: float, T: float) -> bool:
    """Whether a condition lies in the corner of :data:`CORNER`."""
    return P_mm >= CORNER[0] - 1e-6 and T <= CORNER[1] + 1e-9


#: C3 (paper 4.2.1): the driver "was tuned when the precompression was set to around 8 mm" [mm], where the bowl of
#: its loss over stride time is read, and its optimum is "a walking duration of 1.5 sec/stride" [s], from which on
#: its constant draw makes "the energy loss per stride higher at slower walking velocities"
TUNED_P_MM, BOWL_FROM = 8.0, 1.5


def driver_bowl(lost: dict, fraction: dict) -> dict:
    """C3's reading of the driver's loss over the bench grid. ``lost``: {(P [mm], T [s]): energy lost in the driver
    per stride [J]}; ``fraction``: the same as a fraction of the source energy. Returns ``T_min`` (the stride time
    of the smallest fraction at :data:`TUNED_P_MM`), ``short`` (the fraction at the shortest stride less the
    smallest at the longer ones: > 0 where the bowl rises towards short strides), ``long`` (the smallest rise of
    the loss per stride [J] from one stride time to the next from :data:`BOWL_FROM` on, over every
    precompression: >= 0 where the long-stride branch holds) and ``long_by_P`` (that smallest rise per
    precompression)."""
    Ps, Ts = sorted({P for P, _ in lost}), sorted({T for _, T in lost})
    tuned = next(P for P in Ps if math.isclose(P, TUNED_P_MM))
    row = {T: fraction[(tuned, T)] for T in Ts if (tuned, T) in fraction}
    T_min = min(row, key=row.get)
    short = row[Ts[0]] - min(v for T, v in row.items() if T > Ts[0])
    long_by_P = {}
    for P in Ps:
        steps = [lost[(P, b)] - lost[(P, a)] for a, b in zip(Ts, Ts[1:])
                 if a >= BOWL_FROM - 1e-9 and (P, a) in lost and (P, b) in lost]
        long_by_P[P] = min(steps, default=math.inf)
    return dict(T_min=T_min, short=short, long=min(long_by_P.values()), long_by_P=long_by_P)


def follows_as_in_the_paper(duty: dict) -> dict:
    """C8's reading of the required duties of the 36-condition replay grid, ``{(P [mm], T [s]): duty}``: how many
    conditions the motor follows (duty <= :data:`D_MAX`), the duties at 18 mm and 1.2 / 3 s, and whether it holds."""
    fast, slow = duty[(18.0, 1.2)], duty[(18.0, 3.0)]
    follows = sum(d <= D_MAX for d in duty.values())
    return dict(follows=follows, duty_18mm_1p2s=fast, duty_18mm_3s=slow,
                holds=bool(follows >= FOLLOWS_AT_LEAST and fast > D_MAX and slow <= D_MAX))


#: the model of the paper's bench measurements (Table 1, Figs. 8-12 and 15): the actuator under its position
#: controller while the output motor imposes the gait (section 3), so that where the motor cannot follow, the arm
#: lags and the losses of the paper's short, highly precompressed strides appear (4.2.3). The replay (the paper's
#: Simulink approach: the arm exactly on its planned path) gives the duty the plan requires (C8), Fig. 7, Table 2
BENCH = "closed_loop"

#: the paper's measurement points in chain order: a drive train's power sensors, in the order it builds them
POINTS = ("source", "driver", "motor", "link", "output")
STAGES = [("driver", "source", "driver"), ("motor", "driver", "motor"), ("gearing", "motor", "link"),
          ("output", "link", "output")]  # (stage, from point, to point)

@dataclass
class Compiled:
    """A registered model, compiled, with its measurement points (label -> power-sensor reading) and the loss
    variables of each stage between them."""

    sim: object
    points: dict
    stages: dict


def compiled(name: str) -> Compiled:
    """The compiled model of registered model ``name`` (compiled once per process; shared by models with the
    same build key), with the measurement points found from its power sensors."""
    s = spec(name)
    sim = compile_once(("ankle_registry", s.key), s.build)
    if "protocol.compiled" not in sim.derived:
        model = s.build()  # its shared points (an instance, not compiled: cheap)
        acc = sim.accounts
        labels = [p for p in POINTS if p not in model.shared_points]
        if len(acc.sensors) != len(labels):
            raise ModelError(f"model {name!r}: {len(acc.sensors)} power sensors {acc.sensors}, expected one per "
                             f"measurement point {labels}")
        points = dict(zip(labels, acc.sensors))
        points.update({a: points[b] for a, b in model.shared_points.items()})
        stages = {st: (list(acc.stages.get(points[b], [])) if points[a] != points[b] else [])
                  for st, a, b in STAGES}
        sim.derived["protocol.compiled"] = Compiled(sim, points, stages)
    return sim.derived["protocol.compiled"]


@dataclass
class Condition:
    """One bench condition, in SI units: ``P`` in m (the CLI's ``--precompression`` and the paper's figures use
    mm), ``stride_time`` in s, ``overrides`` by parameter name in each parameter's SI unit."""
    P: float  # precompression [m]
    stride_time: float  # [s]
    model: str = "replay"
    preset: str = "library"
    strides: float | None = None  # simulated strides, the last one evaluated (default: the model's, ModelSpec.strides)
    points_per_stride: int = 201
    overrides: dict = field(default_factory=dict)  # run-time parameter overrides by name (e.g. {"link.k": 2e6})

    def __post_init__(self):
        if self.strides is None:
            self.strides = spec(self.model).strides


@dataclass
class StrideResult:
    condition: Condition
    energy: dict  # J per stride at each measurement point
    stage_loss: dict  # J lost between consecutive points (driver, motor, gearing, output)
    peak_power: dict  # W, max |P| over the stride at each point
    balance_residual: float  # (source - losses - output - stored change) / source
    tracking_rms: float = 0.0  # rad, moment-arm reference minus actual (closed loop)
    tracking_max: float = 0.0
    torque_error_max: float = 0.0  # N m, largest |joint torque - gait moment| (models with a joint torque sensor)
    torque_shortfall: float = 0.0  # 1 - peak |joint torque| / peak |gait moment| (the paper: about 10 %)
    max_duty: float = 0.0  # largest |d| the driver needed (replay: > d_max means the motor could not follow)
    peak_motor_speed: float = 0.0  # rad/s
    mean_motor_speed: float = 0.0  # rad/s, the mean of |w| over the stride (the paper's "average motor velocity")
    peak_motor_current: float = 0.0  # A
    rms_motor_current: float = 0.0  # A over the stride
    peak_motor_voltage: float = 0.0  # V, largest |v| at the motor terminals
    returned: float = 0.0  # J per stride flowing back into the supply at the source point (negative power)
    loss_energy: dict = field(default_factory=dict)  # J per stride of each loss power of the energy balance
    params: dict = field(default_factory=dict)  # every parameter's value in the run (defaults included)
    stages: dict = field(default_factory=dict)  # stage -> loss-power variables between its two points
    time: np.ndarray = field(default_factory=lambda: np.zeros(0))  # s, from the start of the evaluated stride
    power: dict = field(default_factory=dict)  # W over the evaluated stride at each measurement point
    traces: dict = field(default_factory=dict)  # time series of the evaluated stride (when asked for)

    @property
    def efficiency(self) -> dict:
        """Efficiency up to each point relative to the source (Table 1's middle column)."""
        return {k: self.energy[k] / self.energy["source"] for k in POINTS}

    @property
    def loss_fraction(self) -> dict:
        """Loss relative to the previous point (Table 1's last column)."""
        out = {"source": 0.0}
        for a, b in zip(POINTS, POINTS[1:]):
            out[b] = 1.0 - self.energy[b] / self.energy[a]
        return out

    def row(self) -> dict:
        c = self.condition
        r = {"model": c.model, "preset": c.preset, "P_mm": c.P * 1e3, "stride_time_s": c.stride_time}
        r.update({f"E_{k}_J": v for k, v in self.energy.items()})
        r.update({f"loss_{k}_J": v for k, v in self.stage_loss.items()})
        r.update({f"peak_{k}_W": v for k, v in self.peak_power.items()})
        r.update({f"min_{k}_W": float(np.min(p)) for k, p in self.power.items()})
        r.update(efficiency=self.efficiency["output"], balance_residual=self.balance_residual,
                 tracking_rms_rad=self.tracking_rms, tracking_max_rad=self.tracking_max,
                 torque_error_max_Nm=self.torque_error_max, torque_shortfall=self.torque_shortfall,
                 max_duty=self.max_duty,
                 peak_motor_speed=self.peak_motor_speed, peak_motor_current=self.peak_motor_current)
        return r


def run_condition(cond: Condition, traces: tuple = ()) -> StrideResult:
    """Simulate one bench condition and evaluate its last stride."""
    s = spec(cond.model)
    c = compiled(cond.model)
    sim = c.sim
    T = cond.stride_time
    # a preset is written for the paper's actuator: keys naming parts a model does not have (the linkage of a
    # direct drive) do not apply to it (every key is a parameter of the replay model: tests/test_inference)
    params = {k: v for k, v in preset(cond.preset).items() if sim.has_parameter(k)}
    params.update({**s.params, "stride_time": T})
    if s.uses_precompression:
        params["P_nominal"] = cond.P
    params.update(cond.overrides)
    values = dict(zip(sim.param_names, sim.param_vector(params)))
    inputs = s.condition_inputs(values)
    pps = max(cond.points_per_stride, s.min_points_per_stride)
    settle = round((cond.strides - 1) * (pps - 1))  # output intervals before the evaluated stride
    if cond.strides < 1 or not math.isclose(settle, (cond.strides - 1) * (pps - 1)):
        raise ModelError(f"condition {cond}: strides must be >= 1 and put the evaluated stride on the output grid "
                         f"((strides - 1) x (points_per_stride - 1) = {(cond.strides - 1) * (pps - 1):g} intervals)")
    n = settle + pps
    # the evaluated stride is [0, T] (gait phase = t / T): what settles runs before t = 0
    res = sim.simulate(T, t_start=-settle * T / (pps - 1), params=params, inputs=inputs, n_points=n, **s.tol)
    k0 = settle
    window = slice(k0, None)
    points = c.points

    def stride_energy(name):
        e = res.energy(name)
        return float(e[-1] - e[k0])

    energy = {k: stride_energy(points[k]) for k in POINTS}
    stage_loss = {st: energy[a] - energy[b] for st, a, b in STAGES}
    power = {k: np.asarray(res[points[k]][window]) for k in POINTS}
    peak = {k: float(np.max(np.abs(p))) for k, p in power.items()}
    bal = balance(res, sim.accounts, k0)
    t = res.t[window] - res.t[k0]
    i_m = np.asarray(res["motor.i"][window])
    w_m = np.abs(np.asarray(res["motor.w"][window]))
    r = StrideResult(cond, energy, stage_loss, peak, bal.residual,
                     max_duty=float(np.max(np.abs(res["driver.d"][window]))),
                     peak_motor_speed=float(np.max(w_m)),
                     mean_motor_speed=float(np.sum(np.diff(t) * (w_m[1:] + w_m[:-1]) / 2) / t[-1]),
                     peak_motor_current=float(np.max(np.abs(i_m))),
                     rms_motor_current=float(np.sqrt(np.sum(np.diff(t) * (i_m[1:]**2 + i_m[:-1]**2) / 2) / t[-1])),
                     peak_motor_voltage=float(np.max(np.abs(res["motor.v"][window]))),
                     returned=negative_energy(t, power["source"]),
                     loss_energy=dict(bal.losses), params={k: float(v) for k, v in values.items()},
                     stages=c.stages, time=t, power=power)
    if "tracking_error" in res:
        e = res["tracking_error"][window]
        r.tracking_rms, r.tracking_max = float(np.sqrt(np.mean(e**2))), float(np.max(np.abs(e)))
    if "joint_torque" in res:
        moment = values["body_mass"] * unit_cycle().torque(np.mod(res.t[window] / T, 1.0))
        tau = np.asarray(res["joint_torque"][window])
        r.torque_error_max = float(np.max(np.abs(tau - moment)))
        r.torque_shortfall = 1.0 - float(np.max(np.abs(tau)) / np.max(np.abs(moment)))
    if traces:
        r.traces = {"time": t, **{name: np.asarray(res[name][window]) for name in traces if name in res}}
    return r


def negative_energy(t, p) -> float:
    """Integral of the negative part of a sampled power, ``-int min(p, 0) dt`` [J] (trapezoids, each sign change
    located by linear interpolation)."""
    t, p = np.asarray(t, dtype=float), np.asarray(p, dtype=float)
    q = np.minimum(p, 0.0)
    dt = np.diff(t)
    a, b = p[:-1], p[1:]
    whole = 0.5 * dt * (q[:-1] + q[1:])
    cross = (a * b) < 0
    # on a crossing interval only the negative triangle counts: 0.5 * dt_neg * min(a, b)
    frac = np.where(cross, np.minimum(a, b) / np.where(cross, (np.minimum(a, b) - np.maximum(a, b)), 1.0), 0.0)
    part = 0.5 * dt * frac * np.minimum(a, b)
    return float(-np.sum(np.where(cross, part, whole)))


def _run(args):
    cond, traces = args
    return run_condition(cond, traces)


def sweep(conditions, executor: Executor | None = None, progress: bool = True, traces: tuple = ()) -> list:
    """Run conditions (in order) through ``executor`` (default: a process pool on all cores), with a progress
    bar on stderr. Any ``concurrent.futures.Executor`` works (a dask ``Client.get_executor()``, ray...)."""
    return run_sweep(_run, [(c, traces) for c in conditions], executor=executor, progress=progress,
                     label="conditions")


def as_grid(results, key) -> np.ndarray:
    """Values of ``key(result)`` on the (precompression x stride time) grid of a full protocol sweep."""
    Ps = sorted({r.condition.P for r in results})
    Ts = sorted({r.condition.stride_time for r in results})
    grid = np.full((len(Ps), len(Ts)), np.nan)
    for r in results:
        grid[Ps.index(r.condition.P), Ts.index(r.condition.stride_time)] = key(r)
    return np.array(Ps), np.array(Ts), grid
