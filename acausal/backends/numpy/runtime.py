"""Numeric helpers called by generated code: broadcasting linear solves and Newton iterations.

Values in generated code are floats or numpy arrays that broadcast against each other (time samples, batches of
parameter sets); these helpers keep that contract.

A numeric block that fails raises :class:`~acausal.errors.SimulationError` naming the simulation time (the
generated functions pass their time argument ``t``, s), the block's variables, the components its equations come
from, the values where the iteration stopped, and what to try.
"""
from __future__ import annotations

import numpy as np

from ...errors import SimulationError

LINE_SEARCH_HALVINGS = 10  # the damped Newton step is halved at most this often (down to 2**-10 of the full step)
ACCEPTED_RESIDUAL = 1e-8  # a residual below this after the last iteration is accepted (the step test not met)


def rows(values, length: int) -> np.ndarray:
    """Values of a generated function (arrays over ``length`` samples, or numbers for constants) as one float
    array of rows."""
    out = np.empty((len(values), length))
    for i, v in enumerate(values):
        out[i] = v
    return out


def as_rows(values, shape) -> list:
    """The same as a list of float arrays of ``shape``, without a copy of a row that already is one."""
    return [v if type(v) is np.ndarray and v.shape == shape and v.dtype == float
            else np.broadcast_to(np.asarray(v, dtype=float), shape) for v in values]


class Block:
    """An algebraic block as its failure messages name it: ``kind`` (``"linear"`` or ``"nonlinear"``), its
    variables ``vars`` (names), ``origins`` (the components its equations come from, e.g. ``"Resistor 'R'"``) and,
    for a Newton block, the start values ``starts`` its iteration begins from (in the variables' units) and which
    of its variables are indeterminate (``free``, :class:`~acausal.model.components.Indeterminate`)."""

    __slots__ = ("kind", "vars", "origins", "starts", "free")

    def __init__(self, kind: str, vars, origins, starts=(), free=()):
        self.kind, self.vars, self.origins, self.starts = kind, tuple(vars), tuple(origins), tuple(starts)
        self.free = tuple(bool(f) for f in free)

    def __str__(self):
        return (f"the {self.kind} block of {', '.join(map(repr, self.vars))} "
                f"(equations from {', '.join(self.origins)})")

    __repr__ = __str__


def bstack(values) -> np.ndarray:
    """Stack scalars and arrays into one array of shape ``(len(values),) + broadcast shape``."""
    arrs = np.broadcast_arrays(*[np.asarray(v, dtype=float) for v in values])
    return np.stack(arrs) if arrs else np.zeros((0,))


def piecewise(*args):
    """``sympy.Piecewise`` at run time: ``args`` = value, condition, value, condition, ... (the first true
    condition's value; NaN if none holds). Scalar conditions take a plain branch; arrays go through
    :func:`numpy.select` (every value is evaluated in both cases, as the generated code computes them first)."""
    values, conds = args[0::2], args[1::2]
    if all(isinstance(c, (bool, np.bool_)) for c in conds):
        for v, c in zip(values, conds):
            if c:
                return v
        return np.nan
    shape = np.broadcast_shapes(*(np.shape(a) for a in args))
    return np.select([np.broadcast_to(c, shape) for c in conds], [np.broadcast_to(v, shape) for v in values],
                     default=np.nan)


