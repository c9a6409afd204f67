"""Discrete modes and state events, shared by every simulation path: the zero functions' values, the crossings
between two points of a solution (Brent's method on it), the assignments an event makes, settling the modes at a
start and the cascade of mode changes after an event. The one event loop (:mod:`acausal.simulation.loop`) and its
segment integrators call the same functions, so every path switches the same way.
"""
from __future__ import annotations

import numpy as np
from scipy import optimize

from ..errors import SimulationError

SETTLE_ITER = 20  # rounds of settle_modes at most (at a start)
CASCADE_ITER = 20  # rounds of the event iteration at most (cascade)


def zeros(cm, t, x, p, d, u, check: bool = True, off=None):
    """The zero functions at one point (time ``t`` [s], states ``x``, modes ``d``); a NaN or infinite value is a
    :class:`SimulationError` (:func:`check_zeros`), never a crossing. ``check=False``: the values as they are
    (the end of a solver step, where :func:`crossings_in_step` first looks for a crossing before the value went
    bad). ``off``: the thresholds the crossings are watched at (:func:`knee_offsets`; default zero), subtracted."""
    z = np.array([float(z) for z in cm.funcs["zeros"](t, x, p, d, u)])
    if off is not None:
        z = z - off
    if check:
        check_zeros(cm, t, z, d)
    return z


def check_zeros(cm, t, z, d) -> None:
    """Raise a :class:`SimulationError` naming the event's component, its zero function, the time and the modes
    when a zero function's value ``z`` (one value per event, or one row of values per event at the times ``t``)
    is NaN or infinite: such a value has no sign, and taking it for a crossing would switch modes at random."""
    z = np.asarray(z, dtype=float)
    if np.all(np.isfinite(z)):
        return
    rows = np.atleast_1d(np.any(~np.isfinite(z.reshape(len(cm.event_zeros), -1)), axis=1))
    i = int(np.flatnonzero(rows)[0])
    tt = np.atleast_1d(np.asarray(t, dtype=float))
    col = np.flatnonzero(~np.isfinite(z.reshape(len(cm.event_zeros), -1)[i]))[0]
    when = float(tt[min(col, tt.size - 1)])
    ev = cm.flat.events[i]
    modes = ", ".join(f"{n} = {v:g}" for n, v in zip(cm.discrete_names, np.asarray(d, dtype=float).ravel()))
    value = z.reshape(len(cm.event_zeros), -1)[i, col]
    raise SimulationError(f"the zero function of an event of {ev.origin} is {value} at t = {when:.9g} s: "
                          f"{cm.event_zeros[i]} (modes {modes}); a NaN or infinite "
                          "switching value has no sign to switch on (a division by a coefficient that is zero in "
                          "this mode, or a function used outside its domain)")


def crossings(seg, sol, t0, t1, z0, z1, off=None):
    """The earliest zero crossing(s) in (t0, t1] of the segment ``seg`` (:class:`~.run.Segment`) whose solution is
    ``sol``, as a list of (time, event index, rising?), all at (nearly) the same time: zero functions that cross
    together (e.g. the speeds of two gear stages) are handled together. ``off``: the thresholds
    (:func:`knee_offsets`) that ``z0``, ``z1`` are already relative to."""
    cm, p, d, u = seg.cm, seg.p, seg.d, seg.u
    off = np.zeros(len(z0)) if off is None else off
    found = []
    for i in range(len(z0)):
        a, b = z0[i], z1[i]
        if a == 0 and b != 0:  # leaving an exact zero (e.g. starting at rest): decide by the direction now
            found.append((t0, i, b > 0))
            continue
        if (a < 0 < b) or (a > 0 > b) or (a != 0 and b == 0):
            g = lambda tt, i=i: _finite(cm, i, tt, float(cm.funcs["zeros"](tt, sol(tt), p, d, u)[i]) - off[i], d)
            try:
                te = optimize.brentq(g, t0, t1, xtol=1e-13 * max(1.0, abs(t1)), rtol=4 * np.finfo(float).eps)
            except ValueError:
                te = t1
            # stop just past the crossing so the new mode starts on the correct side
            g_te = g(te)
            if (a < 0 and g_te < 0) or (a > 0 and g_te > 0):
                te = min(t1, te + 1e-12 * max(1.0, abs(te)))
            found.append((te, i, a < 0))
    return together(found) if found else []


def together(found) -> list:
    """Of crossings ``found`` (``(time, event index, rising?)``), the earliest and those within 1e-9 (relative) of
    it, all at the latest of their times: zero functions that cross together are handled together."""
    t_first = min(f[0] for f in found)
    first = [f for f in found if f[0] <= t_first + 1e-9 * max(1.0, abs(t_first))]
    t_e = max(f[0] for f in first)
    return [(t_e, i, rising) for _, i, rising in first]


