"""Standard errors of a least-squares fit whose residuals are correlated within groups (strides, recordings).

The textbook covariance ``s^2 (J^T J)^-1`` assumes independent residuals. A replayed recording's residuals are not:
the sensor noise is white, but what the model misses, and the smoothed replay's own small error, stay correlated
over a stride. With 10^5 samples that make a few dozen strides, the textbook errors are then several times too
small (a parameter 0.2 % from the truth can sit 18 "standard errors" away).

:func:`cluster_covariance` gives the cluster-robust ("sandwich") covariance of an M-estimator: with ``H`` the
Gauss-Newton Hessian of the (robust) cost and ``s_g`` the gradient contribution of cluster ``g``,

    cov = c H^-1 (sum_g s_g s_g^T) H^-1,    c = G / (G - 1) * (m - 1) / (m - n)

(the usual small-sample factor, "CR1"; ``G`` clusters, ``m`` residuals, ``n`` parameters). It allows any
correlation within a cluster and assumes clusters are independent, so the clusters must be at least as long as
the residual's correlation: a stride of a recording (the model's errors repeat with the gait, not across strides
that are refitted together). With fewer than :data:`MIN_CLUSTERS` clusters the estimate itself is too uncertain to
be trusted and the caller should widen the clusters' count (more strides) rather than believe it.

Robust losses (:func:`scipy.optimize.least_squares`'s ``soft_l1``, ``huber``, ``cauchy``, ``arctan``) enter
through ``rho'`` and ``rho''`` of the loss at each scaled residual: ``H = J_s^T J_s`` with the Jacobian ``J_s`` that
``least_squares`` returns (scaled by ``sqrt(rho' + 2 rho'' f^2)``), and each sample's gradient is ``rho' f J``.
"""
from __future__ import annotations

import numpy as np

#: below this many clusters a cluster-robust covariance is itself too noisy to report without a caveat
MIN_CLUSTERS = 10

#: the name the fits report their standard errors under (``method``: with what the clusters are)
METHOD = "cluster-robust sandwich (CR1), clustered by stride of each recording"


def method(experiments) -> str:
    """How the standard errors of a fit of ``experiments`` are computed, in words: :data:`METHOD`, or with the
    clusters the experiments name (``Experiment.info["clusters"]``, e.g. ``"recording"``)."""
    what = {e.info.get("clusters") for e in experiments if e.info.get("clusters")}
    return METHOD if not what else f"cluster-robust sandwich (CR1), clustered by {', '.join(sorted(what))}"


def loss_derivatives(f, loss: str, f_scale: float) -> tuple:
    """``(rho', rho'')`` of :func:`scipy.optimize.least_squares`'s ``loss`` at residuals ``f`` (``z = (f / C)^2``,
    ``rho''`` already divided by ``C^2`` as scipy does)."""
    z = (np.asarray(f, dtype=float) / f_scale) ** 2
    if loss == "linear":
        return np.ones_like(z), np.zeros_like(z)
    if loss == "soft_l1":
        t = 1.0 + z
        return t**-0.5, -0.5 * t**-1.5 / f_scale**2
    if loss == "huber":
        big = z > 1.0
        zs = np.where(big, z, 1.0)
        return np.where(big, zs**-0.5, 1.0), np.where(big, -0.5 * zs**-1.5, 0.0) / f_scale**2
    if loss == "cauchy":
        t = 1.0 + z
        return 1.0 / t, -1.0 / t**2 / f_scale**2
    if loss == "arctan":
        t = 1.0 + z**2
        return 1.0 / t, -2.0 * z / t**2 / f_scale**2
    raise ValueError(f"unknown loss {loss!r}")


def groups_of(experiments, signals, mask: str = "train") -> np.ndarray:
    """Cluster label of every row of :func:`~.calibrate.residual_vector` (same order: experiments, then signals,
    then the ``mask`` samples): the experiment and its clusters (``Experiment.clusters``, by default its strides,
    ``Experiment.stride``); an experiment without either counts as one cluster per cycle (``Experiment.period``)
    or, without one either, as 20 consecutive blocks. A cluster's samples of all signals are one cluster."""
    labels, offset = [], 0
    for e in experiments:
        m = getattr(e, mask)
        if not m.any():
            continue
        labels_e = e.clusters if getattr(e, "clusters", None) is not None else e.stride
        if labels_e is not None:
            g = np.asarray(labels_e)[m]
        elif e.period:
            g = np.floor((e.t[m] - e.t[0]) / e.period).astype(int)
        else:
            g = np.arange(int(m.sum())) * 20 // int(m.sum())
        g = np.unique(g, return_inverse=True)[1].ravel()
        for _ in signals:
            labels.append(g + offset)
        offset += int(g.max()) + 1
    return np.concatenate(labels)


def cluster_covariance(jac, residual, groups, loss: str = "linear", f_scale: float = 1.0) -> tuple:
    """``(cov, G)``: the cluster-robust covariance (see the module docstring) of the parameters whose scaled
    Jacobian ``jac`` (as :func:`scipy.optimize.least_squares` returns it) and residuals ``residual`` are given,
    with cluster labels ``groups`` per residual; ``G`` the number of clusters. Infinite where ``H`` is singular."""
    J = np.asarray(jac, dtype=float)
    r = np.asarray(residual, dtype=float)
    g = np.unique(np.asarray(groups), return_inverse=True)[1].ravel()
    m, n = J.shape
    G = int(g.max()) + 1 if g.size else 0
    rho1, rho2 = loss_derivatives(r, loss, f_scale)
    scale = np.sqrt(np.maximum(rho1 + 2.0 * rho2 * r**2, np.finfo(float).eps))
    score = (rho1 * r / scale)[:, None] * J  # rho' f J, with J the unscaled Jacobian J_s / scale
    S = np.zeros((G, n))
    np.add.at(S, g, score)
    try:
        Hinv = np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        return np.full((n, n), np.inf), G
    if G < 2 or m <= n:
        return np.full((n, n), np.inf), G
    c = G / (G - 1) * (m - 1) / (m - n)
    return c * Hinv @ (S.T @ S) @ Hinv, G
