"""The servo recordings as a calibration and diagnosis problem (``acausal diagnose --model servo_pendulum``).

Each recording is replayed in closed loop: the model starts at the first measured position, at rest, and follows
the logged goal, supply voltage and torque enable; its simulated position is compared with the measured one
(there is no current or torque measurement; BAM scores its models the same way). Residuals are counted in units of
the position reading's quantisation noise (one encoder step ``q`` over sqrt(12); ``q`` is the smallest position
change in the data, so another servo's resolution is found, not typed).

* **Baseline**: Coulomb + viscous friction at the output (BAM's M1): ``servo.kt``, ``servo.R``,
  ``servo.armature``, ``pendulum.phi0`` (mounting offset), ``servo.tau_c``, ``servo.d``.
* **Candidates** (one parameter each, zero = absent): the library of :mod:`~.effects` across the chain (friction
  laws, firmware, electrics, sensing), plus a user's own (``extra``: :func:`~.effects.user_effect` records).
* **Held out**: by default every recording at one gain ``kp`` (the middle of the distinct values; BAM's
  ``--validation_kp``), else one trajectory, else every fourth recording; ``Split`` chooses another. Training
  recordings are cut into ``segment`` second pieces: the groups of the leave-one-group-out score.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from acausal import DataError
from acausal.identify.calibrate import Experiment, Free
from acausal.identify.diagnose import Problem, Thresholds, diagnose
from acausal.simulation.compiled.substep_control import SubstepControl, fixed_step_runs

from . import bam_logs, effects as fx
from .model import BASELINE, READING, compiled
from .recording_format import POSITION, inputs, inputs_from, replay_columns, rig_params, start

SIGNALS = (POSITION,)



#: the replays' integrator: RK4 on the recording's own samples (:mod:`acausal.simulation.compiled.fixed_step`), the
#: logged inputs linear inside each step, at first ``SUBSTEPS`` steps per sample interval, doubled per recording and
#: model while the fixed step's error exceeds :func:`replay_tolerance` (the fixed step's error control,
#: :class:`~acausal.simulation.compiled.substep_control.SubstepControl`, checked as the fit moves:
#: :class:`ReplayBatch`). On the XL330 set the baseline's replays with sensitivities take 4 to 8 substeps at a
#: fifth of the cost of CVODES at rtol 1e-5; the smooth Coulomb law's 0.01 rad/s (times the load friction's gain)
#: is what needs more, and the play of ``backlash`` 8 to 16 with its flanks (``effects.FLANKS``)
SUBSTEPS = 4
#: tolerances of a replay on CVODES (``substeps=None``): within 5e-5 rad of rtol 1e-8 on the XL330 set; with load
#: friction (``coulomb`` and ``load`` at the benchmark's parameters) within 2.1e-4 rad on the native loop (median
#: over the 16 recordings 6.6e-5) and 3.0e-4 on CasADi's CVODES (median 3.6e-5)
RTOL, ATOL = 1e-5, 1e-7


@dataclass(frozen=True)
class Split:
    """Which recordings are held out: ``by`` = ``"kp"`` (every recording at gain ``value``), ``"trajectory"``
    (every recording of trajectory ``value``) or ``"auto"`` (kp if the set has several gains, else trajectory,
    else every fourth recording); ``value=None`` takes the middle of the sorted distinct values.
    ``segment`` [s]: length of the pieces of a training recording scored leave-one-out."""

    by: str = "auto"
    value: object = None
    segment: float = 1.0

    def held_out(self, recordings) -> tuple:
        """``(mask over recordings, description)``."""
        if self.by not in ("auto", "kp", "trajectory"):
            raise DataError(f"split: by must be 'auto', 'kp' or 'trajectory', got {self.by!r}")
        kps = [r.meta["kp"] for r in recordings]
        trajs = [r.meta.get("trajectory_name", "") for r in recordings]
        by = self.by
        if by == "auto":
            by = "kp" if len(set(kps)) > 1 else "trajectory" if len(set(trajs)) > 1 else "every"
        if by == "every":
            if len(recordings) < 2:
                raise DataError("split: one recording cannot be split into training and held-out data")
            if len(recordings) < 4:  # every fourth would hold out none
                mask = np.arange(len(recordings)) == len(recordings) - 1
                return mask, (f"the last of {len(recordings)} recordings (one gain and one trajectory only; fewer "
                              "than four)")
            mask = np.arange(len(recordings)) % 4 == 3
            return mask, "every fourth recording (one gain and one trajectory only)"
        values = kps if by == "kp" else trajs
        distinct = sorted(set(values))
        value = distinct[len(distinct) // 2] if self.value is None else self.value
        if by == "kp" and self.value is not None:
            value = float(self.value)
        mask = np.array([v == value for v in values])
        if not mask.any():
            raise DataError(f"split: no recording has {by} = {value!r}; the set has {distinct}")
        if mask.all():
            raise DataError(f"split: every recording has {by} = {value!r}; nothing is left to fit on")
        what = f"kp = {value:g}" if by == "kp" else f"trajectory {value!r}"
        return mask, f"every recording at {what} held out ({int(mask.sum())} of {len(recordings)})"


def model_key(effects) -> tuple:
    """``(friction terms, inserted effects)`` of the baseline extended with ``effects`` (Effect records): what
    :func:`~.model.compiled` builds, and what a worker process needs to build the same model."""
    effects = tuple(effects)
    return fx.terms(effects), tuple(e for e in effects if e.slot not in ("friction", "parameter"))


def replay_job(key, rec, values: dict, names=(), substeps: int | None = SUBSTEPS) -> tuple:
    """The job of :func:`replay` for recording ``rec`` of model ``key`` (:func:`model_key`) with parameter
    ``values`` (over its rig's) and the sensitivities to ``names`` (none: the position only), integrated by RK4
    with ``substeps`` per sample interval (None: CVODES at :data:`RTOL`, :data:`ATOL`)."""
    return (key, rec.t, replay_columns(rec), {**rig_params(rec.meta), **values}, start(rec), tuple(names), substeps)


def replay(job: tuple) -> tuple:
    """One closed-loop replay (a module-level function, so a process pool can run it): ``job`` =
    ``(model key, t, input columns, params, starts, names, substeps)`` (:func:`replay_job`); returns
    ``(position, sens)`` with ``sens`` the sensitivities of the encoder's reading to ``names`` (shape
    ``(len(names), N)``), or ``None`` when ``names`` is empty."""
    key, t, columns, params, x0, names, substeps = job
    cm = compiled(*key)
    u = _inputs(t, columns)
    x0 = _starts(cm, x0)
    if substeps is not None and fixed_step_runs(cm):
        vals, S = cm.sensitivities(t, list(names), names=[READING], params=params, inputs=u, t_start=t[0],
                                   starts=x0, method="RK4", substeps=substeps)
        return np.asarray(vals[READING]), np.asarray(S[READING]) if names else None
    if not names:
        res = cm.simulate(t[-1], t_start=t[0], t_eval=t, params=params, inputs=u, starts=x0,
                          rtol=RTOL, atol=ATOL, dense_output=False)
        return np.asarray(res[READING]), None
    vals, S = cm.sensitivities(t, list(names), names=[READING], params=params, inputs=u, t_start=t[0],
                               starts=x0, rtol=RTOL, atol=ATOL)
    return np.asarray(vals[READING]), np.asarray(S[READING])


#: the inputs of the recordings a process replayed last (by content: the same objects for the same recording,
#: so a fit's replays reuse their stage values, :meth:`~acausal.simulation.compiled.fixed_step.FixedStep.run`)
_INPUTS: dict = {}


def _inputs(t, columns: dict) -> dict:
    """:func:`~.recording_format.inputs_from`, kept per content for the last 64 recordings of this process."""
    key = (t.tobytes(), *((c, v.tobytes()) for c, v in sorted(columns.items())))
    if key not in _INPUTS:
        if len(_INPUTS) >= 64:
            _INPUTS.pop(next(iter(_INPUTS)))
        _INPUTS[key] = inputs_from(t, columns)
    return _INPUTS[key]


def _starts(cm, x0: dict) -> dict:
    """The recording's start (arm at rest at the first reading) for every state of ``cm`` that carries it: the
    rotor's too when play separates it from the arm."""
    out = dict(x0)
    if "servo.rotor.phi" in cm.state_names:
        out.update({"servo.rotor.phi": x0["pendulum.phi"], "servo.rotor.w": 0.0})
    if any(s.endswith(".phi_rel") for s in cm.state_names) and "pendulum.phi" not in cm.state_names:
        out.pop("pendulum.phi", None)
    return out


