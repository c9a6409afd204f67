"""The servo on a pendulum: BAM's test bench as a model of library parts.

::

    supply (logged voltage) --> PositionServo(goal, torque enable) --flange--> Pendulum(m, l, m_arm, phi0)

:class:`~acausal.library.servo.PositionServo` holds the firmware P law, the bridge, the winding, the gear and the
swap-in friction law; :class:`~acausal.library.rotational.Pendulum` the arm. The goal, the supply voltage and the
torque enable are numeric inputs (``goal.signal``, ``supply.v_ref``, ``enable.signal``) that a replay sets per
recording without recompiling; the rig (``servo.kp``, ``servo.error_gain``, ``pendulum.m``, ``pendulum.l``,
``pendulum.m_arm``) comes from the recording's JSON. ``effects`` (:mod:`~.effects` records) put candidate
elements into the servo's slots; the encoder's reading (``servo.sensor.phi``, :data:`READING`) is what a
recording's position is compared with.
"""
from __future__ import annotations

from acausal import Model, SampledSignal, compile_once, connect
from acausal.library.blocks import SignalSource
from acausal.library.electrical import Ground, PrescribedVoltage
from acausal.library.rotational import Pendulum
from acausal.library.servo import PositionServo

#: output-side parameters of the baseline (BAM's m1 set: kt, R, armature, q_offset, Kc, Kv)
BASELINE = ("servo.kt", "servo.R", "servo.armature", "pendulum.phi0", "servo.tau_c", "servo.d")

#: the model's variable that a recording's position column measures (the encoder, on the servo's side of any play)
READING = "servo.sensor.phi.value"

_PLACEHOLDER = SampledSignal([0.0, 1.0], [0.0, 0.0], name="placeholder (set per recording)")


class ServoPendulum(Model):
    """A position servo swinging a pendulum, its inputs replayed from a recording (see the module docstring)."""

    def __init__(self, friction_terms=("coulomb",), inserts=(), load_measure: str = "transmitted", **kw):
        self.friction_terms = tuple(friction_terms)
        self.inserts = tuple(inserts)
        self.load_measure = load_measure
        super().__init__(**kw)

    def build(self):
        self.supply = PrescribedVoltage(v_ref=_PLACEHOLDER)
        self.ground = Ground()
        self.goal = SignalSource(signal=_PLACEHOLDER)
        self.enable = SignalSource(signal=_PLACEHOLDER)
        self.servo = PositionServo(friction_terms=self.friction_terms, inserts=self.inserts,
                                   load_measure=self.load_measure, kp=100.0, error_gain=0.0028774)
        self.pendulum = Pendulum(m=0.49, l=0.1, bias_output=self.load_measure == "external")
        connect(self.supply.p, self.servo.bus_p)
        connect(self.supply.n, self.servo.bus_n, self.ground.p)
        connect(self.goal.y, self.servo.position_ref)
        connect(self.enable.y, self.servo.enable)
        connect(self.servo.flange, self.pendulum.flange)
        if self.load_measure == "external":  # BAM's load measure: the friction sees the arm's gravity torque
            connect(self.pendulum.tau_bias, self.servo.load_torque)


def compiled(friction_terms=("coulomb",), effects=(), load_measure: str = "transmitted"):
    """The compiled model with the friction ``terms`` (and their ``load_measure``) and the candidate ``effects``
    put into the servo's slots (:mod:`~.effects` records; cached per process)."""
    from .effects import inserts

    terms, chosen = tuple(friction_terms), tuple(effects)
    return compile_once(("servo_pendulum", terms, chosen, load_measure),
                        lambda: ServoPendulum(friction_terms=terms, inserts=inserts(chosen), load_measure=load_measure))
