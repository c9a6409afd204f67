"""The states at many times inside many solver steps at once: the energy integrals of a scipy-path result evaluate
every step's dense interpolant at its Gauss nodes (:meth:`Result._quadrature_nodes
<acausal.results.result.Result>`), a few hundred steps of a few nodes each. Calling each step's interpolant from Python
cost more than the run itself; LSODA's and BDF's interpolants (the two scipy integrators the project uses by
default) are polynomials whose coefficients are stacked here and evaluated in one array operation. Any other
interpolant is called step by step."""
from __future__ import annotations

import operator

import numpy as np


class StatesOnly:
    """A dense interpolant of the states and quadratures, answering the first ``n`` rows (the states) only."""

    def __init__(self, sol, n: int):
        self.sol, self.n = sol, n

    def __call__(self, t):
        return np.asarray(self.sol(t))[:self.n]


try:  # scipy's private classes: if a scipy release moves them, every interpolant is called step by step
    from scipy.integrate._ivp.bdf import BdfDenseOutput
    from scipy.integrate._ivp.lsoda import LsodaDenseOutput
except ImportError:  # pragma: no cover
    BdfDenseOutput = LsodaDenseOutput = None


def states_at(segments, which, tn, nx: int) -> np.ndarray:
    """The states (``nx`` rows) at ``tn`` (pieces x nodes): piece ``i`` lies in step ``segments[which[i]]``, a
    ``(t0, t1, interpolant, modes)`` of the scipy driver. Returns ``nx x pieces x nodes``."""
    Xn = np.zeros((nx,) + tn.shape)
    every = which.size == len(segments) and bool(np.all(which == np.arange(which.size)))  # each step once, in order
    used = which if every else np.unique(which)
    inner = [_inner(segments[k][2]) for k in used.tolist()]  # one pass over the steps: each step's interpolant
    kinds = [type(sol) for sol in inner]
    for kind in dict.fromkeys(kinds):
        rows = [r for r, kd in enumerate(kinds) if kd is kind] if len(set(kinds)) > 1 else range(len(kinds))
        steps = used[list(rows)]
        sols = [inner[r] for r in rows]
        pieces = np.flatnonzero(np.isin(which, steps)) if len(steps) < len(used) else np.arange(which.size)
        at = np.searchsorted(steps, which[pieces])  # each piece's step, as a row of the stacked coefficients
        if LsodaDenseOutput is not None and kind is LsodaDenseOutput:
            Xn[:, pieces, :] = _lsoda(sols, at, tn[pieces], nx)
        elif BdfDenseOutput is not None and kind is BdfDenseOutput:
            Xn[:, pieces, :] = _bdf(sols, at, tn[pieces], nx)
        else:
            for k in steps:
                m = which == k
                Xn[:, m, :] = np.asarray(segments[k][2](tn[m].ravel())).reshape((nx,) + tn[m].shape)
    return Xn


def _inner(sol):
    return sol.sol if type(sol) is StatesOnly else sol


_YH, _T, _H = operator.attrgetter("yh"), operator.attrgetter("t"), operator.attrgetter("h")


def _COLUMNS(a):
    return a.shape[1]


def _lsoda(sols, at, t, nx):
    """LSODA's Nordsieck form: y(t) = sum_j yh[:, j] ((t - t_n) / h)^j."""
    yh = list(map(_YH, sols))
    sizes = np.fromiter(map(_COLUMNS, yh), dtype=int, count=len(yh))
    J = int(sizes.max())
    # each step's coefficients (orders differ) side by side, then put into one zero-padded stack at once
    flat = np.concatenate(yh, axis=1)[:nx]
    step = np.repeat(np.arange(len(sols)), sizes)
    order = np.arange(flat.shape[1]) - np.repeat(np.cumsum(sizes) - sizes, sizes)
    YH = np.zeros((J, nx, len(sols)))
    YH[order, :, step] = flat.T
    T = np.fromiter(map(_T, sols), dtype=float, count=len(sols))
    H = np.fromiter(map(_H, sols), dtype=float, count=len(sols))
    x = ((t - T[at][:, None]) / H[at][:, None])[None]  # (1, pieces, nodes)
    C = YH[:, :, at, None]  # (J, nx, pieces, 1)
    y = np.broadcast_to(C[J - 1], (nx,) + t.shape)  # Horner's rule
    for j in range(J - 2, -1, -1):
        y = y * x + C[j]
    return np.array(y)


def _bdf(sols, at, t, nx):
    """BDF's divided-difference form: y(t) = D_0 + sum_j D_(j+1) prod_(i<=j) (t - t_i) / ((i + 1) h)."""
    J = max(s.order for s in sols)
    D0 = np.zeros((len(sols), nx))
    D = np.zeros((len(sols), J, nx))
    shift, denom = np.zeros((len(sols), J)), np.ones((len(sols), J))
    for r, s in enumerate(sols):
        D0[r] = s.D[0][:nx]
        D[r, :s.order] = s.D[1:s.order + 1, :nx]
        shift[r, :s.order], denom[r, :s.order] = s.t_shift, s.denom
    x = (t[:, :, None] - shift[at][:, None, :]) / denom[at][:, None, :]
    p = np.cumprod(x, axis=2)
    return np.matmul(p, D[at]).transpose(2, 0, 1) + D0[at].T[:, :, None]
