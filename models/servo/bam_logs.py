"""BAM's own raw log format (Rhoban/bam ``record.py``, Apache-2.0) read directly as servo recordings.

A BAM log is one JSON file: the rig (``mass``, ``arm-mass``, ``length``), the firmware gain ``kp``, the nominal
``vin``, the ``motor`` name, the ``trajectory`` name and ``entries``, one per sample, each with ``timestamp`` [s],
``position`` [rad], ``goal_position`` [rad], ``torque_enable``, ``input_volts`` [V] (Dynamixel X series; logs
without it take ``vin``), and optionally ``speed``, ``load`` (the read-back duty) and ``temp``. What the log does
not hold is the firmware's duty per rad of error per unit of ``kp``: BAM keeps it per actuator class, and so does
:data:`ERROR_GAINS` (give ``error_gain`` for another servo).

:func:`convert` writes the servo format (CSV + JSON, :data:`~.recording_format.SERVO_FORMAT`);
:func:`load` reads a folder of either kind, converting BAM logs on the way.
"""
from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path

import numpy as np

from acausal import DataError
from acausal.identify import load_recordings
from acausal.identify.recordings import write_recording

from .recording_format import SERVO_FORMAT

#: duty per rad of position error per unit of kp, by BAM's motor name (Rhoban/bam ``dynamixel/actuator.py``,
#: ``feetech/actuator.py``: determined with an oscilloscope; XL330 from its register scaling)
ERROR_GAINS = {"xl330": (4096 / (2 * math.pi)) / (256 * 885), "mx64": 0.158, "mx106": 0.158, "xl320": 0.05048199,
               "sts3215": 0.166, "sts3250": 0.166}

_ENTRY_KEYS = ("timestamp", "position", "goal_position", "torque_enable")


def is_bam_log(path) -> bool:
    """Whether ``path`` is a BAM raw log (a JSON object with ``entries``)."""
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError):
        return False
    return isinstance(data, dict) and isinstance(data.get("entries"), list)


def _error_gain(motor: str, path: Path, error_gain):
    if error_gain is not None:
        return float(error_gain)
    key = str(motor).lower().replace("-", "").replace("_", "")
    for name, gain in ERROR_GAINS.items():
        if key.startswith(name):
            return gain
    raise DataError(f"{path}: motor {motor!r} has no known error gain (known: {', '.join(ERROR_GAINS)}); give "
                    "error_gain (duty per rad of error per unit of kp)")


def convert(src, dst, error_gain: float | None = None) -> list:
    """Every BAM log (``*.json`` with ``entries``) in folder ``src`` written to ``dst`` in the servo format;
    returns the names. Each missing key or entry field is named with its file (and entry index)."""
    src, names = Path(src), []
    logs = sorted(p for p in src.glob("*.json") if is_bam_log(p))
    if not logs:
        raise DataError(f"{src}: no BAM log (a JSON file with 'entries')")
    for path in logs:
        data = json.loads(path.read_text())
        for key in ("mass", "length", "kp"):
            if not isinstance(data.get(key), (int, float)) or isinstance(data.get(key), bool):
                raise DataError(f"{path}: key {key!r} is missing or not a number")
        entries = data["entries"]
        if len(entries) < 2:
            raise DataError(f"{path}: {len(entries)} entries; a replay needs at least 2")
        cols = {}
        for field in _ENTRY_KEYS:
            try:
                cols[field] = np.array([float(e[field]) for e in entries])
            except (KeyError, TypeError, ValueError):
                bad = next(k for k, e in enumerate(entries) if not isinstance(e.get(field), (int, float)))
                raise DataError(f"{path}: entry {bad} has no number {field!r}") from None
        vin = data.get("vin")
        volts = np.array([float(e.get("input_volts", vin if vin is not None else np.nan)) for e in entries])
        if not np.all(np.isfinite(volts)):
            raise DataError(f"{path}: no 'input_volts' in the entries and no 'vin'")
        t = cols["timestamp"] - cols["timestamp"][0]
        columns = {"time_s": t, "position_rad": cols["position"], "goal_position_rad": cols["goal_position"],
                   "torque_enable": cols["torque_enable"], "input_voltage_V": volts}
        for field, column in (("speed", "speed_rad_s"), ("load", "duty_frac"), ("temp", "temperature_C")):
            if all(isinstance(e.get(field), (int, float)) for e in entries):
                columns[column] = np.array([float(e[field]) for e in entries])
        arm = data.get("arm-mass", data.get("arm_mass"))
        meta = {"kp": data["kp"], "controller": {"error_gain_per_rad": _error_gain(data.get("motor", ""), path,
                                                                                  error_gain)},
                "mass_kg": data["mass"], "arm_length_m": data["length"], "arm_mass_kg": arm,
                "trajectory_name": str(data.get("trajectory", "")), "source": f"BAM log {path.name}",
                "motor": data.get("motor")}
        write_recording(dst, path.stem, columns, meta, SERVO_FORMAT)
        names.append(path.stem)
    return names


def load(folder, error_gain: float | None = None, strict: bool = False) -> list:
    """The recordings of ``folder``: the servo format as it is, or BAM's raw logs converted (into a temporary
    folder) when the folder holds those and no CSV; screened unless ``strict`` (:func:`~acausal.identify.
    recordings.load_recordings`)."""
    folder = Path(folder)
    if not any(folder.glob("*.csv")) and any(is_bam_log(p) for p in folder.glob("*.json")):
        tmp = Path(tempfile.mkdtemp(prefix="acausal_bam_"))
        convert(folder, tmp, error_gain)
        return load_recordings(tmp, SERVO_FORMAT, strict)
    return load_recordings(folder, SERVO_FORMAT, strict)
