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
from acausal.identify.recordings import Column, Key, RecordingFormat

SERVO_FORMAT = RecordingFormat(
    name="servo on a pendulum (BAM log)",
    columns=(
        Column("time_s", "s", "time since the trajectory started (host clock)"),
        Column("position_rad", "rad", "measured output angle, 0 = arm hanging down"),
        Column("goal_position_rad", "rad", "commanded position sent to the servo"),
        Column("torque_enable", "1", "torque enable sent to the servo (1 on, 0 off)"),
        Column("input_voltage_V", "V", "measured supply voltage"),
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
    ),
    unknown_keys="note",
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


def start(rec) -> dict:
    """Initial state: the first measured position, at rest (the logs start with the arm still)."""
    return {"pendulum.phi": float(rec[POSITION][0]), "pendulum.w": 0.0}
