"""The scipy backend: scipy's integrators (``BDF``, ``Radau``, ``LSODA``, ``RK45``...) driven step by step, so that a
failure is reported with the time, the step size and the variable, and state events stop the step exactly at the
zero crossing (located by Brent's method on the step's dense output, :mod:`acausal.simulation.events`); the event
there and the restart are the one event loop's (:mod:`acausal.simulation.loop`: :class:`Stepper` is its segment
integrator). With ``quadratures`` the energy integrals of the accounts are carried as extra states outside the error
control (:mod:`acausal.simulation.scipy.quadratures`; on LSODA inside it, :data:`CORRECTOR_ON_WEIGHTS`)."""
from __future__ import annotations

import math

import numpy as np
from scipy import integrate as scipy_integrate

from ...errors import SimulationError
from .failures import non_finite_error, step_failure
from ..events import crossings_in_step, together, zeros
from ..loop import event_modes, integrate_segments
from .quadratures import Quadratures
from ...results.interpolants import StatesOnly

METHODS = {"BDF": scipy_integrate.BDF, "Radau": scipy_integrate.Radau, "LSODA": scipy_integrate.LSODA,
           "RK45": scipy_integrate.RK45, "RK23": scipy_integrate.RK23, "DOP853": scipy_integrate.DOP853}
IMPLICIT = {"BDF", "Radau", "LSODA"}
#: absolute tolerance of the energy integrals carried as states: so large that they take no part in the error
#: control (as CVODES's quadratures on the compiled path): they follow the states' steps, evaluated at the
#: integrator's own states, not at its interpolants
UNCONTROLLED = 1e300
MAX_STEPS = 2_000_000  # scipy steps of an implicit integrator at most (about 3 minutes of stepping)
MAX_STEPS_EXPLICIT = 200_000  # of an explicit one: more means the model is stiff for it


#: integrators whose corrector stops when its correction is a fair part of the error weights (LSODA's: 0.5/(order
#: + 2) of them, against 1e-3 for scipy's BDF and Radau at rtol 1e-6): an integral outside the error control, left
#: out of that test, stays the last correction behind the states, and an integrand that amplifies them (the current
#: through a diode's 1e-5 ohm) makes that percents of its energy (1.5 % on a half-wave rectifier). Their energy
#: integrals take part in the error control, at an absolute tolerance from the energies the run moves (``energy_atol``)
CORRECTOR_ON_WEIGHTS = {"LSODA"}


def integrate(run, method: str, why: str, quadratures: bool = False, energy_atol: float | None = None):
    """Integrate ``run`` (:class:`~.run.Run`) with the scipy integrator ``method``; ``why`` it was chosen goes to
    ``res.solver``. ``quadratures``: the energy integrals as states (see the module docstring); ``energy_atol`` [J]:
    their absolute tolerance on an integrator of :data:`CORRECTOR_ON_WEIGHTS` (elsewhere, or None: outside the
    error control). The Result remembers ``scipy_method``."""
    return integrate_segments(run, Stepper(run, method, why, quadratures, energy_atol))


