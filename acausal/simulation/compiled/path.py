"""Integration on the compiled path: CasADi CVODES (BDF with Newton on CasADi's exact, sparse Jacobian), or IDAS
when Newton blocks are integrated as algebraic variables.

One :class:`CompiledPath` per compiled model builds, on first use, the right-hand side as a CasADi function of
time, states, parameters and discrete modes (the numeric inputs' tables inside it), and caches integrators by
what fixes their structure (the inputs, the quadratures and the normalised output grid). Time is scaled onto
``[0, 1]`` inside the integrator (``t = t0 + tau * span``), so runs over the same number of evenly spaced outputs
(sweeps, protocol conditions, fits) share one integrator whatever their start and length, and only the numbers
change per run.

What the path cannot run (a signal or a zero function without a closed form, per-state tolerances, a model
without states) is reported by :meth:`CompiledPath.unsupported` as a reason; the caller then takes the scipy path
and says why. State events are handled in :mod:`acausal.simulation.compiled.events`.
"""
from __future__ import annotations

import functools
import typing

import numpy as np

from ...errors import BudgetExceeded, SimulationError
from .calls import first_line, run_integrator, steps_taken

MAX_NUM_STEPS = 1_000_000
EPS = float(np.finfo(float).eps)
VARIATION_SCALE = 1e-250  # the zero functions' variations enter CVODES's error test with no weight (see integrate)


