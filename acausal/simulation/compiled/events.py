"""State events on the compiled path through CasADi's integrators: CVODES integrates between events, the crossings
are found and handled as on the scipy path. Where a C compiler and SUNDIALS's IDAS are installed, runs take the
native loop instead (:mod:`acausal.simulation.compiled.native_loop`, about four times faster: its crossings are found
inside one integration); this path runs the rest, and a run the native loop fails on.

Each segment (constant discrete modes) is integrated over a window of output times in one call, together with
the *total variation* of every event zero function (the integral of ``|dz/dt|``). A crossing shows as a sign
change of ``z`` between two output times; one that enters and leaves between them (a diode conducting for a
moment) cannot hide: the interval's variation is then at least ``|z(a)| + |z(b)|``, and such an interval is
integrated again on a finer grid, recursively, until the crossing is seen or shown not to exist. A crossing is
located by Brent's method on ``z`` along one integrator solution of its interval (see :meth:`Windows._locate`),
then the event itself (its assignments, the cascade of mode changes, the restart) is the one event loop's
(:mod:`acausal.simulation.loop`, whose segment integrator :class:`Windows` is), so every path switches the same way.

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

from ...errors import BudgetExceeded, SimulationError
from ..events import crossings
from ..loop import event_modes, integrate_segments

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


def simulate_with_events(run, integrals=None):
    """The run (:class:`~acausal.simulation.run.Run`) of a model with state events on the compiled path; returns
    the Result. ``integrals``: the names integrated as quadratures with the states (default: the energy accounts,
    with ``dense_output``); the Result runs the same integration again for a name it is asked the energy of that is
    not among them."""
    return integrate_segments(run, Windows(run, integrals))


class Windows:
    """The segment integrator of the compiled path on CasADi's integrators (:mod:`acausal.simulation.loop`): a
    segment is integrated in windows of output times, one CVODES run each, until a window shows a crossing that
    makes an event (see the module); ``integrals``: as :func:`simulate_with_events`."""

    def __init__(self, run, integrals=None):
        from ...compile.accounts import account_integrals
        cm = run.cm
        self.run, self.cm, self.path = run, cm, cm.compiled_path
        if integrals is None:
            integrals = account_integrals(cm.accounts) if run.dense_output and cm.accounts is not None else []
        self.names = self.path.integrable(integrals, run.u) if integrals else []
        self.widest = max(WINDOW, run.t_out.size // WINDOWS_PER_RUN)  # output times per run at most (dense: more)
        self.window = self.widest
        self.halvings = 0  # > 0: the next output interval could not be crossed in one run; go a 2**-halvings part
        self.done = {name: 0.0 for name in self.names}  # integral from t_start to where the loop is
        self.seg, self.off = None, None  # the present segment, its zero functions' thresholds

    def advance(self, loop):
        """The segment from ``(loop.t, loop.x)``, window by window, up to the first crossing that makes an event
        (returned: ``(t_e, x_e, hits, new modes)``) or the run's end (None)."""
        path, names, t_out = self.path, self.names, self.run.t_out
        seg = self.seg = loop.segment()
        self.off = loop.off
        t, x = loop.t, loop.x
        while True:
            loop.outputs_at(t, x, self.done)
            if loop.finished:
                return None
            k_out = loop.k
            grid = t_out[k_out:k_out + self.window]
            if self.halvings:  # a part of the interval up to the next output (no output there)
                grid = np.array([t + (grid[0] - t) * 0.5**self.halvings])
                if not grid[0] > t:  # parts below round-off: no run gets on from t in this mode
                    raise SimulationError(f"compiled path ({path.integrator_name(seg.u)}): no run gets past t = "
                                          f"{t!r} s towards the output at {t_out[k_out]!r} s in the present modes")
            try:
                Xs, Qs = path.integrate(t, x, grid, seg, integrals=names, variation=True, max_num_steps=WINDOW_STEPS)
            except BudgetExceeded:  # a run under a budget (the trust check's own) spent it: no closer look
                raise
            except SimulationError:
                if self.window > 1:
                    self.window //= 2  # the old mode may not go on far past a crossing: look closer
                    self.widest = max(WINDOW, min(self.widest, self.window))  # a dense grid's windows stop growing
                elif self.halvings < INTERVAL_HALVINGS:
                    self.halvings += 1  # not even to the next output: a part of the way
                else:
                    raise
                continue
            hit = self._first_crossing(t, x, grid, Xs, Qs)
            done = self.done
            if hit is None and self.halvings:  # on from the part's end (its state is no output), a longer part
                self.done = {name: done[name] + Qs[name][-1] for name in names}
                t, x = float(grid[-1]), Xs[:, -1].copy()
                self.halvings -= 1  # doubled: back to whole windows after a part at half the interval
                continue
            if hit is None:
                loop.write(k_out + grid.size, Xs, {name: done[name] + Qs[name] for name in names})
                self.done = {name: done[name] + Qs[name][-1] for name in names}
                t, x = float(grid[-1]), Xs[:, -1].copy()
                self.window = min(2 * self.window, self.widest)
                continue
            t_e, x_e, hits, d_new = hit
            # outputs before the event keep this segment's values (a part's end is no output: none)
            upto = 0 if self.halvings else np.searchsorted(grid, t_e, side="right")
            loop.write(k_out + upto, Xs[:, :upto], {name: done[name] + Qs[name][:upto] for name in names})
            if names:  # the integrals up to the event: from the last output before it (a short run)
                if upto:
                    t_a, x_a = float(grid[upto - 1]), Xs[:, upto - 1]
                    done = {name: done[name] + Qs[name][upto - 1] for name in names}
                else:
                    t_a, x_a = t, x
                _, q_e = path.integrate(t_a, x_a, np.array([t_e]), seg, integrals=names)
                self.done = {name: done[name] + q_e[name][0] for name in names}
            self.window, self.halvings = 1, 0  # events come in groups: start close after one
            return t_e, x_e, hits, d_new

    def result(self, loop):
        """The Result, its integrals those run with the states (and more by running again, with dense output)."""
        from ...results.result import DenseOutput, Result
        run, path = self.run, self.path

        def later(more):  # the same run again, those integrated with the states
            if not path.integrable(more, run.u):  # none has a compiled form: nothing to run again for
                return {}
            return simulate_with_events(dataclasses.replace(run, dense_output=False),
                                        integrals=list(more)).dense.integrals

        return Result(run.cm, run.t_out, loop.X, run.p, run.u, loop.D, events=loop.events,
                      dense=DenseOutput(integrals=loop.Q, more=later if run.dense_output else None),
                      solver=f"{path.integrator_name(run.u)} (compiled path, CasADi; events located between its "
                             "runs)")

    def _first_crossing(self, t, x, grid, Xs, Qs):
        """The first crossing after ``t`` that makes an event: ``(t_e, x_e, hits, new modes)``, or None. ``Xs``,
        ``Qs``: states and integrals (with the zero functions' variations) at ``grid``, integrated from ``(t, x)``
        in the present segment, its zero functions watched at the thresholds ``off``
        (:func:`acausal.simulation.events.knee_offsets`)."""
        times = np.concatenate([[t], grid])
        states = np.concatenate([x[:, None], Xs], axis=1)
        return self._scan(times, states, _variations(self.cm, Qs), depth=0)

    def _scan(self, times, states, var, depth):
        z = _zero_values(self.seg, times, states, self.off)
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
                hit = self._refine(a, b, xa, depth)
            elif np.any(crossed):
                hit = self._locate(a, b, xa, states[:, k + 1], za, zb)
            else:
                hit = self._refine(a, b, xa, depth)
            if hit is not None:
                return hit
        return None

    def _refine(self, a, b, xa, depth):
        """:meth:`_scan` of ``[a, b]`` on :data:`REFINE` sub-intervals, integrated again from ``(a, xa)``."""
        sub = np.linspace(a, b, REFINE + 1)
        Xs, Qs = self.path.integrate(a, xa, sub[1:], self.seg, variation=True)
        return self._scan(sub, np.concatenate([xa[:, None], Xs], axis=1), _variations(self.cm, Qs), depth + 1)

    def _locate(self, a, b, xa, xb, za, zb, depth=0):
        """The crossing(s) in ``(a, b]`` by Brent's method (:func:`acausal.simulation.events.crossings`, the scipy
        path's own); None when they make no event.

        The trial states all come from one CVODES solution from ``a`` (:class:`_Dense`): its states at
        :data:`DENSE` output times bracket the crossing, and a cubic Hermite interpolant between the two stands in
        for the solver's dense output. Root, nudge past it and the state the new mode starts from are thus
        consistent: runs ending at each trial time, or even one more run with other output times, differ at the
        tolerance level, enough to move a gently crossing zero function (an ideal diode's current through its
        small on-resistance) by a bracket, and each run starts the solver cold, at order one and a tiny step. If
        that solution no longer shows the sign change that the window's run showed at ``b``, the crossing is at
        ``b`` within the tolerance and the window's state there, on the far side, is taken.

        A bracket the cubic cannot represent (a transient much faster than the node spacing, such as the settling
        of a leakage path right after a switch: :meth:`_Dense.smooth`) is located on a run of its own across that
        bracket, recursively (:data:`LOCATE_DEPTH` levels). A crossing that makes no event hides its zero function
        only up to its bracket: a later crossing of the same function in the interval (a diode that turned on at
        ``a`` turning off again) is still found.
        """
        seg, off = self.seg, self.off
        dense = _Dense(self.path, seg, a, b, xa)
        zn = _zero_values(seg, dense.nodes, dense.states, off)
        handled: dict = {}  # zero function -> last node up to which its crossings made no event
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
                if depth < LOCATE_DEPTH and not dense.smooth(j):
                    hit = self._locate(dense.nodes[j], dense.nodes[j + 1], dense.states[:, j], dense.states[:, j + 1],
                                       zn[:, j], zn[:, j + 1], depth + 1)
                    if hit is not None:
                        return hit
                    handled.update({int(i): j + 1 for i in crossing})
                    continue
                hits = crossings(seg, dense.sol, dense.nodes[j], dense.nodes[j + 1], zm[:, j], zm[:, j + 1], off)
                t_e = hits[0][0] if hits else dense.nodes[j + 1]
                x_e = dense.sol(t_e)
                upto = j + 1
            else:
                hits = [(b, i, bool(zm[i, 0] < 0) if zm[i, 0] != 0 else bool(zb_m[i] > 0))
                        for i in np.flatnonzero(_crossed(zm[:, 0], zb_m))]
                t_e, x_e, upto = b, xb, DENSE
            if not hits:
                return None
            d_new = event_modes(seg, hits, t_e, x_e)
            if d_new is not None:
                return t_e, x_e, hits, d_new
            handled.update({int(i): upto for _, i, _ in hits})  # a crossing that makes no event needs no restart


