"""Simulation: consistent initialisation, stiff integration, state events, algebraic models.

Two paths give the same answers (to the tolerances):

* the **compiled path** (:mod:`acausal.compiled`, optional CasADi): the model's equations as CasADi expressions,
  integrated by SUNDIALS CVODES (BDF, exact sparse Jacobian) with the step loop in compiled code, numeric inputs
  looked up inside it. It runs models without state events whose state derivatives need no Newton block.
* the **scipy path**: scipy's integrators (``BDF``, ``Radau``, ``LSODA``, ``RK45``...) driven step by step, so that a
  failure is reported with the time, the step size and the variable, and events stop the step exactly at the zero
  crossing (located by Brent's method on the dense output).

``method="auto"`` (the default) takes the compiled path when the model and the run allow it and scipy's ``LSODA``
otherwise (it switches between Adams and BDF by itself and was the fastest of scipy's integrators at the same
accuracy: 5x BDF on the reference drive), ``BDF`` for a model with state events (LSODA's switching stumbles at an
ideal diode's switch: convergence failures and events found twice);
:attr:`Result.solver <acausal.result.Result.solver>` says which ran and why. A model with no states
after index reduction is evaluated algebraically at the output times.
"""
from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from scipy import integrate

from .errors import ModelError, SimulationError
from .failures import non_finite_error, step_failure
from .modes import (algebraic_modes, apply_hits, crossings_in_step, handle_event, restarts, settle_modes,
                    zeros)
from .quadratures import Quadratures, StatesOnly

METHODS = {"BDF": integrate.BDF, "Radau": integrate.Radau, "LSODA": integrate.LSODA, "RK45": integrate.RK45,
           "RK23": integrate.RK23, "DOP853": integrate.DOP853}
IMPLICIT = {"BDF", "Radau", "LSODA"}
COMPILED = "CVODES"  # the compiled path's integrator (method="CVODES" asks for it explicitly)
FALLBACK = "LSODA"  # what method="auto" uses on the scipy path (ROBUST for a model with state events)
ROBUST = "BDF"  # models with events, and a failed compiled run run again (its failure report names the step)
#: absolute tolerance of the energy integrals carried as states: so large that they take no part in the error
#: control (as CVODES's quadratures on the compiled path): they follow the states' steps, evaluated at the
#: integrator's own states, not at its interpolants
UNCONTROLLED = 1e300
MAX_STEPS = 2_000_000  # scipy steps of an implicit integrator at most (about 3 minutes of stepping)
MAX_STEPS_EXPLICIT = 200_000  # of an explicit one: more means the model is stiff for it


def simulate(cm, t_end: float, *, t_start: float = 0.0, params: dict | None = None, inputs: dict | None = None,
             starts: dict | None = None, method: str = "auto", rtol: float = 1e-6, atol: float = 1e-9,
             t_eval=None, n_points: int = 501, max_step: float = np.inf, first_step: float | None = None,
             max_events: int = 10_000, dense_output: bool = True, trust: str = "raise", max_steps: int | None = None):
    """Simulate a :class:`~acausal.compiler.CompiledModel` and return a :class:`~acausal.result.Result`.

    ``params``: parameter overrides by name (no recompilation). ``inputs``: replacement :class:`Signal` s for
    numeric inputs by name. ``starts``: start values by variable name (fixed initial conditions).
    ``t_eval``: output times (default ``n_points`` evenly spaced). ``method``: ``"auto"`` (the compiled path when
    the model allows it, else scipy's LSODA), ``"CVODES"`` (the compiled path or a ModelError saying why not) or a
    scipy integrator name. ``dense_output``: keep what :meth:`Result.energy` needs to integrate to solver
    accuracy (every step's interpolant; on the compiled path the states at Gauss nodes); set False for the
    fastest runs (energies then use Simpson's rule on the output grid, and the energy balance is not checked).
    ``trust``: what the trust checks (:mod:`acausal.trust`: conditioning of every variable on the states'
    tolerances, the energy balance) do with a result they reject: ``"raise"`` an
    :class:`~acausal.trust.UntrustedResult`, ``"warn"``, or ``"off"``; their findings are ``res.trust``.
    ``max_steps``: steps of a scipy integrator at most (default :data:`MAX_STEPS` for an implicit method,
    :data:`MAX_STEPS_EXPLICIT` for an explicit one: a stiff model on RK45 stops with an error saying so instead of
    running for hours).
    """
    from .trust import check, check_mode, integration_fault

    check_mode(trust)
    run = dict(t_start=t_start, params=params, inputs=inputs, starts=starts, method=method, rtol=rtol, atol=atol,
               t_eval=t_eval, n_points=n_points, max_step=max_step, first_step=first_step, max_events=max_events,
               dense_output=dense_output, max_steps=max_steps)
    res = _simulate(cm, t_end, **run)
    if trust != "off" and dense_output and integration_fault(res, rtol):
        # the scipy path's energies, integrated on the steps' interpolants, miss what every account holds: the
        # run again with them as states, under the integrator's error control (acausal.quadratures)
        res = _simulate(cm, t_end, **{**run, "method": res.scipy_method}, quadratures=True)
    scipy_method = getattr(res, "scipy_method", None)
    with_quadratures = scipy_method is not None and bool(res._integrals)  # the scipy path's energies as states

    def retry(k):  # the same run, both tolerances divided by k, unchecked (the balance's cause, acausal.trust)
        tighter = {"rtol": np.asarray(rtol, dtype=float) / k, "atol": np.asarray(atol, dtype=float) / k}
        tighter = {name: float(v) if v.ndim == 0 else v for name, v in tighter.items()}
        return _simulate(cm, t_end, **{**run, **tighter, "method": scipy_method or method},
                         quadratures=with_quadratures)

    check(res, rtol, atol, trust, dense_output, retry)
    return res


