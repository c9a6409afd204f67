"""The 5-point Gauss-Legendre rule a :class:`~acausal.results.result.Result` integrates its energies with: nodes on the
intervals between breakpoints (the solver's steps, cut at the output times or not), the states there from the
steps' interpolants, cumulative integrals at the breakpoints; Simpson's rule where only samples are known."""
from __future__ import annotations

import numpy as np
from scipy.integrate import cumulative_simpson

from .interpolants import states_at


def gauss_cumulative(nodes, what) -> np.ndarray:
    """The cumulative integral of ``what`` (:meth:`Result._integrand`) at the breakpoints of ``nodes`` (a
    :meth:`Result._quadrature_nodes` set: 5-point Gauss-Legendre on every interval between them)."""
    bps, shape, half, wg, sub = nodes
    y = np.asarray(sub._integrand(what), dtype=float).reshape(shape)
    return np.concatenate([[0.0], np.cumsum(half * (y @ wg))])


def gauss_nodes(bps):
    """5-point Gauss-Legendre nodes ``(intervals, 5)`` of the intervals between breakpoints ``bps``, their
    half-widths and the weights."""
    a, b = bps[:-1], bps[1:]
    half, mid = (b - a) / 2, (a + b) / 2
    return mid[:, None] + half[:, None] * _GAUSS_X[None, :], half, _GAUSS_W


#: the 5-point Gauss-Legendre rule on [-1, 1]: nodes and weights (computed once: numpy's leggauss finds them by an
#: eigenvalue problem, a tenth of the trust check's time when asked for every run)
_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(5)
_GAUSS_X.flags.writeable = _GAUSS_W.flags.writeable = False


def integrate_cumulative(y, t):
    """Cumulative integral of samples ``y(t)`` (Simpson; trapezoid for fewer than 3 samples)."""
    y = np.asarray(y, dtype=float)
    if t.size < 3:
        return np.concatenate([[0.0], np.cumsum(np.diff(t) * (y[1:] + y[:-1]) / 2)])
    return cumulative_simpson(y, x=t, initial=0.0)


def nodes_at(res, cuts, samples=None) -> tuple:
    """The Gauss nodes of every solver step of result ``res`` (:meth:`Result._quadrature_nodes
    <acausal.results.result.Result>`), the steps also cut at the times ``cuts`` (None: the steps alone):
    ``(breakpoints, node shape, half-widths, weights, a result of the same class at the nodes)``. ``samples``:
    :func:`node_samples` of the same cuts, if already found."""
    bps, tn, half, wg, Xn, Dn = samples or node_samples(res, cuts)
    sub = type(res)(res.model, tn.ravel(), Xn, res.params, res.inputs, Dn, events=[],
                    dense=type(res.dense)(exact_time=res.dense.nodes is None and res.dense.exact_time))
    return (bps, tn.shape, half, wg, sub)


def node_samples(res, cuts) -> tuple:
    """The samples :func:`nodes_at` builds its result from: ``(breakpoints, node times (intervals, 5),
    half-widths, weights, states (n_states, nodes), modes (a vector, or n_modes x nodes))``."""
    t = res.t
    cm = res.model
    nx = len(cm.state_names)
    if res.dense.nodes is not None:
        bps, Xn = res.dense.nodes()
        tn, half, wg = gauss_nodes(bps)
        return (bps, tn, half, wg, Xn.reshape(nx, tn.size),
                np.asarray(res.modes if np.ndim(res.modes) == 1 else res.modes[:, 0], dtype=float))
    segs = res.dense.steps
    if segs:
        starts = np.array([s[0] for s in segs])
        bps = np.append(starts, segs[-1][1]) if cuts is None else np.union1d(np.append(starts, segs[-1][1]), cuts)
        bps = bps[(bps >= t[0]) & (bps <= t[-1])]
    else:
        bps = t
    a = bps[:-1]
    tn, half, wg = gauss_nodes(bps)
    Xn = np.zeros((nx,) + tn.shape)
    if segs:
        which = np.clip(np.searchsorted(starts, a, side="right") - 1, 0, len(segs) - 1)
        Xn = states_at(segs, which, tn, nx)
        Dn = np.zeros((len(cm.discrete_names),) + tn.shape)
        if Dn.size:
            Dn[:] = np.asarray([segs[k][3] for k in which], dtype=float).T[:, :, None]
    else:
        Dn = res.modes if np.ndim(res.modes) == 1 else \
            np.repeat(res.modes[:, np.searchsorted(t, a, side="right") - 1][:, :, None], 5, axis=2)
    nd = len(cm.discrete_names)
    Dflat = np.asarray(Dn, dtype=float).reshape(nd, tn.size) if np.ndim(Dn) > 1 else np.asarray(Dn, dtype=float)
    return (bps, tn, half, wg, Xn.reshape(nx, tn.size), Dflat)