#: interior points of a solver step at which the scipy path also checks the zero functions (the compiled path
#: integrates each zero function's total variation instead, see :mod:`acausal.simulation.compiled.events`)
SUBSTEPS = 8


def crossings_in_step(seg, sol, t0, t1, z0, z1, substeps: int = SUBSTEPS, off=None):
    """:func:`crossings` in a solver step ``(t0, t1]`` of the segment ``seg`` whose dense output is ``sol``, looked
    for at the step's
    ends and at ``substeps`` interior points: a zero function that crosses zero and back within one long step
    (nearly constant states, a diode bridge run on past its last switch) shows at an interior point even when
    its sign at both ends agrees, and of several crossings in one step the first is found (Brent's method on the
    whole step would find any one of them). Zero functions faster than the states (a fast source) can still
    cross twice between two of these points: bound the step (``max_step``) below half their shortest switching
    interval on this path.

    A zero function may turn NaN or infinite within the step (``z1`` unchecked: ``sqrt(x)`` with ``x`` falling
    through zero): the step is then searched up to the last time its values are finite (bisection), and only
    when no crossing comes before it is the bad value an error (:func:`check_zeros`, at the first bad time).
    ``off``: the thresholds (:func:`knee_offsets`) that ``z0``, ``z1`` are already relative to."""
    cm, p, d, u = seg.cm, seg.p, seg.d, seg.u
    off = np.zeros(len(z0)) if off is None else off
    ts = t0 + (t1 - t0) * np.arange(1, max(substeps, 0) + 1) / (max(substeps, 0) + 1)
    if ts.size and len(z0):
        X = np.asarray(sol(ts))
        Z = np.array([np.broadcast_to(np.asarray(v, dtype=float), ts.shape)
                      for v in cm.funcs["zeros"](ts, X, p, d, u)]) - off[:, None]
    else:
        Z = np.zeros((len(z0), 0))
    times = np.append(ts, t1)
    Z = np.concatenate([Z, np.asarray(z1, dtype=float).reshape(-1, 1)], axis=1)
    bad = np.flatnonzero(~np.all(np.isfinite(Z), axis=0))
    if bad.size:  # cut the step at the last finite values before the first bad ones
        k = int(bad[0])
        lo, hi, z_hi = _last_finite(cm, sol, times[k - 1] if k else t0, times[k], Z[:, k], p, d, u)
        if lo > t0:
            times = np.append(times[:k], lo)
            Z = np.concatenate([Z[:, :k], zeros(cm, lo, sol(lo), p, d, u, False, off).reshape(-1, 1)], axis=1)
        else:
            times, Z = times[:0], Z[:, :0]
    za, ta = np.asarray(z0, dtype=float), t0
    for k in range(times.size):
        zb = Z[:, k]
        found = crossings(seg, sol, ta, times[k], za, zb, off)
        if found:
            return found
        za, ta = zb, times[k]
    if bad.size:
        check_zeros(cm, hi, z_hi, d)
    return []


def _last_finite(cm, sol, lo, hi, z_hi, p, d, u):
    """``(lo, hi, z at hi)``: bisection of ``[lo, hi]`` (zero functions finite at ``lo``, not at ``hi``) down to
    round-off of the time, for the last time they are all finite."""
    for _ in range(100):
        if hi - lo <= 1e-13 * max(1.0, abs(hi)):
            break
        mid = 0.5 * (lo + hi)
        z_mid = zeros(cm, mid, sol(mid), p, d, u, check=False)
        if np.all(np.isfinite(z_mid)):
            lo = mid
        else:
            hi, z_hi = mid, z_mid
    return lo, hi, z_hi


def _finite(cm, i, t, value, d):
    if not np.isfinite(value):
        z = np.ones(len(cm.event_zeros))
        z[i] = value
        check_zeros(cm, t, z, d)
    return value


def record_events(cm, events: list, hits, t_e: float, max_events: int) -> None:
    """Append the crossings ``hits`` at ``t_e`` to ``events`` as ``(time, event index, "rising"|"falling")``; a
    SimulationError naming the last event's origin when there are more than ``max_events``."""
    for _, i_ev, rising in hits:
        events.append((t_e, i_ev, "rising" if rising else "falling"))
    if len(events) > max_events:
        raise SimulationError(f"more than {max_events} events by t = {t_e:.6g} s (last from "
                              f"{cm.flat.events[hits[-1][1]].origin}): the model chatters")