def _simulate(cm, t_end, *, t_start, params, inputs, starts, method, rtol, atol, t_eval, n_points, max_step,
              first_step, max_events, dense_output, max_steps, quadratures: bool = False):
    from .result import Result

    t_start, t_end, t_out = _check_run(t_start, t_end, method, rtol, atol, max_step, first_step, max_events, t_eval,
                                       n_points, max_steps)
    p = cm.param_vector(params)
    if p.dtype == object:  # an array of values: a batch of runs
        batch = [name for name, value in (params or {}).items() if np.ndim(value) > 0]
        raise ModelError(f"simulate runs one parameter set, but {', '.join(map(repr, batch))} "
                         f"{'is an array' if len(batch) == 1 else 'are arrays'} of values: give numbers, or run the "
                         f"sets with sim.simulate_many(t_end, [{{...}}, ...]) or acausal.sweep.sweep")
    u = cm.input_tuple(inputs, p)
    d = cm.discrete_start()
    n = len(cm.state_names)
    if n == 0:
        d_arr = algebraic_modes(cm, t_out, p, d, u) if cm.event_zeros else None
        X = np.zeros((0, t_out.size))
        initialize(cm, t_start, p, d, u, starts)  # no states, but fixed starts must still hold
        return Result(cm, t_out, X, p, u, d if d_arr is None else d_arr, events=[], exact_time_function=True)
    x0 = initialize(cm, t_start, p, d, u, starts)
    if method in ("auto", COMPILED):
        method, why = _choose_path(cm, method, u, rtol, atol)
        if method == COMPILED:
            try:
                if cm.event_zeros:
                    from .compiled.events import simulate_with_events
                    return simulate_with_events(cm, t_start, x0, t_out, p, d, u, rtol, atol, max_step, first_step,
                                                max_events, dense_output, starts)
                return _simulate_compiled(cm, t_start, x0, t_out, p, d, u, rtol, atol, max_step, first_step,
                                          dense_output)
            except SimulationError as exc:  # the scipy path names the time, the step and the variable
                method, why = ROBUST, str(exc)
    else:
        why = "asked for"
    solver_label = f"{method} (scipy: {why})"
    d = settle_modes(cm, t_start, x0, p, d, u)
    x0 = initialize(cm, t_start, p, d, u, starts) if cm.discrete_names else x0
    X = np.empty((n, t_out.size))
    D = np.empty((len(d), t_out.size))
    events = []
    segments = []  # (t0, t1, dense interpolant, modes) of every accepted step, for exact energy integrals
    quad = Quadratures(cm) if quadratures else None  # energy integrals carried as states
    nq = len(quad.names) if quad is not None else 0
    Q = np.zeros((nq, t_out.size))
    t, x = t_start, (np.concatenate([x0, np.zeros(nq)]) if nq else x0)
    k_out = 0
    n_out = t_out.size
    solver_cls = METHODS[method]
    has_events = bool(cm.event_zeros)
    off = np.zeros(len(cm.event_zeros))  # thresholds the zero functions are watched at (modes.knee_offsets)
    steps_left = limit = max_steps if max_steps is not None else MAX_STEPS if method in IMPLICIT else MAX_STEPS_EXPLICIT
    while True:
        fun, jac = _make_functions(cm, p, d, u, quad)
        opts = dict(rtol=rtol, atol=atol, max_step=max_step)
        if nq:  # the integrals outside the error control; the states' tolerances tightened so that scipy's RMS
            # error norm over states and integrals (these contributing nothing) weighs the states as without them
            k = math.sqrt(n / (n + nq))
            opts["rtol"] = np.asarray(rtol, dtype=float) * k
            opts["atol"] = np.concatenate([np.broadcast_to(np.asarray(atol, dtype=float) * k, (n,)),
                                           np.full(nq, UNCONTROLLED)])
        if first_step is not None:
            opts["first_step"] = first_step
        if method in IMPLICIT:
            opts["jac"] = jac
        try:
            solver = solver_cls(fun, t, x, t_end, **opts)  # evaluates the model to choose its first step
        except _NonFinite as exc:
            raise non_finite_error(cm, exc.t, exc.x, p, d, u, exc.where) from None
        z_old = zeros(cm, t, x[:n], p, d, u, off=off) if has_events else None
        restarted = False
        while solver.status == "running":
            t_prev = solver.t
            try:
                msg = solver.step()
            except _NonFinite as exc:  # see _make_functions
                raise non_finite_error(cm, exc.t, exc.x, p, d, u, exc.where) from None
            y_sum = float(solver.y.sum())  # (with quadratures, the states are solver.y[:n])
            if solver.status == "failed" or y_sum - y_sum != 0.0:  # failed, or NaN/inf in the states
                bad = _find_non_finite(cm, solver, t_prev, p, d, u)
                raise bad if bad is not None else step_failure(cm, solver, msg, p, d, u, rtol, atol)
            t_new = solver.t
            steps_left -= 1
            if steps_left < 0:
                raise _too_many_steps(cm, method, limit, t_prev, t_new, t_start, t_end)
            if t_new == t_prev:
                continue
            need_out = k_out < n_out and t_out[k_out] <= t_new
            full = solver.dense_output() if (need_out or has_events or dense_output) else None
            sol = StatesOnly(full, n) if nq and full is not None else full
            hit = None
            if has_events:
                z_new = zeros(cm, t_new, solver.y[:n], p, d, u, False, off)  # a bad value: after any crossing
                hits = crossings_in_step(cm, sol, t_prev, t_new, z_old, z_new, p, d, u, off=off)
                z_old = z_new
                if hits:
                    t_e = hits[0][0]
                    x_e = sol(t_e)
                    d_new = apply_hits(cm, hits, t_e, x_e, p, d, u)
                    if not np.array_equal(d_new, d) or restarts(cm, hits):  # else no restart is needed
                        hit = hits
            t_stop = hit[0][0] if hit else t_new
            if dense_output:
                segments.append((t_prev, t_stop, sol, d.copy()))
            if need_out:
                k_end = np.searchsorted(t_out, t_stop, side="right")
                if k_end > k_out:
                    X[:, k_out:k_end] = sol(t_out[k_out:k_end])
                    D[:, k_out:k_end] = d[:, None]
                    if nq:
                        Q[:, k_out:k_end] = np.asarray(full(t_out[k_out:k_end]))[n:]
                    k_out = k_end
            if hit:
                x_e, d, off = handle_event(cm, events, hit, t_e, x_e, p, d, d_new, u, max_events)
                t, x = t_e, (np.concatenate([x_e, np.asarray(full(t_e))[n:]]) if nq else x_e)
                restarted = True
                break
        if not restarted or t >= t_end:
            break
    if k_out < n_out:  # t_end itself
        X[:, k_out:] = solver.y[:n, None]
        D[:, k_out:] = d[:, None]
        Q[:, k_out:] = solver.y[n:, None]
    integrals = dict(zip(quad.names, Q)) if nq else None
    if nq:
        solver_label = solver_label[:-1] + "; energies integrated as states)"
    res = Result(cm, t_out, X, p, u, D, events=events, segments=segments, solver=solver_label, integrals=integrals)
    res.scipy_method = method
    return res


