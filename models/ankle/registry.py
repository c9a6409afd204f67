"""The registry of ankle-drive models that the bench protocol and ``acausal compare`` run.

Each entry (:class:`ModelSpec`) says how to build the model (a class of :mod:`acausal.models` named by its
module path and its options, imported only when the model is built, so listing the registry loads no model),
how a condition becomes run-time parameters and inputs, and the motor's and driver's limits it is checked against.
The energy accounts and measurement points are not listed here: they are found from the model's components
(:attr:`acausal.CompiledModel.accounts`). Models that differ only in parameters (the windings) share one compiled
model (``build_key``).
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass, field

import numpy as np

from acausal import ModelError
from acausal.library.drives import EPOS2

from . import windings

RPM = 2 * np.pi / 60.0
#: every MACCEPA actuator of the registry has the frictional linkage; the ``library`` preset sets its friction to
#: zero (the paper's lossless Eq. 1-3), ``paper_fit`` to the inferred values
LINKAGE = {"linkage": "frictional"}


@dataclass(frozen=True)
class Limits:
    """Ratings a run is checked against (``docs/parameters.md``)."""

    motor_speed: float = 25000 * RPM  # rad/s: the motor's maximum speed (maxon: 25 000 rpm)
    nominal_torque: float = 0.095  # N m: the motor's nominal (continuous, thermal) torque
    driver_current_peak: float = 25.0  # A: EPOS2 70/10 peak output current
    driver_current_continuous: float = 10.0  # A: EPOS2 70/10 continuous output current
    duty: float = EPOS2.d_max.default  # the EPOS2's output voltage is at most about 0.9 of its supply


def _resolve(ref: str):
    """``"module:attribute"`` (module relative to acausal.models) -> the object."""
    module, _, attr = ref.partition(":")
    return getattr(importlib.import_module(f"acausal.models.{module}"), attr) if attr else \
        importlib.import_module(f"acausal.models.{module}")


@dataclass(frozen=True)
class ModelSpec:
    """How to build and run one registered model (see the module docstring)."""

    name: str
    summary: str  # one line: what it is and what changes against the paper's actuator
    model: str  # "module:Class" under acausal.models
    options: dict = field(default_factory=dict)  # constructor keywords
    inputs: str = ""  # "module:function" (spec, run-time parameter values) -> {input: Signal}; "" = the model's own
    params: dict = field(default_factory=dict)  # fixed run-time parameter overrides
    uses_precompression: bool = True  # the condition's P sets P_nominal
    # energy balances within 3.3e-7 on the paper's grids (the rule is 1e-6); energies within 1e-6 of rtol 1e-8's,
    # which takes a fifth longer (balances within 1.3e-7)
    tol: dict = field(default_factory=lambda: dict(rtol=3e-8, atol=1e-10))
    build_key: str = ""  # models with the same key share a compiled model (default: the name)
    limits: Limits = Limits()
    min_points_per_stride: int = 0  # output resolution needed (a model without states is integrated on it)
    # simulated strides of a protocol condition, the last one evaluated. The gait is periodic, so any stride-long
    # window is a stride: 1.25 lets a replay's bus settle for a quarter stride (microseconds would do; the energies
    # equal those of a second whole stride to 1e-7); a closed loop needs a whole stride for its controller to settle
    strides: float = 1.25
    doc_from: str = ""  # "module" whose docstring says what changes against the paper's actuator and why

    @property
    def key(self) -> str:
        return self.build_key or self.name

    def build(self):
        """A new instance of the model."""
        return _resolve(self.model)(**self.options)

    def condition_inputs(self, values: dict) -> dict:
        """Inputs for a run with run-time parameter values ``values`` (every parameter of the model by name)."""
        return _resolve(self.inputs)(self, values) if self.inputs else {}

    @property
    def doc(self) -> str:
        """What changes against the paper's actuator and why (the docstring of the module that says so)."""
        return _resolve(self.doc_from or self.model.partition(":")[0]).__doc__ or ""


def _winding(name: str) -> ModelSpec:
    w = windings.WINDINGS[name]
    return ModelSpec(f"winding_{name}", f"the paper's actuator with the motor's {name} winding and a {w['V']:g} V "
                     "supply (R_int, brake threshold scaled)", "ankle.actuator:AnkleActuator", LINKAGE,
                     params=windings.winding_params(name), build_key="replay",
                     limits=Limits(nominal_torque=w["nominal_torque"]), doc_from="ankle.windings")


_SPECS = [
    ModelSpec("replay", "the paper's actuator: MACCEPA series spring, replayed along the planned moment-arm angle",
              "ankle.actuator:AnkleActuator", LINKAGE),
    ModelSpec("closed_loop", "the paper's actuator under PID control within the bus voltage (tracking error)",
              "ankle.actuator:AnkleActuator", {"mode": "closed_loop", **LINKAGE},
              tol=dict(rtol=1e-7, atol=1e-9), strides=2.0),  # balances within 6.5e-7 on the paper's grids
    ModelSpec("direct_drive", "no spring: the same motor and gears move the joint along the gait (paper Fig. 7)",
              "drivetrains.direct_drive:DirectDrive", uses_precompression=False),
    ModelSpec("bench_output_motor", "the bench's output motor imposing the gait angle while the actuator pushes the "
              "joint (the paper's direct drive of Fig. 7; drive train guessed as the actuator's)",
              "drivetrains.direct_drive:BenchOutputMotor", uses_precompression=False),
    ModelSpec("sea", "linear torsion spring in place of the MACCEPA, stiffness by the paper's peak-power criterion",
              "drivetrains.sea:SeriesElastic", uses_precompression=False),
    ModelSpec("parallel_elastic", "torsion spring in parallel with the joint plus the drive (no series spring)",
              "drivetrains.parallel_elastic:ParallelElastic", uses_precompression=False),
    ModelSpec("self_locking", "MACCEPA with a self-locking (non-backdrivable) 10:1 worm stage, driver always on",
              "drivetrains.switch_off:SelfLockingMaccepa", LINKAGE, inputs="drivetrains.switch_off:condition_inputs"),
    ModelSpec("switch_off", "MACCEPA, self-locking worm stage, driver switched off while little torque is needed",
              "drivetrains.switch_off:SelfLockingMaccepa", LINKAGE, inputs="drivetrains.switch_off:condition_inputs",
              build_key="self_locking"),
    _winding("24V"),
    _winding("36V"),
    # without the rectifier's bus capacitor the replay has no states: energies are integrated on the output grid,
    # which must resolve the kinks of |i| in the driver's switching loss (1601 points: balance to ~1e-10)
    ModelSpec("battery", "the paper's actuator on a battery (48 V, 0.05 ohm) that takes regenerated energy back",
              "ankle.actuator:AnkleActuator", {"supply": "battery", **LINKAGE}, min_points_per_stride=1601,
              doc_from="drivetrains.battery"),
]

MODELS = {s.name: s for s in _SPECS}


def spec(name: str) -> ModelSpec:
    """The registered model ``name``; an unknown name is a :class:`ModelError` listing the known ones."""
    try:
        return MODELS[name]
    except (KeyError, TypeError):
        raise ModelError(f"unknown model {name!r}; known models: {', '.join(MODELS)}") from None
