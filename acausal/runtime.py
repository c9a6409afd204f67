"""Numeric helpers called by generated code: broadcasting linear solves and Newton iterations.

Values in generated code are floats or numpy arrays that broadcast against each other (time samples, batches of
parameter sets); these helpers keep that contract.
"""
from __future__ import annotations

import numpy as np

from .errors import SimulationError


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


def linsolve(A_rows, b) -> list:
    """Solve ``A y = b`` for every broadcast sample; ``A_rows`` is a list of rows of entries."""
    m = len(b)
    entries = [e for row in A_rows for e in row] + list(b)
    arrs = np.broadcast_arrays(*[np.asarray(e, dtype=float) for e in entries])
    shape = arrs[0].shape
    A = np.stack(arrs[: m * m], axis=-1).reshape(shape + (m, m))
    rhs = np.stack(arrs[m * m:], axis=-1)[..., None]
    try:
        y = np.linalg.solve(A, rhs)[..., 0]
    except np.linalg.LinAlgError:
        raise SimulationError("singular linear system in a numeric block") from None
    return [y[..., i] for i in range(m)]


def newton(fun, guesses, args, label: str, tol: float = 1e-12, maxiter: int = 60) -> list:
    """Solve ``r(y, *args) = 0`` by Newton's method with the exact Jacobian ``fun`` returns ``(r, J)``.

    Vectorised: ``y`` entries broadcast with ``args``; converged samples stop changing. Raises
    :class:`SimulationError` naming the block when it does not converge.
    """
    shape = np.broadcast_shapes(*[np.shape(a) for a in args]) if args else ()
    y = [np.broadcast_to(np.asarray(g, dtype=float), shape).copy() for g in guesses]
    m = len(y)
    for _ in range(maxiter):
        r, J = fun(y, *args)
        r_arr = bstack(list(r) + [np.zeros(shape)])[:m]
        J_arr = bstack([e for row in J for e in row] + [np.zeros(shape)])[: m * m]
        J_arr = np.moveaxis(J_arr.reshape((m, m) + J_arr.shape[1:]), (0, 1), (-2, -1))
        r_last = np.moveaxis(r_arr, 0, -1)[..., None]
        try:
            dy = np.linalg.solve(J_arr, -r_last)[..., 0]
        except np.linalg.LinAlgError:
            raise SimulationError(f"Newton iteration for {label}: singular Jacobian") from None
        step = 0.0
        for i in range(m):
            y[i] = y[i] + dy[..., i]
            step = np.maximum(step, np.max(np.abs(dy[..., i]) / (1.0 + np.abs(y[i]))))
        if not np.all(np.isfinite(step)):
            raise SimulationError(f"Newton iteration for {label}: non-finite iterate")
        if np.all(step < tol):
            return y
    r, _ = fun(y, *args)
    worst = max(float(np.max(np.abs(ri))) for ri in r)
    if worst < 1e-8:
        return y
    raise SimulationError(f"Newton iteration for {label} did not converge (residual {worst:.3g})")
