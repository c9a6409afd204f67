"""BAM's published XL330 friction models (Rhoban/bam, Apache-2.0) replayed on this model.

``data/xl330/published.json`` holds BAM's parameter files for the XL330 (models m1-m6 on BAM's main branch, and m1
of the commit that recorded these logs) and the scores the data set's README quotes (BAM's own simulator on these
16 logs, and BAM's branch scores on its full data). :func:`replay` maps a set onto
:class:`~.model.ServoPendulum` with BAM's own load measure (the friction sees ``G = |tau_ext - tau_motor|``, the
arm's gravity torque minus the motor's: ``load_measure="external"`` of
:class:`~acausal.library.friction.GearFriction`) and scores it the way the diagnosis does (closed loop from the
logged goal, mean absolute position error):

==========================================  ======================================  ==================================
BAM                                         here                                    model
==========================================  ======================================  ==================================
kt, R, armature                             servo.kt, servo.R, servo.armature       all
q_offset                                    pendulum.phi0                           all
friction_base, friction_viscous             servo.tau_c, servo.d                    M1 and up
friction_stribeck, dtheta_stribeck, alpha   servo.friction.tau_s, w_s, alpha        M2, M4-M6
load_friction_base                          servo.friction.k_l                      M3, M4
load_friction_stribeck                      servo.friction.k_ls                     M4
load_friction_motor, _external (_stribeck)  servo.friction.k_m, k_e (k_ms, k_es)    M5, M6
load_friction_motor_quad, _external_quad    servo.friction.k_mq, k_eq               M6
==========================================  ======================================  ==================================

BAM integrates with explicit Euler at the log's time step and clips the friction so it cannot reverse the motion
within a step; this model integrates continuously with a smooth Coulomb law (see :mod:`acausal.library.friction`),
so the same parameters score slightly differently here (a few mrad).
"""
from __future__ import annotations

import json
from importlib import resources

import numpy as np

from .problem import ReplayBatch, replay_tolerance, resolution
from .recording_format import POSITION

#: BAM parameter name -> our parameter
MAPPING = {"kt": "servo.kt", "R": "servo.R", "armature": "servo.armature", "q_offset": "pendulum.phi0",
           "friction_base": "servo.tau_c", "friction_viscous": "servo.d", "friction_stribeck": "servo.friction.tau_s",
           "dtheta_stribeck": "servo.friction.w_s", "alpha": "servo.friction.alpha",
           "load_friction_base": "servo.friction.k_l", "load_friction_stribeck": "servo.friction.k_ls",
           "load_friction_motor": "servo.friction.k_m", "load_friction_external": "servo.friction.k_e",
           "load_friction_motor_stribeck": "servo.friction.k_ms",
           "load_friction_external_stribeck": "servo.friction.k_es",
           "load_friction_motor_quad": "servo.friction.k_mq", "load_friction_external_quad": "servo.friction.k_eq"}

#: the friction terms of each BAM model (BAM ``bam/model.py``: M2 Stribeck, M3 load-dependent, M4 with its Stribeck
#: part, M5 directional, M6 quadratic)
TERMS = {"m1": ("coulomb",), "m2": ("coulomb", "stribeck"), "m3": ("coulomb", "load"),
         "m4": ("coulomb", "stribeck", "load", "load_stribeck"), "m5": ("coulomb", "stribeck", "directional"),
         "m6": ("coulomb", "stribeck", "directional", "quadratic")}


def published() -> dict:
    """The shipped record of BAM's published parameters and scores."""
    return json.loads(resources.files("acausal.models.servo").joinpath("data/xl330/published.json").read_text())


def mapped(params: dict) -> dict:
    """A BAM parameter set as parameter values of :class:`~.model.ServoPendulum`."""
    return {MAPPING[k]: float(v) for k, v in params.items() if k in MAPPING}


def replay_set(recordings, label: str, params: dict, executor=None) -> dict:
    """Mean absolute position error of BAM set ``label`` on each recording: ``{recording name: mae}``. The replays
    take the diagnosis's fixed step with its checked substeps (a quarter of the reading's noise)."""
    model = label.split()[-1]
    key = (TERMS[model], (), "external")
    values = mapped(params)
    batch = ReplayBatch(key, list(recordings), [False] * len(recordings), executor,
                        replay_tolerance(resolution(recordings)))
    return {r.name: float(np.mean(np.abs(batch.get(k, values)[0] - r[POSITION]))) for k, r in enumerate(recordings)}


def replay_all(recordings, executor=None) -> list:
    """Rows ``{"set", "mae", "mae_bam_simulator", per-trajectory maes}`` for every replayable published set."""
    rec = published()
    rows = []
    for label, params in rec["sets"].items():
        if label.split()[-1] not in TERMS:
            continue
        per = replay_set(recordings, label, params, executor)
        row = {"set": f"BAM {label}", "mae": float(np.mean(list(per.values()))),
               "mae_bam_simulator": rec["bam_replay_mae_rad"].get(label)}
        for traj in sorted({r.meta.get("trajectory_name", "") for r in recordings}):
            row[traj or "all"] = float(np.mean([per[r.name] for r in recordings
                                                if r.meta.get("trajectory_name", "") == traj]))
        rows.append(row)
    return rows