class ReplayBatch:
    """The replays of one model's experiments, run together (through ``executor`` when given) the first time any
    of them is asked for with a parameter set, and kept for the other experiments' calls with the same set.
    Experiments are batched with those of the same role (fitted or held out), since a calibration asks only for
    the fitted ones.

    **Substeps** (RK4 per sample interval) are the fixed step's error control's
    (:class:`~acausal.simulation.compiled.substep_control.SubstepControl`, ``control``): chosen per recording at the
    first parameter set asked for (from ``start``) and held within ``tol`` [rad] of a replay at twice the substeps;
    at every new parameter set asked for with sensitivities (a fit's accepted iterates) or for the held-out
    recordings, the recording of the batch closest to its limit is checked (its replay at twice the substeps runs in
    the same call as the batch), and all of them again where it fails. ``start``: the substeps to start from (one
    number for every recording, or per recording; None: CVODES); ``extends``: the batch of the model this one
    extends, already checked: its substeps are taken and checked on the recording closest to its limit only (an
    extension at its zero is that model); ``parent``, ``index``: the batch and recording whose substeps a
    one-recording batch takes."""

    def __init__(self, key, recordings, held, executor, tol: float = np.inf, parent=None, index: int = 0,
                 start=SUBSTEPS, extends=None):
        self.key, self.recordings, self.held, self.executor = key, recordings, held, executor
        self.tol, self.parent, self.index = tol, parent, index
        start = start if isinstance(start, dict) else {j: start for j in range(len(recordings))}
        self.control = SubstepControl(compiled(*key), tol, start)
        if extends is not None and extends.control.chosen is not None:
            self.control.adopt(extends.control)
        self._cache: dict = {}

    def _map(self, jobs):
        return list((self.executor.map if self.executor is not None else map)(replay, jobs))

    def _positions(self, values: dict):
        """The control's ``run``: the replayed positions of ``(recording, substeps)`` pairs at ``values``."""
        def run(pairs):
            return [r[0] for r in self._map([replay_job(self.key, self.recordings[j], values, (), k)
                                             for j, k in pairs])]
        return run

    def _start(self, values: dict) -> None:
        """The substeps at the parameter set asked for first: those of the model extended (or of the parent), or
        chosen on every recording."""
        control = self.control
        if control.chosen is None and self.parent is not None and self.parent.control.chosen is not None:
            control.chosen, control.probe_next = {0: self.parent.control.chosen[self.index]}, True
        control.choose(self._positions(values))

    def _run(self, group: list, values: dict, names: tuple) -> list:
        """The replays of recordings ``group`` at ``values`` with sensitivities to ``names``; the substeps checked
        as the class docstring says."""
        self._start(values)
        control = self.control
        jobs = [replay_job(self.key, self.recordings[j], values, names, control.chosen[j]) for j in group]
        probe = None
        if names or control.probe_next or self.held[group[0]]:
            probe = control.nearest_limit(group)
        if probe is not None:
            jobs.append(replay_job(self.key, self.recordings[probe], values, (), 2 * control.chosen[probe]))
        results = self._map(jobs)
        if probe is None:
            return results
        fine = results.pop()
        if control.accepts(probe, results[group.index(probe)][0], fine[0]):
            return results
        control.chosen = control.refine(self._positions(values), control.chosen)
        return self._map([replay_job(self.key, self.recordings[j], values, names, control.chosen[j])
                          for j in group])

    def get(self, k: int, values: dict, names=()) -> tuple:
        key = (tuple(sorted(values.items())), tuple(names), bool(self.held[k]))
        if not names:  # a run with sensitivities at the same values has the position already
            near = next((v for k2, v in self._cache.items() if k2[0] == key[0] and k2[2] == key[2]), None)
            if near is not None:
                return near[k][0], None
        if key not in self._cache:
            group = [j for j in range(len(self.recordings)) if self.held[j] == self.held[k]]
            results = self._run(group, values, tuple(names))
            self._cache = {k2: v for k2, v in self._cache.items() if k2[1] != tuple(names) or k2[2] != key[2]}
            self._cache[key] = dict(zip(group, results))
        return self._cache[key][k]


