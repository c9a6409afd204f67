"""Exact parameter sensitivities of a compiled model's variables (forward sensitivity analysis).

``d y / d p_j`` for variables ``y`` (unknowns, states, aliases) and parameters ``p_j`` at given parameter values,
from derivatives generated symbolically through the solved equations (:meth:`CodeGenerator.sensitivity_function`,
generated on the first request and cached; compilation is unaffected). Units: ``sens[y][j]`` is in
[unit of y] / [unit of p_j]; the sign is that of the plain derivative (positive: y grows with p_j).

* A model without states is evaluated directly and vectorised at the output times (its discrete modes settled
  at each output time, as :func:`acausal.simulation.simulate.simulate` does).
* A model with states integrates the states ``x`` and their sensitivities ``S = dx/dp`` (``n x q``) together,
  ``dx/dt = f(t, x, p)``, ``dS/dt = f_x S + f_p``, on the compiled path (CVODES) or with scipy; outputs follow
  from ``dy/dp = y_x S + y_p``. The start values are taken as independent of the parameters (``S(t_start) = 0``),
  also where initialisation adjusts states to meet fixed starts of other variables.

A parameter bound to an expression of others (e.g. ``winding.C = 1/winding_heating``) follows its binding: the
sensitivity to ``winding_heating`` includes the path through ``winding.C`` (unless ``winding.C`` is overridden in
``params`` or itself named in ``wrt``, which makes it independent). Not supported: a parameter in the argument of
an input signal (e.g. a gait's ``stride_time``) and models with both states and events (:class:`ModelError`).
"""
from __future__ import annotations

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

from ..errors import ModelError, SimulationError
from .events import algebraic_modes
from . import check_finite_times, check_tolerances
from .run import from_start
from .initial import whole
from ..model.symbols import der_name, var_symbol