def linsolve(A_rows, b, block=None, t=None, scale=None) -> list:
    """Solve ``A y = b`` for every broadcast sample; ``A_rows`` is a list of rows of entries.

    ``block`` (a :class:`Block` or a description) and ``t`` (the time, s; a float or an array broadcasting with
    the entries) name the block and the time in the :class:`SimulationError` a singular system raises.
    ``scale`` (one entry per unknown): the system may be singular; where it is, the solution minimising
    ``sum(y**2 / scale)`` (:func:`least_norm`)."""
    m = len(b)
    entries = [e for row in A_rows for e in row] + list(b) + list(scale if scale is not None else ())
    arrs = np.broadcast_arrays(*[np.asarray(e, dtype=float) for e in entries])
    shape = arrs[0].shape
    A = np.stack(arrs[: m * m], axis=-1).reshape(shape + (m, m))
    rhs = np.stack(arrs[m * m: m * m + m], axis=-1)
    if scale is not None:
        try:
            y = least_norm(A, rhs, np.stack(arrs[m * m + m:], axis=-1), getattr(block, "free", None))
        except np.linalg.LinAlgError:
            raise _singular_linear(A, block, t) from None
        return [y[..., i] for i in range(m)]
    try:
        y = np.linalg.solve(A, rhs[..., None])[..., 0]
    except np.linalg.LinAlgError:
        raise _singular_linear(A, block, t) from None
    return [y[..., i] for i in range(m)]


SPLIT_RCOND = 1e-10  # singular values below this fraction of the largest count as zero in a split block's solve


def least_norm(A, b, scale, free=None) -> np.ndarray:
    """The solution ``y`` of ``A y = b`` (shapes ``(..., m, m)``, ``(..., m)``) minimising ``sum(y**2 / scale)``
    (``scale`` > 0, shape ``(..., m)``) where ``A`` is singular (singular values below :data:`SPLIT_RCOND` of the
    largest count as zero); where it is regular, the solution. Least squares where the system has no solution
    (the caller judges its residual). ``free`` (booleans, one per unknown): the unknowns the system may leave
    undetermined; a singular direction that moves another one raises ``numpy.linalg.LinAlgError``."""
    root = np.sqrt(scale)
    u, sv, vh = np.linalg.svd(A * root[..., None, :])
    keep = sv > SPLIT_RCOND * sv[..., :1]
    if free is not None and not all(free) and not keep.all():
        null = np.abs(vh) * ~keep[..., :, None]  # the right singular vectors of the dropped singular values
        if np.any(null[..., [not f for f in free]] > 1e-8):
            raise np.linalg.LinAlgError("singular in a determined variable")
    inv = np.where(keep, 1.0 / np.where(keep, sv, 1.0), 0.0)
    z = np.swapaxes(vh, -1, -2) @ (inv[..., None] * (np.swapaxes(u, -1, -2) @ b[..., None]))
    return root * z[..., 0]


def _split_step(J, r, y, split, args, free=None):
    """The Newton step of a block with indeterminate variables (``split(y, *args)`` gives their nominal values
    and scales, :class:`~acausal.model.components.Indeterminate`): the solution of ``J dy = -r`` that brings ``y + dy``
    nearest to the nominal values in the scales' weights (the plain Newton step where ``J`` is regular). Shapes:
    ``J (..., m, m)``, ``r`` and ``y`` ``(..., m)``; ``free`` as :func:`least_norm` takes it."""
    nominal, scale = split(list(np.moveaxis(y, -1, 0)), *args)
    shape = y.shape[:-1]
    nominal = np.stack([np.broadcast_to(np.asarray(v, dtype=float), shape) for v in nominal], axis=-1)
    scale = np.stack([np.broadcast_to(np.asarray(v, dtype=float), shape) for v in scale], axis=-1)
    off = y - nominal
    return least_norm(J, (J @ off[..., None])[..., 0] - r, scale, free) - off


def starts(given, names, defaults) -> tuple:
    """A Newton block's start values where the caller of the generated function gives some (``given``: values by
    variable name, arrays over the samples, e.g. the integrator's algebraic variables at the outputs): those, and
    ``defaults`` (its variables' start values) for the others. The generated call checks ``given is None`` itself
    (no call then)."""
    return tuple(given.get(name, value) for name, value in zip(names, defaults))


