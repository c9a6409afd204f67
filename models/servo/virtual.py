"""A virtual servo bench: recordings of a simulated servo on a pendulum, in the servo format, with effects hidden
in the truth (for hidden-effect tests of the diagnosis, and to try a diagnosis before a rig exists).

The default servo is unlike the XL330 on purpose: a stronger motor behind a 12 V supply, its own firmware error
gain, a heavier pendulum on a longer arm (:data:`OTHER`). Each recording follows one goal trajectory at one
firmware gain (BAM's protocol: several gains, several trajectories, one of them dropping the torque), sampled
at about 200 Hz with the host's jitter; the position is quantised to the encoder's step and the supply voltage
to 0.1 V with noise, as a real log is. The JSON carries the keys a real log has (and unknown ones, which the
loader notes and ignores).
"""
from __future__ import annotations

import math

import numpy as np

from acausal import DataError
from acausal.identify.recordings import write_recording

from . import effects as fx
from .model import READING, compiled
from .problem import _starts, model_key
from .recording_format import SERVO_FORMAT, inputs_from

#: the simulated servo's output-side parameters (a 12 V servo with a stronger motor than the XL330)
OTHER = {"servo.kt": 0.9, "servo.R": 6.0, "servo.armature": 0.004, "pendulum.phi0": 0.01, "servo.tau_c": 0.02,
         "servo.d": 0.01}
#: its firmware's duty per rad of error per unit of kp, supply [V], encoder step [rad], and the rig
OTHER_GAIN, OTHER_SUPPLY, STEP = 0.004, 12.0, 2 * math.pi / 4096
RIG = {"mass_kg": 0.6, "arm_length_m": 0.12}
GAINS = (150, 300, 600, 1200)
TRAJECTORIES = ("sin_sin", "up_and_down", "lift_and_drop")


def goal(name: str, t):
    """Goal [rad] and torque enable of trajectory ``name`` at times ``t`` (BAM's shapes, rescaled to 3 s)."""
    if name == "sin_sin":
        return np.sin(t) * np.pi / 2 + 0.5 * np.sin(5 * t) * np.sin(2 * t), np.ones_like(t)
    if name == "up_and_down":
        s = np.clip(t / 1.5, 0, 1)
        return np.where(t < 1.5, np.pi / 2 * (3 * s**2 - 2 * s**3), 0.8 * np.pi / 2), np.ones_like(t)
    if name == "lift_and_drop":
        s = np.clip(t / 1.5, 0, 1)
        return -np.pi / 2 * (3 * s**2 - 2 * s**3), (t < 2.0).astype(float)
    raise DataError(f"unknown trajectory {name!r}; known: {', '.join(TRAJECTORIES)}")


def record(folder, hidden: dict | None = None, truth: dict | None = None, seed: int = 3, gains=GAINS,
           trajectories=TRAJECTORIES[:2], duration: float = 3.0) -> list:
    """Write recordings of the simulated servo to ``folder`` (one per gain and trajectory); ``hidden``: effect
    id -> size (:data:`~.effects.EFFECTS`) put into the truth; ``truth``: parameters over :data:`OTHER`.
    Returns the recordings' names."""
    hidden = dict(hidden or {})
    effects = tuple(fx.effect(k) for k in hidden)
    cm = compiled(*model_key(effects))
    params = {**OTHER, **(truth or {}), **{fx.effect(k).parameter: float(v) for k, v in hidden.items()}}
    rng = np.random.default_rng(seed)
    names = []
    for kp in gains:
        for traj in trajectories:
            t = np.cumsum(rng.uniform(0.0045, 0.0060, int(duration / 0.0045) + 2))
            t = t[t <= duration]
            g, enable = goal(traj, t)
            volts = np.round((OTHER_SUPPLY + rng.normal(0, 0.05, t.size)) * 10) / 10
            columns = {"goal_position_rad": g, "input_voltage_V": volts, "torque_enable": enable}
            p = {"servo.kp": kp, "servo.error_gain": OTHER_GAIN, "pendulum.m": RIG["mass_kg"],
                 "pendulum.l": RIG["arm_length_m"], "pendulum.m_arm": 0.0, **params}
            res = cm.simulate(t[-1], t_start=t[0], t_eval=t, params=p, inputs=inputs_from(t, columns),
                              starts=_starts(cm, {"pendulum.phi": 0.0, "pendulum.w": 0.0}), rtol=1e-8, atol=1e-10)
            pos = np.round(np.asarray(res[READING]) / STEP) * STEP
            meta = {"kp": np.asarray(kp).item(),  # a numpy gain as a plain number (JSON)
                    "controller": {"error_gain_per_rad": OTHER_GAIN, "vendor_note": "simulated"},
                    "mass_kg": RIG["mass_kg"], "arm_length_m": RIG["arm_length_m"], "arm_mass_kg": None,
                    "trajectory_name": traj, "actuator": "a simulated 12 V servo", "rig": {"type": "pendulum"},
                    "hidden": {k: float(v) for k, v in hidden.items()}}
            name = f"other_kp{kp}_{traj}"
            write_recording(folder, name, {"time_s": t, "position_rad": pos, **columns}, meta, SERVO_FORMAT)
            names.append(name)
    return names