def _too_many_steps(cm, method, limit, t_prev, t_new, t_start, t_end) -> SimulationError:
    hint = (f"the model is stiff for the explicit {method}: use method='auto' or 'BDF'" if method not in IMPLICIT
            else "a stiff or chattering model: look at the fastest state, or raise max_steps")
    return SimulationError(f"simulate {cm.flat.name}: {method} took {limit} steps and reached t = {t_new:.6g} s of "
                           f"{t_start:g}..{t_end:g} s (last step {t_new - t_prev:.3g} s): {hint}")


def _choose_path(cm, method, u, rtol, atol):
    """``(method, reason)``: the compiled path when it is available and supports the run, else the scipy
    fallback with the reason (``method == "CVODES"`` raises instead of falling back)."""
    from .compiled import available
    if not available():
        why = 'the compiled path needs CasADi (pip install "acausal[fast]")'
    else:
        why = cm.compiled_path.unsupported(u, rtol, atol)
        if why is None:
            return COMPILED, ""
    if method == COMPILED:
        raise ModelError(f"simulate(method={COMPILED!r}): model {cm.flat.name} cannot take the compiled path: {why}")
    return _fallback(cm), why


def _fallback(cm) -> str:
    """The scipy integrator ``method="auto"`` uses when the compiled path is not taken."""
    return ROBUST if cm.event_zeros else FALLBACK