def newton(fun, guesses, args, label, tol: float = 1e-12, maxiter: int = 60, t=None, split=None) -> list:
    """Solve ``r(y, *args) = 0`` by damped Newton with the exact Jacobian: ``fun(y, *args)`` returns ``(r, J)``.

    Vectorised: ``y`` entries broadcast with ``args`` (time samples, parameter batches). Each iteration solves
    ``J dy = -r`` and tries the full step; a sample whose residual norm ``max |r_i|`` does not decrease there (or
    is not finite) has its step halved, at most :data:`LINE_SEARCH_HALVINGS` times, while the others keep theirs
    (the common case, every full step good, costs one evaluation per iteration as plain Newton does). A sample
    converges when its step is below ``tol`` relative to ``1 + |y|``; converged samples are not damped. After
    ``maxiter`` iterations a residual below :data:`ACCEPTED_RESIDUAL` is accepted.

    ``label`` (a :class:`Block` or a description) and ``t`` (the time, s, broadcasting with the samples; None
    when unknown) name the block and the time in the :class:`SimulationError` raised when the iteration does not
    converge, the Jacobian is singular, or the residual is not finite even on the shortest step; the message
    gives the last iterate and what to try. Trial points may overflow (an exponential far from its solution):
    numpy's warnings are silenced inside, the values judged.

    ``split(y, *args)`` (a block with indeterminate variables, :class:`~acausal.model.components.Indeterminate`) gives
    their nominal values and scales: every step is :func:`_split_step`, so where ``J`` is singular the iteration
    ends at the solution nearest to the nominal values (evaluated there) in the scales' weights.
    """
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        if all(np.ndim(a) == 0 for a in args):
            return _newton_point(fun, guesses, args, label, tol, maxiter, t, split)
        return _newton_samples(fun, guesses, args, label, tol, maxiter, t, split)


def _newton_point(fun, guesses, args, label, tol, maxiter, t, split=None) -> list:
    """:func:`newton` at one sample (every argument a scalar, as in the integrator's calls): the same iteration
    on numpy scalars, without the stacking and broadcasting that would cost most of its time."""
    m = len(guesses)
    y = [np.float64(g) for g in guesses]
    r, J = fun(y, *args)
    r = np.array(r, dtype=float)
    nr = np.max(np.abs(r))
    if not np.isfinite(nr):
        raise _newton_error("the residual is not finite at the start values", label, t, y, r, True)
    for _ in range(maxiter):
        if split is not None:
            try:
                dy = _split_step(np.array(J, dtype=float), r, np.array(y, dtype=float), split, args,
                                 getattr(label, "free", None))
            except np.linalg.LinAlgError:
                raise _newton_error("singular Jacobian", label, t, y, r, True) from None
        elif m == 1:
            j = J[0][0]
            if j == 0:
                raise _newton_error("singular Jacobian", label, t, y, r, True)
            dy = (-r[0] / j,)
        else:
            try:
                dy = np.linalg.solve(np.array(J, dtype=float), -r)
            except np.linalg.LinAlgError:
                raise _newton_error("singular Jacobian", label, t, y, r, True) from None
        y_new = [y[i] + dy[i] for i in range(m)]
        step = max([abs(dy[i]) / (1.0 + abs(y_new[i])) for i in range(m)])
        if not np.isfinite(step):
            raise _newton_error("non-finite Newton step (the Jacobian is not finite or nearly singular)", label, t,
                                y, r, True)
        if step < tol:
            return y_new
        r_new, J = fun(y_new, *args)
        r_new = np.array(r_new, dtype=float)
        nr_new = np.max(np.abs(r_new))
        if not nr_new <= nr:  # worse, or not finite: backtrack
            lam = 1.0
            for _ in range(LINE_SEARCH_HALVINGS):
                lam *= 0.5
                y_new = [y[i] + lam * dy[i] for i in range(m)]
                r_new, J = fun(y_new, *args)
                r_new = np.array(r_new, dtype=float)
                nr_new = np.max(np.abs(r_new))
                if nr_new <= nr:
                    break
            if not np.isfinite(nr_new):
                raise _newton_error(_NOT_FINITE, label, t, y, r, True)
        y, r, nr = y_new, r_new, nr_new
    if nr < ACCEPTED_RESIDUAL:
        return y
    raise _newton_error(f"did not converge in {maxiter} iterations (residual {nr:.3g})", label, t, y, r, True)


