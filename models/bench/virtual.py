"""Virtual test bench: the paper's protocol run on a chosen truth model, written as bench recordings.

The bench does what the real one did (paper section 4): the output motor moves the ankle along the gait angle at the
condition's stride time, and the actuator's controller tracks the planned moment-arm angle for the condition's
precompression (closed loop, :meth:`AnkleActuator.eq4 <acausal.models.ankle.actuator.AnkleActuator.eq4>`). The truth
model is the paper's Eq. (4) structure with ``truth`` parameter values, plus hidden ``effects``
(:mod:`acausal.models.ankle.effects`) at chosen sizes; or, with ``chain`` (a preset name such as ``"paper_fit"``),
the whole component chain of the paper's bench (:data:`~acausal.models.ankle.protocol.BENCH`: supply, rectifier,
EPOS2 driver, motor, lossy gears, frictional MACCEPA) with that preset's parameters (``truth`` on top): the bench as
the paper recorded it, to calibrate a simpler model on (C13). Each condition is simulated for ``settle`` strides
(discarded: the controller settles) and then ``strides`` recorded strides.

Sensors (:class:`Sensors`), sampled at 1 kHz: 14-bit absolute encoders (AS5048A: 2 pi / 16384 steps) on the ankle
and moment-arm angles, motor current as the driver reports it (Gaussian noise, optional offset and first-order
filter), supply current (noise, the same filter)
and voltage (noise), joint torque (noise). Noise is seeded per recording from ``(seed, index)``: the same call
writes the same files.
"""
from __future__ import annotations

from concurrent.futures import Executor
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
from scipy.signal import lfilter

from acausal import DataError, compile_once
from acausal.results.files import atomic_write_text
from acausal.identify.recordings import write_manifest, write_recording
from acausal.simulation.sweep import sweep

from acausal.library.drives import DCMotor
from acausal.library.maccepa import Maccepa

from ..ankle.actuator import AnkleActuator
from ..ankle.presets import EQ4_LUMPED, preset
from ..ankle.protocol import BENCH, PRECOMPRESSIONS, STRIDE_TIMES, compiled
from ..ankle.effects import EFFECTS, effect
from .recording_format import ANKLE_FORMAT, RANGES, SIGNALS

#: the truth's parameters when nothing else is said: Eq. 4's lumped values (presets.EQ4_LUMPED) and the motor's
#: datasheet L and k (the DCMotor defaults)
TRUTH = {**EQ4_LUMPED, "motor.L": DCMotor.L.default, "motor.k": DCMotor.k.default}
BODY_MASS = AnkleActuator.body_mass.default
K_SPRING = Maccepa.k.default


@dataclass(frozen=True)
class Sensors:
    encoder_bits: int = 14  # AS5048A absolute magnetic encoder
    motor_current_noise: float = 0.03  # A (std)
    motor_current_offset: float = 0.0  # A
    supply_current_noise: float = 0.02  # A (std)
    supply_voltage_noise: float = 0.02  # V (std)
    torque_noise: float = 0.4  # N m (std)
    rate: float = 1000.0  # Hz
    #: Hz: first-order low-pass filter of both current readings, noise included (a driver reports its current
    #: filtered); 0: none (the readings are the sampled values)
    current_filter_hz: float = 0.0

    @property
    def encoder_step(self) -> float:
        return 2 * np.pi / 2**self.encoder_bits

    def _pole(self) -> float:
        """The current filter's discrete pole ``exp(-2 pi f / rate)`` (0: no filter)."""
        return float(np.exp(-2 * np.pi * self.current_filter_hz / self.rate)) if self.current_filter_hz > 0 else 0.0

    def filtered(self, x):
        """A current reading through the filter (:attr:`current_filter_hz`), started at its first value."""
        a = self._pole()
        if not a:
            return x
        return lfilter([1 - a], [1, -a], x, zi=[a * x[0]])[0]

    def noise_floor(self) -> dict:
        """Standard deviation a perfect model leaves on each recorded signal (the currents' white noise after the
        filter: ``sigma sqrt((1 - a) / (1 + a))`` with the filter's pole ``a``)."""
        a = self._pole()
        g = np.sqrt((1 - a) / (1 + a))
        return {"motor_current_A": g * self.motor_current_noise, "supply_current_A": g * self.supply_current_noise,
                "joint_torque_Nm": self.torque_noise, "supply_voltage_V": self.supply_voltage_noise}


