"""Calibration of the ankle actuator's Eq. (4) model against bench recordings (paper section 4.3, Table 2, Fig. 14).

Each recording is replayed: its measured ankle angle theta(t) and moment-arm angle phi(t) are smoothed
(:class:`~acausal.identify.smoothing.SmoothingSpline`, quintic least-squares spline, knots chosen per recording
by a bias/variance rule for the acceleration: :class:`Split`) and
prescribed to the Eq. (4) model (:meth:`~acausal.models.ankle.actuator.AnkleActuator.eq4`) in replay mode; index
reduction derives speeds, accelerations, the motor current, voltages and the supply current, and the replay is purely
algebraic (no integrator) unless an effect adds a state. The chosen parameters are fitted by bounded least squares on
motor current (and, by default, supply current, which is what makes R identifiable: the motor current does not depend
on R when the motion is prescribed) over all recordings at once, on the training strides; every third stride is held
out.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from acausal import DataError, compile_once
from acausal.identify import load_recordings
from acausal.identify.recordings import screening_summary, screening_warnings
from acausal.identify.calibrate import Calibration, Experiment, Free, calibrate, rmse_table
from acausal.identify.smoothing import SmoothingSpline, derivative_spacing, edge_margin

from ..ankle.actuator import AnkleActuator
from ..ankle.presets import MOTOR_DATASHEET, PRESETS
from ..ankle.effects import EFFECTS
from .recording_format import ANKLE_FORMAT, SIGNALS, model_params

#: short names accepted by ``--params`` and the API
SHORT = {"R": "motor.R", "J": "motor.J", "b": "motor.b", "L": "motor.L", "k": "motor.k"}

#: where a calibration starts: the motor's datasheet (Table 2 "motor parameter", inertia/friction swap corrected)
START = dict(MOTOR_DATASHEET)

DEFAULT_SIGNALS = ("motor_current_A", "supply_current_A")

#: whether the replay knows the driver's duty limit (``AnkleActuator(driver_limit=...)``), unless a call says; off:
#: on clean fast strides it does not bring the motor current closer to the noise (measured, see :class:`Split`)
DRIVER_LIMIT = False

def replay_model(effects=(), driver_limit: bool | None = None):
    """The compiled replay model with ``effects`` (cached per process); ``driver_limit``: the replay knows the
    driver's duty limit (default :data:`DRIVER_LIMIT`)."""
    limit = DRIVER_LIMIT if driver_limit is None else bool(driver_limit)
    chosen = tuple(sorted(effects))
    return compile_once(("ankle_eq4_replay", chosen, limit),
                        lambda: AnkleActuator.eq4(mode="replay", effects=chosen, driver_limit=limit))


def parameter_names(spec) -> list:
    """``"R,J,b"`` or a list -> hierarchical names (short names and effect parameters allowed)."""
    items = [s.strip() for s in spec.split(",")] if isinstance(spec, str) else list(spec)
    out = []
    for s in items:
        if not s:
            continue
        name = SHORT.get(s, s)
        if name not in START and name not in {e.parameter for e in EFFECTS.values()}:
            raise DataError(f"unknown parameter {s!r} to fit; known: {', '.join(SHORT)} (motor), or an effect "
                            f"parameter: {', '.join(e.parameter for e in EFFECTS.values())}")
        out.append(name)
    if not out:
        raise DataError("no parameters to fit")
    return out


def free_parameter(name: str, start: dict | None = None) -> Free:
    """Motor parameter or effect parameter ``name`` to fit: a motor parameter with the range and scale the motor
    declares (:class:`~acausal.library.drives.DCMotor`), started at ``start`` or the datasheet (:data:`START`); an
    effect's as its candidate record says."""
    start = start or {}
    if name in START:
        return Free.declared(replay_model(), name, {name: start.get(name, START[name])})
    return next(e for e in EFFECTS.values() if e.parameter == name).free(start)


#: the start of the knot-spacing rule: stride_time / 80 (the gait's content scales with the stride time)
KNOTS_PER_STRIDE = 80

#: the integrator tolerances of every replay (an algebraic replay ignores them; effects with states use them)
REPLAY_TOL = {"rtol": 1e-7, "atol": 1e-9}


