"""A run, checked and frozen: what every backend integrates (:class:`Run`), and :func:`prepare`, which checks a
``simulate()`` call's settings, naming the one at fault, and builds it."""
from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from ..errors import BudgetExceeded, ModelError
from .choose import COMPILED
from .initial import initialize, number, whole
from .scipy.driver import METHODS


@dataclasses.dataclass(frozen=True)
class Run:
    """One simulation of a compiled model, ready for a backend (:mod:`acausal.simulation`): the model ``cm``, the
    span ``t_start``..``t_end`` [s] and output times ``t_out``, the parameter vector ``p``, the discrete start
    ``d``, the inputs ``u`` (:meth:`~acausal.compiled_model.CompiledModel.input_tuple`), the consistent start ``x0``
    (:func:`~.initial.initialize`), and the settings of :func:`acausal.simulation.simulate.simulate` (``method`` as
    asked: ``"auto"``, ``"CVODES"`` or a scipy integrator). A backend copies what it changes."""

    cm: object
    t_start: float
    t_end: float
    t_out: np.ndarray
    p: np.ndarray
    d: np.ndarray
    u: tuple
    x0: np.ndarray
    method: str
    rtol: object
    atol: object
    max_step: float
    first_step: float | None
    max_events: int
    dense_output: bool
    max_steps: int | None
    starts: dict | None
    budget: "Budget | None" = None  # steps and seconds it may spend at most (the trust check's own runs)

    def tighter(self, k: float) -> "Run":
        """The same run with both tolerances divided by ``k``."""
        def div(tol):
            v = np.asarray(tol, dtype=float) / k
            return float(v) if v.ndim == 0 else v
        return dataclasses.replace(self, rtol=div(self.rtol), atol=div(self.atol))

    def segment(self, d=None, u=None) -> "Segment":
        """The :class:`Segment` of this run in the modes ``d`` (default: the discrete start), with the inputs ``u``
        (default: the run's)."""
        return Segment(self.cm, self.p, self.d if d is None else d, self.u if u is None else u, self.rtol,
                       self.atol, self.max_step, self.first_step, self.budget)


@dataclasses.dataclass(frozen=True, eq=False)
class Segment:
    """What stays fixed while a run is integrated between two of its events, as every segment integrator takes it:
    the model ``cm``, the parameter vector ``p``, the modes ``d``, the inputs ``u``, the tolerances and the step
    bounds [s] (:meth:`Run.segment` builds it from a :class:`Run`)."""

    cm: object
    p: np.ndarray
    d: np.ndarray
    u: tuple
    rtol: object
    atol: object
    max_step: float = np.inf
    first_step: float | None = None
    budget: "Budget | None" = None  # the run's (:class:`Budget`)

    def tighter(self, k: float) -> "Segment":
        """The same segment with both tolerances multiplied by ``k``."""
        return dataclasses.replace(self, rtol=self.rtol * k, atol=self.atol * k)


class Budget:
    """What runs may spend together: ``steps`` integrator steps and ``seconds`` of wall time from the budget's
    creation, for the runs the trust check makes for itself (:mod:`acausal.results.trust`: a tighter run that
    tells a loose tolerance from a stiff model), which must end however the model behaves (a thermostat's
    state-dependent switch chatters, and its steps grow as fast as the tolerance tightens). A segment integrator
    reports what it spent (:meth:`spend`); the budget raises :class:`~acausal.errors.BudgetExceeded` once either is
    spent. A run under a budget takes no slower path when it fails (the compiled path's fallback to scipy)."""

    def __init__(self, steps: int, seconds: float):
        self.steps, self.seconds = int(steps), float(seconds)
        self.used = 0
        self._start = time.monotonic()

    @property
    def steps_left(self) -> int:
        return max(self.steps - self.used, 0)

    def elapsed(self) -> float:
        return time.monotonic() - self._start

    def spend(self, steps: int = 0, t: float | None = None) -> None:
        """Count ``steps`` more; raise :class:`~acausal.errors.BudgetExceeded` where the steps or the seconds are
        spent (``t``: the simulated time reached, for the message)."""
        self.used += int(steps)
        where = "" if t is None else f" at t = {t:.6g} s"
        if self.used > self.steps:
            raise BudgetExceeded(f"stopped{where} after {self.used} steps, over its budget of {self.steps} steps")
        elapsed = self.elapsed()
        if elapsed > self.seconds:
            raise BudgetExceeded(f"stopped{where} after {elapsed:.3g} s ({self.used} steps), over its budget of "
                                 f"{self.seconds:g} s")