def apply_event(cm, i, rising, t, x, p, d, u):
    """The modes after event ``i`` crosses (``rising`` or not) at ``t``: its assignments evaluated before it (states
    ``x``, modes ``d``); ``d`` itself when it assigns nothing that way."""
    table = cm.event_assignments(i, rising)
    if not table:
        return d
    new = d.copy()
    for (name, _), value in zip(table, assigned(cm, table, t, x, p, d, u)):
        new[cm.discrete_names.index(name)] = float(value)
    return new


def assigned(cm, table, t, x, p, d, u) -> list:
    """The values of the expressions of ``table`` (``(name, sympy expression)`` pairs: an event's assignments or
    reinits) at one time: one generated function per table, through only the steps they need (an event that
    switches a diode reads its current, not the whole model's Newton blocks)."""
    return cm.generator.expressions_function([expr for _, expr in table])(t, x, p, d, u)


def restarts(cm, hits) -> bool:
    """Whether the crossings ``hits`` reinitialise a state (a rising crossing of an event with ``reinit``): the
    integration must then restart even where no mode changes."""
    return any(rising and cm.event_reinits(i) for _, i, rising in hits)


def apply_reinits(cm, hits, t, x, p, d, u):
    """The states after the reinits of the crossings ``hits`` (rising crossings of events with ``reinit``), their
    values evaluated just before the event (states ``x``, modes ``d``); ``x`` itself when there are none."""
    pairs = [pair for _, i, rising in hits if rising for pair in cm.event_reinits(i)]
    if not pairs:
        return x
    new = np.array(x, dtype=float).copy()
    for (name, _), value in zip(pairs, assigned(cm, pairs, t, x, p, d, u)):
        new[cm.state_names.index(name)] = float(value)
    return new


def apply_hits(cm, hits, t, x, p, d, u):
    """The modes after the crossings ``hits`` (``(time, event index, rising?)``, all at ``t``): each event's
    assignments applied in turn (equal to ``d`` when none changes a mode)."""
    for _, i, rising in hits:
        d = apply_event(cm, i, rising, t, x, p, d, u)
    return d


def settle_modes(cm, t, x, p, d, u, max_iter: int = SETTLE_ITER):
    """Apply the rising/falling assignments of every event by the sign of its zero until modes stop changing."""
    if not cm.event_zeros:
        return d
    for _ in range(max_iter):
        z = zeros(cm, t, x, p, d, u)
        new = d.copy()
        for i, zi in enumerate(z):
            if zi > 0:
                new = apply_event(cm, i, True, t, x, p, new, u)
            elif zi < 0:
                new = apply_event(cm, i, False, t, x, p, new, u)
        if np.array_equal(new, d):
            return d
        d = new
    raise SimulationError(f"discrete modes do not settle at t = {t:.6g} s: "
                          + ", ".join(f"{n} = {v}" for n, v in zip(cm.discrete_names, d)))


#: a zero function within this of zero [SI unit of the function] is at its switching point: when the modes
#: after an event would cycle and the zero functions that would close the cycle are this small in the present
#: modes (an ideal diode at its knee, where the switching variable is round-off of either sign; a brake breaking
#: away at exactly zero speed), the present modes are consistent and the cascade keeps them
KNEE = 1e-6
#: a zero function that leaves an exact zero right after an event by less than this [SI unit of the function] has
#: moved by round-off (:func:`knee_offsets`); small enough that what the model carries from it (a clutch stuck at
#: this relative speed) is far below any tolerance
ROUNDOFF = 1e-12