@dataclass
class Split:
    """How a recording is used: every ``holdout_every``-th stride is held out; the smoothing knots are spaced
    ``knot_spacing`` seconds, by default (None) chosen per recording from its moment-arm angle so that the
    smoothed angle's second derivative is most accurate
    (:func:`~acausal.identify.smoothing.derivative_spacing`, starting from ``stride_time / 80``): the motor
    acceleration is ``n = 860`` times it, and the replayed motor current ``n J / k`` times that, so the knot
    spacing sets how much of the encoder's quantisation reaches the current. It depends on the encoder step, the
    sample rate and the motion (60-80 knots per stride for 14-bit encoders at 1 kHz, 80-140 for 16-bit ones). On
    clean virtual-bench recordings at 2-2.5 s per stride this brings the held-out motor-current RMSE from 1.16 to
    1.07 times the sensor noise (tests/models/bench/test_noise_floor.py). Where the driver reaches its voltage limit (fast
    strides, small precompression) the motor current drops within ~4 ms (the motor's electromechanical time
    constant J R / k^2), a step no smoothing of 14-bit angles can follow: there the held-out RMSE stays 2-3 times
    the noise (1.2-1.5 s per stride) whatever the spacing.

    A replay that knows the driver's duty limit (:data:`DRIVER_LIMIT`, ``AnkleActuator(driver_limit=True)``) does
    not change this. Inside a saturated stretch the recorded motion is the one the limited voltage made, so the
    voltage the smoothed motion needs sits on the limit to within the smoothing's error (+-0.2 V RMS) and exceeds it
    only half of the time; most of the error is at the stretches' ends (53 % of the squared error within half a knot
    spacing of an entry or exit, where the current has a corner) and in the least-squares spline's ringing around
    them (93 % within five knot spacings). Even with the true saturated stretches and the voltage-limited current
    ``(0.9 V - k w) / R`` from the smoothed speed there, the replay's error at the truth's parameters only falls
    from 0.134 to 0.130 A (P = 5 mm, T = 1.2 s). Calibrated, clean sets at T = 1.2 and 1.5 s, P = 5 and 11 mm
    (default sensors, seeds 400 and 402): held-out motor current 2.99 -> 3.04 times the noise, supply current
    2.52 -> 2.35 (2.54 -> 2.38), at 10-25 times the cost (the current becomes a state); at 2.0 and 2.5 s (seed 401)
    1.081 and 1.011 either way. An extra knot at each true entry and exit brings the error at the truth's
    parameters to 0.10 A, but the stretches' ends are not found from the data to the millisecond this needs."""

    holdout_every: int = 3  # strides n-1, 2n-1, ... are held out
    knot_spacing: float | None = None  # [s]

    def knots(self, stride_time: float, rec=None) -> float:
        """The knot spacing [s]: ``knot_spacing`` if set, else chosen from ``rec``'s moment-arm angle (else, without
        a recording, the rule's start ``stride_time / 80``)."""
        if self.knot_spacing:
            return self.knot_spacing
        guess = stride_time / KNOTS_PER_STRIDE
        if rec is None:
            return guess
        return derivative_spacing(rec.t, rec["moment_arm_angle_rad"], guess, order=2,
                                  name=f"{rec.name}: moment-arm angle")


def replay_inputs(rec, split: Split = Split()) -> dict:
    """The replay's prescribed motions: the recording's ankle and moment-arm angles, smoothed (quintic
    least-squares splines, knots ``split.knots(stride time, rec)`` apart, the same for both angles). Smoothing a
    long recording is the costly part of building an experiment: a diagnosis builds them once per recording and
    shares them between candidates."""
    h = split.knots(rec.meta["stride_time_s"], rec)
    return {"ankle.phi_ref": SmoothingSpline(rec.t, rec["ankle_angle_rad"], h, name=f"{rec.name}: ankle angle"),
            "arm_target.signal": SmoothingSpline(rec.t, rec["moment_arm_angle_rad"], h,
                                                 name=f"{rec.name}: moment-arm angle")}


def experiment(rec, effects=(), split: Split = Split(), fixed: dict | None = None,
               inputs: dict | None = None) -> Experiment:
    """A recording as a replay :class:`Experiment` of the model with ``effects`` (``inputs``: the recording's
    :func:`replay_inputs`, made here when not given)."""
    sim = replay_model(effects)
    t = rec.t
    T = rec.meta["stride_time_s"]
    inputs = replay_inputs(rec, split) if inputs is None else inputs
    # the edge margin of the spacing the inputs were smoothed with
    h = max(getattr(u, "knot_spacing", 0.0) for u in inputs.values()) or split.knots(T)
    base = {**model_params(rec.meta), **(fixed or {})}
    stride = np.floor((t - t[0]) / T + 1e-9).astype(int)
    m = edge_margin(h)
    inner = (t >= t[0] + m) & (t <= t[-1] - m) & ~rec.masked_rows(SIGNALS)  # a masked reading is left out
    held = (stride % split.holdout_every) == split.holdout_every - 1
    if not (inner & held).any() or not (inner & ~held).any():
        raise DataError(f"{rec.path or rec.name}: {stride.max() + 1} stride(s) of {T} s are too few to hold out one "
                        f"stride in every {split.holdout_every} and fit on the rest")
    measured = {s: rec[s] for s in SIGNALS}
    wanted = dict(SIGNALS)

    def predict(values: dict) -> dict:
        res = sim.simulate(t[-1], t_start=t[0], t_eval=t, params={**base, **values}, inputs=inputs,
                           dense_output=False, **REPLAY_TOL)
        return {col: np.asarray(res[var]) for col, var in wanted.items()}

    return Experiment(rec.name, t, measured, predict, inner & ~held, inner & held, stride,
                      info={"meta": rec.meta, "inputs": inputs, "params": base, "effects": tuple(effects)},
                      period=T)