class Stepper:
    """The scipy path's segment integrator (:mod:`acausal.simulation.loop`): per segment a scipy integrator
    ``method``, stepped one step at a time; each step's dense output searched for crossings
    (:func:`~acausal.simulation.events.crossings_in_step`; Radau's on the solution itself, a dip of an interpolant
    confirmed by integrating to it), the outputs it passes read off it. ``quadratures``: the energy integrals carried
    as states outside the error control (but see :data:`CORRECTOR_ON_WEIGHTS`, ``energy_atol``)."""

    def __init__(self, run, method: str, why: str, quadratures: bool = False, energy_atol: float | None = None):
        cm = run.cm
        self.run, self.cm, self.method, self.why = run, cm, method, why
        self.n = len(cm.state_names)
        self.quad = Quadratures(cm) if quadratures else None  # energy integrals carried as states
        self.names = list(self.quad.names) if self.quad is not None else []
        self.nq = len(self.names)
        self.q = np.zeros(self.nq)  # the integrals where the next segment starts
        self.energy_atol = float(energy_atol) if energy_atol is not None and method in CORRECTOR_ON_WEIGHTS else \
            UNCONTROLLED
        self.solver_cls = METHODS[method]
        self.has_events = bool(cm.event_zeros)
        self.limit = run.max_steps if run.max_steps is not None else \
            MAX_STEPS if method in IMPLICIT else MAX_STEPS_EXPLICIT
        self.steps_left = self.limit
        self.steps: list = []  # (t0, t1, dense interpolant, modes) of every accepted step, for exact energy integrals
        self.solver = None

    def advance(self, loop):
        """One segment from ``(loop.t, loop.x)``: a fresh integrator stepped until a crossing makes an event (returned)
        or the run ends (None)."""
        run, cm, n, nq, method = self.run, self.cm, self.n, self.nq, self.method
        t_end, t_out = run.t_end, run.t_out
        t = loop.t
        if t >= t_end:  # an event at the end: nothing left to integrate
            return None
        seg = loop.segment()
        p, d, u, off = seg.p, seg.d, seg.u, loop.off
        rtol, atol = run.rtol, run.atol
        n_out = t_out.size
        has_events = self.has_events
        budget = run.budget
        x = np.concatenate([loop.x, self.q]) if nq else loop.x
        fun, jac = _make_functions(seg, self.quad)
        opts = dict(rtol=rtol, atol=atol, max_step=run.max_step)
        if nq:  # the integrals outside the error control (but see CORRECTOR_ON_WEIGHTS); the states' tolerances
            # tightened so that scipy's RMS error norm over states and integrals (these contributing nothing) weighs
            # the states as without them
            k = math.sqrt(n / (n + nq))
            opts["rtol"] = np.asarray(rtol, dtype=float) * k
            opts["atol"] = np.concatenate([np.broadcast_to(np.asarray(atol, dtype=float) * k, (n,)),
                                           np.full(nq, self.energy_atol)])
        if run.first_step is not None:
            opts["first_step"] = run.first_step
        if method in IMPLICIT:
            opts["jac"] = jac
        try:
            solver = self.solver_cls(fun, t, x, t_end, **opts)  # evaluates the model to choose its first step
        except _NonFinite as exc:
            raise non_finite_error(cm, exc.t, exc.x, p, d, u, exc.where) from None
        self.solver = solver
        again = _Again(seg, self.solver_cls, fun, opts, off, n)  # integrating a step again from its start
        z_old = zeros(cm, t, x[:n], p, d, u, off=off) if has_events else None
        while solver.status == "running":
            t_prev = solver.t
            x_prev = solver.y.copy() if has_events or method in COARSE_INTERPOLANT else None
            try:
                msg = solver.step()
            except _NonFinite as exc:  # see _make_functions
                raise non_finite_error(cm, exc.t, exc.x, p, d, u, exc.where) from None
            y_sum = float(solver.y.sum())  # (with quadratures, the states are solver.y[:n])
            if solver.status == "failed" or y_sum - y_sum != 0.0:  # failed, or NaN/inf in the states
                bad = _find_non_finite(cm, solver, t_prev, p, d, u)
                raise bad if bad is not None else step_failure(cm, solver, msg, p, d, u, rtol, atol)
            t_new = solver.t
            self.steps_left -= 1
            if self.steps_left < 0:
                raise _too_many_steps(cm, method, self.limit, t_prev, t_new, run.t_start, t_end)
            if budget is not None:
                budget.spend(1, t_new)
            if t_new == t_prev:
                continue
            need_out = loop.k < n_out and t_out[loop.k] <= t_new
            full = solver.dense_output() if (need_out or has_events or run.dense_output) else None
            sol = StatesOnly(full, n) if nq and full is not None else full
            hit = None
            if has_events:
                z_new = zeros(cm, t_new, solver.y[:n], p, d, u, False, off)  # a bad value: after any crossing
                hits = crossings_in_step(seg, sol, t_prev, t_new, z_old, z_new, off=off)
                x_e = None
                if hits and method in COARSE_INTERPOLANT:  # the crossing located on the solution, not its interpolant
                    hits, x_e = again.located_on_solution(t_prev, x_prev, t_new, solver.y, sol, hits)
                elif hits and _dip_only(z_old, z_new, hits) and not again.dip_confirmed(t_prev, x_prev, t_new, sol,
                                                                                          hits):
                    hits = []  # the interpolant dipped across zero where the solution does not
                z_old = z_new
                if hits:
                    t_e = hits[0][0]
                    q_e = None if x_e is None or not nq else np.asarray(x_e[n:], dtype=float)
                    x_e = sol(t_e) if x_e is None else x_e[:n]
                    d_new = event_modes(seg, hits, t_e, x_e)
                    if d_new is not None:  # else no restart is needed
                        hit = hits
            t_stop = hit[0][0] if hit else t_new
            if run.dense_output:
                self.steps.append((t_prev, t_stop, sol, d.copy()))
            if need_out:
                k_out = loop.k
                k_end = np.searchsorted(t_out, t_stop, side="right")
                if k_end > k_out:
                    if method in COARSE_INTERPOLANT:  # the outputs integrated to, not read off the interpolant
                        at = again.chain(t_prev, x_prev, t_out[k_out:k_end])
                        loop.write(k_end, at[:n], dict(zip(self.names, at[n:])))
                    else:
                        loop.write(k_end, sol(t_out[k_out:k_end]),
                                   dict(zip(self.names, np.asarray(full(t_out[k_out:k_end]))[n:])) if nq else None)
            if hit:
                if nq:  # where the crossing was located on the solution, the integrals integrated to it too
                    self.q = np.asarray(full(t_e))[n:] if q_e is None else q_e
                return t_e, x_e, hit, d_new
        return None

    def result(self, loop):
        """The Result: the outputs, the steps' interpolants (with dense output), the integrals carried as states."""
        from ...results.result import DenseOutput, Result

        run, n, solver = self.run, self.n, self.solver
        X, D, Q, k_out = loop.X, loop.D, loop.Q, loop.k
        if k_out < run.t_out.size:  # t_end itself
            X[:, k_out:] = solver.y[:n, None]
            D[:, k_out:] = loop.d[:, None]
            for j, name in enumerate(self.names):
                Q[name][k_out:] = solver.y[n + j]
        label = f"{self.method} (scipy: {self.why})"
        if self.nq:
            label = label[:-1] + "; energies integrated as states)"
        res = Result(run.cm, run.t_out, X, run.p, run.u, D, events=loop.events,
                     dense=DenseOutput(steps=self.steps, integrals=Q), solver=label)
        res.scipy_method = self.method
        return res