@dataclass(frozen=True)
class BenchCondition:
    P: float  # nominal precompression [m]
    stride_time: float  # [s]
    strides: int = 6
    settle: int = 1
    body_mass: float = BODY_MASS  # [kg] the gait torque is scaled with (the user the bench emulates)

    def __post_init__(self):
        checks = (("P", self.P >= 0, "m"), ("stride_time", self.stride_time > 0, "s"),
                  ("body_mass", self.body_mass > 0, "kg (acausal bench --body-mass)"))
        for name, ok, unit in checks:
            if not ok:
                raise DataError(f"BenchCondition: {name} must be positive, got {getattr(self, name):g} {unit}")


def _check_truth(effects: tuple, truth: dict | None, chain: str | None) -> None:
    """A chain with hidden effects, or an unknown preset: the error, before anything is simulated."""
    if chain is not None and effects:
        raise DataError(f"virtual bench: hidden effects ({', '.join(effects)}) are parts of the Eq. (4) truth; "
                        f"the component chain (chain={chain!r}) has its losses as components already")
    truth_values(truth, chain)


def _truth_model(effects: tuple, chain: str | None = None):
    if chain is not None:
        return compiled(BENCH).sim
    return compile_once(("ankle_eq4_closed_loop", tuple(effects)),
                        lambda: AnkleActuator.eq4(mode="closed_loop", effects=effects))


def truth_values(truth: dict | None = None, chain: str | None = None) -> dict:
    """The truth's parameter overrides: Eq. (4)'s :data:`TRUTH`, or the preset ``chain`` of the component chain,
    with ``truth`` on top."""
    return {**(TRUTH if chain is None else preset(chain)), **(truth or {})}


def truth_body_mass(chain: str | None = None) -> float:
    """The body mass of the user the truth emulates: the preset ``chain``'s, else the default."""
    return float(truth_values(chain=chain).get("body_mass", BODY_MASS))


def record(cond: BenchCondition, effects: dict | None = None, truth: dict | None = None,
           sensors: Sensors = Sensors(), seed: int = 0, index: int = 0, final: dict | None = None,
           chain: str | None = None) -> tuple:
    """Simulate one condition on the truth model (``chain``: module docstring); returns ``(columns, meta)`` of the
    recording. ``final``: a dict filled with the truth's winding temperature at the recording's end
    (``"winding_K"``: what a session carries to its next recording; only with the ``winding_temperature``
    effect)."""
    effects = dict(effects or {})
    _check_truth(tuple(effects), truth, chain)
    sim = _truth_model(tuple(sorted(effects)), chain)
    params = {**truth_values(truth, chain), "stride_time": cond.stride_time, "P_nominal": cond.P,
              "link.k": K_SPRING, "body_mass": cond.body_mass}
    for name, value in effects.items():
        params[effect(name).parameter] = value
    T = cond.stride_time
    dt = 1.0 / sensors.rate
    n_settle = int(round(cond.settle * T / dt))
    n_rec = int(round(cond.strides * T / dt))
    res = sim.simulate((n_settle + n_rec) * dt, params=params,
                       n_points=n_settle + n_rec + 1, rtol=1e-7, atol=1e-9, dense_output=False)
    w = slice(n_settle, n_settle + n_rec)
    if final is not None and "winding_temperature" in effects:
        final["winding_K"] = float(res["motor.heat_port.T"][-1])
    rng = np.random.default_rng([seed, index])
    q = sensors.encoder_step
    n = n_rec
    cols = {
        "time_s": res.t[w] - res.t[n_settle],
        "ankle_angle_rad": np.round(res["ankle.theta"][w] / q) * q,
        "moment_arm_angle_rad": np.round(res["arm_angle.phi.value"][w] / q) * q,
        "moment_arm_setpoint_rad": res["arm_ref.y.value"][w],
        "joint_torque_Nm": res[SIGNALS["joint_torque_Nm"]][w] + sensors.torque_noise * rng.standard_normal(n),
        "supply_voltage_V": res[SIGNALS["supply_voltage_V"]][w] + sensors.supply_voltage_noise * rng.standard_normal(n),
        "supply_current_A": sensors.filtered(res[SIGNALS["supply_current_A"]][w]
                                             + sensors.supply_current_noise * rng.standard_normal(n)),
        "motor_current_A": sensors.filtered(res[SIGNALS["motor_current_A"]][w] + sensors.motor_current_offset
                                            + sensors.motor_current_noise * rng.standard_normal(n)),
    }
    meta = {"precompression_m": cond.P, "stride_time_s": T, "spring_stiffness_N_per_m": K_SPRING,
            "body_mass_kg": cond.body_mass, "supply_voltage_V": float(res["supply.V"][0]), "strides": cond.strides,
            "description": f"virtual bench (acausal bench), seed {seed}: simulated data, not a measurement"}
    return cols, meta