_NOT_FINITE = "the residual is not finite on the Newton step nor on the shortest damped step"


def _newton_samples(fun, guesses, args, label, tol, maxiter, t, split=None) -> list:
    """:func:`newton` over broadcast samples (arrays of time samples or parameter sets)."""
    shape = np.broadcast_shapes(*[np.shape(a) for a in args]) if args else ()
    y = [np.broadcast_to(np.asarray(g, dtype=float), shape).copy() for g in guesses]
    m = len(y)
    r, J = fun(y, *args)
    r_arr, nr = _residual(r, m, shape)
    if not np.all(np.isfinite(nr)):
        raise _newton_error("the residual is not finite at the start values", label, t, y, r_arr, ~np.isfinite(nr))
    for _ in range(maxiter):
        J_arr = bstack([e for row in J for e in row] + [np.zeros(shape)])[: m * m]
        J_arr = np.moveaxis(J_arr.reshape((m, m) + J_arr.shape[1:]), (0, 1), (-2, -1))
        try:
            if split is not None:
                dy = _split_step(J_arr, np.moveaxis(r_arr, 0, -1), np.stack(y, axis=-1), split, args,
                                 getattr(label, "free", None))
            else:
                dy = np.linalg.solve(J_arr, -np.moveaxis(r_arr, 0, -1)[..., None])[..., 0]
        except np.linalg.LinAlgError:
            raise _newton_error("singular Jacobian", label, t, y, r_arr, _singular_samples(J_arr)) from None
        y_new = [y[i] + dy[..., i] for i in range(m)]
        step = np.abs(dy[..., 0]) / (1.0 + np.abs(y_new[0]))
        for i in range(1, m):
            step = np.maximum(step, np.abs(dy[..., i]) / (1.0 + np.abs(y_new[i])))
        if not np.all(np.isfinite(step)):
            raise _newton_error("non-finite Newton step (the Jacobian is not finite or nearly singular)", label, t,
                                y, r_arr, ~np.isfinite(step))
        if np.all(step < tol):
            return y_new
        r, J = fun(y_new, *args)
        r_new, nr_new = _residual(r, m, shape)
        worse = ~(nr_new <= nr) & (step >= tol)  # NaN compares False: a non-finite residual is worse
        if worse.any():
            y_new, r, J, r_new, nr_new = _line_search(fun, args, y, dy, y_new, worse, nr, r, J, r_new, nr_new,
                                                      m, shape)
            if not np.all(np.isfinite(nr_new)):
                raise _newton_error(_NOT_FINITE, label, t, y, r_arr, ~np.isfinite(nr_new))
        y, r_arr, nr = y_new, r_new, nr_new
    worst = float(np.max(np.abs(r_arr))) if r_arr.size else 0.0
    if worst < ACCEPTED_RESIDUAL:
        return y
    raise _newton_error(f"did not converge in {maxiter} iterations (residual {worst:.3g})", label, t, y, r_arr,
                        np.max(np.abs(r_arr), axis=0) >= ACCEPTED_RESIDUAL)


def _residual(r, m, shape):
    """``(residuals stacked (m,) + shape, their max-norm per sample)``. The max-norm cannot overflow where the
    residuals do not, and a short Newton step shrinks every residual alike, so it serves the line search."""
    r_arr = bstack(list(r) + [np.zeros(shape)])[:m]
    return r_arr, np.max(np.abs(r_arr), axis=0)


