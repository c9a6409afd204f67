"""BAM's published XL330 friction models (Rhoban/bam, Apache-2.0) replayed on this model.

``data/xl330/published.json`` holds BAM's parameter files for the XL330 (models m1-m6 on BAM's main branch, and m1
of the commit that recorded these logs) and the scores the data set's README quotes (BAM's own simulator on these
16 logs, and BAM's branch scores on its full data). :func:`replay` maps a set onto
:class:`~.model.ServoPendulum` and scores it the way the diagnosis does (closed loop from the logged goal, mean
absolute position error):

=====================  ==========================  ===========================================================
BAM                    here                        note
=====================  ==========================  ===========================================================
kt, R, armature        servo.kt, servo.R,          output-side motor constant, winding resistance, reflected
                       servo.armature              rotor inertia: the same quantities
q_offset               pendulum.phi0               gravity acts at q + q_offset in both
friction_base, _viscous  servo.tau_c, servo.d      Coulomb budget and viscous coefficient (BAM M1)
friction_stribeck,     servo.friction.tau_s, w_s,  Stribeck budget ``exp(-(|w|/w_s)^alpha)`` (BAM M2)
dtheta_stribeck, alpha alpha
load_friction_base     servo.friction.k_l          BAM M3 multiplies ``|tau_external - tau_motor|``; here the
                                                   budget grows with the transmitted motor torque
                                                   ``|tau_motor|``, which is half of BAM's measure while the
                                                   motor holds the arm still, so ``k_l = 2 Kl`` (an
                                                   approximation: the two differ while the arm accelerates)
=====================  ==========================  ===========================================================

M4-M6 (directional, quadratic) have no exact counterpart and are not replayed. BAM integrates with explicit Euler
at the log's time step and clips the friction so it cannot reverse the motion within a step; this model
integrates continuously with a smooth Coulomb law (see :mod:`acausal.library.friction`), so the same parameters
score slightly differently here (a few mrad).
"""
from __future__ import annotations

import json
from importlib import resources

import numpy as np

from .problem import replay, replay_job
from .recording_format import POSITION

#: BAM parameter name -> (our parameter, factor)
MAPPING = {"kt": ("servo.kt", 1.0), "R": ("servo.R", 1.0), "armature": ("servo.armature", 1.0),
           "q_offset": ("pendulum.phi0", 1.0), "friction_base": ("servo.tau_c", 1.0),
           "friction_viscous": ("servo.d", 1.0), "friction_stribeck": ("servo.friction.tau_s", 1.0),
           "dtheta_stribeck": ("servo.friction.w_s", 1.0), "alpha": ("servo.friction.alpha", 1.0),
           "load_friction_base": ("servo.friction.k_l", 2.0)}

#: the friction terms each replayable BAM model needs
TERMS = {"m1": ("coulomb",), "m2": ("coulomb", "stribeck"), "m3": ("coulomb", "load")}


def published() -> dict:
    """The shipped record of BAM's published parameters and scores."""
    return json.loads(resources.files("acausal.models.servo").joinpath("data/xl330/published.json").read_text())


def mapped(params: dict) -> dict:
    """A BAM parameter set as parameter values of :class:`~.model.ServoPendulum`."""
    return {MAPPING[k][0]: float(v) * MAPPING[k][1] for k, v in params.items() if k in MAPPING}


def replay_set(recordings, label: str, params: dict, executor=None) -> dict:
    """Mean absolute position error of BAM set ``label`` on each recording: ``{recording name: mae}``."""
    model = label.split()[-1]
    terms = TERMS[model]
    values = mapped(params)
    jobs = [replay_job(terms, r, values) for r in recordings]
    runner = executor.map if executor is not None else map
    out = {}
    for r, (pos, _) in zip(recordings, runner(replay, jobs)):
        out[r.name] = float(np.mean(np.abs(pos - r[POSITION])))
    return out


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
