"""A session's slow state: the winding temperature carried from one recording to the next.

Recordings made one after another on one bench form a *session* (their JSON ``session_time_s`` says when each
started). The winding does not cool to ambient between them: with the motor's 1180 s time constant a recording
starts about as warm as the one before ended, less what it lost over the pause. The ``winding_temperature``
candidate therefore does not start every recording at ambient when the recordings form a session: recording ``k``
starts ``theta_k`` above ambient,

    theta_0 = 0  (the session starts cold),
    theta_k = theta_end,k-1 * exp(-gap_k * G * h)      (the lumped motor cooling over the pause),

with ``theta_end,k-1`` the winding's excess temperature at the end of the previous recording, ``gap_k`` the pause
between the two (``session_time_s`` of ``k`` minus the previous recording's start and length), ``G`` the motor's
conductance to ambient (``winding_G``, fitted with the candidate from the datasheet's
:data:`~acausal.models.ankle.actuator.WINDING_G`) and ``h`` the fitted ``winding_heating``
(1 / heat capacity). The start enters the replay as the parameter ``winding_excess`` (a
:class:`~acausal.library.thermal.DecayingTemperatureStep`), so the chain has exact derivatives: every recording's
sensitivities to the fitted parameters include their effect through the starts of all recordings before it.
Whatever happened between recordings other than cooling (settling strides before a recording starts, another
load) is not seen; the first recording is assumed to start at ambient.

Recordings that do not say when each was made (no ``session_time_s``) cannot carry a temperature from one to the
next; the winding candidate then gives each recording its own start temperature, a parameter fitted with the rest
(:func:`free_winding_starts`), so a winding warming over an unrecorded session is still testable (by the
starts' differences: an offset common to them all is the same as a higher resistance).
"""
from __future__ import annotations

import numpy as np

from acausal import DataError
from acausal.identify.evidence import PER_EXPERIMENT
from acausal.library.drives import DCMotor

from ..ankle.actuator import WINDING_G
from ..ankle.effects import EFFECTS
from .calibration import REPLAY_TOL
from .recording_format import SIGNALS

HEATING = EFFECTS["winding_temperature"].parameter
EXCESS, START, CONDUCTANCE = "winding_excess", "winding_t0", "winding_G"
REPLAY_PARAMS = "replay_params"  # an experiment's info key: values -> the parameters its replay runs with
WINDING_T = "motor.heat_port.T"  # the winding's temperature in the replay model [K]


def own_start(name: str) -> str:
    """The parameter holding recording ``name``'s winding start (excess over ambient, K) when the recordings do
    not form a session."""
    return f"{EXCESS}{PER_EXPERIMENT}{name}"


def free_winding_starts(exps) -> None:
    """Rewrite the ``predict`` and ``sensitivity`` of ``exps`` (replays with the winding effect, recordings that do
    not say when each was made) so that each starts at its own winding temperature, the parameter
    :func:`own_start` of its name: a winding warming over an unrecorded session is then one start temperature per
    recording, fitted with the rest, instead of every recording starting at ambient."""
    for e in exps:
        own, t0 = own_start(e.name), float(e.t[0])
        predict, sensitivity = e.predict, e.sensitivity

        def mapped(values, own=own, t0=t0):
            kept = {k: v for k, v in values.items() if PER_EXPERIMENT not in k}
            return {**kept, EXCESS: float(values.get(own, 0.0)), START: t0}

        e.predict = (lambda values, f=predict, m=mapped: f(m(values)))
        e.info[REPLAY_PARAMS] = (lambda values, m=mapped, e=e: {**e.info["params"], **m(values)})
        if sensitivity is not None:
            e.sensitivity = (lambda values, names, f=sensitivity, m=mapped, own=own:
                             _own_rows(f, m(values), list(names), own))