#: integrators whose dense output is of lower order than their steps (Radau IIA: the collocation polynomial, order 3,
#: against the step's 5): their crossings are located by integrating to trial times, not on the interpolant
COARSE_INTERPOLANT = {"Radau"}


class _Again:
    """Integrating again from a step's start in one segment (``seg``: :class:`~..run.Segment`), by a fresh solver of
    the same integrator (``solver_cls``, right-hand side ``fun``, options ``opts``): where an interpolant cannot be
    trusted (Radau's, of lower order than its steps; a dip across zero). ``off``: the thresholds the zero functions
    are watched at; ``n``: the states (the first rows of the integrated vector)."""

    def __init__(self, seg, solver_cls, fun, opts, off, n):
        self.seg, self.solver_cls, self.fun, self.opts, self.off, self.n = seg, solver_cls, fun, opts, off, n

    def to(self, t0, x0, t1):
        """The states at ``t1`` integrated from ``(t0, x0)`` by a fresh solver (same integrator and tolerances)."""
        if t1 <= t0:
            return np.array(x0, dtype=float)
        again = self.solver_cls(self.fun, t0, x0, t1, **{**self.opts, "first_step": None})
        budget = self.seg.budget
        while again.status == "running":
            msg = again.step()
            if budget is not None:
                budget.spend(1, again.t)
        if again.status != "finished":
            raise SimulationError(f"integrating again from t = {t0:.9g} s to {t1:.9g} s (to locate an event or an "
                                  f"output inside a step) failed: {msg}")
        return again.y

    def chain(self, t0, x0, times) -> np.ndarray:
        """The states (columns) at ``times`` (increasing, in the step after ``t0``), each integrated from the one
        before, the first from ``(t0, x0)``."""
        out, t, x = [], t0, x0
        for tk in times:
            x = self.to(t, x, float(tk))
            out.append(np.array(x, dtype=float))
            t = float(tk)
        return np.array(out).T

    def _zero(self, t, x, i) -> float:
        """Zero function ``i`` (relative to its threshold) at ``t`` with the states ``x`` (their first ``n``)."""
        seg = self.seg
        return float(zeros(seg.cm, t, x[:self.n], seg.p, seg.d, seg.u, False, self.off)[i])

    def located_on_solution(self, t_prev, x_prev, t_new, y_new, sol, hits):
        """``hits`` with their time refined on the solution itself (Brent's method on the zero function of states
        integrated from the step's start), and the states there; a zero function that does not cross on the
        solution drops out (a dip of the interpolant only). The bracket's far end is the step's end, or for a dip
        the interpolant's deepest point."""
        from scipy import optimize

        if hits[0][0] == t_prev:  # leaving an exact zero at the step's start (modes.crossings): nothing to locate
            return hits, np.array(x_prev, dtype=float)

        def g(t, i):
            return self._zero(t, self.to(t_prev, x_prev, t), i)

        kept = []
        for _, i, rising in hits:
            hi = t_new
            z_end = self._zero(t_new, y_new, i)
            if not ((z_end > 0) if rising else (z_end < 0)):  # a dip: the far end is its deepest point
                hi = self.deepest(sol, t_prev, t_new, i, rising)
            def past(t):  # the solution's zero function on the crossing's far side at t
                return g(t, i) > 0 if rising else g(t, i) < 0

            if not past(hi):
                continue
            te = optimize.brentq(g, t_prev, hi, args=(i,), xtol=1e-13 * max(1.0, abs(hi)),
                                 rtol=4 * np.finfo(float).eps)
            if not past(te):  # just past the crossing, as modes.crossings does
                te = min(hi, te + 1e-12 * max(1.0, abs(te)))
            kept.append((te, i, rising))
        if not kept:
            return [], None
        hits = together(kept)
        return hits, self.to(t_prev, x_prev, hits[0][0])

    def deepest(self, sol, t_prev, t_new, i, rising) -> float:
        """The time inside the step where the interpolant ``sol`` takes zero function ``i`` furthest past zero in
        the crossing's direction (64 points)."""
        seg, off = self.seg, self.off
        ts = t_prev + (t_new - t_prev) * np.linspace(0.0, 1.0, 65)[1:-1]
        z = np.broadcast_to(np.asarray(seg.cm.funcs["zeros"](ts, np.asarray(sol(ts)), seg.p, seg.d, seg.u)[i],
                                       dtype=float), ts.shape)
        return float(ts[int(np.argmax(z - off[i] if rising else off[i] - z))])

    def dip_confirmed(self, t_prev, x_prev, t_new, sol, hits) -> bool:
        """Whether the solution itself crosses where the interpolant ``sol`` dips: the states integrated again from
        the step's start to the interpolant's deepest point of the dip (same integrator and tolerances), their zero
        function checked there. A dip the integrator does not confirm is no event."""
        for _, i, rising in hits:
            t_probe = self.deepest(sol, t_prev, t_new, i, rising)
            z = self._zero(t_probe, self.to(t_prev, x_prev, t_probe), i)
            if (z > 0) if rising else (z < 0):
                return True
        return False