def _record(args):
    return record(*args)


def run_session(out_dir, conditions, effects: dict | None = None, truth: dict | None = None,
                sensors: Sensors = Sensors(), seed: int = 0, pause: float = 10.0) -> list:
    """Record ``conditions`` one after another as one bench session into ``out_dir`` (as :func:`run_bench`): the
    winding stays warm from one recording to the next (``winding_temperature`` effect: each starts at the
    temperature the previous one ended with, cooled over ``pause`` seconds with the lumped motor's time constant),
    and each recording's JSON says when it started (``session_time_s``). Every stride is recorded (the conditions'
    settling strides are not made: they would heat the winding unrecorded), so each recording starts with the
    actuator at rest. Recorded serially (each needs the one before). Returns the CSV paths."""
    from ..ankle.actuator import WINDING_G

    out = Path(out_dir)
    conditions = [replace(c, settle=0) for c in conditions]
    effects = dict(effects or {})
    for name in effects:
        effect(name)
    if not pause >= 0:
        raise DataError(f"run_session: the pause between recordings must be >= 0 s, got {pause!r}")
    names = [f"S{k:02d}_P{c.P * 1e3:04.1f}mm_T{c.stride_time:.1f}s" for k, c in enumerate(conditions)]
    about = {"written_by": "acausal bench (session)", "seed": seed, "effects": effects, "pause_s": pause}
    out.mkdir(parents=True, exist_ok=True)
    write_manifest(out, names, complete=False, about=about)
    h = float(effects.get("winding_temperature", 0.0))
    ambient = DCMotor.T_ref.default
    excess, clock, paths = 0.0, 0.0, []
    for k, (c, name) in enumerate(zip(conditions, names)):
        final: dict = {}
        cols, meta = record(c, effects, {**(truth or {}), "winding_excess": excess}, sensors, seed, k, final)
        meta["session_time_s"] = clock
        clock += c.strides * c.stride_time + pause
        if "winding_K" in final:
            G = float((truth or {}).get("winding_G", WINDING_G))
            excess = (final["winding_K"] - ambient) * np.exp(-pause * G * h)
        paths.append(write_recording(out, name, cols, meta, ANKLE_FORMAT))
    _write_readme(out, conditions, effects, {**TRUTH, **(truth or {})}, sensors, seed)
    write_manifest(out, names, complete=True, about=about)
    return paths


def default_conditions(strides: int = 6, body_mass: float = BODY_MASS) -> list:
    """The paper's 36 conditions (precompression x stride time)."""
    return [BenchCondition(P, T, strides, body_mass=body_mass) for P in PRECOMPRESSIONS for T in STRIDE_TIMES]


def run_bench(out_dir, conditions=None, effects: dict | None = None, truth: dict | None = None,
              sensors: Sensors = Sensors(), seed: int = 0, executor: Executor | str | None = None,
              chain: str | None = None) -> list:
    """Record every condition into ``out_dir`` (``P08mm_T2.0s.csv`` + ``.json`` ...) and describe the run in
    ``out_dir/README.md`` (truth, hidden effects, sensors: the answer key, which a loader ignores).
    ``executor`` as in :func:`acausal.simulation.sweep.sweep` (default: a process pool on all cores; ``"serial"``);
    ``chain``: record the component chain with this preset instead of Eq. (4) (module docstring).
    Returns the CSV paths."""
    out = Path(out_dir)
    conditions = list(conditions or default_conditions())
    effects = dict(effects or {})
    for name in effects:
        effect(name)
    _check_truth(tuple(effects), truth, chain)
    jobs = [(c, effects, truth, sensors, seed, i, None, chain) for i, c in enumerate(conditions)]
    names = [f"P{c.P * 1e3:04.1f}mm_T{c.stride_time:.1f}s" for c in conditions]
    about = {"written_by": "acausal bench", "seed": seed, "effects": effects, "chain": chain}
    out.mkdir(parents=True, exist_ok=True)
    write_manifest(out, names, complete=False, about=about)  # an interrupted run leaves this: loading then fails
    recs = sweep(_record, jobs, executor=executor)
    paths = [write_recording(out, name, cols, meta, ANKLE_FORMAT) for name, (cols, meta) in zip(names, recs)]
    _write_readme(out, conditions, effects, truth_values(truth, chain), sensors, seed, chain)
    write_manifest(out, names, complete=True, about=about)
    return paths