def _own_rows(sensitivity, values, names, own):
    """Sensitivities to ``names`` where this recording's start parameter ``own`` is the model's
    :data:`EXCESS` and the other recordings' starts have none (zero rows)."""
    asked = [n for n in names if PER_EXPERIMENT not in n or n == own]
    pred, sens = sensitivity(values, [EXCESS if n == own else n for n in asked])
    rows = [k for k, n in enumerate(names) if PER_EXPERIMENT not in n or n == own]
    full = {}
    for c, S in sens.items():
        out = np.zeros((len(names),) + np.shape(S)[1:])
        out[rows] = S
        full[c] = out
    return pred, full


def is_session(recordings) -> bool:
    """Every recording says when it started (JSON ``session_time_s``); :func:`check_session` first."""
    return bool(recordings) and all("session_time_s" in r.meta for r in recordings)


#: the longest a session may span [s]: one sitting at the bench (the winding cools to ambient within about an hour;
#: a longer span is session times in another unit, or recordings of several sessions)
MAX_SESSION_S = 24 * 3600.0


def check_session(recordings) -> None:
    """A DataError naming the recordings where the session times cannot be what they say: some recordings with
    ``session_time_s`` and some without (session handling would silently be off), a recording that starts before
    the one before it ended (equal or overlapping times: the pause would be clamped to none), or a session longer
    than :data:`MAX_SESSION_S` (times in ms)."""
    have = [r for r in recordings if "session_time_s" in r.meta]
    if not have:
        return
    if len(have) < len(recordings):
        lacking = [r.name for r in recordings if "session_time_s" not in r.meta]
        raise DataError(f"{len(have)} of {len(recordings)} recordings say when they were made (JSON "
                        f"session_time_s) and {len(lacking)} do not ({', '.join(lacking[:3])}"
                        f"{', ...' if len(lacking) > 3 else ''}): give it to every recording of the session, or to "
                        "none")
    ordered = sorted(have, key=lambda r: r.meta["session_time_s"])
    for a, b in zip(ordered, ordered[1:]):
        ta, tb, length = float(a.meta["session_time_s"]), float(b.meta["session_time_s"]), float(a.t[-1] - a.t[0])
        if tb < ta + length - 1e-6 * max(1.0, length):
            raise DataError(f"{b.path or b.name}: session_time_s = {tb:g} s, but {a.name} started at {ta:g} s and "
                            f"lasts {length:.4g} s: the recordings overlap (equal or wrong session times, or "
                            "times in another unit than seconds)")
    span = float(ordered[-1].meta["session_time_s"]) - float(ordered[0].meta["session_time_s"])
    if span > MAX_SESSION_S:
        raise DataError(f"{ordered[-1].path or ordered[-1].name}: session_time_s = "
                        f"{float(ordered[-1].meta['session_time_s']):g} s, {span / 3600:.4g} h after the first "
                        f"recording; a session is one sitting at the bench (at most {MAX_SESSION_S / 3600:g} h): "
                        "session times in ms, or recordings of several sessions")


def carry_winding(exps, cm) -> None:
    """Rewrite the ``predict`` and ``sensitivity`` of ``exps`` (replays with the winding effect, in session order,
    model ``cm``) so that each starts at the temperature the previous one left (module docstring)."""
    chain = _Chain(exps, cm)
    for k, e in enumerate(exps):
        e.predict = (lambda values, k=k: chain.run(k, values, ())[0])
        e.sensitivity = (lambda values, names, k=k: chain.run(k, values, tuple(names))[:2])
        e.info["session_gap_s"] = chain.gaps[k]
        e.info[REPLAY_PARAMS] = (lambda values, k=k: chain.params(k, values))


def replay_params(exp, values: dict) -> dict:
    """The parameters recording ``exp``'s replay runs with at the fit's ``values``: its own and the fit's, with its
    winding start where the winding candidate set one (carried over the session, or its own start parameter); what
    a report's extra simulation of a recording must take, so that it replays what the fit replayed."""
    if REPLAY_PARAMS in exp.info:
        return exp.info[REPLAY_PARAMS](values)
    return {**exp.info["params"], **values}