def prepare(cm, t_end, *, t_start, params, inputs, starts, method, rtol, atol, t_eval, n_points, max_step,
            first_step, max_events, dense_output, max_steps) -> Run:
    """Check the settings of :func:`acausal.simulation.simulate.simulate` (each error names its setting) and build the
    :class:`Run`: the parameter vector, the inputs, the discrete start and the consistent initial states."""
    t_start, t_end, t_out = check_run(t_start, t_end, method, rtol, atol, max_step=max_step, first_step=first_step,
                                      max_events=max_events, t_eval=t_eval, n_points=n_points, max_steps=max_steps,
                                      states=cm.state_names, dense_output=dense_output)
    p = cm.param_vector(params)
    if p.dtype == object:  # an array of values: a batch of runs
        batch = [name for name, value in (params or {}).items() if np.ndim(value) > 0]
        raise ModelError(f"simulate runs one parameter set, but {', '.join(map(repr, batch))} "
                         f"{'is an array' if len(batch) == 1 else 'are arrays'} of values: give numbers, or run the "
                         f"sets with sim.simulate_many(t_end, [{{...}}, ...]) or acausal.simulation.sweep.sweep")
    u = cm.input_tuple(inputs, p)
    return from_start(cm, t_start, t_end, t_out, p, u, starts=starts, method=method, rtol=rtol, atol=atol,
                      max_step=max_step, first_step=first_step, max_events=max_events, dense_output=dense_output,
                      max_steps=max_steps)


def from_start(cm, t_start, t_end, t_out, p, u, *, starts, method, rtol, atol, max_step=np.inf, first_step=None,
               max_events=10_000, dense_output=False, max_steps=None) -> Run:
    """The :class:`Run` of ``cm`` over ``t_start``..``t_end`` (outputs ``t_out``) with the parameter vector ``p``
    and the inputs ``u``, from the discrete start and the consistent initial states (:func:`~.initial.initialize`,
    with ``starts``); the settings as given (checked by the caller): what :func:`prepare` and
    :func:`acausal.simulation.sensitivity.sensitivities` build their runs with."""
    d = cm.discrete_start()
    x0 = initialize(cm, t_start, p, d, u, starts)  # without states too: fixed starts must still hold
    return Run(cm, t_start, t_end, t_out, p, d, u, x0, method, rtol, atol, max_step, first_step, max_events,
               dense_output, max_steps, starts)


