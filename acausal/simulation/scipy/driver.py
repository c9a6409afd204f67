"""The scipy backend: scipy's integrators (``BDF``, ``Radau``, ``LSODA``, ``RK45``...) driven step by step, so that a
failure is reported with the time, the step size and the variable, and state events stop the step exactly at the
zero crossing (located by Brent's method on the step's dense output, :mod:`acausal.simulation.events`). With
``quadratures`` the energy integrals of the accounts are carried as extra states outside the error control
(:mod:`acausal.simulation.scipy.quadratures`)."""
from __future__ import annotations

import math

import numpy as np
from scipy import integrate as scipy_integrate

from ...errors import SimulationError
from .failures import non_finite_error, step_failure
from ..events import after_end, apply_hits, crossings_in_step, handle_event, restarts, settle_modes, together, zeros
from .quadratures import Quadratures
from ...results.interpolants import StatesOnly
from ..initial import initialize

METHODS = {"BDF": scipy_integrate.BDF, "Radau": scipy_integrate.Radau, "LSODA": scipy_integrate.LSODA,
           "RK45": scipy_integrate.RK45, "RK23": scipy_integrate.RK23, "DOP853": scipy_integrate.DOP853}
IMPLICIT = {"BDF", "Radau", "LSODA"}
#: absolute tolerance of the energy integrals carried as states: so large that they take no part in the error
#: control (as CVODES's quadratures on the compiled path): they follow the states' steps, evaluated at the
#: integrator's own states, not at its interpolants
UNCONTROLLED = 1e300
MAX_STEPS = 2_000_000  # scipy steps of an implicit integrator at most (about 3 minutes of stepping)
MAX_STEPS_EXPLICIT = 200_000  # of an explicit one: more means the model is stiff for it


def integrate(run, method: str, why: str, quadratures: bool = False):
    """Integrate ``run`` (:class:`~.run.Run`) with the scipy integrator ``method``; ``why`` it was chosen goes to
    ``res.solver``. ``quadratures``: the energy integrals as states (see the module docstring). The Result
    remembers ``scipy_method``."""
    from ...results.result import Result

    cm, t_start, t_end, t_out = run.cm, run.t_start, run.t_end, run.t_out
    p, d, u, x0, starts = run.p, run.d.copy(), run.u, run.x0.copy(), run.starts  # (the run stays as it was)
    rtol, atol, max_step, first_step = run.rtol, run.atol, run.max_step, run.first_step
    max_events, dense_output, max_steps = run.max_events, run.dense_output, run.max_steps
    n = len(cm.state_names)
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
                x_e = None
                if hits and method in COARSE_INTERPOLANT:  # the crossing located on the solution, not its interpolant
                    hits, x_e = _located_on_solution(cm, solver_cls, fun, opts, t_prev, x_prev, t_new, solver.y,
                                                     sol, hits, p, d, u, off, n)
                elif hits and _dip_only(z_old, z_new, hits) and not _dip_confirmed(
                        cm, solver_cls, fun, opts, t_prev, x_prev, t_new, sol, hits, p, d, u, off, n):
                    hits = []  # the interpolant dipped across zero where the solution does not
                z_old = z_new
                if hits:
                    t_e = hits[0][0]
                    x_e = sol(t_e) if x_e is None else x_e[:n]
                    d_new = apply_hits(cm, hits, t_e, x_e, p, d, u)
                    if not np.array_equal(d_new, d) or restarts(cm, hits):  # else no restart is needed
                        hit = hits
            t_stop = hit[0][0] if hit else t_new
            if dense_output:
                segments.append((t_prev, t_stop, sol, d.copy()))
            if need_out:
                k_end = np.searchsorted(t_out, t_stop, side="right")
                if k_end > k_out:
                    if method in COARSE_INTERPOLANT:  # the outputs integrated to, not read off the interpolant
                        at = _chain(solver_cls, fun, opts, t_prev, x_prev, t_out[k_out:k_end])
                        X[:, k_out:k_end], Q[:, k_out:k_end] = at[:n], at[n:]
                    else:
                        X[:, k_out:k_end] = sol(t_out[k_out:k_end])
                        if nq:
                            Q[:, k_out:k_end] = np.asarray(full(t_out[k_out:k_end]))[n:]
                    D[:, k_out:k_end] = d[:, None]
                    k_out = k_end
            if hit:
                x_e, d, off = handle_event(cm, events, hit, t_e, x_e, p, d, d_new, u, max_events)
                after_end(t_out, t_e, X, D, x_e, d)
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


#: integrators whose dense output is of lower order than their steps (Radau IIA: the collocation polynomial, order 3,
#: against the step's 5): their crossings are located by integrating to trial times, not on the interpolant
COARSE_INTERPOLANT = {"Radau"}


