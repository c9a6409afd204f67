"""The registry of ankle-actuator models that the bench protocol and ``acausal compare`` run.

Each entry (:class:`ModelSpec`) says how to build the model, which variables are its five measurement points,
which loss powers and stored energies make up its energy balance, how a condition (precompression, stride
time, parameter overrides) becomes run-time parameters and inputs, and the motor's and driver's limits it is
checked against. Models that differ only in parameters (the windings) share one compiled model (``build_key``).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from acausal import ModelError

from . import cyberlegs, direct_drive, parallel_elastic, regenerative, sea, switch_off, windings
from .elastic import MEASUREMENT_POINTS

RPM = 2 * np.pi / 60.0


@dataclass(frozen=True)
class Limits:
    """Ratings a run is checked against (``../shared/data/parameters.md``)."""

    motor_speed: float = 25000 * RPM  # rad/s: the motor's maximum speed (maxon: 25 000 rpm)
    nominal_torque: float = 0.095  # N m: the motor's nominal (continuous, thermal) torque
    driver_current_peak: float = 25.0  # A: EPOS2 70/10 peak output current
    driver_current_continuous: float = 10.0  # A: EPOS2 70/10 continuous output current
    duty: float = 0.9  # the EPOS2's output voltage is at most about 0.9 of its supply


@dataclass(frozen=True)
class ModelSpec:
    """How to build, run and account one registered model (see the module docstring)."""

    name: str
    summary: str  # one line: what it is and what changes against the paper's actuator
    build: Callable  # () -> Model
    accounts: dict  # {"loss_groups": {stage: [loss power names]}, "stored": [stored energy names]}
    inputs: Callable | None = None  # (P [m], params) -> {input name: Signal}
    params: dict = field(default_factory=dict)  # fixed run-time parameter overrides
    uses_precompression: bool = True  # the condition's P sets link.P
    tol: dict = field(default_factory=lambda: dict(rtol=1e-8, atol=1e-10))
    build_key: str = ""  # models with the same key share a compiled model (default: the name)
    points: tuple = tuple(MEASUREMENT_POINTS)
    limits: Limits = Limits()
    min_points_per_stride: int = 0  # output resolution needed (a model without states is integrated on it)
    doc: str = ""  # the docstring that says what changes against the paper's actuator and why

    @property
    def losses(self) -> list:
        return [n for group in self.accounts["loss_groups"].values() for n in group]

    @property
    def key(self) -> str:
        return self.build_key or self.name


def _cyberlegs_accounts() -> dict:
    return {"loss_groups": {k: list(v) for k, v in cyberlegs.LOSS_GROUPS.items()}, "stored": list(cyberlegs.STORED)}


def _maccepa_inputs(P, params):
    return cyberlegs.condition_inputs(P, k=float(params.get("link.k", 132e3)), A=float(params.get("link.A", 0.1)),
                                      B=float(params.get("link.B", 0.06)),
                                      body_mass=float(params.get("body_mass", 60.0)))


def _winding(name: str) -> ModelSpec:
    w = windings.WINDINGS[name]
    return ModelSpec(f"winding_{name}", f"the paper's actuator with the motor's {name} winding and a {w['V']:g} V "
                     "supply (R_int, brake threshold scaled)", lambda: cyberlegs.CyberlegsAnkle(mode="replay"),
                     _cyberlegs_accounts(), _maccepa_inputs, params=windings.winding_params(name), build_key="replay",
                     limits=Limits(nominal_torque=w["nominal_torque"]), doc=windings.__doc__)


_direct_accounts = _cyberlegs_accounts()
_direct_accounts["stored"] = [n for n in _direct_accounts["stored"] if n != "link.energy"]

_SPECS = [
    ModelSpec("replay", "the paper's actuator: MACCEPA series spring, replayed along the planned moment-arm angle",
              lambda: cyberlegs.CyberlegsAnkle(mode="replay"), _cyberlegs_accounts(), _maccepa_inputs,
              doc=cyberlegs.__doc__),
    ModelSpec("closed_loop", "the paper's actuator under PID control within the bus voltage (tracking error)",
              lambda: cyberlegs.CyberlegsAnkle(mode="closed_loop"), _cyberlegs_accounts(), _maccepa_inputs,
              tol=dict(rtol=1e-6, atol=1e-8), doc=cyberlegs.__doc__),
    ModelSpec("direct_drive", "no spring: the same motor and gears move the joint along the gait (paper Fig. 7)",
              direct_drive.DirectDrive, _direct_accounts, uses_precompression=False,
              points=tuple(direct_drive.MEASUREMENT_POINTS), doc=direct_drive.__doc__),
    ModelSpec("sea", "linear torsion spring in place of the MACCEPA, stiffness by the paper's peak-power criterion",
              sea.SeriesElastic, sea.accounts(), lambda P, params: sea.condition_inputs(params),
              uses_precompression=False, doc=sea.__doc__),
    ModelSpec("parallel_elastic", "torsion spring in parallel with the joint plus the drive (no series spring)",
              parallel_elastic.ParallelElastic, parallel_elastic.accounts(), uses_precompression=False,
              points=tuple(parallel_elastic.MEASUREMENT_POINTS), doc=parallel_elastic.__doc__),
    ModelSpec("self_locking", "MACCEPA with a self-locking (non-backdrivable) 10:1 worm stage, driver always on",
              switch_off.SelfLockingMaccepa, switch_off.accounts(),
              lambda P, params: switch_off.condition_inputs(P, params, switching=False), doc=switch_off.__doc__),
    ModelSpec("switch_off", "MACCEPA, self-locking worm stage, driver switched off while little torque is needed",
              switch_off.SelfLockingMaccepa, switch_off.accounts(),
              lambda P, params: switch_off.condition_inputs(P, params, switching=True), build_key="self_locking",
              doc=switch_off.__doc__),
    _winding("24V"),
    _winding("36V"),
    # without the rectifier's bus capacitor the replay has no states: energies are integrated on the output grid,
    # which must resolve the kinks of |i| in the driver's switching loss (1601 points: balance to ~1e-10)
    ModelSpec("battery", "the paper's actuator on a battery (48 V, 0.05 ohm) that takes regenerated energy back",
              regenerative.RegenerativeAnkle, regenerative.accounts(), _maccepa_inputs, min_points_per_stride=1601,
              doc=regenerative.__doc__),
]

MODELS = {s.name: s for s in _SPECS}


def spec(name: str) -> ModelSpec:
    """The registered model ``name``; an unknown name is a :class:`ModelError` listing the known ones."""
    try:
        return MODELS[name]
    except (KeyError, TypeError):
        raise ModelError(f"unknown model {name!r}; known models: {', '.join(MODELS)}") from None