def sensitivities(cm, t, wrt, names=None, params=None, inputs=None, rtol: float = 1e-8, atol: float = 1e-10, *,
                  t_start: float = 0.0, starts: dict | None = None, method: str = "auto", substeps: int = 4):
    """Values and parameter sensitivities of variables of the compiled model ``cm`` at times ``t``.

    ``wrt``: parameter names ``p_1..p_q``; ``names``: variables (aliases included; default every state and
    unknown); ``params``/``inputs``: overrides as for :meth:`CompiledModel.simulate`. ``rtol``/``atol``: the
    integrator's tolerances, applied to states and sensitivities alike (models with states only); states start at
    ``t_start`` (default 0 s, with ``starts`` as in ``simulate``) and ``t`` must be increasing and not before it.
    ``method``: ``"auto"`` (default: the compiled path, CVODES with CasADi's exact derivatives, when the model
    allows it, else scipy's LSODA), ``"CVODES"`` (the compiled path or a ModelError), the implicit scipy integrator
    ``"BDF"``, ``"LSODA"`` or ``"Radau"``, or ``"RK4"``: fixed steps on the grid ``t`` (``substeps`` per interval,
    no error control: ``rtol``/``atol`` are not used; the sensitivities are those of the discrete solution; see
    :mod:`acausal.simulation.compiled.fixed_step`), a ModelError where the model has no such form.

    Returns ``(values, sens)``: ``values[name]`` of shape ``(N,)``, ``sens[name]`` of shape ``(q, N)`` with
    ``sens[name][j] = d name / d wrt[j]``.
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if t.ndim != 1:
        raise ModelError("sensitivities: t must be a 1-D array of times")
    check_finite_times(t, "sensitivities: t")
    check_tolerances(rtol, atol, "sensitivities", cm.state_names)
    whole(substeps, "sensitivities: substeps", 1)
    if isinstance(wrt, str):
        raise ModelError(f"sensitivities: wrt must be a list of parameter names, got the string {wrt!r}")
    wrt = list(wrt)
    for w in wrt:
        cm.param_index(w)  # an unknown name raises, with suggestions
    if len(set(wrt)) != len(wrt):
        raise ModelError(f"sensitivities: wrt names a parameter twice: {wrt}")
    names = list(cm.state_names) + list(cm.unknown_names) if names is None else list(names)
    outputs = [_output_expr(cm, n) for n in names]
    p = cm.param_vector(params)
    if p.dtype == object:
        raise ModelError("sensitivities: parameter values must be scalars (one parameter set)")
    u = cm.input_tuple(inputs, p)
    d = cm.discrete_start()
    overridden = set(params or {})
    bindings = {n: info.value for n, info in cm.flat.parameters.items()
                if n not in overridden and isinstance(info.value, sp.Basic) and not info.value.is_number}
    gen = cm.generator
    out_fn = gen.sensitivity_function(wrt, bindings, outputs)
    n, q, N = len(cm.state_names), len(wrt), t.size
    if n == 0:
        modes = algebraic_modes(cm, t, p, d, u) if cm.event_zeros else d
        vals, _, dy = out_fn(t, np.zeros((0, N)), p, modes, u)
    else:
        if cm.event_zeros:
            raise ModelError("sensitivities of models with events and states are not supported")
        if N and (t[0] < t_start or np.any(np.diff(t) < 0)):
            raise ModelError(f"sensitivities: t must be increasing and not before t_start = {t_start}")
        asked = method

        def start():  # the states' Run from their consistent start, built where an integration first needs it
            return from_start(cm, t_start, float(t[-1]) if N else t_start, t, p, u, starts=starts, method=asked,
                              rtol=rtol, atol=atol)

        X, S, run = None, None, None
        if method == "RK4":
            stepper = _fixed_step(cm, wrt, bindings, substeps)
            run = start()
            X, S = stepper.run(run.t_start, run.x0, run.t_out, run.p, run.d, run.u)
        elif method in ("auto", "CVODES"):
            from . import COMPILED, ROBUST, choose_path
            method, _ = choose_path(cm, method, u, rtol, atol)
            if method == COMPILED:
                run = start()
                try:
                    X, S = cm.compiled_path.sensitivities(run.t_start, run.x0, run.t_out, run.segment(), wrt,
                                                          bindings)
                except SimulationError:  # the scipy path says where and why
                    method = ROBUST
        if X is None:
            rhs_fn = gen.sensitivity_function(wrt, bindings, [var_symbol(der_name(s)) for s in cm.state_names])
            if method not in ("BDF", "LSODA", "Radau"):
                raise ModelError(f"sensitivities: method must be 'auto', 'CVODES', 'BDF', 'LSODA' or 'Radau', got "
                                 f"{method!r}")
            X, S = _integrate(run if run is not None else start(), rhs_fn, q, method)
        vals, dx, dp = out_fn(t, X, p, d, u)
        dy = np.einsum("mk...,kj...->mj...", dx, S) + dp  # y_x S + y_p
    values, sens = {}, {}
    for k, name in enumerate(names):
        values[name] = np.broadcast_to(np.asarray(vals[k], dtype=float), (N,)).copy()
        sens[name] = np.broadcast_to(np.asarray(dy[k], dtype=float), (q, N)).copy()
    return values, sens


def _fixed_step(cm, wrt, bindings, substeps):
    """The stepper of :mod:`acausal.simulation.compiled.fixed_step` (RK4, ``substeps`` per output interval) with the
    sensitivities to ``wrt``; a ModelError where the model has no such form or CasADi is missing."""
    try:
        from .compiled.fixed_step import fixed_step
        from ..backends.casadi import Unsupported
    except ImportError as exc:  # no CasADi
        raise ModelError(f"sensitivities: method 'RK4' needs CasADi (the 'fast' extra): {exc}") from None
    try:
        return fixed_step(cm, int(substeps), wrt, bindings)
    except Unsupported as exc:
        raise ModelError(f"sensitivities: method 'RK4' cannot run this model: {exc}") from None


def _output_expr(cm, name):
    """The sympy expression of a variable: its own symbol, or the definition of an eliminated alias."""
    if name in cm.state_names or name in cm.unknown_names:
        return var_symbol(name)
    if name in cm.flat.aliases:
        return sp.sympify(cm.flat.aliases[name])
    raise cm.unknown_name_error(name, "variable", cm.names())


def _integrate(run, rhs_fn, q, method):
    """States ``X`` (n, N) and sensitivities ``S`` (n, q, N) to ``q`` parameters at ``run``'s output times,
    integrated together from its start by the scipy integrator ``method`` (:class:`~.run.Run`: its parameters,
    modes, inputs, tolerances and consistent start)."""
    cm, t, t_start, p, d, u = run.cm, run.t_out, run.t_start, run.p, run.d, run.u
    rtol, atol, x0 = run.rtol, run.atol, run.x0
    n = len(cm.state_names)
    y0 = np.concatenate([x0, np.zeros(n * q)])
    pl, dl = p.tolist(), d.tolist()
    eye_q = np.eye(q)

    def parts(tt, x):  # f, f_x, f_p at one time (plain lists are the generated code's fast path)
        return rhs_fn(tt, x.tolist(), pl, dl, u)

    def fun(tt, y):
        x, S = y[:n], y[n:].reshape(n, q)
        f, fx, fp = parts(tt, x)
        return np.concatenate([f, (fx @ S + fp).ravel()])

    def jac(tt, y):
        # [[f_x, 0], [d(f_x S + f_p)/dx, f_x (x) I_q]]: the diagonal blocks are exact; the coupling block (second
        # derivatives of f) by forward differences of the exact f_x, f_p. It only steers the Newton iterations.
        x, S = y[:n], y[n:].reshape(n, q)
        _, fx, fp = parts(tt, x)
        g0 = (fx @ S + fp).ravel()
        J = np.zeros((n + n * q, n + n * q))
        J[:n, :n] = fx
        J[n:, n:] = np.kron(fx, eye_q)
        for i in range(n):
            h = 1.5e-8 * max(1.0, abs(x[i]))
            xh = x.copy()
            xh[i] += h
            _, fxh, fph = parts(tt, xh)
            J[n:, i] = ((fxh @ S + fph).ravel() - g0) / h
        return J

    N = t.size
    if N == 0 or t[-1] <= t_start:
        Y = np.repeat(y0[:, None], N, axis=1)
    else:
        try:
            sol = solve_ivp(fun, (t_start, t[-1]), y0, method=method, t_eval=t, jac=jac, rtol=rtol, atol=atol)
        except ArithmeticError as exc:  # Python floats: a division by zero raises instead of giving inf
            raise SimulationError(f"sensitivity integration: non-finite value ({exc})") from None
        if sol.status != 0 or not np.all(np.isfinite(sol.y)):
            reached = np.asarray(sol.t, dtype=float)  # a list when scipy stops before its first step
            raise SimulationError(f"sensitivity integration failed at t = {reached[-1] if reached.size else t_start:.6g}"
                                  f" s: {sol.message}")
        Y = sol.y
    return Y[:n], Y[n:].reshape(n, q, N)
