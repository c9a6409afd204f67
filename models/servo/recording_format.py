"""The servo-on-a-pendulum recording format (BAM's logs as CSV + JSON) and what the model takes from it.

Columns (SI units; extra columns such as ``speed_rad_s``, ``duty_frac``, ``temperature_C`` are kept and unused):
the measured position is the fitted output; the goal, the measured supply voltage and the torque enable are the
replay's inputs. JSON keys: the controller gain register ``kp`` and its ``controller.error_gain_per_rad``, the
pendulum (``mass_kg``, ``arm_length_m``, optional ``arm_mass_kg``); every other key (provenance, notes, quality
flags) is ignored with a note.
"""
from __future__ import annotations

import numpy as np

from acausal import SampledSignal
from acausal.identify.plausibility import column_range, first, key_range, line_of, sample_interval
from acausal.identify.recordings import Column, Key, RecordingFormat

#: the fewest rows a replay is fitted on (a recording is cut into 1-s segments; a servo is polled at 100 Hz or more)
MIN_ROWS = 20
#: plausibility ranges of a servo on a pendulum: a sample interval (s), a supply voltage (V), a mass (kg), an arm
#: length (m) and a position or goal (rad): a value outside is a unit slip (ms, mV, g, mm, degrees), not physics
RANGES = {"sample interval": (1e-5, 0.1), "input_voltage_V": (1.0, 60.0), "mass_kg": (0.0, 50.0),
          "arm_mass_kg": (0.0, 50.0), "arm_length_m": (0.0, 2.0), "angle": (-4 * np.pi, 4 * np.pi)}

#: the fastest the arm turns [rad/s] and its largest angular acceleration [rad/s^2]: a free pendulum from the top
#: reaches sqrt(4 g / l) (28 rad/s at l = 5 cm), a hobby servo's no-load speed is under 10 rad/s, and its stall
#: torque accelerates the lightest arm at a few hundred rad/s^2; the limits are ten times past those, so a sample
#: beyond them is a read error (the encoder's exactly -pi), never motion
MAX_SPEED, MAX_ACCEL = 60.0, 5000.0

#: the longest lead of the position over the goal that is not a swap [s]: the firmware cannot move the arm
#: before it is sent the goal, so a position that leads by more (and by more than two samples) is the goal
MAX_LEAD = 0.01
#: the lags searched for the position's delay behind the goal [s]
LAG_WINDOW = 0.25


def lag(t, goal, position, enable) -> float | None:
    """The delay [s] of ``position`` behind ``goal`` over the torque-enabled samples: the lag (within
    +-:data:`LAG_WINDOW`, on the median sample interval) of the largest cross-correlation of the two, mean
    removed; negative: the position leads. None where fewer than 50 samples have the torque on or the goal does
    not move."""
    on = enable > 0.5
    t, goal, position = t[on], goal[on], position[on]
    if t.size < 50 or np.ptp(goal) == 0:
        return None
    dt = float(np.median(np.diff(t)))
    grid = np.arange(t[0], t[-1], dt)
    g = np.interp(grid, t, goal)
    p = np.interp(grid, t, position)
    g, p = g - g.mean(), p - p.mean()
    k = min(int(round(LAG_WINDOW / dt)), g.size - 1)
    lags = np.arange(-k, k + 1)  # j: the position j samples after the goal
    c = [float(g[max(-j, 0):g.size - max(j, 0)] @ p[max(j, 0):p.size - max(-j, 0)]) for j in lags]
    return float(lags[int(np.argmax(c))] * dt)


def _plausible(columns: dict, meta: dict) -> str | None:
    """What makes a servo recording physically implausible (see :data:`RANGES`), or None."""
    t, enable = columns["time_s"], columns["torque_enable"]
    if t.size < MIN_ROWS:
        return f"only {t.size} rows; a replay is fitted on {MIN_ROWS} at least"
    off = ~np.isin(enable, (0.0, 1.0))
    found = first(
        sample_interval(t, RANGES["sample interval"], "a servo log is polled"),
        (f"line {line_of(off)}, column 'torque_enable': {enable[off][0]:g}; the torque enable is 0 (off) or 1 (on)"
         if off.any() else None),
        column_range(columns, "input_voltage_V", RANGES["input_voltage_V"], "V",
                     "a servo's supply (a dead supply, a sign slip, or mV)"),
        *(column_range(columns, n, RANGES["angle"], "rad", "more than two turns from zero: degrees or encoder "
                       "counts in a column of radians?") for n in ("position_rad", "goal_position_rad")))
    if found:
        return found
    delay = lag(t, columns["goal_position_rad"], columns["position_rad"], enable)
    if delay is not None and delay < -max(MAX_LEAD, 2 * float(np.median(np.diff(t)))):
        return (f"columns 'position_rad' and 'goal_position_rad': the position leads the goal by {-delay:.3g} s; a "
                "servo follows its goal, it cannot lead it: are the two columns swapped?")
    return first(*(key_range(meta, k, RANGES[k], "a pendulum on a servo: grams or mm where SI units are declared, "
                             "or a sign slip") for k in ("mass_kg", "arm_mass_kg", "arm_length_m")))