class _Chain:
    """The session's replays run in order at one parameter set, each from the previous one's end temperature;
    results are kept for the last few parameter sets (a calibration asks for values, then derivatives, at the same
    point, recording by recording)."""

    KEEP = 4

    def __init__(self, exps, cm):
        self.exps, self.cm = list(exps), cm
        starts = [float(e.info["meta"]["session_time_s"]) for e in self.exps]
        # check_session refused overlaps; what is left below zero is rounding
        self.gaps = [0.0] + [max(starts[k] - starts[k - 1] - float(self.exps[k - 1].t[-1] - self.exps[k - 1].t[0]),
                                 0.0) for k in range(1, len(self.exps))]
        self._memo: dict = {}

    def run(self, k: int, values: dict, names: tuple) -> tuple:
        """``(predicted, sensitivities or None, theta_end, dtheta_end)`` of recording ``k`` at ``values``."""
        key = (tuple(sorted(values.items())), names)
        runs = self._memo.get(key)
        if runs is None:
            if len(self._memo) >= self.KEEP:
                self._memo.pop(next(iter(self._memo)))
            runs = self._memo[key] = {}
        if k not in runs:
            runs[k] = self._replay(k, values, names)
        return runs[k]

    def params(self, k: int, values: dict) -> dict:
        """The parameters recording ``k`` replays with at ``values``: the fit's, with its start temperature."""
        theta0 = 0.0
        if k:
            *_, theta_end, _ = self.run(k - 1, values, ())
            theta0 = theta_end * self._decay(k, values)
        return {**self.exps[k].info["params"], **values, EXCESS: theta0, START: float(self.exps[k].t[0])}

    def _decay(self, k, values) -> float:
        e = self.exps[k]
        h = float(values.get(HEATING, e.info["params"].get(HEATING, EFFECTS["winding_temperature"].typical)))
        G = float(values.get(CONDUCTANCE, e.info["params"].get(CONDUCTANCE, WINDING_G)))
        return float(np.exp(-self.gaps[k] * G * h))

    def _replay(self, k, values, names):
        e = self.exps[k]
        q = len(names)
        theta0, dtheta0 = 0.0, np.zeros(q)
        if k:
            *_, theta_end, dtheta_end = self.run(k - 1, values, names)
            h = float(values.get(HEATING, e.info["params"].get(HEATING, EFFECTS["winding_temperature"].typical)))
            G = float(values.get(CONDUCTANCE, e.info["params"].get(CONDUCTANCE, WINDING_G)))
            decay = np.exp(-self.gaps[k] * G * h)
            theta0 = theta_end * decay
            dtheta0 = decay * dtheta_end
            if HEATING in names:
                dtheta0[names.index(HEATING)] -= self.gaps[k] * G * theta_end * decay
            if CONDUCTANCE in names:
                dtheta0[names.index(CONDUCTANCE)] -= self.gaps[k] * h * theta_end * decay
        params = {**e.info["params"], **values, EXCESS: theta0, START: float(e.t[0])}
        ambient = float(params.get("motor.T_ref", DCMotor.T_ref.default))
        cols = {c: v for c, v in SIGNALS.items() if c in e.measured}
        if not names:
            res = self.cm.simulate(e.t[-1], t_start=e.t[0], t_eval=e.t, params=params, inputs=e.info["inputs"],
                                   dense_output=False, **REPLAY_TOL)
            pred = {c: np.asarray(res[v]) for c, v in cols.items()}
            return pred, None, float(res[WINDING_T][-1]) - ambient, dtheta0
        wanted = list(cols.values()) + [WINDING_T]
        vals, S = self.cm.sensitivities(e.t, list(names) + [EXCESS], names=wanted, params=params,
                                        inputs=e.info["inputs"], t_start=e.t[0])
        pred, sens = {}, {}
        for c, v in cols.items():
            s = np.asarray(S[v])
            pred[c] = np.asarray(vals[v])
            sens[c] = s[:q] + np.outer(dtheta0, s[q])  # through this recording's start temperature
        sT = np.asarray(S[WINDING_T])
        return pred, sens, float(vals[WINDING_T][-1]) - ambient, sT[:q, -1] + dtheta0 * sT[q, -1]