def _write_readme(out: Path, conditions, effects, truth, sensors, seed, chain: str | None = None):
    model = ("Eq. (4) structure with:" if chain is None else
             f"the component chain of the paper's bench (`{BENCH}`: supply, rectifier, EPOS2 driver, motor, lossy "
             f"gears, frictional MACCEPA) with preset `{chain}`, its defaults and:")
    lines = ["# Virtual bench recordings (simulated, not measured)", "",
             f"Written by `acausal bench` with seed {seed}: {len(conditions)} recordings in the format of "
             "`acausal.models.bench.recording_format` (closed loop, paper protocol).", "",
             "## Truth model (the answer key)", "", model, ""]
    lines += [f"- `{k}` = {v:g}" for k, v in sorted(truth.items())]
    lines += ["", "Hidden effects: " + (", ".join(f"`{k}` = {v:g} {EFFECTS[k].unit}" for k, v in effects.items())
                                        or "none"), "", "## Sensors", ""]
    lines += [f"- {k} = {v}" for k, v in asdict(sensors).items()]
    atomic_write_text(out / "README.md", "\n".join(lines) + "\n")


#: what each sensor setting may be: (lowest, highest, whole number, unit); the encoder needs one bit at least and a
#: 64-bit float resolves no more than 52 of a turn, the rate is one the recordings' loader takes (their sample
#: interval, :data:`.recording_format.RANGES`: 10 Hz-100 kHz), noise not negative, the current filter below the
#: Nyquist frequency (checked against the rate)
SENSOR_RANGES = {"encoder_bits": (1, 52, True, "bits"), "motor_current_noise": (0.0, np.inf, False, "A"),
                 "motor_current_offset": (-np.inf, np.inf, False, "A"),
                 "supply_current_noise": (0.0, np.inf, False, "A"), "supply_voltage_noise": (0.0, np.inf, False, "V"),
                 "torque_noise": (0.0, np.inf, False, "N m"), "rate": (1.0 / RANGES["sample interval"][1],
                                                                 1.0 / RANGES["sample interval"][0], False, "Hz"),
                 "current_filter_hz": (0.0, np.inf, False, "Hz")}


def sensors_with(overrides: dict) -> Sensors:
    """:class:`Sensors` with fields overridden (``--sensor NAME=VALUE``); an unknown field lists the known ones, a
    value that is not a number or outside :data:`SENSOR_RANGES` names the setting and the range."""
    from acausal import DataError

    known = set(asdict(Sensors()))
    values = {}
    for k, text in overrides.items():
        if k not in known:
            raise DataError(f"unknown sensor setting {k!r}; known: {', '.join(sorted(known))}")
        lo, hi, whole, unit = SENSOR_RANGES[k]
        try:
            v = float(text)
        except (TypeError, ValueError):
            v = float("nan")
        if not (np.isfinite(v) and lo <= v <= hi and (not whole or v == int(v))):
            span = (f" {lo:g}-{hi:g}" if np.isfinite(hi) else " >= 0" if lo == 0
                    else "")
            raise DataError(f"--sensor {k}={text}: {'a whole number' if whole else 'a finite number'}{span} "
                            f"expected [{unit}]")
        values[k] = int(v) if whole else v
    sensors = replace(Sensors(), **values)
    if sensors.current_filter_hz >= sensors.rate / 2:
        raise DataError(f"--sensor current_filter_hz={sensors.current_filter_hz:g}: the current filter must be "
                        f"below half the sample rate ({sensors.rate:g} Hz)")
    return sensors

