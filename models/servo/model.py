"""The servo on a pendulum: BAM's test bench as a model of library parts.

::

    supply (logged voltage) --> PositionServo(goal, torque enable) --flange--> Pendulum(m, l, m_arm, phi0)

:class:`~acausal.library.servo.PositionServo` holds the firmware P law, the bridge, the winding, the gear and the
swap-in friction law; :class:`~acausal.library.rotational.Pendulum` the arm. The goal, the supply voltage and the
torque enable are numeric inputs (``goal.signal``, ``supply.v_ref``, ``enable.signal``) that a replay sets per
recording without recompiling; the rig (``servo.kp``, ``servo.error_gain``, ``pendulum.m``, ``pendulum.l``,
``pendulum.m_arm``) comes from the recording's JSON.
"""
from __future__ import annotations

from acausal import Model, SampledSignal, compile_model, connect
from acausal.library.blocks import SignalSource
from acausal.library.electrical import Ground, PrescribedVoltage
from acausal.library.rotational import Pendulum
from acausal.library.servo import PositionServo

#: output-side parameters of the baseline (BAM's m1 set: kt, R, armature, q_offset, Kc, Kv)
BASELINE = ("servo.kt", "servo.R", "servo.armature", "pendulum.phi0", "servo.tau_c", "servo.d")

_PLACEHOLDER = SampledSignal([0.0, 1.0], [0.0, 0.0], name="placeholder (set per recording)")


class ServoPendulum(Model):
    """A position servo swinging a pendulum, its inputs replayed from a recording (see the module docstring)."""

    def __init__(self, friction_terms=("coulomb",), **kw):
        self.friction_terms = tuple(friction_terms)
        super().__init__(**kw)

    def build(self):
        self.supply = PrescribedVoltage(v_ref=_PLACEHOLDER)
        self.ground = Ground()
        self.goal = SignalSource(signal=_PLACEHOLDER)
        self.enable = SignalSource(signal=_PLACEHOLDER)
        self.servo = PositionServo(friction_terms=self.friction_terms, kp=100.0, error_gain=0.0028774)
        self.pendulum = Pendulum(m=0.49, l=0.1)
        connect(self.supply.p, self.servo.bus_p)
        connect(self.supply.n, self.servo.bus_n, self.ground.p)
        connect(self.goal.y, self.servo.position_ref)
        connect(self.enable.y, self.servo.enable)
        connect(self.servo.flange, self.pendulum.flange)


_COMPILED: dict = {}


def compiled(friction_terms=("coulomb",)):
    """The compiled model with the friction ``terms`` (cached per process)."""
    key = tuple(friction_terms)
    if key not in _COMPILED:
        _COMPILED[key] = compile_model(ServoPendulum(friction_terms=key))
    return _COMPILED[key]