class CompiledPath:
    """The compiled simulation path of one :class:`~acausal.compiled_model.CompiledModel`."""

    def __init__(self, cm):
        self.cm = cm
        self._rhs: dict = {}  # signal layout -> (casadi rhs pieces) or Unsupported reason
        self._integrators: dict = {}
        self._last = None  # (signals, their entry) of the last run

    # ------------------------------------------------------------------ support
    def unsupported(self, u, rtol, atol) -> str | None:
        """Why this run cannot take the compiled path (None: it can)."""
        cm = self.cm
        if not cm.state_names:
            return "the model has no states (it is evaluated algebraically)"
        if not (isinstance(atol, float) or np.ndim(atol) == 0) or not (isinstance(rtol, float) or np.ndim(rtol) == 0):
            return "tolerances given per state"
        entry = self._rhs_entry(u)
        if isinstance(entry, str):
            return entry
        if cm.event_zeros and isinstance(self.zero_functions(entry), str):
            return self.zero_functions(entry)
        return None

    def integrator_name(self, u) -> str:
        """``"CVODES"``, or ``"IDAS"`` for a model whose Newton blocks are integrated as algebraic variables."""
        entry = self._rhs_entry(u)
        return "IDAS" if not isinstance(entry, str) and entry["z"].numel() else "CVODES"

    def zero_functions(self, entry):
        """The event zero functions and their time derivatives along the solution (CasADi), or the reason they
        have no CasADi form."""
        if "zeros" not in entry:
            import casadi as ca

            from ...backends.casadi import Unsupported, translate
            try:
                z = ca.vertcat(*translate(self.cm, self.cm.event_zeros, entry["signals"], entry["t"], entry["x"],
                                          entry["p"], entry["d"], given=entry["given"]))
                entry["zeros"] = (z, _rate(z, entry))
            except Unsupported as exc:
                entry["zeros"] = f"an event's zero function: {exc}"
        return entry["zeros"]

    def _rhs_entry(self, u):
        last = self._last
        if last is not None and len(last[0]) == len(u) and all(a is b for a, b in zip(last[0], u)):
            return last[1]  # the same signals as the run before (a run asks several times)
        from ...backends.casadi import Signals, Unsupported
        try:
            layout = Signals.layout(self.cm, u)
        except Unsupported as exc:
            return str(exc)
        if layout not in self._rhs:
            if len(self._rhs) > 256:  # input tables of many recordings: keep the memory bounded
                self._rhs.clear()
                self._integrators.clear()
            self._rhs[layout] = self.build_rhs(u)
        self._last = (u, self._rhs[layout])
        return self._last[1]

    def build_rhs(self, u, signals=None):
        """The right-hand side pieces of the run's signals ``u`` (a dict, see the cache comment), or why it has no
        CasADi form. ``signals``: a function of the time symbol returning the :class:`~.translate.Signals` to
        translate with (default: the tables' numbers inside the expressions)."""
        import casadi as ca

        from ...backends.casadi import Signals, Unsupported, state_derivatives, translate
        cm = self.cm
        try:
            t = ca.SX.sym("t")
            sig = Signals(cm, u) if signals is None else signals(t)
            x = ca.SX.sym("x", len(cm.state_names))
            p = ca.SX.sym("p", len(cm.param_names))
            d = ca.SX.sym("d", len(cm.discrete_names))
            algebraic = []
            f = translate(cm, state_derivatives(cm), sig, t, x, p, d, algebraic=algebraic)
        except Unsupported as exc:
            return str(exc)
        from ...model.symbols import var_symbol
        names = [n for names, _, _ in algebraic for n in names]
        zs = [z for _, block, _ in algebraic for z in block]
        # cache: integrand by name, quadrature sets ("set", names, variation), DAE functions ("dae", names)
        return dict(t=t, x=x, p=p, d=d, pds=ca.vertcat(p, d), f=ca.vertcat(*f), signals=sig, cache={},
                    z=ca.vertcat(*zs) if zs else ca.SX(0, 1),
                    alg=ca.vertcat(*[r for _, _, res in algebraic for r in res]) if zs else ca.SX(0, 1),
                    z_index=[cm.unknown_names.index(n) for n in names],
                    given={var_symbol(n): z for n, z in zip(names, zs)})

    def quadratures(self, entry, names, variation=False):
        """``(names integrated, their CasADi integrands)``: the names among ``names`` whose integrand
        (:func:`acausal.compile.accounts.integrand_expr`) has a CasADi form; with ``variation``, then the total
        variation of every event zero function (``("variation", i)``: the integral of ``|dz_i/dt|``)."""
        import casadi as ca

        from ...compile.accounts import integrand_expr
        from ...backends.casadi import Unsupported, translate
        key = ("set", tuple(names), variation)  # the integrator calls this per run: build each set once
        if key in entry["cache"]:
            return entry["cache"][key]
        def conv(es):
            return translate(self.cm, es, entry["signals"], entry["t"], entry["x"], entry["p"], entry["d"],
                             given=entry["given"])

        new = [name for name in dict.fromkeys(names) if name not in entry["cache"]]
        if new:  # translated together: the steps they share are converted once
            exprs = {name: integrand_expr(self.cm, name) for name in new}
            new = [name for name in new if exprs[name] is not None]
            entry["cache"].update({name: False for name, e in exprs.items() if e is None})
            try:
                entry["cache"].update(zip(new, conv([exprs[name] for name in new]) if new else []))
            except Unsupported:  # one at a time: which of them has no CasADi form
                for name in new:
                    try:
                        entry["cache"][name] = conv([exprs[name]])[0]
                    except Unsupported:
                        entry["cache"][name] = False
        done, exprs = [], []
        for name in names:
            q = entry["cache"][name]
            if q is not False:
                done.append(name)
                exprs.append(q)
        if variation:  # scaled far below any tolerance: integrated on the states' steps, never steering them
            _, dz = self.zero_functions(entry)
            for i in range(dz.numel()):
                done.append(("variation", i))
                exprs.append(VARIATION_SCALE * ca.fabs(dz[i]))
        entry["cache"][key] = (tuple(done), ca.cse(ca.vertcat(*exprs)) if exprs else None)
        return entry["cache"][key]

    # ------------------------------------------------------------------ integration
    def integrate(self, t_start, x0, t_out, seg, *, integrals=(), variation=False, max_num_steps=MAX_NUM_STEPS):
        """``(X, Q)``: states at the output times ``t_out`` (non-decreasing; shape ``(n_states, len(t_out))``),
        integrated from ``t_start`` with the states ``x0`` in the segment ``seg`` (:class:`~..run.Segment`: its
        parameters, modes, inputs, tolerances and step bounds), and ``Q[name]``, the time integral from ``t_start`` of
        each of ``integrals`` (names as :meth:`Result.energy <acausal.results.result.Result.energy>` takes them) that
        has a compiled form, integrated by CVODES under the same error control as the states (relative to each
        integral's own size: a port through which energy flows back and forth, netting little, is integrated to
        the tolerance of that net). With ``variation``, ``Q[("variation", i)]`` is the total variation of event
        zero function ``i`` (what a crossing hidden between two output times needs). Raises
        :class:`SimulationError` when CVODES fails."""
        return self.integrate_many(t_start, [x0], t_out, [seg], integrals=integrals, variation=variation,
                                   max_num_steps=max_num_steps)[0]

    def integrate_many(self, t_start, x0s, t_out, segs, *, integrals=(), threads: int = 1, variation=False,
                       max_num_steps=MAX_NUM_STEPS) -> list:
        """:meth:`integrate` for several start states ``x0s`` and segments ``segs`` (one each: their parameter
        vectors differ; the inputs, modes, tolerances and step bounds are the first's) in one call: CasADi maps the
        integrator over them, on ``threads`` threads."""
        seg = segs[0]
        d, u, rtol, atol, max_step, first_step = seg.d, seg.u, seg.rtol, seg.atol, seg.max_step, seg.first_step
        ps = [s.p for s in segs]
        entry = self._rhs_entry(u)
        t_out = np.asarray(t_out, dtype=float)
        t_end = float(t_out[-1]) if t_out.size else t_start
        span = t_end - t_start
        B, n = len(x0s), len(x0s[0])
        names, qexpr = self.quadratures(entry, integrals, variation) if integrals or variation else ((), None)
        X = np.empty((B, n, t_out.size))
        Q = np.zeros((B, len(names), t_out.size))
        # the outputs at the start (t_out is sorted)
        first = int(np.searchsorted(t_out, t_start, side="right")) if t_out.size and t_out[0] <= t_start else 0
        if first:
            X[:, :, :first] = np.asarray(x0s, dtype=float)[:, :, None]
        later = t_out[first:]
        if later.size:
            back = slice(None)
            tau = _scaled_grid(later, t_start, span)
            if tau is None:  # CVODES takes strictly increasing output times: repeated ones are read back
                grid, back = np.unique(later, return_inverse=True)
                tau = _scaled_grid(grid, t_start, span)
                if tau is None:  # distinct times equal on the scaled time (a round-off apart): CVODES says so
                    tau = (grid - t_start) / span
            budget = seg.budget if B == 1 else None  # a run under a budget (the trust check's own): counted
            clamped = False
            if budget is not None:
                budget.spend(0, t_start)  # its seconds spent already: stop before the call
                clamped = budget.steps_left < int(max_num_steps)
                if clamped:  # a power of two: the integrators cached by their limits stay few
                    max_num_steps = 1 << max(budget.steps_left, 1).bit_length() - 1
            limits = _Limits(float(rtol), float(atol), max_step / span,
                             None if first_step is None else first_step / span, int(max_num_steps))
            integ = self._integrator(entry, names, qexpr, tau, limits)
            if B == 1:
                P = np.concatenate(([t_start, span], ps[0], d))[:, None]
            else:
                P = np.empty((2 + len(ps[0]) + len(d), B))
                P[0], P[1], P[2 + len(ps[0]):] = t_start, span, np.reshape(d, (-1, 1))
                for b, p in enumerate(ps):
                    P[2:2 + len(p), b] = p
            X0 = np.asarray(x0s, dtype=float).T
            call = {"x0": X0, "p": P}
            if entry["z_index"]:  # the algebraic variables' start: the Python Newton iteration's values there
                call["z0"] = np.stack([self.algebraic_start(entry, t_start, x0, p, d, u)
                                       for x0, p in zip(x0s, ps)], axis=1)
            if B > 1:
                key = ("map", id(integ), B, threads)
                if key not in self._integrators:
                    self._integrators[key] = integ.map(B, "thread", threads) if threads > 1 else integ.map(B)
                integ = self._integrators[key]
            out, failed, said = run_integrator(integ, call, "z0" in call)
            if failed is not None and "IDACalcIC" in failed and B == 1:
                # IDAS's consistent initialisation failed (its line search, at a kink of a Max or Min of the
                # Newton block). The start is consistent already (the Python Newton solve of the algebraic
                # variables); with the state derivatives there, IDAS starts without initialising.
                xdot0 = span * self._state_rates(entry, t_start, call["x0"][:, 0], call["z0"][:, 0], P[2:, 0])
                out, failed, said = run_integrator(self._integrator(entry, names, qexpr, tau, limits, xdot0), call,
                                                   True)
            if budget is not None:
                budget.spend(steps_taken(integ), t_end if failed is None else None)
                if failed is not None and clamped and "TOO_MUCH_WORK" in failed:  # the budget's steps stopped it
                    raise BudgetExceeded(f"stopped between t = {t_start:.6g} and {t_end:.6g} s, its steps over its "
                                         f"budget of {budget.steps} steps")
            if failed is not None:
                raise SimulationError(f"compiled path ({self.integrator_name(u)}): integration from t = "
                                      f"{t_start:g} s to {t_end:g} s failed: {failed}"
                                      + (f" (SUNDIALS: {said})" if said else "")) from None
            X[:, :, first:] = out["xf"].reshape(n, B, -1).transpose(1, 0, 2)[:, :, back]
            if names:
                Q[:, :, first:] = out["qf"].reshape(len(names), B, -1).transpose(1, 0, 2)[:, :, back]
        if not names:
            return [(X[b], {}) for b in range(B)]
        scale = np.array([1 / VARIATION_SCALE if isinstance(k, tuple) else 1.0 for k in names])
        return [(X[b], dict(zip(names, Q[b] * scale[:, None]))) for b in range(B)]

    def _state_rates(self, entry, t, x, z, pds) -> np.ndarray:
        """The state derivatives at ``(t, x)`` with the algebraic variables ``z`` (``pds``: parameters, then modes)."""
        import casadi as ca
        if "rates" not in entry["cache"]:
            entry["cache"]["rates"] = ca.Function("rates", [entry["t"], entry["x"], entry["z"], entry["pds"]],
                                                  [entry["f"]])
        return np.asarray(entry["cache"]["rates"](t, x, z, pds), dtype=float).ravel()

    def algebraic_start(self, entry, t, x, p, d, u, near=None) -> np.ndarray:
        """The algebraic variables at ``(t, x)``: the generated code's Newton solve of their blocks (only the steps
        they need), from their start values or from ``near`` (their values nearby, in ``entry``'s order)."""
        if "z_values" not in entry["cache"]:
            names = [self.cm.unknown_names[i] for i in entry["z_index"]]
            entry["cache"]["z_values"] = (self.cm.generator.values_function(names), names)
        fn, names = entry["cache"]["z_values"]
        vals = fn(t, np.asarray(x, dtype=float).tolist(), p.tolist(), d.tolist(), u,
                  None if near is None else dict(zip(names, np.asarray(near, dtype=float).tolist())))
        return np.array([float(v) for v in vals])

    def integrable(self, names, u) -> list:
        """The names among ``names`` whose integrand has a compiled form (what CVODES can integrate as a
        quadrature beside the states)."""
        return list(self.quadratures(self._rhs_entry(u), tuple(names))[0])

    def quadratures_later(self, t_start, x0, t_out, seg):
        """A function ``names -> {name: integral from t_start at t_out}`` that runs the integration of the segment
        ``seg`` again with those names as quadratures (what :meth:`Result.energy
        <acausal.results.result.Result.energy>` asks of a name that is not one of the accounts integrated with the
        run: its integral to the integrator's accuracy, not to the output grid's)."""
        def integrals(names):
            names = self.integrable(names, seg.u)
            if not names:
                return {}
            return self.integrate(t_start, x0, t_out, seg, integrals=names)[1]
        return integrals

    def gauss_states(self, t_start, x0, t_out, seg):
        """A function returning ``(t_out, states at the 5 Gauss-Legendre nodes of every output interval)`` of the
        segment ``seg``, integrated when called (what :meth:`Result.energy <acausal.results.result.Result.energy>`
        needs for an integral that is not one of the quadratures)."""
        def states():
            from ...results.gauss import gauss_nodes
            tn, _, _ = gauss_nodes(t_out)
            Xn, _ = self.integrate(t_start, x0, tn.ravel(), seg)
            return t_out, Xn.reshape((len(x0),) + tn.shape)
        return states

    def _integrator(self, entry, names, qexpr, tau, limits, xdot0=None):
        """The CasADi integrator of ``entry``'s right-hand side with the quadratures ``names`` (``qexpr``) and the
        scaled output times ``tau``, under ``limits`` (:class:`_Limits`, on the scaled time); one made for a
        consistent start ``xdot0`` (the state derivatives there) is not kept."""
        import casadi as ca
        rtol, atol, max_step, first_step, max_num_steps = limits
        key = (id(entry), names, tau.tobytes(), rtol, atol, max_step, first_step, max_num_steps)
        integ = self._integrators.get(key) if xdot0 is None else None  # one made for its start is not kept
        if integ is None:
            if len(self._integrators) > 256:
                self._integrators.clear()
            dae = self._dae(entry, names, qexpr)
            opts = {"abstol": atol, "reltol": rtol, "max_num_steps": max_num_steps, "disable_internal_warnings": True,
                    "show_eval_warnings": False}  # a failed run is reported (and run again on the scipy path)
            if qexpr is not None:
                # the quadratures under the same tolerances as the states: CVODES's error test takes the larger of
                # the two weighted norms (states', quadratures'), so the states keep exactly their own accuracy
                opts["quad_err_con"] = True
            if np.isfinite(max_step):
                opts["max_step_size"] = max_step
            if first_step is not None:
                opts["step0"] = first_step
            plugin = "idas" if entry["z"].numel() else "cvodes"  # Newton blocks: a DAE, their variables algebraic
            if plugin == "idas":  # the error test on the states only: the algebraic variables follow from them
                opts["suppress_algebraic"] = True
                if xdot0 is not None:  # the start is consistent as given: no initialisation of IDAS's own
                    opts["calc_ic"] = False
                    opts["init_xdot"] = [float(v) for v in xdot0]
            integ = ca.integrator("acausal", plugin, dae, 0.0, tau.tolist(), opts)
            if xdot0 is None:
                self._integrators[key] = integ
        return integ


    def _dae(self, entry, names, qexpr):
        """The right-hand side (and quadratures) in scaled time as one CasADi function, built once per set of
        quadratures: integrators for new output grids are then built from it in about a millisecond."""
        import casadi as ca
        key = ("dae", names)
        if key not in entry["cache"]:
            s, params, scaled = _scaled_time(entry)
            # CVODES/IDAS take dense outputs only: an integrand that is structurally zero in a mode (an energy
            # account of a gear at rest until a load steps on) would leave a sparse entry
            dae = {"x": entry["x"], "t": s, "p": params, "z": entry["z"], "u": ca.SX(0, 1), "zero": ca.SX(0, 1),
                   "alg": ca.densify(ca.cse(scaled(entry["alg"], rate=False))),
                   "ode": ca.densify(ca.cse(scaled(entry["f"]))),
                   "quad": ca.SX(0, 1) if qexpr is None else ca.densify(scaled(qexpr))}
            entry["cache"][key] = ca.Function("dae", dae, ca.dyn_in(), ca.dyn_out())
        return entry["cache"][key]

    # ------------------------------------------------------------------ sensitivities
    def sensitivities(self, t_start, x0, t, seg, wrt, bindings):
        """``(X, S)``: states ``(n, N)`` and their sensitivities ``S = dx / d wrt`` ``(n, q, N)`` at the times
        ``t``, integrated together by CVODES from ``t_start`` (``S = 0`` there) in the segment ``seg`` (its
        parameters, modes, inputs and tolerances): ``dS/dt = f_x S + f_p B`` with CasADi's exact derivatives, ``B``
        the derivatives of the parameters with respect to ``wrt`` through their ``bindings``
        (:func:`acausal.compile.parameters.binding_totals`)."""
        p, d, u, rtol, atol = seg.p, seg.d, seg.u, seg.rtol, seg.atol
        entry = self._rhs_entry(u)
        if entry["z_index"]:
            raise SimulationError("compiled path: sensitivities of a model with a Newton block run on the scipy path")
        t = np.asarray(t, dtype=float)
        n, q, N = len(x0), len(wrt), t.size
        X = np.repeat(np.asarray(x0, dtype=float)[:, None], N, axis=1)
        S = np.zeros((n, q, N))
        later = t > t_start
        if not later.any():
            return X, S
        span = float(t[-1]) - t_start
        grid, back = np.unique(t[later], return_inverse=True)
        key = ("sens", id(entry), tuple(wrt), frozenset((k, str(v)) for k, v in bindings.items()),
               (grid - t_start).tobytes(), span, float(rtol), float(atol))
        integ = self._integrators.get(key)
        if integ is None:
            integ = self._sens_integrator(entry, wrt, bindings, (grid - t_start) / span, float(rtol), float(atol))
            self._integrators[key] = integ
        try:
            out = integ(x0=np.concatenate([x0, np.zeros(n * q)]), p=np.concatenate([[t_start, span], p, d]))
        except RuntimeError as exc:
            raise SimulationError(f"compiled path (CVODES): sensitivity integration from t = {t_start:g} s failed: "
                                  f"{first_line(exc)}") from None
        Y = np.asarray(out["xf"]).reshape(n * (1 + q), -1)[:, back]
        X[:, later] = Y[:n]
        if q:  # CasADi stacks S column by column
            S[:, :, later] = Y[n:].reshape(q, n, -1).transpose(1, 0, 2)
        return X, S

    def _sens_integrator(self, entry, wrt, bindings, tau, rtol, atol):
        import casadi as ca

        from ...backends.casadi import variational
        f, x = entry["f"], entry["x"]
        S, dS = variational(self.cm, f, x, entry["p"], wrt, bindings)
        s, params, scaled = _scaled_time(entry)
        dae = {"x": ca.vertcat(x, S), "t": s, "p": params, "ode": scaled(ca.vertcat(f, dS))}
        return ca.integrator("acausal_sens", "cvodes", dae, 0.0, tau.tolist(),
                             {"abstol": atol, "reltol": rtol, "max_num_steps": MAX_NUM_STEPS,
                              "disable_internal_warnings": True, "show_eval_warnings": False})


