"""State events on the compiled path: CVODES integrates between events, the crossings are found and handled as
on the scipy path.

Each segment (constant discrete modes) is integrated over a window of output times in one call, together with
the *total variation* of every event zero function (the integral of ``|dz/dt|``). A crossing shows as a sign
change of ``z`` between two output times; one that enters and leaves between them (a diode conducting for a
moment) cannot hide: the interval's variation is then at least ``|z(a)| + |z(b)|``, and such an interval is
integrated again on a finer grid, recursively, until the crossing is seen or shown not to exist. A crossing is
located by Brent's method on ``z`` along one integrator solution of its interval (see :func:`_locate`), then the
event's assignments, the cascade of mode changes and the restart follow the scipy path's own functions
(:mod:`acausal.simulate`), so both paths switch the same way.

Each run covers a window of output times that restarts at one output after an event and doubles while nothing
happens: CVODES continuing past a crossing in the old mode can run into steps it cannot take, and a failed run
(capped at :data:`WINDOW_STEPS` steps) is retried on half the window. Taken only on request
(``method="CVODES"``): on the paper's actuator it gives the scipy path's switches and results, but the whole
``acausal paper`` takes longer (restarts, Brent trials as integrator runs), so the scipy path stays the default for
models with events (see the users' guide, Simulation paths).
"""
from __future__ import annotations

import numpy as np

from ..errors import SimulationError
from ..modes import apply_event, cascade, crossings, record_events, settle_modes, zeros

REFINE = 16  # sub-intervals of a suspect interval
MAX_DEPTH = 4  # refinements of refinements
WINDOW = 64  # output times per CVODES run at most: an event restarts the run, so the work after it is not thrown away
WINDOW_STEPS = 4_000  # CVODES steps per run at most: a run that cannot go on (the old mode past a crossing) fails fast


def simulate_with_events(cm, t_start, x0, t_out, p, d, u, rtol, atol, max_step, first_step, max_events,
                         dense_output, starts=None):
    """The run of a model with state events on the compiled path; returns the Result."""
    from ..energy import account_integrals
    from ..result import Result
    from ..simulate import initialize

    path = cm.compiled_path
    args = (rtol, atol, max_step, first_step)
    names = account_integrals(cm.accounts) if dense_output and cm.accounts is not None else []
    d = settle_modes(cm, t_start, x0, p, d, u)
    x0 = initialize(cm, t_start, p, d, u, starts) if cm.discrete_names else x0
    n, N = len(x0), t_out.size
    X, D = np.empty((n, N)), np.empty((len(d), N))
    Q = {name: np.zeros(N) for name in names}
    events = []
    t, x, k_out, window = t_start, np.asarray(x0, dtype=float), 0, WINDOW
    done = {name: 0.0 for name in names}  # integral from t_start to t
    while True:
        while k_out < N and t_out[k_out] <= t:  # outputs at the restart time itself
            X[:, k_out], D[:, k_out] = x, d
            for name in names:
                Q[name][k_out] = done[name]
            k_out += 1
        if k_out == N:
            break
        grid = t_out[k_out:k_out + window]
        try:
            Xs, Qs = path.integrate(t, x, grid, p, d, u, *args, integrals=names, variation=True,
                                    max_num_steps=WINDOW_STEPS)
        except SimulationError:
            if window == 1:
                raise
            window //= 2  # the old mode may not go on far past a crossing: look closer
            continue
        hit = _first_crossing(cm, path, t, x, grid, Xs, Qs, p, d, u, args)
        if hit is None:
            X[:, k_out:k_out + grid.size], D[:, k_out:k_out + grid.size] = Xs, d[:, None]
            for name in names:
                Q[name][k_out:k_out + grid.size] = done[name] + Qs[name]
            done = {name: done[name] + Qs[name][-1] for name in names}
            k_out += grid.size
            t, x = float(grid[-1]), Xs[:, -1].copy()
            window = min(2 * window, WINDOW)
            continue
        t_e, x_e, hits, d_new = hit
        upto = np.searchsorted(grid, t_e, side="right")  # outputs before the event keep this segment's values
        X[:, k_out:k_out + upto], D[:, k_out:k_out + upto] = Xs[:, :upto], d[:, None]
        for name in names:
            Q[name][k_out:k_out + upto] = done[name] + Qs[name][:upto]
        if names:
            _, q_e = path.integrate(t, x, np.array([t_e]), p, d, u, *args, integrals=names)
            done = {name: done[name] + q_e[name][0] for name in names}
        k_out += upto
        record_events(cm, events, hits, t_e, max_events)
        d = cascade(cm, t_e, x_e, p, d, d_new, u)
        t, x = t_e, x_e
        window = 1  # events come in groups: start close after one
    return Result(cm, t_out, X, p, u, D, events=events, integrals=Q,
                  solver=f"{path.integrator_name(u)} (compiled path, CasADi; events located between its runs)")


