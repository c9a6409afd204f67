"""The paper's actuator on a supply that accepts regenerated energy: a battery with internal resistance in place
of the non-regenerative rectifier.

What changes against the paper's actuator and why: on the bench the driver's negative power (down to about
-50 W, paper Fig. 8) could not return to the source: the rectifier's diode blocks it, the bus capacitor charges
and the brake chopper burns the rest (:class:`~acausal.library.electrical.NonRegenerativeRectifier`). A
prosthesis runs from a battery, which takes that energy back. Here the supply (48 V behind 0.05 ohm, the same
:class:`~acausal.library.electrical.Supply` as the bench's, which accepts negative current) is wired straight to
the driver's bus; nothing else changes. The source measurement point then sees the net energy (drawn minus
returned); the energy returned per stride is reported separately (``StrideResult.returned``).

Registered as ``battery``: :class:`~acausal.models.ankle.actuator.AnkleActuator` with ``supply="battery"``.

Assumption: the internal resistance stays the lab supply's 0.05 ohm so that only regeneration differs
(a 13S Li-ion pack of 18650 cells would have about 0.1-0.3 ohm: set ``supply.R_int``).
"""