class _Limits(typing.NamedTuple):
    """An integrator's tolerances and step bounds on the scaled time (``max_step``, ``first_step``: over the span),
    and its steps per call at most."""

    rtol: float
    atol: float
    max_step: float
    first_step: float | None
    max_num_steps: int


def _scaled_time(entry):
    """``(tau, parameters, scaled)``: the scaled time symbol, the integrator's parameter vector ``(t0, span, p, d)``
    and a function that rewrites an expression of ``t`` in ``tau`` (``t = t0 + tau span``); a ``rate`` (a time
    derivative or an integrand) is also multiplied by ``span``."""
    import casadi as ca
    s, t0, span = ca.SX.sym("tau"), ca.SX.sym("t0"), ca.SX.sym("span")

    def scaled(expr, rate=True):
        out = ca.substitute(expr, entry["t"], t0 + s * span)
        return span * out if rate else out
    return s, ca.vertcat(t0, span, entry["pds"]), scaled


def _scaled_grid(grid, t_start, span):
    """The output times ``grid`` (after ``t_start``, sorted) on the integrator's scaled time ``(t - t_start) /
    span``: the cached evenly spaced grid of their count where they are that up to the round-off of the times
    (one integrator per count), None where two of them are equal."""
    tau = (grid - t_start) / span
    even = _even(tau.size)
    if abs(tau - even).max() <= 16 * EPS * max(abs(t_start), abs(t_start + span), 1.0) / span:
        return even
    return tau if tau.size < 2 or (tau[1:] > tau[:-1]).all() else None


@functools.lru_cache(maxsize=64)
def _even(size: int) -> np.ndarray:
    """``1/size, 2/size, ..., 1``: an evenly spaced output grid on the scaled time (read-only, cached)."""
    out = np.arange(1, size + 1) / size
    out.setflags(write=False)
    return out


def _rate(expr, entry):
    """The time derivative of ``expr`` along the solution: through the states, time, and the algebraic variables
    (whose rate follows from their residuals, ``dz/dt = -(dr/dz)^-1 (dr/dx f + dr/dt)``)."""
    import casadi as ca
    x, t, f, z, r = entry["x"], entry["t"], entry["f"], entry["z"], entry["alg"]
    rate = ca.mtimes(ca.jacobian(expr, x), f) + ca.jacobian(expr, t)
    if z.numel():
        dz = -ca.solve(ca.jacobian(r, z), ca.mtimes(ca.jacobian(r, x), f) + ca.jacobian(r, t))
        rate = rate + ca.mtimes(ca.jacobian(expr, z), dz)
    return rate