SERVO_FORMAT = RecordingFormat(
    name="servo on a pendulum (BAM log)",
    columns=(
        Column("time_s", "s", "time since the trajectory started (host clock)"),
        Column("position_rad", "rad", "measured output angle, 0 = arm hanging down", bounds=RANGES["angle"],
               max_rate=MAX_SPEED, max_accel=MAX_ACCEL),
        Column("goal_position_rad", "rad", "commanded position sent to the servo"),
        Column("torque_enable", "1", "torque enable sent to the servo (1 on, 0 off)"),
        Column("input_voltage_V", "V", "measured supply voltage", bounds=RANGES["input_voltage_V"]),
    ),
    keys=(
        Key("kp", "1", "firmware position gain (register value)"),
        Key("controller.error_gain_per_rad", "1/rad", "duty per rad of position error per unit of kp"),
        Key("mass_kg", "kg", "point mass at the end of the arm"),
        Key("arm_length_m", "m", "distance of the mass from the shaft"),
        Key("arm_mass_kg", "kg", "mass of the arm (null or absent: not recorded, taken as 0 as BAM does)",
            required=False, positive=False, nullable=True),
        Key("trajectory_name", "", "name of the goal trajectory (groups recordings in the report)", required=False,
            kind="text"),
        Key("duration_s", "s", "length of the log, last time minus first (optional: checks the time column's unit)",
            required=False),
    ),
    unknown_keys="note",
    # the JSON's duration_s is last time minus first; the loader's span counts one sample interval more, within 1.5
    expected_span=lambda meta: meta.get("duration_s"),
    checks=(_plausible,),
    # a lost read of the servo's registers: every reading 0 (BAM's logs mark such rows by a 0 V supply and 0 degC)
    dropout=("input_voltage_V", "temperature_C"),
    # rows missing (a host that stalled): the replay restarts after the gap from the reading there, moving
    split_at_gaps=True,
)

#: the fitted output and its column
POSITION = "position_rad"

#: samples of the supply-voltage median filter (the reading has 0.1 V steps and single-sample spikes)
VOLTAGE_MEDIAN = 5


def rig_params(meta: dict) -> dict:
    """The recording's settings as parameter values of :class:`~.model.ServoPendulum`."""
    return {"servo.kp": meta["kp"], "servo.error_gain": meta["controller.error_gain_per_rad"],
            "pendulum.m": meta["mass_kg"], "pendulum.l": meta["arm_length_m"],
            "pendulum.m_arm": meta.get("arm_mass_kg", 0.0)}


#: the columns a replay needs (its inputs)
INPUT_COLUMNS = ("goal_position_rad", "input_voltage_V", "torque_enable")


def replay_columns(rec) -> dict:
    """The recording's input columns as plain arrays (what a worker process needs to rebuild the inputs)."""
    return {c: np.asarray(rec[c], dtype=float) for c in INPUT_COLUMNS}


def inputs(rec) -> dict:
    """The replay's inputs of recording ``rec`` (see :func:`inputs_from`)."""
    return inputs_from(rec.t, replay_columns(rec), rec.name)


def inputs_from(t, columns: dict, name: str = "recording") -> dict:
    """The replay's inputs: the logged goal, the supply voltage (running median of :data:`VOLTAGE_MEDIAN`
    samples) and the torque enable, linearly interpolated between samples."""
    v = columns["input_voltage_V"]
    h = VOLTAGE_MEDIAN // 2
    padded = np.pad(v, h, mode="edge")
    v_med = np.median(np.lib.stride_tricks.sliding_window_view(padded, VOLTAGE_MEDIAN), axis=1)
    return {"goal.signal": SampledSignal(t, columns["goal_position_rad"], name=f"{name}: goal"),
            "supply.v_ref": SampledSignal(t, v_med, name=f"{name}: supply voltage"),
            "enable.signal": SampledSignal(t, columns["torque_enable"], name=f"{name}: torque enable")}


#: the readings a part after a gap takes its start speed from [s] (a line through them)
RESTART_WINDOW = 0.03


def start(rec) -> dict:
    """Initial state: the first measured position, at rest (the logs start with the arm still); a part of a log
    split at a gap (``rec.part > 1``) starts where the arm was moving, at the slope of a line through its readings
    of the first :data:`RESTART_WINDOW`."""
    t, q = rec.t, np.asarray(rec[POSITION])
    w = 0.0
    if getattr(rec, "part", 0) > 1:
        n = max(3, int(np.searchsorted(t, t[0] + RESTART_WINDOW, side="right")))
        w = float(np.polyfit(t[:n] - t[0], q[:n], 1)[0])
    return {"pendulum.phi": float(q[0]), "pendulum.w": w}


def shipped_recordings():
    """The folder of the 16 XL330 recordings that ship with the package (Rhoban/bam, Apache-2.0), in this format."""
    from importlib import resources
    from pathlib import Path
    return Path(str(resources.files("acausal.models.servo").joinpath("data/xl330/recordings")))