def _first_crossing(cm, path, t, x, grid, Xs, Qs, p, d, u, args):
    """The first crossing after ``t`` that changes a mode: ``(t_e, x_e, hits, new modes)``, or None. ``Xs``, ``Qs``:
    states and integrals (with the zero functions' variations) at ``grid``, integrated from ``(t, x)``."""
    times = np.concatenate([[t], grid])
    states = np.concatenate([x[:, None], Xs], axis=1)
    return _scan(cm, path, times, states, _variations(cm, Qs), p, d, u, args, depth=0)


def _scan(cm, path, times, states, var, p, d, u, args, depth):
    z = _zero_values(cm, times, states, p, d, u)
    for k in range(times.size - 1):
        a, b = times[k], times[k + 1]
        if b <= a:
            continue
        za, zb = z[:, k], z[:, k + 1]
        xa = states[:, k]
        crossed = _crossed(za, zb)
        leaving = crossed & (za == 0)  # from an exact zero (at rest): the direction right after a decides
        if np.any(leaving) and not np.any(crossed & ~leaving) and depth < MAX_DEPTH:
            hit = _refine(cm, path, a, b, xa, p, d, u, args, depth)
        elif np.any(crossed):
            hit = _locate(cm, path, a, b, xa, states[:, k + 1], za, zb, p, d, u, args)
        elif np.any((var[:, k + 1] - var[:, k] >= (np.abs(za) + np.abs(zb)) * (1 - 1e-9)) & (za != 0)) \
                and depth < MAX_DEPTH:  # the variation could have gone to zero and back
            hit = _refine(cm, path, a, b, xa, p, d, u, args, depth)
        else:
            hit = None
        if hit is not None:
            return hit
    return None


def _refine(cm, path, a, b, xa, p, d, u, args, depth):
    """:func:`_scan` of ``[a, b]`` on :data:`REFINE` sub-intervals, integrated again from ``(a, xa)``."""
    sub = np.linspace(a, b, REFINE + 1)
    Xs, Qs = path.integrate(a, xa, sub[1:], p, d, u, *args, variation=True)
    return _scan(cm, path, sub, np.concatenate([xa[:, None], Xs], axis=1), _variations(cm, Qs), p, d, u, args,
                 depth + 1)


def _variations(cm, Qs) -> np.ndarray:
    """The zero functions' total variations from the run's start, one row each, with the start's zero first."""
    return np.array([np.concatenate([[0.0], Qs[("variation", i)]]) for i in range(len(cm.event_zeros))])


def _zero_values(cm, times, states, p, d, u) -> np.ndarray:
    """The zero functions at the columns of ``states`` (times ``times``), one row each."""
    return np.array([np.broadcast_to(np.asarray(v, dtype=float), times.shape)
                     for v in cm.funcs["zeros"](times, states, p, d, u)])


def _locate(cm, path, a, b, xa, xb, za, zb, p, d, u, args):
    """The crossing(s) in ``(a, b]`` by Brent's method (:func:`acausal.modes.crossings`, the scipy path's own);
    None when they change no mode.

    Every trial state comes from a CVODES run from ``a`` to ``b`` with the trial time as an extra output: CVODES's
    steps do not depend on the output times, so all trials read one and the same dense solution, and the root,
    the nudge past it and the state the new mode starts from are consistent (runs ending at the trial times would
    each carry their own tolerance-level error, enough to put a gentle crossing on the wrong side). If that
    solution no longer shows the sign change that the window's run showed at ``b``, the crossing is at ``b``
    within the tolerance and the window's state there, on the far side, is taken.
    """
    xb_run = path.integrate(a, xa, np.array([b]), p, d, u, *args)[0][:, 0]
    zb_run = zeros(cm, b, xb_run, p, d, u)

    def sol(tt):
        tt = float(tt)
        if tt <= a:
            return xa
        if tt >= b:
            return xb_run
        return path.integrate(a, xa, np.array([tt, b]), p, d, u, *args)[0][:, 0]

    handled: set = set()  # crossings that changed no mode: a later one in the same interval may
    while True:
        za_m, zr_m, zb_m = za.copy(), zb_run.copy(), np.asarray(zb, dtype=float).copy()
        for i in handled:  # the same nonzero value at both ends: no crossing
            za_m[i] = zr_m[i] = zb_m[i] = 1.0
        if np.any(_crossed(za_m, zr_m)):
            hits = crossings(cm, sol, a, b, za_m, zr_m, p, d, u)
            t_e = hits[0][0] if hits else b
            x_e = sol(t_e)
        else:
            hits = [(b, i, bool(za_m[i] < 0) if za_m[i] != 0 else bool(zb_m[i] > 0))
                    for i in np.flatnonzero(_crossed(za_m, zb_m))]
            t_e, x_e = b, xb
        if not hits:
            return None
        d_new = d
        for _, i_ev, rising in hits:
            d_new = apply_event(cm, i_ev, rising, t_e, x_e, p, d_new, u)
        if not np.array_equal(d_new, d):
            return t_e, x_e, hits, d_new
        handled |= {i for _, i, _ in hits}  # a crossing that changes no mode needs no restart


def _crossed(za, zb):
    """Which zero functions cross between two values: a sign change, leaving an exact zero or reaching one."""
    return ((za < 0) & (zb >= 0)) | ((za > 0) & (zb <= 0)) | ((za == 0) & (zb != 0))