def _variations(cm, Qs) -> np.ndarray:
    """The zero functions' total variations from the run's start, one row each, with the start's zero first."""
    return np.array([np.concatenate([[0.0], Qs[("variation", i)]]) for i in range(len(cm.event_zeros))])


def _zero_values(seg, times, states, off) -> np.ndarray:
    """The zero functions of the segment ``seg`` at the columns of ``states`` (times ``times``), one row each,
    relative to the thresholds ``off`` they are watched at."""
    z = np.array([np.broadcast_to(np.asarray(v, dtype=float), times.shape)
                  for v in seg.cm.funcs["zeros"](times, states, seg.p, seg.d, seg.u)])
    return z - np.asarray(off)[:, None]


class _Dense:
    """One CVODES solution of the segment ``seg`` from ``(a, xa)`` to ``b`` (tolerances :data:`LOCATE_TOL` times the
    segment's), read at any time in between: its states at :data:`DENSE` output times (``nodes``: the solver's own
    interpolating polynomials there; extra output times do not add steps) and a cubic Hermite interpolant (states
    and their derivatives) between two of them."""

    def __init__(self, path, seg, a, b, xa):
        self.seg, self.a, self.b, self.xa = seg, a, b, xa
        self.nodes = np.linspace(a, b, DENSE + 1)
        self.nodes[-1] = b
        X, _ = path.integrate(a, xa, self.nodes[1:], seg.tighter(LOCATE_TOL))
        self.states = np.concatenate([xa[:, None], X], axis=1)
        self.rates = {}

    def rate(self, k):
        if k not in self.rates:
            seg = self.seg
            try:
                self.rates[k] = np.asarray(seg.cm.funcs["rhs"](float(self.nodes[k]), self.states[:, k].tolist(),
                                                               seg.p.tolist(), seg.d.tolist(), seg.u), dtype=float)
            except (ZeroDivisionError, OverflowError, ValueError):  # a division by zero, a root of a negative
                from ..scipy.failures import non_finite_error
                raise non_finite_error(seg.cm, float(self.nodes[k]), self.states[:, k], seg.p, seg.d,
                                       seg.u) from None
        return self.rates[k]

    def smooth(self, k) -> bool:
        """Whether the cubic between nodes ``k`` and ``k + 1`` can stand for the solution: each state's end slopes
        predict a change over the bracket that differs from the actual one by no more than that change itself (or
        the segment's tolerance). A smooth solution sampled finer than its time scale passes; a transient that
        settles within the bracket (slopes thousands of times the secant) does not, and the cubic through it
        overshoots into roots that are not there."""
        h = self.nodes[k + 1] - self.nodes[k]
        xa, xb = self.states[:, k], self.states[:, k + 1]
        change = np.abs(xb - xa)
        tol = self.seg.atol + self.seg.rtol * np.maximum(np.abs(xa), np.abs(xb))
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
