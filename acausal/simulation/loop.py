"""The event loop of a run with states, written once for every backend: the modes settled and the states made
consistent at the start, then segment after segment (constant modes) integrated by the backend's *segment
integrator* up to the first crossing that makes an event, the event handled there as Modelica's event iteration
does (the crossings logged, the reinits, the cascade of mode changes, the thresholds to watch from there:
:mod:`acausal.simulation.events`), the outputs written as the segments pass them, and the integration restarted from
the state after the event.

A segment integrator is an object with

* ``names``: the integrals it carries with the states (the rows of :attr:`Loop.Q`);
* ``advance(loop)``: integrate from ``(loop.t, loop.x)`` in the modes ``loop.d`` (its :meth:`Loop.segment`, the
  zero functions watched at the thresholds ``loop.off``), write the outputs it passes (:meth:`Loop.write`,
  :meth:`Loop.outputs_at`) and return the first crossing that makes an event, ``(t_e, x_e, hits, new modes)``
  (:func:`event_modes` tells which crossings do; the others it passes), or None at the end of the run;
* ``result(loop)``: the :class:`~acausal.results.result.Result`, handed one
  :class:`~acausal.results.result.DenseOutput`.

Three do: the scipy stepper (:class:`acausal.simulation.scipy.driver.Stepper`: a scipy integrator stepped one step
at a time, crossings located on the steps' dense output), CasADi's windows
(:class:`acausal.simulation.compiled.events.Windows`: CVODES runs over windows of output times, crossings located on
a dense run of their interval) and the native loop (:class:`acausal.simulation.compiled.native_loop.NativeSegments`:
SUNDIALS stepped in C, one call per segment, crossings located in its steps).
"""
from __future__ import annotations

import numpy as np

from .events import apply_hits, apply_reinits, cascade, knee_offsets, record_events, restarts, settle_modes
from .initial import initialize

SAME_TIME_ULPS = 4  # an output this few units in the last place after a restart is taken at the restart


def integrate_segments(run, integrator):
    """The :class:`~acausal.results.result.Result` of ``run`` (:class:`~.run.Run`), its segments integrated by
    ``integrator`` (a segment integrator, see the module) and its events handled between them."""
    loop = Loop(run, integrator.names)
    while (crossing := integrator.advance(loop)) is not None:
        loop.event(*crossing)
    return integrator.result(loop)


def event_modes(seg, hits, t, x):
    """The modes after the crossings ``hits`` (``(time, event index, rising?)``) at ``t`` with the states ``x`` in
    the segment ``seg`` (:class:`~.run.Segment`) when they make an event (a mode changes, or a state is
    reinitialised); None for crossings the integration passes without a restart."""
    cm = seg.cm
    d_new = apply_hits(cm, hits, t, x, seg.p, seg.d, seg.u)
    if not np.array_equal(d_new, seg.d) or restarts(cm, hits):
        return d_new
    return None


class Loop:
    """One run's event loop: where it is (time ``t``, states ``x``, modes ``d``, the thresholds ``off`` the zero
    functions are watched at), the ``events`` so far as ``(time, event index, "rising"|"falling")``, and the outputs:
    states ``X`` and modes ``D`` at the output times, the integrals ``Q`` (name -> values there), ``k`` the next
    output to write."""

    def __init__(self, run, names=()):
        cm = run.cm
        self.run, self.cm = run, cm
        self.d = settle_modes(cm, run.t_start, run.x0, run.p, run.d.copy(), run.u)
        x = initialize(cm, run.t_start, run.p, self.d, run.u, run.starts) if cm.discrete_names else run.x0.copy()
        self.t, self.x = run.t_start, np.asarray(x, dtype=float)
        self.off = np.zeros(len(cm.event_zeros))
        self.events: list = []
        N = run.t_out.size
        self.X, self.D = np.empty((len(self.x), N)), np.empty((len(self.d), N))
        self.Q = {name: np.zeros(N) for name in names}
        self.k = 0

    @property
    def finished(self) -> bool:
        """Whether every output has been written."""
        return self.k == self.run.t_out.size

    def segment(self):
        """The present segment (:class:`~.run.Segment`: the run in the modes ``d``)."""
        return self.run.segment(self.d)

    def write(self, upto, X, Q=None) -> None:
        """The outputs from ``k`` to before ``upto``: the states ``X`` (a column each), the present modes, the
        integrals ``Q`` (name -> a value each)."""
        k = self.k
        self.X[:, k:upto] = X
        self.D[:, k:upto] = self.d[:, None]
        for name, q in (Q or {}).items():
            self.Q[name][k:upto] = q
        self.k = upto

    def outputs_at(self, t, x, done) -> None:
        """Write the outputs from ``k`` on that lie at the time ``t`` a segment starts from, or within round-off of
        it (an event a few ulps before an output: no run can be that short, and the state does not move over it):
        states ``x``, the present modes, the integrals ``done`` so far (by name)."""
        t_out = self.run.t_out
        while self.k < t_out.size and t_out[self.k] <= t + SAME_TIME_ULPS * np.spacing(abs(t)):
            self.X[:, self.k], self.D[:, self.k] = x, self.d
            for name in self.Q:
                self.Q[name][self.k] = done[name]
            self.k += 1

    def event(self, t_e, x_e, hits, d_new) -> None:
        """The event of the crossings ``hits`` at ``t_e`` (states ``x_e`` before it, modes ``d_new`` after the hits):
        logged (:func:`~.events.record_events`), the states reinitialised (:func:`~.events.apply_reinits`), the modes
        iterated (:func:`~.events.cascade`), the thresholds to watch from there (:func:`~.events.knee_offsets`), an
        output at ``t_end`` given the values after it; the loop goes on from there."""
        cm, run = self.cm, self.run
        record_events(cm, self.events, hits, t_e, run.max_events)
        x_e = apply_reinits(cm, hits, t_e, x_e, run.p, self.d, run.u)
        kept: list = []
        d = cascade(cm, t_e, x_e, run.p, self.d, d_new, run.u, hits=hits, kept=kept)
        self.off = knee_offsets(cm, t_e, x_e, run.p, d, run.u, kept)
        self.d = d
        after_end(run.t_out, t_e, self.X, self.D, x_e, d)
        self.t, self.x = t_e, x_e


def after_end(t_out, t_e, X, D, x_e, d) -> None:
    """An event at the last output time (``t_end``): the outputs there take the values after it, the final value a
    Modelica tool reports (a sample at ``t_end`` that resets a Mean block shows the new mean). An output at an
    earlier event keeps the value before it."""
    if t_out.size and t_e >= t_out[-1]:
        at = t_out >= t_e
        X[:, at] = np.asarray(x_e, dtype=float)[:, None]
        D[:, at] = np.asarray(d, dtype=float)[:, None]
