"""What a servo on a pendulum may do that the baseline leaves out: the candidate library of the servo diagnosis.

The candidates span the chain, firmware to sensor. Each is one library component put into a slot of
:class:`~acausal.library.servo.PositionServo` (or a friction term, or a baseline parameter freed from its neutral
value), with one parameter that sets its size:

* friction (:class:`~acausal.library.friction.GearFriction` terms): ``stribeck``, ``load``, ``backdrive``,
  ``unpowered_friction``;
* firmware (:mod:`acausal.library.firmware`): ``goal_rate_limit``, ``goal_accel_limit``, ``error_deadband``,
  ``error_dependent_gain``, ``gain_error``, ``duty_limit``, ``punch``, ``loop_delay``;
* electrics: ``supply_sag`` (a resistance between the logged supply voltage and the bridge),
  ``duty_quantisation``, ``current_limit`` (the driver caps the winding's current), ``torque_off_brake`` (the
  bridge brakes the back-driven motor with the torque off instead of letting it coast);
* sensing and drive train: ``encoder_offset``, ``backlash`` (play between the shaft the encoder reads and the
  output), ``gear_backlash`` (play in the gear train ahead of an encoder that reads the output shaft).

``zero`` is the value at which the extended model is the baseline. ``probe`` (where given) is a size at which
the effect shows for certain: an effect that is a hard limit (a rate or duty limit, a play) has no first-order
effect at zero, so the diagnosis takes its fingerprint as the change from zero to the probe, and starts its refit
there.
``typical`` is a realistic size (the hidden-effect tests use it); ``doc`` says where it comes from.

A user's own candidate is an :class:`Effect` too, made from a plain dict (:func:`user_effect`; ``acausal diagnose
--candidate`` or ``--candidates-file``): its component is named by reference (``MODULE:CLASS`` or
``FILE.py:CLASS``), so worker processes build the same model.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from acausal import Component, DataError, ModelError, Parameter
from acausal.library.friction import TERMS
from acausal.library.servo import SLOTS
from acausal.cli.references import load_class
from acausal.identify.verdict import Candidate


@dataclass(frozen=True, kw_only=True)
class Effect(Candidate):
    """A candidate of the servo model (:class:`~acausal.identify.verdict.Candidate`: ``parameter`` sets its size,
    ``zero`` is the baseline, ``bounds`` and ``scale`` its fit, ``probe`` the fingerprint's and refit's size of a
    hard limit, ``typical`` a realistic size), and how it is built: ``slot`` (a PositionServo slot, ``"friction"``
    for a friction term or ``"parameter"`` for a baseline parameter freed), ``component`` (``MODULE:CLASS`` of the
    inserted element; the term's name for a friction term; ``""`` for a parameter) and ``fixed`` (``(name, value)``
    pairs of the element's other parameters)."""

    slot: str
    component: str
    fixed: tuple = field(default_factory=tuple)

    def factory(self):
        """A callable building the inserted element (with its size at ``zero``; the replay sets the size)."""
        return _Factory(self.component, self.fixed, self.parameter.rsplit(".", 1)[-1], self.zero)


class _Factory:
    """A picklable element factory: the class by reference, its fixed parameters and its size at zero."""

    def __init__(self, ref, fixed, size_name, zero):
        self.ref, self.fixed, self.size_name, self.zero = ref, tuple(fixed), size_name, zero

    def __call__(self, **over):
        cls = load_class(self.ref, Component, "candidate component")
        return cls(**{**dict(self.fixed), self.size_name: self.zero, **over})


F = "acausal.library.firmware:"
#: the encoder step of a 4096-count encoder [rad] (XL330, STS3215)
_STEP = 2 * 3.141592653589793 / 4096

#: the flanks of a play (``backlash``, ``gear_backlash``: :class:`~acausal.library.rotational.ElastoBacklash`'s
#: fixed parameters): stiff, 500 N m/rad (a small servo's stall torque, 0.6 N m for the XL330, deflects them by
#: 1.2 mrad, under one step of a 4096-step encoder: at zero play the candidate is the baseline to a third of a
#: step), damped (2 N m s/rad) with the damping coming in over 1 mrad of deflection (below an encoder step).
#: Stiffer flanks and a sharper onset change little the data can see and make the replays stiff: at 1000 N m/rad,
#: 1 N m s/rad and 1e-5 rad, RK4 on the XL330 recordings of square steps needed more than 32 substeps per sample
#: (CVODES), at these values 8 to 16
FLANKS = (("c", 500.0), ("d", 2.0), ("phi_d", 1e-3))

EFFECTS = {e.id: e for e in [
    Effect(id="stribeck", slot="friction", component="stribeck", parameter="servo.friction.tau_s",
           unit="N.m", zero=0.0, typical=0.01, bounds=(0.0, 2.0), scale=0.01,
           doc="breakaway friction at low speed (BAM M2; w_s, alpha at the library's defaults)"),
    Effect(id="load", slot="friction", component="load", parameter="servo.friction.k_l",
           unit="1", zero=0.0, typical=0.2, bounds=(0.0, 2.0), scale=0.1,
           doc="friction proportional to the transmitted torque (BAM M3 with the servo's own load measure)"),
    Effect(id="backdrive", slot="friction", component="backdrive", parameter="servo.friction.k_b",
           unit="1", zero=0.0, typical=0.2, bounds=(0.0, 2.0), scale=0.1,
           doc="more load friction while the load drives the gear (BAM M4's direction dependence)"),
    Effect(id="unpowered_friction", slot="friction", component="unpowered", parameter="servo.friction.tau_u",
           unit="N.m", zero=0.0, typical=0.02, bounds=(0.0, 1.0), scale=0.01,
           doc="more Coulomb friction while the torque is off and the load back-drives the train (BAM fits "
               "torque-off phases apart; the rotor's cogging, a mesh loaded by the rotor's own inertia; typical 0.02 N "
               "m, the XL330's powered Kc)"),
    Effect(id="goal_rate_limit", slot="goal", component=F + "GoalRateLimit", parameter="servo.goal_rate_limit.t_v",
           unit="s/rad", zero=0.0, typical=0.19, bounds=(0.0, 2.0), scale=0.1,
           doc="the firmware moves its internal goal no faster than 1/t_v (Feetech STS3215: 3400 steps/s = 5.2 rad/s, "
               "t_v 0.19 s/rad, Rhoban/bam feetech/actuator.py; Dynamixel Profile Velocity)", probe=0.25),
    Effect(id="goal_accel_limit", slot="goal", component=F + "GoalAccelLimit", parameter="servo.goal_accel_limit.t_a",
           unit="s2/rad", zero=0.0, typical=0.05, bounds=(0.0, 2.0), scale=0.02,
           doc="the firmware changes the speed of its internal goal no faster than 1/t_a (Dynamixel Profile "
               "Acceleration, steps of 0.374 rad/s2: a goal step becomes a speed ramp; typical 20 rad/s2). A hard "
               "limit: fingerprinted by the secant to 0.05 s2/rad", probe=0.05),
    Effect(id="error_deadband", slot="error", component=F + "DeadZone", parameter="servo.error_deadband.uMax",
           unit="rad", zero=0.0, typical=3 * _STEP, bounds=(0.0, 0.1), scale=0.003,
           doc="no drive within a band of position error (Dynamixel compliance margin, Feetech insensitive zone; "
               "typical 3 encoder steps)"),
    Effect(id="error_dependent_gain", slot="error", component=F + "ErrorGain", parameter="servo.error_dependent_gain.c",
           unit="1/rad", zero=0.0, typical=2.0, bounds=(0.0, 100.0), scale=1.0,
           doc="the duty falls short of the linear law at large errors, duty = k e / (1 + c |e|) (torque-limit "
               "protection, an inner current loop; typical: half the gain at 0.5 rad)"),
    Effect(id="gain_error", slot="error", component=F + "GainScale", parameter="servo.gain_error.s",
           unit="1", zero=0.0, typical=0.2, bounds=(-0.9, 5.0), scale=0.1,
           doc="the firmware's gain differs from the declared error gain by the fraction s (BAM's error_gain_ratio of "
               "the STS3215, fitted in 0.1-10)"),
    Effect(id="duty_limit", slot="parameter", component="", parameter="servo.d_max",
           unit="1", zero=1.0, typical=0.9, bounds=(0.2, 1.0), scale=0.1,
           doc="the largest duty is below 1 (MX-64/106: 0.9625, STS3215: 0.97, Rhoban/bam; a PWM Limit register below "
               "its maximum)", probe=0.9),
    Effect(id="punch", slot="duty", component=F + "Punch", parameter="servo.punch.p",
           unit="1", zero=0.0, typical=0.03, bounds=(0.0, 0.3), scale=0.01,
           doc="a minimum duty added once the firmware drives (Dynamixel AX punch, Feetech minimum startup force; "
               "typical 3 %)", fixed=(("u_c", 0.002),)),
    Effect(id="loop_delay", slot="position", component=F + "LoopDelay", parameter="servo.loop_delay.T",
           unit="s", zero=0.0, typical=0.003, bounds=(0.0, 0.05), scale=0.001,
           doc="the firmware regulates a reading T old (sampling and PWM update; typical 3 ms)"),
    Effect(id="supply_sag", slot="bus", component="acausal.library.electrical:Resistor",
           parameter="servo.supply_sag.R", unit="Ohm", zero=0.0, typical=1.0, bounds=(0.0, 50.0), scale=0.5,
           doc="resistance between the logged supply voltage and the bridge: the bus sags with the drawn current "
               "(connector, traces, a thin supply cable; typical 1 ohm)"),
    Effect(id="duty_quantisation", slot="duty", component=F + "DeadZone", parameter="servo.duty_quantisation.uMax",
           unit="1", zero=0.0, typical=0.01, bounds=(0.0, 0.2), scale=0.005,
           doc="the duty truncated to a register step q, in the mean: duty - clamp(duty, -q/2, q/2) (uMax = q/2; "
               "XL330: q = 1/885, a coarse 7-bit PWM: q = 0.008)"),
    Effect(id="encoder_offset", slot="position", component="acausal.library.blocks:Bias",
           parameter="servo.encoder_offset.bias", unit="rad", zero=0.0, typical=0.02, bounds=(-0.3, 0.3), scale=0.01,
           doc="the reading the firmware regulates is off the logged one by a constant (a homing offset applied on "
               "one side only); the arm's own mounting offset is the baseline's phi0"),
    Effect(id="backlash", slot="output",
           component="acausal.library.rotational:ElastoBacklash", parameter="servo.backlash.b",
           unit="rad", zero=0.0, typical=0.02, bounds=(0.0, 0.3), scale=0.005,
           doc="play between the shaft the encoder reads and the output (gear backlash; plastic servo gears 0.5-2 "
               "deg); flanks stiff and damped (FLANKS). A hard nonlinearity: the play's first order effect at zero "
               "flips with the sign of the flanks' deflection, so it is fingerprinted by the secant to 0.01 rad (0.6 "
               "deg, the low end of that range)", fixed=FLANKS, probe=0.01, excludes=("gear_backlash",)),
    Effect(id="gear_backlash", slot="drive",
           component="acausal.library.rotational:ElastoBacklash", parameter="servo.gear_backlash.b",
           unit="rad", zero=0.0, typical=0.02, bounds=(0.0, 0.3), scale=0.005,
           doc="play in the gear train between the rotor and an encoder that reads the output shaft (the XL330's "
               "magnetic encoder does): the firmware regulates the output, so the rotor crosses the gap unseen when "
               "the torque reverses; flanks and fingerprint as for backlash. Not with backlash: two plays in series "
               "with no inertia between them are one play", fixed=FLANKS, probe=0.01, excludes=("backlash",)),
    Effect(id="torque_off_brake", slot="winding", component="acausal.library.electrical:BrakingWinding",
           parameter="servo.winding.brake", unit="1", zero=0.0, typical=1.0, bounds=(0.0, 1.0), scale=0.1,
           doc="with the torque off the bridge shorts the winding instead of floating (dynamic braking: the "
               "back-driven rotor's back-EMF drives a current kt^2 w / R against it); the fraction of the "
               "winding's conductance left, 1 for a full short", excludes=("current_limit",)),
    Effect(id="current_limit", slot="winding",
           component="acausal.library.electrical:CurrentLimitedResistor", parameter="servo.winding.inv_i_max",
           unit="1/A", zero=0.0, typical=1 / 1.75, bounds=(0.0, 20.0), scale=0.5,
           doc="the driver caps the winding's current at 1/inv_i_max (Dynamixel Current Limit register; XL330-M288: "
               "1750 mA, ROBOTIS e-manual). A hard limit: fingerprinted by the secant to a 1 A cap", probe=1.0),
]}


def effect(name: str, known: dict | None = None) -> Effect:
    known = EFFECTS if known is None else known
    try:
        return known[name]
    except KeyError:
        raise ModelError(f"unknown servo effect {name!r}; known: {', '.join(known)}") from None


def terms(effects) -> tuple:
    """The friction terms of the baseline extended with ``effects`` (Effect records), in the library's order."""
    named = {e.component for e in effects if e.slot == "friction"}
    return tuple(t for t in TERMS if t == "coulomb" or t in named)


def inserts(effects) -> tuple:
    """The ``PositionServo`` inserts of ``effects``: ``(slot, name, factory)`` in the given order; effects that
    exclude each other are refused, naming both."""
    for k, a in enumerate(effects):
        for b in effects[k + 1:]:
            if b.id in a.excludes or a.id in b.excludes:
                raise ModelError(f"servo effects {a.id!r} and {b.id!r} cannot be in one model ({a.id} excludes "
                                 f"{b.id})")
    return tuple((e.slot, e.id, e.factory()) for e in effects if e.slot in SLOTS)


# ------------------------------------------------------------------------------------------------ user's own
_USER_KEYS = {"id", "slot", "component", "parameter", "unit", "zero", "typical", "bounds", "scale", "doc", "probe",
              "fixed"}


def user_effect(spec: dict, where: str = "candidate") -> Effect:
    """A user's candidate from a dict: ``id``, ``slot`` (one of PositionServo's slots), ``component``
    (``MODULE:CLASS`` or ``FILE.py:CLASS``), ``parameter`` (the component's size parameter), ``bounds``
    ``[lo, hi]``; optional ``zero`` (default 0), ``unit``, ``typical``, ``scale``, ``probe``, ``doc``, ``fixed``
    (its other parameters). The component is loaded and built once here, so a wrong reference, slot or
    parameter is named now, not inside a worker (that the model compiles with it and is unchanged at its zero is
    checked on the data: :meth:`~.problem.ServoProblem.check_user_effect`). ``where`` names the source in
    messages."""
    if not isinstance(spec, dict):
        raise DataError(f"{where}: a candidate is an object of keys ({', '.join(sorted(_USER_KEYS))}), got a "
                        f"{type(spec).__name__}: {spec!r}")
    unknown = sorted(set(spec) - _USER_KEYS)
    if unknown:
        raise DataError(f"{where}: unknown key(s) {', '.join(unknown)}; known: {', '.join(sorted(_USER_KEYS))}")
    for key in ("id", "slot", "component", "parameter", "bounds"):
        if key not in spec:
            raise DataError(f"{where}: key {key!r} is missing")
    bounds = spec["bounds"]
    if isinstance(bounds, (str, bytes, dict)) or not hasattr(bounds, "__len__") or len(bounds) != 2:
        raise DataError(f"{where}: bounds must be a pair [lo, hi], got {bounds!r}")
    cid, slot, param = str(spec["id"]), str(spec["slot"]), str(spec["parameter"])
    if not cid.isidentifier():
        raise DataError(f"{where}: id {cid!r} must be a name (letters, digits, _)")
    if cid in EFFECTS:
        raise DataError(f"{where}: id {cid!r} is a built-in candidate; choose another")
    if slot not in SLOTS:
        raise DataError(f"{where}: slot {slot!r} is not one of {', '.join(SLOTS)}")
    try:
        lo, hi = (float(v) for v in spec["bounds"])
        zero = float(spec.get("zero", 0.0))
        probe = None if spec.get("probe") is None else float(spec["probe"])
        fixed = tuple((str(k), float(v)) for k, v in dict(spec.get("fixed", {})).items())
        scale = float(spec.get("scale", max(abs(hi - lo) / 10, 1e-12)))
        typical = float(spec.get("typical", probe if probe is not None else (zero + hi) / 2))
    except (TypeError, ValueError) as exc:
        raise DataError(f"{where}: bounds, zero, probe, scale, typical and fixed must be numbers ({exc})") from None
    if not all(math.isfinite(v) for v in (lo, hi, zero, scale, typical) + ((probe,) if probe is not None else ())):
        raise DataError(f"{where}: bounds, zero, probe, scale and typical must be finite numbers (a fit searches a "
                        f"finite range), got bounds [{lo}, {hi}]")
    if not lo <= zero <= hi or lo >= hi:
        raise DataError(f"{where}: bounds [{lo}, {hi}] must be increasing and hold zero = {zero}")
    if probe is not None and (not lo <= probe <= hi or probe == zero):
        raise DataError(f"{where}: probe = {probe} must lie inside bounds [{lo}, {hi}] and differ from zero = "
                        f"{zero} (the fingerprint is the change from zero to the probe)")
    if not lo <= typical <= hi:
        raise DataError(f"{where}: typical = {typical} must lie inside bounds [{lo}, {hi}]")
    if scale <= 0:
        raise DataError(f"{where}: scale = {scale} must be positive (the size's typical magnitude)")
    where_param = "winding" if slot == "winding" else cid  # a replaced winding keeps its name
    e = Effect(id=cid, slot=slot, component=str(spec["component"]), parameter=f"servo.{where_param}.{param}",
               unit=str(spec.get("unit", "")), zero=zero, typical=typical, bounds=(lo, hi), scale=scale,
               doc=str(spec.get("doc", "a user's candidate")), probe=probe, fixed=fixed)
    cls = load_class(e.component, Component, f"{where}: component")
    declared = cls.declarations()
    known = ", ".join(k for k, d in declared.items() if isinstance(d, Parameter)) or "none"
    if param not in declared:
        raise DataError(f"{where}: {e.component} has no parameter {param!r}; its parameters: {known}")
    if not isinstance(declared[param], Parameter):
        raise DataError(f"{where}: {param!r} of {e.component} is a {type(declared[param]).__name__}, not a "
                        f"parameter; its parameters: {known}")
    element = e.factory()(**({"R": 1.0} if slot == "winding" else {}))  # a wrong fixed parameter is named here
    ports = SLOTS[slot]
    if not all(hasattr(element, p) for p in ports):
        raise DataError(f"{where}: {e.component} has no ports {ports} for slot {slot!r}")
    return e


def parse_candidate(text: str) -> Effect:
    """``id=NAME,slot=SLOT,component=REF,parameter=P,bounds=LO:HI[,zero=Z][,probe=X][,unit=U]`` (the command
    line's ``--candidate``) -> :func:`user_effect`."""
    spec: dict = {}
    for part in text.split(","):
        key, sep, value = part.partition("=")
        if not sep:
            raise DataError(f"--candidate {text!r}: {part!r} is not KEY=VALUE")
        key = key.strip()
        value = value.strip()
        if key in spec and key != "fixed":
            raise DataError(f"--candidate {text!r}: key {key!r} is given twice")
        if key == "bounds":
            spec[key] = value.split(":")
            if len(spec[key]) != 2:
                raise DataError(f"--candidate {text!r}: bounds must be LO:HI, got {value!r}")
        elif key == "fixed":
            name, _, v = value.partition(":")
            if name in spec.get("fixed", {}):
                raise DataError(f"--candidate {text!r}: fixed parameter {name!r} is given twice")
            spec.setdefault("fixed", {})[name] = v
        else:
            spec[key] = value
    return user_effect(spec, f"--candidate {text!r}")


def load_candidates_file(path) -> list:
    """A JSON file holding a list of candidate dicts (:func:`user_effect`), each named by file and index."""
    path = Path(path)
    def unique(pairs):
        keys = [k for k, _ in pairs]
        twice = sorted({k for k in keys if keys.count(k) > 1})
        if twice:
            raise DataError(f"{path}: key(s) {', '.join(repr(k) for k in twice)} given twice in one object")
        return dict(pairs)

    try:
        items = json.loads(path.read_text(), object_pairs_hook=unique)
    except FileNotFoundError:
        raise DataError(f"{path}: no such candidates file") from None
    except json.JSONDecodeError as exc:
        raise DataError(f"{path}: not JSON: line {exc.lineno}, column {exc.colno}: {exc.msg}") from None
    if not isinstance(items, list):
        raise DataError(f"{path}: expected a JSON list of candidates")
    return [user_effect(spec, f"{path} [{k}]") for k, spec in enumerate(items)]