def experiment(rec, k: int, batch: ReplayBatch, effects=(), held_out: bool = False, segment: float = 1.0) -> Experiment:
    """Recording ``rec`` (number ``k`` of ``batch``) as a closed-loop replay :class:`Experiment`."""
    t = rec.t
    piece = np.floor((t - t[0]) / segment).astype(int)

    def predict(values: dict) -> dict:
        return {POSITION: batch.get(k, values)[0]}

    def sensitivity(values: dict, names):
        pos, S = batch.get(k, values, tuple(names))
        return {POSITION: pos}, {POSITION: S}

    read = ~rec.masked_rows((POSITION,))  # a masked reading is left out of the residual (the replay runs on)
    train, test = np.full(t.size, not held_out) & read, np.full(t.size, held_out) & read
    # a closed-loop replay's position error carries over from one segment to the next: a recording is one cluster
    # of the standard errors
    return Experiment(rec.name, t, {POSITION: np.asarray(rec[POSITION])}, predict, train, test, piece,
                      info={"meta": rec.meta, "inputs": inputs(rec), "params": rig_params(rec.meta),
                            "effects": tuple(effects), "start": start(rec), "clusters": "recording"},
                      sensitivity=sensitivity, clusters=np.zeros(t.size, dtype=int),
                      solo=lambda: experiment(rec, 0, ReplayBatch(batch.key, [rec], [held_out], None, batch.tol, batch,
                                                             k), effects, held_out, segment))


