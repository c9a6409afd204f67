"""Other windings of the same motor (maxon EC-4pole 30, 200 W) with a matching supply.

What changes against the paper's actuator and why: the paper's motor has the 48 V winding (part 305015). The
same motor is sold with 24 V (305013) and 36 V (305014) windings: the same magnetic circuit, rotor, friction
and no-load speed, with fewer turns of thicker wire, so a lower torque constant ``k`` (more current for the same
torque) and a lower resistance and inductance. Each comes with a supply of its nominal voltage, so the motor
reaches the same speeds at the same duty cycle. A lower voltage shifts loss from the motor's copper (the same
``R i^2`` at the same torque to within the winding's fill factor) to the conduction and supply losses, which grow
with the current, and brings the driver's current limits (10 A continuous, 25 A peak) closer.

Values (datasheet columns, ``docs/parameters.md``)::

    winding  R [ohm]  L [H]     k [N m/A]  nominal torque [N m]
    24 V     0.102    1.6e-5    0.0136     0.0946
    36 V     0.21     3.7e-5    0.0206     0.0952
    48 V     0.386    6.53e-5   0.0274     about 0.095 (paper's motor, the library default)

The matching supply (assumptions): no-load voltage = the winding's nominal voltage; internal resistance scaled with
the voltage squared from the lab supply's 0.05 ohm at 48 V (the same relative drop at the same power); the
rectifier's brake-chopper threshold scaled with the voltage (50 V at 48 V). Rotor inertia, friction and temperature
coefficient do not depend on the winding and keep the library's values. Everything else is the paper's actuator
(MACCEPA, replayed). These are parameter sets of :class:`~acausal.models.ankle.actuator.AnkleActuator`
(``mode="replay"``): they share its compiled model.
"""
from __future__ import annotations

from acausal.library.electrical import NonRegenerativeRectifier, Supply

V_PAPER = Supply.V.default  # V: the paper's winding and supply (48 V)
R_INT_PAPER = Supply.R_int.default  # ohm: lab supply (assumption)
V_BRAKE_PAPER = NonRegenerativeRectifier.V_brake.default  # V: brake chopper threshold at 48 V

#: datasheet values per winding: R [ohm], L [H], k [N m/A], nominal torque [N m]
WINDINGS = {
    "24V": dict(R=0.102, L=0.016e-3, k=0.0136, nominal_torque=0.0946, V=24.0),
    "36V": dict(R=0.21, L=0.037e-3, k=0.0206, nominal_torque=0.0952, V=36.0),
    "48V": dict(R=0.386, L=0.0653e-3, k=0.0274, nominal_torque=0.095, V=48.0),
}


def winding_params(name: str) -> dict:
    """Run-time parameter overrides of the replayed actuator for winding ``name`` ("24V", "36V", "48V")."""
    from acausal import ModelError

    if name not in WINDINGS:
        raise ModelError(f"unknown winding {name!r}; known: {', '.join(WINDINGS)}")
    w = WINDINGS[name]
    scale = w["V"] / V_PAPER
    return {"motor.R": w["R"], "motor.L": w["L"], "motor.k": w["k"], "supply.V": w["V"],
            "supply.R_int": R_INT_PAPER * scale**2, "rect.V_brake": V_BRAKE_PAPER * scale}