def _simulate_compiled(cm, t_start, x0, t_out, p, d, u, rtol, atol, max_step, first_step, dense_output):
    """The run on the compiled path. With ``dense_output`` the energy integrals of the model's accounts are
    integrated by CVODES beside the states (under its error control); the integral of anything else takes the
    states at the Gauss nodes of the output intervals, integrated again when first asked for."""
    from .energy import account_integrals
    from .result import Result
    path = cm.compiled_path
    args = (rtol, atol, max_step, first_step)
    nodes, integrals = None, {}
    if dense_output and t_out.size > 1:
        names = account_integrals(cm.accounts) if cm.accounts is not None else []
        X, integrals = path.integrate(t_start, x0, t_out, p, d, u, *args, integrals=names)
        nodes = path.gauss_states(t_start, x0, t_out, p, d, u, *args)
    else:
        X, _ = path.integrate(t_start, x0, t_out, p, d, u, *args)
    if not np.isfinite(X).all():
        raise SimulationError("compiled path: non-finite states")
    later = path.quadratures_later(t_start, x0, t_out, p, d, u, *args) if nodes is not None else None
    return Result(cm, t_out, X, p, u, d, events=[], nodes=nodes, integrals=integrals, more_integrals=later,
                  solver=f"{path.integrator_name(u)} (compiled path, CasADi)")


def _check_run(t_start, t_end, method, rtol, atol, max_step, first_step, max_events, t_eval, n_points,
               max_steps=None):
    """The checked run settings of :func:`simulate`: ``(t_start, t_end, output times)``; a ModelError naming the
    setting at fault otherwise."""
    if method not in METHODS and method not in ("auto", COMPILED):
        raise ModelError(f"unknown integration method {method!r}; choose 'auto', {COMPILED!r} or one of "
                         f"{sorted(METHODS)}")
    t_start, t_end = _number(t_start, "t_start"), _number(t_end, "t_end")
    for what, value in (("t_start", t_start), ("t_end", t_end)):
        if not math.isfinite(value):  # an infinite span never ends (and has no output grid)
            raise ModelError(f"simulate: {what} must be a finite time, got {value}")
    if not t_end > t_start:
        raise ModelError(f"t_end = {t_end} must be after t_start = {t_start}")
    check_tolerances(rtol, atol, "simulate")
    for what, step in (("max_step", max_step), ("first_step", first_step)):
        if step is not None and not _number(step, what) > 0:
            raise ModelError(f"simulate: {what} must be positive, got {step}")
    if max_steps is not None and (not isinstance(max_steps, (int, np.integer)) or max_steps < 1):
        raise ModelError(f"simulate: max_steps must be a positive integer, got {max_steps!r}")
    if not isinstance(max_events, (int, np.integer)) or max_events < 0:
        raise ModelError(f"simulate: max_events must be a non-negative integer, got {max_events!r}")
    if t_eval is None:
        if not isinstance(n_points, (int, np.integer)) or n_points < 1:
            raise ModelError(f"simulate: n_points must be a positive integer, got {n_points!r}")
        return t_start, t_end, np.linspace(t_start, t_end, n_points)  # increasing, from t_start to t_end
    try:
        t_out = np.asarray(t_eval, dtype=float)
    except (TypeError, ValueError):
        raise ModelError("simulate: t_eval must be an array of times") from None
    if t_out.ndim != 1:
        raise ModelError(f"simulate: t_eval must be a 1-d array of times, got shape {t_out.shape}")
    if not np.all(np.isfinite(t_out)):
        k = int(np.argmax(~np.isfinite(t_out)))
        raise ModelError(f"simulate: t_eval[{k}] is {t_out[k]}; output times must be finite numbers")
    if t_out.size and (t_out[0] < t_start or t_out[-1] > t_end or np.any(np.diff(t_out) < 0)):
        raise ModelError("t_eval must be increasing and within [t_start, t_end]")
    return t_start, t_end, t_out