def _line_search(fun, args, y, dy, y_new, bad, nr, r, J, r_new, nr_new, m, shape):
    """Backtracking: halve the step of the samples in ``bad`` until their residual norm is below ``nr`` (the
    norm at ``y``) or :data:`LINE_SEARCH_HALVINGS` halvings; the others keep their full step."""
    lam = 1.0
    for _ in range(LINE_SEARCH_HALVINGS):
        lam *= 0.5
        y_new = [np.where(bad, y[i] + lam * dy[..., i], y_new[i]) for i in range(m)]
        r, J = fun(y_new, *args)
        r_new, nr_new = _residual(r, m, shape)
        bad = bad & ~(nr_new <= nr)
        if not bad.any():
            break
    return y_new, r, J, r_new, nr_new


def _singular_samples(J_arr) -> np.ndarray:
    """Which samples' Jacobians (shape ``sample shape + (m, m)``) are singular (or not finite)."""
    with np.errstate(all="ignore"):
        finite = np.all(np.isfinite(J_arr), axis=(-2, -1))
        rank = np.linalg.matrix_rank(np.where(finite[..., None, None], J_arr, 0.0))
    return ~finite | (rank < J_arr.shape[-1])


def _first(mask, *arrays):
    """The values of ``arrays`` (each broadcasting with ``mask``) at the first sample where ``mask`` holds
    (the first sample when none does), as floats."""
    shape = np.broadcast_shapes(np.shape(mask), *[np.shape(a) for a in arrays])
    flat = np.broadcast_to(mask, shape).ravel()
    k = int(np.argmax(flat)) if flat.size else 0
    return [float(np.broadcast_to(a, shape).ravel()[k]) if flat.size else float("nan") for a in arrays]


def _at_time(t, mask) -> str:
    """`` at t = ... s``: the time of the first failing sample (empty when the time is unknown)."""
    if t is None:
        return ""
    t = np.asarray(t, dtype=float)
    try:
        (t0,) = _first(mask, t)
    except ValueError:  # a time grid that does not broadcast with the block's samples: its start
        t0 = float(t.ravel()[0]) if t.size else float("nan")
    return f" at t = {t0:.9g} s"


def _names(label) -> tuple:
    return getattr(label, "vars", ())


def _newton_error(what, label, t, y, r_arr, mask) -> SimulationError:
    """The failure of Newton block ``label``: ``what`` went wrong at the first sample in ``mask`` (time, last
    iterate and residuals there) and what to try."""
    mask = np.asarray(mask, dtype=bool)
    vals = _first(mask, *y, *r_arr)
    ys, rs = vals[: len(y)], vals[len(y):]
    names = _names(label) or [f"y{i}" for i in range(len(y))]
    starts = getattr(label, "starts", ())
    iterate = ", ".join(f"{n!r} = {v:.6g}" for n, v in zip(names, ys))
    if len(starts) == len(names):
        iterate += " (start " + ", ".join(f"{s:.6g}" for s in starts) + ")"
    resid = ", ".join(f"{v:.3g}" for v in rs)
    return SimulationError(f"Newton iteration for {label}{_at_time(t, mask)}: {what}; last iterate {iterate}, "
                           f"residuals {resid}. {_hint(names)}")


def _hint(names) -> str:
    who = ", ".join(map(repr, names))
    return (f"Hint: every evaluation starts this block from its start values, so give {who} a start value near "
            "the solution (Start(value) where the component is made, or Variable(start=...) in its class: "
            "simulate(starts={...}) gives initial values the states must meet, not this block's iteration start); "
            "if the integrator stepped far (a trial state), try method='BDF' or a smaller max_step.")


def _singular_linear(A, block, t) -> SimulationError:
    with np.errstate(all="ignore"):
        bad = _singular_samples(A)
    names = _names(block)
    what = f"the equations of {block}" if block is not None else "a numeric linear block"
    who = ", ".join(map(repr, names)) if names else "its variables"
    return SimulationError(f"singular linear system{_at_time(t, bad)}: {what} do not determine {who} there. "
                           "Hint: a parameter of those components at zero (a resistance, an inertia, a ratio) or "
                           "a mode in which the block has no unique solution makes it singular: give it a "
                           "nonzero value; if the integrator stepped far, try method='BDF' or a smaller max_step.")
