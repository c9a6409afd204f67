"""Circuits several test modules share: an RC charged by a source, and a three-phase diode bridge."""
import sympy as sp

from acausal import Model, Start, connect, time
from acausal.library.electrical import Capacitor, Ground, IdealDiode, PrescribedVoltage, Resistor


class RC(Model):
    """A source (``v_ref``, default 10 sin(2 pi t) V) charging ``C`` [F] (default 0.05) through ``R`` [ohm]
    (default 2), the capacitor empty at the start."""

    def __init__(self, v_ref=None, R=2.0, C=0.05, **kw):
        super().__init__(**kw)
        self._v_ref, self._R_value, self._C_value = v_ref, R, C

    def build(self):
        self.src = PrescribedVoltage(v_ref=10 * sp.sin(2 * sp.pi * time) if self._v_ref is None else self._v_ref)
        self.R = Resistor(R=self._R_value)
        self.C = Capacitor(C=self._C_value, v=Start(0.0))
        self.gnd = Ground()
        connect(self.src.p, self.R.p)
        connect(self.R.n, self.C.p)
        connect(self.C.n, self.src.n, self.gnd.p)


class Bridge6(Model):
    """Three-phase six-pulse diode bridge (100 V, 50 Hz) on 20 ohm || 100 uF, the capacitor empty at the start:
    six ideal diodes whose commutations cascade, some at their knee."""

    def build(self):
        self.gnd = Ground()
        for k in range(3):
            setattr(self, f"src{k}", PrescribedVoltage(v_ref=100.0 * sp.sin(2 * sp.pi * 50 * time - 2 * sp.pi * k / 3)))
            setattr(self, f"up{k}", IdealDiode())
            setattr(self, f"lo{k}", IdealDiode())
        self.R, self.C = Resistor(R=20.0), Capacitor(C=1e-4, v=Start(0.0))
        for k in range(3):
            s, up, lo = getattr(self, f"src{k}"), getattr(self, f"up{k}"), getattr(self, f"lo{k}")
            connect(s.p, up.p, lo.n)
            connect(s.n, self.gnd.p) if k == 0 else connect(s.n, self.src0.n)
        connect(self.up0.n, self.up1.n, self.up2.n, self.R.p, self.C.p)
        connect(self.lo0.p, self.lo1.p, self.lo2.p, self.R.n, self.C.n)