def check_tolerances(rtol, atol, who: str) -> None:
    """The integrator's relative and absolute tolerances: ``rtol`` positive, ``atol`` not negative (numbers,
    or one per state); a ModelError naming ``who`` otherwise."""
    if type(rtol) is float and type(atol) is float and rtol > 0 and atol >= 0:  # the usual case, without numpy
        return
    try:
        ok = bool(np.all(np.asarray(rtol, dtype=float) > 0) and np.all(np.asarray(atol, dtype=float) >= 0))
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ModelError(f"{who}: rtol must be positive and atol not negative, got rtol = {rtol!r}, atol = {atol!r}")


def _number(value, what: str) -> float:
    """``value`` as a float; a ModelError naming ``what`` when it is not a number."""
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ModelError(f"{what} must be a number, got {value!r}") from None


# ---------------------------------------------------------------------------------------------- functions
def _make_functions(cm, p, d, u, quad=None):
    """Right-hand side and Jacobian for the integrator. Scalar runs pass plain Python floats to the generated
    code (several times faster arithmetic than numpy scalars). With ``quad`` (:class:`Quadratures`) the energy
    integrals follow the states (their rows of the Jacobian are left zero: nothing depends on them, and the
    Newton iteration of an implicit step converges on them with the states)."""
    rhs, jacf = cm.funcs["rhs"], cm.funcs["jac"]
    pl = p.tolist()
    dl = d.tolist()
    if quad is not None:
        n, nq = len(cm.state_names), len(quad.names)
        fun0, jac0 = _make_functions(cm, p, d, u)

        def fun_q(t, x):
            xs = x[:n]
            return np.concatenate([np.asarray(fun0(t, xs), dtype=float), quad.rhs(t, xs.tolist(), p, d, u)])

        def jac_q(t, x):
            J = np.zeros((n + nq, n + nq))
            J[:n, :n] = jac0(t, x[:n])
            return J

        return fun_q, jac_q

    # On Python floats, 1/(1 - t) at t == 1 raises ZeroDivisionError (a huge power OverflowError) instead of
    # giving inf: it is reported as a non-finite value with its time and variable. A non-finite Jacobian (e.g.
    # of sqrt(x) at x <= 0) would make scipy's LU factorisation fail with a bare ValueError; it is checked here
    # (Jacobians are evaluated rarely, the check is cheap). The try blocks cost nothing when nothing is raised.
    def fun(t, x):
        try:
            return rhs(t, x.tolist(), pl, dl, u)
        except ArithmeticError:
            raise _NonFinite(t, x.copy()) from None

    def jac(t, x):
        try:
            J = jacf(t, x.tolist(), pl, dl, u)
        except ArithmeticError:
            raise _NonFinite(t, x.copy(), "jac") from None
        if not np.isfinite(J.sum()):
            raise _NonFinite(t, x.copy(), "jac")
        return J

    return fun, jac


class _NonFinite(Exception):
    """Raised inside the integrator's callbacks when the model has no finite value at (t, x)."""

    def __init__(self, t, x, where="rhs"):
        super().__init__(t)
        self.t, self.x, self.where = t, x, where


def _find_non_finite(cm, solver, t_prev, p, d, u):
    """After a failed or non-finite step: find a time in the step where some variable is not finite."""
    with np.errstate(all="ignore"):
        for t, x in ((solver.t, solver.y), (t_prev, getattr(solver, "y_old", None))):
            if x is None:
                continue
            try:
                vals = cm.funcs["all_values"](t, x, p, d, u)
                dx = cm.funcs["rhs"](t, x, p, d, u)
            except (ZeroDivisionError, OverflowError, ValueError, FloatingPointError):
                continue
            if not (np.all(np.isfinite(x)) and np.all(np.isfinite(dx))
                    and all(np.all(np.isfinite(v)) for v in vals)):
                return non_finite_error(cm, t, x, p, d, u)
    return None