def _integrate_to(solver_cls, fun, opts, t0, x0, t1):
    """The states at ``t1`` integrated from ``(t0, x0)`` by a fresh solver (same integrator and tolerances)."""
    if t1 <= t0:
        return np.array(x0, dtype=float)
    again = solver_cls(fun, t0, x0, t1, **{**opts, "first_step": None})
    while again.status == "running":
        msg = again.step()
    if again.status != "finished":
        raise SimulationError(f"integrating again from t = {t0:.9g} s to {t1:.9g} s (to locate an event or an output "
                              f"inside a step) failed: {msg}")
    return again.y


def _chain(solver_cls, fun, opts, t0, x0, times) -> np.ndarray:
    """The states (columns) at ``times`` (increasing, in the step after ``t0``), each integrated from the one before,
    the first from ``(t0, x0)``."""
    out, t, x = [], t0, x0
    for tk in times:
        x = _integrate_to(solver_cls, fun, opts, t, x, float(tk))
        out.append(np.array(x, dtype=float))
        t = float(tk)
    return np.array(out).T


def _located_on_solution(cm, solver_cls, fun, opts, t_prev, x_prev, t_new, y_new, sol, hits, p, d, u, off, n):
    """``hits`` with their time refined on the solution itself (Brent's method on the zero function of states
    integrated from the step's start), and the states there; a zero function that does not cross on the solution
    drops out (a dip of the interpolant only). The bracket's far end is the step's end, or for a dip the
    interpolant's deepest point."""
    from scipy import optimize

    if hits[0][0] == t_prev:  # leaving an exact zero at the step's start (modes.crossings): nothing to locate
        return hits, np.array(x_prev, dtype=float)

    def g(t, i):
        return float(zeros(cm, t, _integrate_to(solver_cls, fun, opts, t_prev, x_prev, t)[:n], p, d, u, False,
                           off)[i])

    kept = []
    for _, i, rising in hits:
        hi = t_new
        z_end = float(zeros(cm, t_new, y_new[:n], p, d, u, False, off)[i])
        if not ((z_end > 0) if rising else (z_end < 0)):  # a dip: the far end is its deepest point
            hi = _deepest(cm, sol, t_prev, t_new, i, rising, p, d, u, off)
        def past(t):  # the solution's zero function on the crossing's far side at t
            return g(t, i) > 0 if rising else g(t, i) < 0

        if not past(hi):
            continue
        te = optimize.brentq(g, t_prev, hi, args=(i,), xtol=1e-13 * max(1.0, abs(hi)), rtol=4 * np.finfo(float).eps)
        if not past(te):  # just past the crossing, as modes.crossings does
            te = min(hi, te + 1e-12 * max(1.0, abs(te)))
        kept.append((te, i, rising))
    if not kept:
        return [], None
    hits = together(kept)
    return hits, _integrate_to(solver_cls, fun, opts, t_prev, x_prev, hits[0][0])


def _deepest(cm, sol, t_prev, t_new, i, rising, p, d, u, off) -> float:
    """The time inside the step where the interpolant ``sol`` takes zero function ``i`` furthest past zero in the
    crossing's direction (64 points)."""
    ts = t_prev + (t_new - t_prev) * np.linspace(0.0, 1.0, 65)[1:-1]
    z = np.broadcast_to(np.asarray(cm.funcs["zeros"](ts, np.asarray(sol(ts)), p, d, u)[i], dtype=float), ts.shape)
    return float(ts[int(np.argmax(z - off[i] if rising else off[i] - z))])


def _dip_only(z_old, z_new, hits) -> bool:
    """Whether every zero function of ``hits`` has the same sign at both ends of the step: it crossed zero and
    back inside it, seen only on the step's interpolant."""
    return all(z_old[i] * z_new[i] > 0 for _, i, _ in hits)


def _dip_confirmed(cm, solver_cls, fun, opts, t_prev, x_prev, t_new, sol, hits, p, d, u, off, n) -> bool:
    """Whether the solution itself crosses where the interpolant ``sol`` dips: the states integrated again from the
    step's start to the interpolant's deepest point of the dip (same integrator and tolerances), their zero
    function checked there. A dip the integrator does not confirm is no event."""
    for _, i, rising in hits:
        t_probe = _deepest(cm, sol, t_prev, t_new, i, rising, p, d, u, off)
        z = float(zeros(cm, t_probe, _integrate_to(solver_cls, fun, opts, t_prev, x_prev, t_probe)[:n], p, d, u,
                        False, off)[i])
        if (z > 0) if rising else (z < 0):
            return True
    return False


def _too_many_steps(cm, method, limit, t_prev, t_new, t_start, t_end) -> SimulationError:
    hint = (f"the model is stiff for the explicit {method}: use method='auto' or 'BDF'" if method not in IMPLICIT
            else "a stiff or chattering model: look at the fastest state, or raise max_steps")
    return SimulationError(f"simulate {cm.flat.name}: {method} took {limit} steps and reached t = {t_new:.6g} s of "
                           f"{t_start:g}..{t_end:g} s (last step {t_new - t_prev:.3g} s): {hint}")


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