def _dip_only(z_old, z_new, hits) -> bool:
    """Whether every zero function of ``hits`` has the same sign at both ends of the step: it crossed zero and
    back inside it, seen only on the step's interpolant."""
    return all(z_old[i] * z_new[i] > 0 for _, i, _ in hits)


def _too_many_steps(cm, method, limit, t_prev, t_new, t_start, t_end) -> SimulationError:
    hint = (f"the model is stiff for the explicit {method}: use method='auto' or 'BDF'" if method not in IMPLICIT
            else "a stiff or chattering model: look at the fastest state, or raise max_steps")
    return SimulationError(f"simulate {cm.flat.name}: {method} took {limit} steps and reached t = {t_new:.6g} s of "
                           f"{t_start:g}..{t_end:g} s (last step {t_new - t_prev:.3g} s): {hint}")


def _make_functions(seg, quad=None):
    """Right-hand side and Jacobian for the integrator of the segment ``seg`` (:class:`~..run.Segment`). Scalar runs
    pass plain Python floats to the generated code (several times faster arithmetic than numpy scalars). With
    ``quad`` (:class:`Quadratures`) the energy integrals follow the states (their rows of the Jacobian are left
    zero: nothing depends on them, and the Newton iteration of an implicit step converges on them with the
    states)."""
    cm, p, d, u = seg.cm, seg.p, seg.d, seg.u
    rhs, jacf = cm.funcs["rhs"], cm.funcs["jac"]
    pl = p.tolist()
    dl = d.tolist()
    if quad is not None:
        n, nq = len(cm.state_names), len(quad.names)
        fun0, jac0 = _make_functions(seg)

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
