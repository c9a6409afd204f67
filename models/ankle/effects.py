"""Effects the paper's Eq. (4) model leaves out, each a change of the ankle model made with library components.

:class:`~acausal.models.ankle.actuator.AnkleActuator` takes a tuple of effect identifiers and adds or swaps the
components; the virtual bench hides effects in its truth model (``acausal bench --effect ID=VALUE``) and the
diagnosis (``acausal diagnose``) tries them as candidate extensions of the calibrated baseline.

Every effect has one parameter that sets its size; ``zero`` is the value at which the extended model equals the
baseline (the fingerprint of an effect is the sensitivity of the predicted signals to that parameter there).
``typical`` is a realistic size for this actuator (a source or reasoning in ``doc``).
"""
from __future__ import annotations

from dataclasses import dataclass

from acausal import ModelError
from acausal.identify.verdict import Candidate


@dataclass(frozen=True, kw_only=True)
class Effect(Candidate):
    """A candidate of the ankle model (:class:`~acausal.identify.verdict.Candidate`: ``parameter`` sets its size,
    ``zero`` is the baseline, ``bounds`` and ``scale`` its fit, ``signal`` the recorded column it shows in first,
    ``typical`` the virtual bench's default size); ``measurement``: it sits in a sensor, not in the physics."""

    measurement: bool = False


EFFECTS = {e.id: e for e in [
    Effect(id="gear_coulomb_friction", parameter="gear_friction.tau_c", unit="N.m", zero=0.0, typical=0.012,
           bounds=(0.0, 0.2), signal="motor_current_A",
           doc="Coulomb friction of the gear train referred to the motor shaft (library BearingFriction before the "
               "gear, smooth sign law). Typical: about the motor's no-load friction torque, 9.9 mN m (parameters.md), "
               "more with the gearhead.", scale=0.01),
    Effect(id="gear_load_dependent_loss", parameter="gear.eta", unit="1", zero=1.0, typical=0.85, bounds=(0.3, 1.0),
           signal="motor_current_A",
           doc="mesh efficiency below 1 that scales with the transmitted torque and depends on the direction of power "
               "flow (the ideal gear swapped for the library LossyGear, smooth law). Typical: 85 % for the two stages "
               "(the gearhead catalogue gives at most 70 %, bearings and the helical stage included).", scale=0.1),
    Effect(id="winding_temperature", parameter="winding_heating", unit="K/J", zero=1e-9, typical=1 / 170,
           bounds=(1e-9, 5.0), signal="supply_current_A",
           doc="winding resistance rising with its temperature (copper, alpha_R = 0.00393 1/K) as I^2 R heats the "
               "motor's thermal capacitance C = 1 / winding_heating, coupled to ambient through the datasheet's 0.21 + "
               "7.4 K/W (library DCMotor heat port, HeatCapacitor, ThermalConductor, FixedTemperature). Each recording "
               "starts at ambient. Typical: 1/170 K/J, the motor lumped into one node (winding 2.11 s / 0.21 K/W = 10 "
               "J/K plus housing 1180 s / 7.4 K/W = 160 J/K, parameters.md), which gives the datasheet's 1180 s motor "
               "time constant: the winding alone is no single node, it settles on the housing within seconds. At that "
               "size a minute of gait at the paper's load warms the motor by about 1 K and changes the supply current "
               "by a fraction of a mA: it takes an endurance recording of many minutes (and a precise supply-current "
               "sensor) to see. Its zero is 1e-9 K/J (no heating).", scale=0.1),
    Effect(id="driver_quiescent_power", parameter="driver.P_q", unit="W", zero=0.0, typical=12.5, bounds=(0.0, 60.0),
           signal="supply_current_A",
           doc="constant standby draw of the motor driver (library EPOS2 P_q). Typical: the paper measured 10-15 W "
               "for the EPOS2.", scale=10.0),
    Effect(id="torque_sensor_offset", parameter="torque_offset.bias", unit="N.m", zero=0.0, typical=1.5,
           bounds=(-20.0, 20.0), signal="joint_torque_Nm",
           doc="zero offset of the joint torque sensor's reading (library Bias block in the sensor's signal path). "
               "Typical: 1-2 % of the 100 N m range.", scale=1.0, measurement=True),
    Effect(id="precompression_error", parameter="precompression_error", unit="m", zero=0.0, typical=0.0015,
           bounds=(-0.006, 0.006), signal="joint_torque_Nm",
           doc="the spring's actual precompression differs from the nominal one (the MACCEPA's P parameter). Typical: "
               "1-2 mm (the paper names an error in precompression length as a likely cause, section 4.3).",
           scale=1e-3),
    Effect(id="gear_backlash", parameter="backlash.b", unit="rad", zero=0.0, typical=0.0035, bounds=(0.0, 0.05),
           signal="motor_current_A",
           doc="play between the gear output and the moment arm (library Backlash, rigid flanks, contact changing "
               "over a 0.5 N m torque band): when the arm torque changes sign the motor has to cross the gap, n = 860 "
               "times the play at the motor. Typical: 0.2 deg at the arm (a preloaded final stage; planetary gearheads "
               "of this size are specified at about 1 deg).", scale=1e-3),
]}


def effect(name: str) -> Effect:
    try:
        return EFFECTS[name]
    except KeyError:
        raise ModelError(f"unknown effect {name!r}; known effects: {', '.join(EFFECTS)}") from None


def parse_effects(items) -> dict:
    """``["ID=VALUE", "ID"]`` (command line) -> ``{ID: value}``; a bare ID takes its typical size."""
    out = {}
    for item in items or ():
        name, _, value = item.partition("=")
        e = effect(name.strip())
        if e.id in out:
            raise ModelError(f"--effect {e.id}: given twice; give each effect once")
        try:
            out[e.id] = float(value) if value.strip() else e.typical
        except ValueError:
            raise ModelError(f"--effect {item!r}: the value after '=' must be a number [{e.unit}]") from None
        lo, hi = e.bounds
        if not lo <= out[e.id] <= hi:
            raise ModelError(f"--effect {item!r}: outside the range the diagnosis fits it in, {lo:g}-{hi:g} "
                             f"[{e.unit}] (typical {e.typical:g})")
    return out