# ---------------------------------------------------------------------------------------------- initial values
def initialize(cm, t0, p, d, u, starts: dict | None = None) -> np.ndarray:
    """Consistent initial states.

    States take their start values; variables with ``fixed=True`` (or given in ``starts``) that are not states
    are met by adjusting the states that are not fixed, by a minimum-norm Gauss-Newton iteration from the
    start values. Inconsistent or over-specified initial conditions raise an error naming the variables.
    """
    flat = cm.flat
    if starts is not None and not isinstance(starts, Mapping):
        raise ModelError(f"starts must be a dict by variable name, got {type(starts).__name__}")
    starts = dict(starts or {})
    if starts:
        names = set(cm.names()) | set(flat.variables)
        for k, v in starts.items():
            if k not in names:
                raise cm.unknown_name_error(k, "variable", sorted(names))
            starts[k] = _number(v, f"start value of {k!r}")
    x = np.empty(len(cm.state_names))
    fixed_state = np.zeros(len(cm.state_names), dtype=bool)
    for i, n in enumerate(cm.state_names):
        info = flat.variables.get(n)
        x[i] = info.start if info else 0.0
        if info is not None and info.fixed:
            fixed_state[i] = True
        if n in starts:
            x[i] = starts.pop(n)
            fixed_state[i] = True
        if not np.isfinite(x[i]):
            raise ModelError(f"the start value of {n!r} is {x[i]} (its Start(...) in the model); a start value must "
                             "be a finite number")
    targets = {}  # non-state fixed variables: name -> value
    if "fixed non-states" not in cm.derived:  # which they are is structure: found once per model
        states = set(cm.state_names)
        cm.derived["fixed non-states"] = [n for n, info in flat.variables.items() if info.fixed and n not in states]
    for n in cm.derived["fixed non-states"]:
        targets[n] = flat.variables[n].start
    for n, v in starts.items():
        targets[n] = float(v)
    # fixed starts of variables that alias elimination found to be constant (parameter expressions)
    for n, v in getattr(flat, "fixed_constants", {}).items():
        targets.setdefault(n, v)
    if not targets:
        return x
    free = np.flatnonzero(~fixed_state)
    names_t = sorted(targets)
    want = np.array([targets[n] for n in names_t])

    def resid(xf):
        xx = x.copy()
        xx[free] = xf
        vals = _value_lookup(cm, t0, xx, p, d, u)
        return np.array([vals(n) for n in names_t]) - want

    xf = x[free].copy()
    scale = np.maximum(1.0, np.abs(want))
    for _ in range(50):
        r = resid(xf)
        if np.all(np.abs(r) <= 1e-10 * scale):
            break
        if free.size == 0:
            break
        J = np.empty((r.size, free.size))
        for j in range(free.size):
            h = 1e-7 * max(1.0, abs(xf[j]))
            e = xf.copy()
            e[j] += h
            J[:, j] = (resid(e) - r) / h
        step, *_ = np.linalg.lstsq(J, -r, rcond=None)
        xf = xf + step
        if np.max(np.abs(step)) < 1e-14 * max(1.0, np.max(np.abs(xf))):
            break
    r = resid(xf)
    if not np.all(np.abs(r) <= 1e-7 * scale):
        const = getattr(flat, "fixed_constants", {})
        bad = [f"{n} (wanted {targets[n]:.6g}, got {targets[n] + ri:.6g}"
               + (f", which the equations make the constant {flat.aliases.get(n)})" if n in const else ")")
               for n, ri in zip(names_t, r) if abs(ri) > 1e-7 * max(1.0, abs(targets[n]))]
        fixed_states = [cm.state_names[i] for i in np.flatnonzero(fixed_state)]
        raise SimulationError(
            "inconsistent initial conditions: cannot meet " + ", ".join(bad)
            + (f" with the states {[cm.state_names[i] for i in free]} free" if free.size else " (no state is free)")
            + (f" and {fixed_states} fixed" if fixed_states else ""))
    x[free] = xf
    return x


def _value_lookup(cm, t, x, p, d, u):
    vals = dict(zip(cm.unknown_names, cm.funcs["all_values"](t, x, p, d, u)))
    vals.update(zip(cm.state_names, x))
    aliases = cm.flat.aliases

    def get(name):
        if name in vals:
            return float(vals[name])
        if name in aliases:
            return float(cm.eval_expr(aliases[name], vals, p, d, t))
        raise cm.unknown_name_error(name, "variable", cm.names())

    return get