def replay_tolerance(step: float) -> float:
    """The largest position error [rad] a replay's fixed step may add with the reading's ``step``
    (:func:`resolution`): a quarter of the reading's noise (one step over sqrt(12)); it adds at most 3 % to the
    residual's RMS at the noise floor (CVODES at rtol 1e-5 left up to 0.4 of the noise on the XL330 set with load
    friction)."""
    return 0.25 * step / np.sqrt(12.0)


def resolution(recordings) -> float:
    """The position reading's step: the smallest change between consecutive samples over all recordings."""
    steps = np.concatenate([np.abs(np.diff(r[POSITION])) for r in recordings])
    steps = steps[steps > 1e-12]
    if steps.size == 0:
        raise DataError("the measured position never changes: nothing to fit")
    return float(steps.min())


#: the time stamp at the end of a BAM recording's name
_STAMP = re.compile(r"\d{4}-\d{2}-\d{2}_\d{2}h\d{2}m\d{2}")


class ServoProblem(Problem):
    """The servo recordings (a folder or a list of :class:`~acausal.identify.recordings.Recording`) as a
    diagnosis problem; see the module docstring."""

    #: each evaluation replays every fitted recording with exact sensitivities (``together``: the Jacobian at an
    #: accepted step is that run's; a replay with sensitivities costs 1.8 without); a relative change of 1e-5 in
    #: cost or step is far below what the held-out scores resolve
    fit_options = {"max_nfev": 20, "tol": 1e-5, "together": True}
    #: the library spans the chain (18 candidates): each step refits the four whose fingerprints explain most of
    #: the residual and those significant in the step before, and scores the rest by their linearised step (a
    #: second step looks at them again)
    max_refits = 4

    def __init__(self, recordings, split: Split = Split(), executor=None, extra=(), strict: bool = False):
        self.effects = dict(fx.EFFECTS)
        for e in extra:
            if e.id in self.effects:
                raise DataError(f"candidate {e.id!r} is given twice (built-in or user)")
            self.effects[e.id] = e
        self.candidates = self.effects  # an effect record is the diagnosis's candidate
        if not isinstance(recordings, (list, tuple)):
            recordings = bam_logs.load(recordings, strict=strict)  # the servo format, or BAM's raw logs converted
        self.recordings = list(recordings)
        self.left_out = list(getattr(recordings, "left_out", []))  # too damaged to use, with why
        self.split = split
        self.executor = executor
        self.signals = list(SIGNALS)
        self.mask, self.split_text = split.held_out(self.recordings)
        self.step = resolution(self.recordings)
        self.replay_tolerance = replay_tolerance(self.step)
        self._cache: dict = {}
        self._batches: dict = {}
        for e in extra:
            self.check_user_effect(e)

    def check_user_effect(self, e) -> None:
        """A user's candidate ``e`` is refused, naming it, unless the model compiles with it and, at its zero,
        replays the shortest training recording as the baseline does (within the reading's noise): a size whose
        zero is not neutral (a gain inserted at 0 cuts the servo off) would make every score and detection limit
        false."""
        try:
            cm = compiled(*model_key((e,)))
        except Exception as exc:  # a user's component may fail in any way; it is named, not a traceback
            raise DataError(f"candidate {e.id!r} ({e.component}): the servo model with it does not build or "
                            f"compile: {type(exc).__name__}: {exc}") from exc
        held = np.asarray(self.mask, dtype=bool)
        rec = min((r for r, h in zip(self.recordings, held) if not h), key=lambda r: r.t.size)
        substeps = SUBSTEPS if fixed_step_runs(cm) and fixed_step_runs(compiled(*model_key(()))) else None
        try:
            base = replay(replay_job(model_key(()), rec, {}, (), substeps))[0]
            at_zero = replay(replay_job(model_key((e,)), rec, {e.parameter: e.zero}, (), substeps))[0]
        except Exception as exc:
            raise DataError(f"candidate {e.id!r} ({e.component}): a replay of {rec.name} with it at zero "
                            f"({e.parameter} = {e.zero:g}) fails: {type(exc).__name__}: {exc}") from exc
        off = float(np.max(np.abs(at_zero - base)))
        noise = self.step / np.sqrt(12.0)
        if not off <= noise:
            raise DataError(f"candidate {e.id!r}: at its zero ({e.parameter} = {e.zero:g}) it changes the model "
                            f"(the replay of {rec.name} moves by up to {off:.3g} rad, more than the reading's noise "
                            f"{noise:.2g} rad): give the zero at which {e.component} leaves the servo as it is")

    def experiments(self, effects: tuple) -> list:
        key = model_key(self.effects[e] for e in effects)
        if key not in self._cache:
            # an extension starts from the substeps of the model it extends (at its zero, it is that model)
            inner = self._batches.get(model_key(self.effects[e] for e in effects[:-1])) if effects else None
            batch = self._batches[key] = ReplayBatch(key, self.recordings, self.mask, self.executor,
                                                     self.replay_tolerance, extends=inner)
            self._cache[key] = [experiment(r, k, batch, effects, bool(h), self.split.segment)
                                for k, (r, h) in enumerate(zip(self.recordings, self.mask))]
        return self._cache[key]

    def base_free(self, start: dict) -> list:
        """The baseline parameters, bounds and scales as the servo and the pendulum declare them, started at the
        library's defaults (BAM's xl330 m1 set)."""
        cm = compiled(*model_key(()))
        return [Free.declared(cm, n, start) for n in BASELINE]

    def period(self, exp) -> float:
        return float(exp.t[-1] - exp.t[0]) * (1 + 1e-9)

    def unit(self, name: str) -> str:
        found = compiled(*model_key(())).flat.parameters.get(name)
        return found.unit if found is not None else super().unit(name)

    def noise_scales(self, exps) -> dict:
        return {POSITION: self.step / np.sqrt(12.0)}

    def session_order(self, exps):
        """When each recording was made, from the time stamp its name carries (BAM's logs end in
        ``YYYY-MM-DD_HHhMMmSS``): seconds after the first; None (their order) when a name has none."""
        from datetime import datetime

        found = [_STAMP.search(e.name) for e in exps]
        if not all(found):
            return None
        stamps = [datetime.strptime(f.group(0), "%Y-%m-%d_%Hh%Mm%S") for f in found]
        return ("elapsed session time [s] (from the recordings' names)",
                [(s - min(stamps)).total_seconds() for s in stamps])

    def heldout(self) -> dict:
        return {"signal": POSITION, "unit": "rad", "split": self.split_text}

    def regressors(self, exp, values: dict) -> dict:
        cm = compiled(*model_key(self.effects[e] for e in exp.info["effects"]))
        v = cm.simulate(exp.t[-1], t_start=exp.t[0], t_eval=exp.t, params={**exp.info["params"], **values},
                        inputs=exp.info["inputs"], starts=_starts(cm, exp.info["start"]), rtol=RTOL, atol=ATOL,
                        dense_output=False)
        w = np.asarray(v["pendulum.w"])
        return {"speed": w, "sign(speed)": np.tanh(w / 0.05), "abs(motor torque)": np.abs(np.asarray(v["servo.friction.flange_a.tau"])),
                "gravity torque": np.asarray(v["pendulum.tau_g"]), "duty": np.asarray(v["servo.ctrl.y.value"]),
                "elapsed time": exp.t - exp.t[0]}


def run(recordings, split: Split = Split(), thresholds: Thresholds = Thresholds(),
        max_effects: int | None = None, candidates=None, progress=None, executor=None, extra=(),
        strict: bool = False) -> tuple:
    """Diagnose servo ``recordings`` (list or folder); returns ``(Diagnosis, ServoProblem)``. ``executor``: a
    process pool to run the replays of one parameter set in parallel (default: in this process); ``extra``: the
    user's own candidates (:func:`~.effects.user_effect` records), tried beside the library's; ``strict``: a
    folder's samples that cannot be physical refuse it instead of being masked; ``candidates``: the library's
    candidates to try (None: all), the user's own (``extra``) always with them."""
    problem = ServoProblem(recordings, split, executor, extra, strict)
    if candidates is not None:  # the user's own candidates are tried whatever --candidates names
        candidates = [*candidates, *(e.id for e in extra if e.id not in candidates)]
    d = diagnose(problem, thresholds=thresholds, max_effects=max_effects, candidates=candidates, progress=progress)
    return d, problem
