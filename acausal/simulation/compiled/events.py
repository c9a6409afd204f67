"""State events on the compiled path through CasADi's integrators: CVODES integrates between events, the crossings
are found and handled as on the scipy path. Where a C compiler and SUNDIALS's IDAS are installed, runs take the
native loop instead (:mod:`acausal.simulation.compiled.native_loop`, about four times faster: its crossings are found
inside one integration); this path runs the rest, and a run the native loop fails on.

Each segment (constant discrete modes) is integrated over a window of output times in one call, together with
the *total variation* of every event zero function (the integral of ``|dz/dt|``). A crossing shows as a sign
change of ``z`` between two output times; one that enters and leaves between them (a diode conducting for a
moment) cannot hide: the interval's variation is then at least ``|z(a)| + |z(b)|``, and such an interval is
integrated again on a finer grid, recursively, until the crossing is seen or shown not to exist. A crossing is
located by Brent's method on ``z`` along one integrator solution of its interval (see :func:`_locate`), then the
event's assignments, the cascade of mode changes and the restart follow the scipy path's own functions
(:mod:`acausal.simulation.events`), so both paths switch the same way.

Each run covers a window of output times that restarts at one output after an event and doubles while nothing
happens, up to :data:`WINDOW` outputs, or a :data:`WINDOWS_PER_RUN`-th of them where the outputs are dense (a
1 kHz recording: every run restarts CVODES cold, and 64 outputs there are 64 ms) until a window fails: CVODES
continuing past a crossing in the old mode can run into steps it cannot take, and a failed run (capped at
:data:`WINDOW_STEPS` steps) is retried on half the window; a single output interval that no run can
cross (a crossing inside it, past which the old mode cannot be integrated) is gone in parts of what is left of
it, halved after a run that fails and doubled after one that does not (at most :data:`INTERVAL_HALVINGS`
halvings), until a part shows the crossing. A crossing costs one more run, over its output
interval with :data:`DENSE` output times, its tolerances :data:`LOCATE_TOL` times the window's: Brent's
trials read a Hermite interpolant of those states, not runs of their own (every run restarts CVODES cold, at order
one and a tiny step, so trial runs were what made events expensive), and the tighter run locates a gently crossing,
ill-conditioned zero function (an ideal diode's current through its small on-resistance) where the tolerance of
the states alone would leave it uncertain by more than the switch can bear. On the paper's actuator this is
about twice as fast as the scipy path's BDF, and closer to a tight reference.

CasADi's own zero-crossing support (3.7+) was tried and is not used: it watches only downward crossings, triggers
each function at most once per output interval, and zeroes in on a crossing with solver interpolation that fails
("tout too far back") whenever the crossing lies more than one solver step behind the output time that shows it.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...errors import SimulationError
from ..events import after_end, apply_hits, crossings, handle_event, restarts, settle_modes

REFINE = 16  # sub-intervals of a suspect interval
MAX_DEPTH = 4  # refinements of refinements
WINDOW = 64  # output times per CVODES run at most: an event restarts the run, so the work after it is not thrown away
WINDOWS_PER_RUN = 16  # ... unless the outputs are dense: then a window may hold up to this part of them (until a
# window fails, at WINDOW_STEPS or past a crossing: the windows then grow to half that one at most, not below WINDOW)
WINDOW_STEPS = 1_000  # CVODES steps per run at most: a run that cannot go on (the old mode past a crossing) fails fast
LOCATE_TOL = 1e-2  # the run that locates a crossing: tolerances this much tighter than the window's
DENSE = 1024  # output times across an interval that shows a crossing (one run: the solver's steps)
LOCATE_DEPTH = 3  # runs of runs' brackets where the cubic between two output times cannot be trusted
INTERVAL_HALVINGS = 40  # an output interval no run can cross is gone in parts down to 2**-40 of what is left
SAME_TIME_ULPS = 4  # an output this few units in the last place after a restart is taken at the restart


def simulate_with_events(run, integrals=None):
    """The run (:class:`~acausal.simulation.run.Run`) of a model with state events on the compiled path; returns
    the Result. ``integrals``: the names integrated as quadratures with the states (default: the energy accounts,
    with ``dense_output``); the Result runs the same integration again for a name it is asked the energy of that is
    not among them."""
    from ...compile.accounts import account_integrals
    from ...results.result import Result
    cm, t_start, t_out, p, u, starts = run.cm, run.t_start, run.t_out, run.p, run.u, run.starts
    rtol, atol, max_step, first_step, max_events = run.rtol, run.atol, run.max_step, run.first_step, run.max_events
    dense_output, x0, d = run.dense_output, run.x0.copy(), run.d.copy()
    path = cm.compiled_path
    args = (rtol, atol, max_step, first_step)
    if integrals is None:
        integrals = account_integrals(cm.accounts) if dense_output and cm.accounts is not None else []
    names = path.integrable(integrals, u) if integrals else []
    d, x0 = start(cm, t_start, x0, p, d, u, starts)
    n, N = len(x0), t_out.size
    X, D = np.empty((n, N)), np.empty((len(d), N))
    Q = {name: np.zeros(N) for name in names}
    events = []
    widest = max(WINDOW, N // WINDOWS_PER_RUN)  # output times per run at most (dense outputs: more)
    t, x, k_out, window = t_start, np.asarray(x0, dtype=float), 0, widest
    halvings = 0  # > 0: the next output interval could not be crossed in one run; go a 2**-halvings part of it
    done = {name: 0.0 for name in names}  # integral from t_start to t
    off = np.zeros(len(cm.event_zeros))  # thresholds the zero functions are watched at (modes.knee_offsets)
    while True:
        k_out = outputs_at_restart(t_out, k_out, t, x, d, X, D, Q, done)
        if k_out == N:
            break
        grid = t_out[k_out:k_out + window]
        if halvings:  # a part of the interval up to the next output (no output there)
            grid = np.array([t + (grid[0] - t) * 0.5**halvings])
            if not grid[0] > t:  # parts below round-off: no run gets on from t in this mode
                raise SimulationError(f"compiled path ({path.integrator_name(u)}): no run gets past t = {t!r} s "
                                      f"towards the output at {t_out[k_out]!r} s in the present modes")
        try:
            Xs, Qs = path.integrate(t, x, grid, p, d, u, *args, integrals=names, variation=True,
                                    max_num_steps=WINDOW_STEPS)
        except SimulationError:
            if window > 1:
                window //= 2  # the old mode may not go on far past a crossing: look closer
                widest = max(WINDOW, min(widest, window))  # and a dense grid's wider windows stop growing there
            elif halvings < INTERVAL_HALVINGS:
                halvings += 1  # not even to the next output: a part of the way
            else:
                raise
            continue
        hit = _first_crossing(cm, path, t, x, grid, Xs, Qs, p, d, u, args, off)
        if hit is None and halvings:  # on from the part's end (its state is no output), with a longer part
            done = {name: done[name] + Qs[name][-1] for name in names}
            t, x = float(grid[-1]), Xs[:, -1].copy()
            halvings -= 1  # doubled: back to whole windows after a part at half the interval
            continue
        if hit is None:
            X[:, k_out:k_out + grid.size], D[:, k_out:k_out + grid.size] = Xs, d[:, None]
            for name in names:
                Q[name][k_out:k_out + grid.size] = done[name] + Qs[name]
            done = {name: done[name] + Qs[name][-1] for name in names}
            k_out += grid.size
            t, x = float(grid[-1]), Xs[:, -1].copy()
            window = min(2 * window, widest)
            continue
        t_e, x_e, hits, d_new = hit
        # outputs before the event keep this segment's values (a part's end is no output: none)
        upto = 0 if halvings else np.searchsorted(grid, t_e, side="right")
        X[:, k_out:k_out + upto], D[:, k_out:k_out + upto] = Xs[:, :upto], d[:, None]
        for name in names:
            Q[name][k_out:k_out + upto] = done[name] + Qs[name][:upto]
        if names:  # the integrals up to the event: from the last output before it (a short run)
            if upto:
                t_a, x_a = float(grid[upto - 1]), Xs[:, upto - 1]
                done = {name: done[name] + Qs[name][upto - 1] for name in names}
            else:
                t_a, x_a = t, x
            _, q_e = path.integrate(t_a, x_a, np.array([t_e]), p, d, u, *args, integrals=names)
            done = {name: done[name] + q_e[name][0] for name in names}
        k_out += upto
        x_e, d, off = handle_event(cm, events, hits, t_e, x_e, p, d, d_new, u, max_events)
        after_end(t_out, t_e, X, D, x_e, d)
        t, x = t_e, x_e
        window, halvings = 1, 0  # events come in groups: start close after one
    def later(more):  # the same run again, those integrated with the states
        if not path.integrable(more, u):  # none has a compiled form: nothing to run again for
            return {}
        return simulate_with_events(dataclasses.replace(run, dense_output=False), integrals=list(more))._integrals

    return Result(cm, t_out, X, p, u, D, events=events, integrals=Q, more_integrals=later if dense_output else None,
                  solver=f"{path.integrator_name(u)} (compiled path, CasADi; events located between its runs)")


def start(cm, t_start, x0, p, d, u, starts):
    """``(modes, states)`` a run with events starts from: the modes settled by the zero functions' signs, then the
    states made consistent with them (both event loops of the compiled path)."""
    from ..initial import initialize
    d = settle_modes(cm, t_start, x0, p, d, u)
    return d, (initialize(cm, t_start, p, d, u, starts) if cm.discrete_names else x0)


def outputs_at_restart(t_out, k_out, t, x, d, X, D, Q, done) -> int:
    """Write the outputs from ``k_out`` on that lie at the restart time ``t`` itself, or within round-off of it (an
    event a few ulps before an output: no run can be that short, and the state does not move over it): states ``x``,
    modes ``d``, the integrals ``done`` so far (by name, into ``Q``). Returns the next output to write."""
    while k_out < t_out.size and t_out[k_out] <= t + SAME_TIME_ULPS * np.spacing(abs(t)):
        X[:, k_out], D[:, k_out] = x, d
        for name in Q:
            Q[name][k_out] = done[name]
        k_out += 1
    return k_out


def _first_crossing(cm, path, t, x, grid, Xs, Qs, p, d, u, args, off):
    """The first crossing after ``t`` that changes a mode: ``(t_e, x_e, hits, new modes)``, or None. ``Xs``, ``Qs``:
    states and integrals (with the zero functions' variations) at ``grid``, integrated from ``(t, x)``; ``off``:
    the thresholds the zero functions are watched at (:func:`acausal.simulation.events.knee_offsets`)."""
    times = np.concatenate([[t], grid])
    states = np.concatenate([x[:, None], Xs], axis=1)
    return _scan(cm, path, times, states, _variations(cm, Qs), p, d, u, args, depth=0, off=off)


def _scan(cm, path, times, states, var, p, d, u, args, depth, off):
    z = _zero_values(cm, times, states, p, d, u, off)
    za_all, zb_all = z[:, :-1], z[:, 1:]
    crossed_all = _crossed(za_all, zb_all)  # [zero function, interval]
    # the variation could have gone to zero and back
    bounced_all = (var[:, 1:] - var[:, :-1] >= (np.abs(za_all) + np.abs(zb_all)) * (1 - 1e-9)) & (za_all != 0)
    suspect = np.any(crossed_all, axis=0) | (np.any(bounced_all, axis=0) & (depth < MAX_DEPTH))
    for k in np.flatnonzero(suspect & (times[1:] > times[:-1])):  # in time order, empty intervals skipped
        a, b = times[k], times[k + 1]
        za, zb = z[:, k], z[:, k + 1]
        xa = states[:, k]
        crossed = crossed_all[:, k]
        leaving = crossed & (za == 0)  # from an exact zero (at rest): the direction right after a decides
        if np.any(leaving) and not np.any(crossed & ~leaving) and depth < MAX_DEPTH:
            hit = _refine(cm, path, a, b, xa, p, d, u, args, depth, off)
        elif np.any(crossed):
            hit = _locate(cm, path, a, b, xa, states[:, k + 1], za, zb, p, d, u, args, off)
        else:
            hit = _refine(cm, path, a, b, xa, p, d, u, args, depth, off)
        if hit is not None:
            return hit
    return None


def _refine(cm, path, a, b, xa, p, d, u, args, depth, off):
    """:func:`_scan` of ``[a, b]`` on :data:`REFINE` sub-intervals, integrated again from ``(a, xa)``."""
    sub = np.linspace(a, b, REFINE + 1)
    Xs, Qs = path.integrate(a, xa, sub[1:], p, d, u, *args, variation=True)
    return _scan(cm, path, sub, np.concatenate([xa[:, None], Xs], axis=1), _variations(cm, Qs), p, d, u, args,
                 depth + 1, off)


def _variations(cm, Qs) -> np.ndarray:
    """The zero functions' total variations from the run's start, one row each, with the start's zero first."""
    return np.array([np.concatenate([[0.0], Qs[("variation", i)]]) for i in range(len(cm.event_zeros))])


def _zero_values(cm, times, states, p, d, u, off) -> np.ndarray:
    """The zero functions at the columns of ``states`` (times ``times``), one row each, relative to the thresholds
    ``off`` they are watched at."""
    z = np.array([np.broadcast_to(np.asarray(v, dtype=float), times.shape)
                  for v in cm.funcs["zeros"](times, states, p, d, u)])
    return z - np.asarray(off)[:, None]


def _locate(cm, path, a, b, xa, xb, za, zb, p, d, u, args, off, depth=0):
    """The crossing(s) in ``(a, b]`` by Brent's method (:func:`acausal.simulation.events.crossings`, the scipy path's
    own); None when they change no mode.

    The trial states all come from one CVODES solution from ``a`` (:class:`_Dense`): its states at :data:`DENSE`
    output times bracket the crossing, and a cubic Hermite interpolant between the two stands in for the solver's
    dense output. Root, nudge past it and the state the new mode starts from are thus consistent: runs ending at
    each trial time, or even one more run with other output times, differ at the tolerance level, enough to move a
    gently crossing zero function (an ideal diode's current through its small on-resistance) by a bracket, and each
    run starts the solver cold, at order one and a tiny step. If that solution no longer shows the sign change that
    the window's run showed at ``b``, the crossing is at ``b`` within the tolerance and the window's state there,
    on the far side, is taken.

    A bracket the cubic cannot represent (a transient much faster than the node spacing, such as the settling of
    a leakage path right after a switch: :meth:`_Dense.smooth`) is located on a run of its own across that bracket,
    recursively (:data:`LOCATE_DEPTH` levels). A crossing that changes no mode hides its zero function only up to
    its bracket: a later crossing of the same function in the interval (a diode that turned on at ``a`` turning off
    again) is still found.
    """
    run = _Dense(cm, path, a, b, xa, p, d, u, args)
    zn = _zero_values(cm, run.nodes, run.states, p, d, u, off)
    handled: dict = {}  # zero function -> last node up to which its crossings changed no mode
    while True:
        zm, zb_m = zn.copy(), np.asarray(zb, dtype=float).copy()
        for i, upto in handled.items():  # no crossing up to that node: its value there, constant
            if upto >= DENSE:
                zm[i] = zb_m[i] = 1.0
            else:
                zm[i, :upto] = zm[i, upto]
        brackets = np.flatnonzero(np.any(_crossed(zm[:, :-1], zm[:, 1:]), axis=0))
        if brackets.size:  # a crossing between the ends shows between two neighbouring outputs
            j = int(brackets[0])  # the first
            crossing = np.flatnonzero(_crossed(zm[:, j], zm[:, j + 1]))
            if depth < LOCATE_DEPTH and not run.smooth(j, args):
                hit = _locate(cm, path, run.nodes[j], run.nodes[j + 1], run.states[:, j], run.states[:, j + 1],
                              zn[:, j], zn[:, j + 1], p, d, u, args, off, depth + 1)
                if hit is not None:
                    return hit
                handled.update({int(i): j + 1 for i in crossing})
                continue
            hits = crossings(cm, run.sol, run.nodes[j], run.nodes[j + 1], zm[:, j], zm[:, j + 1], p, d, u, off)
            t_e = hits[0][0] if hits else run.nodes[j + 1]
            x_e = run.sol(t_e)
            upto = j + 1
        else:
            hits = [(b, i, bool(zm[i, 0] < 0) if zm[i, 0] != 0 else bool(zb_m[i] > 0))
                    for i in np.flatnonzero(_crossed(zm[:, 0], zb_m))]
            t_e, x_e, upto = b, xb, DENSE
        if not hits:
            return None
        d_new = apply_hits(cm, hits, t_e, x_e, p, d, u)
        if not np.array_equal(d_new, d) or restarts(cm, hits):
            return t_e, x_e, hits, d_new
        handled.update({int(i): upto for _, i, _ in hits})  # a crossing that changes no mode needs no restart


class _Dense:
    """One CVODES solution from ``(a, xa)`` to ``b`` (tolerances :data:`LOCATE_TOL` times the run's ``args``), read
    at any time in between: its states at :data:`DENSE` output times (``nodes``: the solver's own interpolating
    polynomials there; extra output times do not add steps) and a cubic Hermite interpolant (states and their
    derivatives) between two of them."""

    def __init__(self, cm, path, a, b, xa, p, d, u, args):
        self.cm, self.a, self.b, self.xa, self.p, self.d, self.u = cm, a, b, xa, p, d, u
        self.nodes = np.linspace(a, b, DENSE + 1)
        self.nodes[-1] = b
        X, _ = path.integrate(a, xa, self.nodes[1:], p, d, u, args[0] * LOCATE_TOL, args[1] * LOCATE_TOL, *args[2:])
        self.states = np.concatenate([xa[:, None], X], axis=1)
        self.rates = {}

    def rate(self, k):
        if k not in self.rates:
            self.rates[k] = np.asarray(self.cm.funcs["rhs"](float(self.nodes[k]), self.states[:, k].tolist(),
                                                            self.p.tolist(), self.d.tolist(), self.u), dtype=float)
        return self.rates[k]

    def smooth(self, k, args) -> bool:
        """Whether the cubic between nodes ``k`` and ``k + 1`` can stand for the solution: each state's end slopes
        predict a change over the bracket that differs from the actual one by no more than that change itself (or
        the run's tolerance). A smooth solution sampled finer than its time scale passes; a transient that settles
        within the bracket (slopes thousands of times the secant) does not, and the cubic through it overshoots into
        roots that are not there."""
        h = self.nodes[k + 1] - self.nodes[k]
        xa, xb = self.states[:, k], self.states[:, k + 1]
        change = np.abs(xb - xa)
        tol = args[1] + args[0] * np.maximum(np.abs(xa), np.abs(xb))
        worst = np.maximum(np.abs(h * self.rate(k) - (xb - xa)), np.abs(h * self.rate(k + 1) - (xb - xa)))
        return bool(np.all(worst <= change + tol))

    def sol(self, tt):
        tt = float(tt)
        if tt <= self.a:
            return self.xa
        if tt >= self.b:
            return self.states[:, -1]
        k = min(int(np.searchsorted(self.nodes, tt, side="right")) - 1, DENSE - 1)
        h = self.nodes[k + 1] - self.nodes[k]
        s = (tt - self.nodes[k]) / h
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        X = self.states
        return h00 * X[:, k] + h10 * h * self.rate(k) + h01 * X[:, k + 1] + h11 * h * self.rate(k + 1)


def _crossed(za, zb):
    """Which zero functions cross between two values: a sign change, leaving an exact zero or reaching one."""
    return ((za < 0) & (zb >= 0)) | ((za > 0) & (zb <= 0)) | ((za == 0) & (zb != 0))