def exact_sensitivity(cm, exp):
    """``sensitivity(values, names)`` of the replay :class:`Experiment` ``exp`` on the compiled replay model ``cm``:
    the predicted signals and their exact derivatives (:meth:`CompiledModel.sensitivities`), the Jacobian a fit
    uses in place of finite differences."""
    cols = {col: SIGNALS[col] for col in exp.measured if col in SIGNALS}
    base, inputs, t = exp.info["params"], exp.info["inputs"], exp.t

    def sens(values, names):
        vals, S = cm.sensitivities(t, list(names), names=list(cols.values()), params={**base, **values},
                                   inputs=inputs, t_start=t[0])
        return ({c: np.asarray(vals[v]) for c, v in cols.items()}, {c: np.asarray(S[v]) for c, v in cols.items()})
    return sens


def experiments(recordings, effects=(), split: Split = Split(), fixed: dict | None = None,
                exact: bool = False) -> list:
    """:func:`experiment` of each recording; ``exact``: with :func:`exact_sensitivity` (exact Jacobians)."""
    exps = [experiment(r, effects, split, fixed) for r in recordings]
    if exact:
        cm = replay_model(effects)
        for e in exps:
            e.sensitivity = exact_sensitivity(cm, e)
    return exps


def fit(recordings, params="R,J,b", signals=DEFAULT_SIGNALS, weights=None, effects=(), start=None,
        split: Split = Split(), fixed: dict | None = None, loss: str = "soft_l1", exact: bool = True,
        strict: bool = False) -> tuple:
    """Calibrate ``params`` on ``recordings`` (list of Recording, or a folder, screened unless ``strict``:
    :func:`~acausal.identify.recordings.load_recordings`); returns ``(Calibration, experiments)``; what the
    screening masked or left out leads ``Calibration.warnings``. ``exact``: the fit's Jacobian from the replay's
    exact sensitivities (False: finite differences)."""
    if not isinstance(recordings, (list, tuple)):
        recordings = load_recordings(recordings, ANKLE_FORMAT, strict)
    exps = experiments(recordings, effects, split, fixed, exact)
    free = [free_parameter(n, start) for n in parameter_names(params)]
    cal = calibrate(exps, free, list(signals), weights=weights, fixed=fixed, loss=loss)
    cal.warnings = screening_warnings(screening_summary(recordings)) + cal.warnings
    unseen = [n for n in cal.names if not np.isfinite(cal.std[n])]
    if unseen and not cal.warnings:  # (where the screening flags the data, its warnings say why)
        raise DataError(f"calibration on {', '.join(signals)}: {', '.join(unseen)} cannot be identified (the fitted "
                        "signals do not depend on them, or not independently of the others: the standard error is "
                        "infinite); fit them on a signal that sees them (motor_current_A, supply_current_A)")
    return cal, exps


def table2(cal: Calibration) -> list:
    """Rows of the paper's Table 2 with our calibration: (parameter, unit, datasheet, estimated total, calibrated,
    standard error)."""
    est = PRESETS["paper_estimated_total"]
    rows = []
    for name, label, unit in (("motor.J", "actuator inertia (motor side)", "kg m2"),
                              ("motor.b", "actuator friction (motor side)", "N m s/rad"),
                              ("motor.R", "actuator resistance", "ohm"), ("motor.L", "actuator inductance", "H")):
        rows.append((label, unit, START[name], est[name], cal.values.get(name, np.nan), cal.std.get(name, np.nan)))
    return rows


def rmse_before_after(exps, cal: Calibration, signals=DEFAULT_SIGNALS) -> dict:
    """Held-out RMSE per signal with the datasheet start values and with the calibrated values."""
    out = {}
    for label, values in (("datasheet", {n: START[n] for n in cal.names if n in START}), ("calibrated", cal.values)):
        table = rmse_table(exps, values, signals)
        out[label] = {s: float(np.sqrt(np.mean([v**2 for (e, sig), v in table.items() if sig == s])))
                      for s in signals}
    return out