def check_run(t_start, t_end, method, rtol, atol, *, max_step, first_step, max_events, t_eval, n_points,
              max_steps=None, states=None, dense_output=True):
    """The checked run settings of :func:`simulate`: ``(t_start, t_end, output times)``; a ModelError naming the
    setting at fault otherwise."""
    if method not in METHODS and method not in ("auto", COMPILED):
        raise ModelError(f"unknown integration method {method!r}; choose 'auto', {COMPILED!r} or one of "
                         f"{sorted(METHODS)}")
    t_start, t_end = number(t_start, "t_start"), number(t_end, "t_end")
    for what, value in (("t_start", t_start), ("t_end", t_end)):
        if not math.isfinite(value):  # an infinite span never ends (and has no output grid)
            raise ModelError(f"simulate: {what} must be a finite time, got {value}")
    if not t_end > t_start:
        raise ModelError(f"t_end = {t_end} must be after t_start = {t_start}")
    check_tolerances(rtol, atol, "simulate", states)
    if not isinstance(dense_output, (bool, np.bool_)):
        raise ModelError(f"simulate: dense_output must be True or False, got {dense_output!r}")
    span = t_end - t_start
    for what, step in (("max_step", max_step), ("first_step", first_step)):
        if step is not None and not number(step, what) > 0:
            raise ModelError(f"simulate: {what} must be positive, got {step}")
    if first_step is not None and first_step > span:
        raise ModelError(f"simulate: first_step = {first_step:g} s is longer than the run ({span:g} s, "
                         f"{t_start:g}..{t_end:g})")
    if max_steps is not None:
        whole(max_steps, "simulate: max_steps", 1)
    if max_steps is not None and method == COMPILED:
        raise ModelError(f"simulate: max_steps limits a scipy integrator's steps; method={COMPILED!r} has no such "
                         "limit (leave max_steps out, or choose a scipy method)")
    whole(max_events, "simulate: max_events", 0)
    if t_eval is None:
        whole(n_points, "simulate: n_points", 2, " (the outputs run from t_start to t_end)",
              "; for one time give t_eval=[t]")
        return t_start, t_end, np.linspace(t_start, t_end, n_points)  # increasing, from t_start to t_end
    try:
        t_out = np.asarray(t_eval, dtype=float)
    except (TypeError, ValueError):
        raise ModelError("simulate: t_eval must be an array of times") from None
    if t_out.ndim != 1:
        raise ModelError(f"simulate: t_eval must be a 1-d array of times, got shape {t_out.shape}")
    if t_out.size == 0:
        raise ModelError("simulate: t_eval is empty; give at least one output time (or leave it out: n_points "
                         "evenly spaced times)")
    check_finite_times(t_out, "simulate: t_eval")
    if t_out.size and (t_out[0] < t_start or t_out[-1] > t_end or np.any(np.diff(t_out) < 0)):
        raise ModelError("t_eval must be increasing and within [t_start, t_end]")
    return t_start, t_end, t_out


def check_finite_times(t, what: str) -> None:
    """Output times must be finite numbers: a ModelError naming the first that is not (``what[k]``)."""
    if not np.all(np.isfinite(t)):
        k = int(np.argmax(~np.isfinite(t)))
        raise ModelError(f"{what}[{k}] is {t[k]}; output times must be finite numbers")


def check_tolerances(rtol, atol, who: str, states=None) -> None:
    """The integrator's relative and absolute tolerances: ``rtol`` in (0, 1), ``atol`` finite and not negative;
    each a number or, with the model's ``states`` (names) given, one value per state. A ModelError naming ``who``
    and the setting otherwise."""
    if type(rtol) is float and type(atol) is float and 0 < rtol < 1 and 0 <= atol < math.inf:  # the usual case
        return
    for what, tol in (("rtol", rtol), ("atol", atol)):
        if isinstance(tol, (str, bytes, bool, np.bool_)):
            raise ModelError(f"{who}: {what} must be a number (or one per state), got the {type(tol).__name__} "
                             f"{tol!r}")
        try:
            v = np.asarray(tol, dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"{who}: {what} must be a number (or one per state), got {tol!r}") from None
        if v.ndim > 1 or (v.ndim == 1 and states is not None and v.size != len(states)):
            n = len(states) if states is not None else "?"
            raise ModelError(f"{who}: {what} has {v.size if v.ndim == 1 else f'shape {v.shape} of'} values for "
                             f"{n} state{'s' if n != 1 else ''} {list(states or [])}; give one number or one per "
                             "state")
        if what == "rtol" and not np.all((v > 0) & (v < 1)):
            raise ModelError(f"{who}: rtol must be positive and below 1, got rtol = {tol!r}")
        if what == "atol" and not np.all((v >= 0) & np.isfinite(v)):
            raise ModelError(f"{who}: atol must be finite and not negative, got atol = {tol!r}")