def cascade(cm, t, x, p, d_old, d_new, u, *, max_iter: int = CASCADE_ITER, hits=(), kept=None):
    """After an event: a mode change may flip the sign of other zero functions (which depend on modes); apply
    those events' assignments, and repeat, until nothing flips (Modelica's event iteration).

    The modes visited are remembered. Returning to one of them is a cycle: if the zero functions whose flips would
    close it are within :data:`KNEE` of zero in the present modes, they sit at their switching point (round-off
    decides their sign, and differs per mode and per generated code), so the present modes are kept; otherwise
    no mode is consistent and
    the run stops with a :class:`SimulationError` naming the events' components, their values and the time.
    ``hits``: the crossings that caused the event (``(time, event index, rising?)``); a crossing zero function
    located exactly at zero counts as on the side it crossed to, so a new mode that puts it back is a flip.
    ``kept``: a list that receives the zero functions the knee rule overruled (their sign says leave the present
    modes, by no more than :data:`KNEE`): :func:`knee_offsets` watches them from there."""
    z_prev = zeros(cm, t, x, p, d_old, u)
    side = z_prev.copy()  # the sign each zero function had (a crossing exactly at zero: the side it went to)
    for _, i, rising in hits:
        if side[i] == 0:
            side[i] = 1.0 if rising else -1.0
    d = d_new
    seen = [np.asarray(d_old, dtype=float).copy(), np.asarray(d, dtype=float).copy()]
    flips: list = [[]]  # flips[k]: (event, largest |z| of the flip) made to leave seen[k + 1]
    for _ in range(max_iter):
        z = zeros(cm, t, x, p, d, u)
        flipped = [i for i in range(len(z)) if z[i] != 0 and np.sign(z[i]) != np.sign(side[i]) and side[i] != 0]
        if not flipped:
            return d
        new = d
        for i in flipped:
            new = apply_event(cm, i, z[i] > 0, t, x, p, new, u)
        if np.array_equal(new, d):
            return d
        flips.append([(i, abs(z[i])) for i in flipped])  # how inconsistent the mode being left is
        back = [k for k, s in enumerate(seen) if np.array_equal(new, s)]
        if back:  # a cycle: the modes it would leave are consistent if only round-off said otherwise
            if all(size <= KNEE for _, size in flips[-1]):
                if kept is not None:
                    kept.extend(i for i, _ in flips[-1])
                return d
            cycle = [f for step in flips[back[0]:] for f in step]
            culprits = sorted({cm.flat.events[i].origin for i, size in cycle if size > KNEE})
            break
        seen.append(np.asarray(new, dtype=float).copy())
        z_prev, side, d = z, z.copy(), new
    else:
        culprits = sorted({cm.flat.events[i].origin for step in flips for i, _ in step})
    raise SimulationError(f"discrete modes do not settle after an event at t = {t:.9g} s: the events of "
                          f"{', '.join(culprits)} switch back and forth (no mode is consistent there: the model "
                          "chatters); modes " + ", ".join(f"{n} = {v:g}" for n, v in zip(cm.discrete_names, d)))


def knee_offsets(cm, t, x, p, d, u, kept) -> np.ndarray:
    """The thresholds the zero functions are watched at after an event (one per zero function; 0: the ordinary
    zero). A zero function the knee rule overruled (``kept``, :func:`cascade`), or one that the event left within
    :data:`KNEE` of zero on the side that says leave the present modes (a diode whose current the source's zero
    crossing turned by round-off before its neighbours switched), has the sign that says leave the present modes,
    by less than :data:`KNEE`; watched at zero, it would never cross again as it moves further that
    way (a clutch kept stuck with its holding torque a hair past the limit, the torque then growing: the breakaway
    would be lost). It is watched at twice its value instead (at least :data:`ROUNDOFF` further): once it has moved
    as far again the leaving way, that is a crossing in the same direction, and the event iteration there leaves
    the modes, or keeps them and doubles the threshold again (a few events at most before it is beyond
    :data:`KNEE`). A threshold in proportion keeps what the model carries from the switch small: a clutch that
    sticks at such a threshold holds that relative speed while stuck.

    A zero function exactly at zero after the event (a clutch that has just broken away: its relative speed is
    still exactly 0, and round-off of its tiny acceleration may move it either way) is watched at
    ``+-ROUNDOFF`` when crossing one way would leave the new modes and crossing the other would not: a function
    leaving its exact zero the leaving way by round-off no longer counts, one that truly turns back does (the clutch
    sticks again, its relative speed then :data:`ROUNDOFF` instead of 0). The offsets last until the next event
    (hysteresis, as the level-triggered start modes of Modelica's friction elements give)."""
    off = np.zeros(len(cm.event_zeros))
    z = zeros(cm, t, x, p, d, u)
    kept = set(kept or ())
    for i in range(z.size):  # at its knee on the leaving side without having flipped (it crossed with the event)
        if i not in kept and 0 < abs(z[i]) <= KNEE and \
                not np.array_equal(apply_event(cm, i, z[i] > 0, t, x, p, d, u), d):
            kept.add(i)
    for i in range(z.size):
        if i in kept and z[i] != 0:
            off[i] = z[i] + np.sign(z[i]) * max(abs(z[i]), ROUNDOFF)
        elif z[i] == 0:
            up = not np.array_equal(apply_event(cm, i, True, t, x, p, d, u), d)
            down = not np.array_equal(apply_event(cm, i, False, t, x, p, d, u), d)
            if up != down:
                off[i] = ROUNDOFF if up else -ROUNDOFF
    return off


def algebraic_modes(cm, t, p, d, u):
    """Modes of a model without states at each time of ``t`` [s] (shape ``(n_modes, len(t))``): from the modes
    ``d``, every event's assignment applied by the sign of its zero function until nothing changes, sample by
    sample (each sample starting from the previous one's modes)."""
    out = np.empty((len(d), t.size))
    x = np.zeros(0)
    cur = d
    for k, tk in enumerate(t):
        cur = settle_modes(cm, tk, x, p, cm.time_modes(tk, p, cur), u)  # a time event's mode is 1 from its time on
        out[:, k] = cur
    return out
