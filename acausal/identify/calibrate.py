"""Calibration: bounded nonlinear least squares of model parameters against several experiments at once.

An :class:`Experiment` is model-agnostic: a time base, the measured signals, a ``predict`` function that maps
parameter values to predicted signals (built by model-specific code, e.g. a replay of the recording), and masks
for the samples used to fit (``train``) and to judge (``test``: held-out strides). :func:`calibrate` minimises

    sum over experiments, signals s, training samples k of  w_s * ((predicted - measured) / scale_s)^2

with :func:`scipy.optimize.least_squares` (trust-region reflective, bounds), parameters scaled by their typical
magnitude. ``scale_s`` makes signals of different units comparable: by default the noise level of each measured
signal, estimated from the data (:func:`noise_scales`), so residuals are in units of sensor noise and the fit is
the maximum-likelihood one under white Gaussian noise. ``w_s`` weighs signals (default 1).

The loss is robust by default (``soft_l1`` with ``f_scale = 3``: quadratic up to three noise levels, linear
beyond), so a few samples the model cannot follow (a driver going into saturation makes kinks in the measured
current that the smoothed replay rounds off) do not bias the parameters; ``loss="linear"`` gives plain least
squares.

Uncertainty: the cluster-robust (sandwich) covariance at the optimum, clustered by stride of each recording
(:mod:`~.uncertainty`): residuals correlated within a stride do not make it optimistic, as the textbook
``s^2 (J^T J)^-1`` (kept as ``Calibration.std_white``) is by a factor of several on replayed recordings.
Quality: RMSE per signal and experiment on the training and held-out samples, and ``Calibration.warnings``:
what the screening (:mod:`~.screening`) finds suspect in the data or the fit (a dead sensor, a reversed sign, a
recording far off the others, readings that repeat at another cycle than ``Experiment.period``, a held-out RMSE many
times the noise), on the fitted signals and on every other signal the experiments both record and predict. A
signal that reads one constant value in every experiment is an error: there is nothing to fit on it and its noise
level cannot be estimated. A model error while predicting an experiment (e.g. a setting of its recording outside a
parameter's bounds) names the experiment.
"""
from __future__ import annotations

import difflib
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.optimize import least_squares

from ..errors import AcausalError, DataError
from .screening import screen
from .uncertainty import METHOD, cluster_covariance, groups_of, method

#: the robust losses of :func:`scipy.optimize.least_squares` (``"linear"``: plain least squares)
LOSSES = ("linear", "soft_l1", "huber", "cauchy", "arctan")


@dataclass
class Experiment:
    name: str
    t: np.ndarray
    measured: dict  # signal -> samples
    predict: Callable  # dict(param -> value) -> dict(signal -> samples)
    train: np.ndarray  # bool mask: samples used to fit
    test: np.ndarray  # bool mask: held-out samples
    stride: np.ndarray | None = None  # stride index of every sample (for leave-one-stride-out)
    info: dict = field(default_factory=dict)
    #: optional exact derivatives: ``sensitivity(values, names) -> (predicted, sens)`` with ``sens[signal]`` of
    #: shape ``(len(names), N)``; when every experiment has one, :func:`calibrate` uses it as the Jacobian
    sensitivity: Callable | None = None
    #: the cycle the recorded motion repeats with, in seconds (e.g. the stride time from the recording's settings):
    #: the screening checks the readings repeat with it. None: not cyclic, or not checked
    period: float | None = None
    #: cluster label of every sample for the standard errors (:mod:`~.uncertainty`): samples whose residuals may be
    #: correlated share one. None: the strides (``stride``). ``info["clusters"]`` names them in words
    clusters: np.ndarray | None = None
    #: optional: ``solo()`` returns this experiment set up to run on its own, for a fit of this experiment alone
    #: (a model that runs its experiments together for a pooled fit would otherwise run them all for each of its
    #: parameter sets). None: it runs alone already
    solo: Callable | None = None


@dataclass(frozen=True)
class Free:
    """A parameter to fit: start value, bounds and typical magnitude (the optimiser's scale)."""

    name: str
    start: float
    lower: float = -np.inf
    upper: float = np.inf
    scale: float | None = None

    def __post_init__(self):
        if not self.lower <= self.start <= self.upper:
            raise DataError(f"parameter {self.name!r}: start value {self.start:g} is outside its bounds "
                            f"[{self.lower:g}, {self.upper:g}]")

    @classmethod
    def declared(cls, cm, name: str, start: dict | None = None) -> "Free":
        """Parameter ``name`` of compiled model ``cm`` to fit as its declaration says
        (:class:`~acausal.model.declarations.Parameter`'s ``fit_range`` and ``nominal``), started at its value in
        ``start`` (else the model's own, clipped into the range; a start given outside it is refused)."""
        info = cm.flat.parameters.get(name)
        if info is None:
            raise DataError(f"parameter {name!r} to fit: model {cm.flat.name} has no such parameter")
        if info.fit_range is None or info.nominal is None:
            raise DataError(f"parameter {name!r} to fit: its declaration ({info.owner}) gives no fit_range and "
                            "nominal; give the fit's bounds and scale")
        lo, hi = info.fit_range
        if name in (start or {}):
            return cls(name, float(start[name]), lo, hi, info.nominal)
        if not isinstance(info.value, (int, float)):
            raise DataError(f"parameter {name!r} to fit: its value {info.value} is an expression of other "
                            "parameters; give a start value")
        return cls(name, float(np.clip(info.value, lo, hi)), lo, hi, info.nominal)


@dataclass
class Calibration:
    names: list
    values: dict
    std: dict
    cov: np.ndarray
    cost: float
    nfev: int
    success: bool
    message: str
    signals: list
    rmse_train: dict  # (experiment, signal) -> RMSE
    rmse_test: dict
    start: dict
    counts: dict = field(default_factory=dict)  # "train"/"test" -> (experiment, signal) -> number of samples
    #: what the screening found suspect in the data or the fit (sentences; empty: nothing), :mod:`~.screening`
    warnings: list = field(default_factory=list)
    #: the textbook standard errors ``sqrt(diag(s^2 (J^T J)^-1))``, which assume white residuals (for comparison)
    std_white: dict = field(default_factory=dict)
    #: how many clusters (strides) the standard errors in ``std`` were estimated from
    clusters: int = 0
    #: how ``std`` was computed (:data:`~.uncertainty.METHOD`)
    std_method: str = METHOD

    def rmse(self, signal: str, which: str = "test") -> float:
        """RMSE of one signal over all experiments (pooled samples)."""
        table = self.rmse_test if _check_mask(which) == "test" else self.rmse_train
        vals = [v for (e, s), v in table.items() if s == signal]
        counts = [self.counts[which][(e, s)] for (e, s) in table if s == signal]
        return float(np.sqrt(np.sum(np.square(vals) * counts) / np.sum(counts)))

    def relative_std(self) -> dict:
        return {k: self.std[k] / abs(self.values[k]) if self.values[k] else np.inf for k in self.names}


def _check_mask(mask: str) -> str:
    """``mask`` if it names the training or the held-out samples ("train", "test"); a DataError otherwise."""
    if mask not in ("train", "test"):
        raise DataError(f"the samples must be 'train' or 'test', got {mask!r}")
    return mask


def noise_scales(experiments, signals) -> dict:
    """Noise standard deviation of each measured signal, from its second differences: for white noise of level
    sigma, ``y[k+1] - 2 y[k] + y[k-1]`` has standard deviation ``sqrt(6) sigma`` while a smooth signal sampled
    fast contributes little; the median absolute value makes it robust (``MAD / 0.6745``). Experiments whose
    reading never changes are left out (a dead sensor's zeros would make the noise look small); where most second
    differences are zero the non-zero ones give the level. A signal constant in every experiment is a DataError."""
    out = {}
    for s in signals:
        live = [e for e in experiments if np.ptp(e.measured[s]) > 0]  # a dead sensor's zeros would bias it low
        if not live:
            raise DataError(f"{_dead_everywhere(experiments, s)}; there is nothing to fit on it")
        d2 = np.concatenate([np.diff(e.measured[s], 2) for e in live])
        sigma = float(np.median(np.abs(d2)) / 0.6745 / np.sqrt(6.0))
        if sigma == 0:  # most readings equal their neighbours (a coarse quantisation, or a sensor stuck most of the
            changes = d2[d2 != 0]  # time): the size of the changes that do occur, not the size of the signal
            sigma = float(np.sqrt(np.mean(changes**2)) / np.sqrt(6.0)) if changes.size else 0.0
        out[s] = sigma or 1.0
    return out


def _dead_everywhere(experiments, s: str) -> str:
    values = sorted({float(e.measured[s][0]) for e in experiments})
    return (f"signal {s!r} reads one constant value ({', '.join(f'{v:g}' for v in values[:3])}) throughout every "
            f"experiment ({', '.join(e.name for e in experiments)}): a dead or disconnected sensor, or an empty column")


def _screen(experiments, preds, signals, scales, period) -> list:
    """:func:`~.screening.screen` on the fitted signals and on every other signal that all experiments both record
    and predict (a wrong setting can show where the fit does not look, e.g. in the torque of a current fit)."""
    others = sorted(set.intersection(*(set(e.measured) & set(preds[e.name]) for e in experiments)) - set(signals))
    out, scales = [], dict(scales)
    for s in others:
        if all(np.ptp(e.measured[s]) == 0 for e in experiments):
            out.append(f"{_dead_everywhere(experiments, s)} (a signal not fitted)")
        elif s not in scales:
            scales.update(noise_scales(experiments, [s]))
    checked = list(signals) + [s for s in others if s in scales]
    return screen(experiments, preds, checked, scales, period=period, who="the calibrated model",
                  misfit_hint="the model misses an effect (`acausal diagnose` names it), or the data is wrong") + out


def _named(e: Experiment, fn, *args):
    """``fn(*args)`` for experiment ``e``; an error of the model (e.g. a setting of the recording outside a
    parameter's bounds) is re-raised naming the experiment."""
    try:
        return fn(*args)
    except AcausalError as err:
        if str(err).startswith(f"experiment {e.name!r}"):
            raise
        raise type(err)(f"experiment {e.name!r}: {err}") from err


def residual_vector(experiments, values, signals, weights, scales, mask="train") -> np.ndarray:
    parts = []
    for e in experiments:
        m = getattr(e, _check_mask(mask))
        if not m.any():  # no samples of this kind (e.g. a recording held out whole): nothing to predict
            continue
        pred = _named(e, e.predict, values)
        for s in signals:
            parts.append(np.sqrt(weights.get(s, 1.0)) * (pred[s][m] - e.measured[s][m]) / scales[s])
    return np.concatenate(parts)


def calibrate(experiments, free, signals, *, weights: dict | None = None, scales: dict | None = None,
              fixed: dict | None = None, max_nfev: int = 100, loss: str = "soft_l1",
              f_scale: float = 3.0, tol: float = 1e-10, together: bool = False) -> Calibration:
    """Fit ``free`` (list of :class:`Free`) on the training samples of all ``experiments``.

    ``tol``: the optimiser's relative tolerances on the cost, the step and the gradient (``ftol``, ``xtol``,
    ``gtol`` of :func:`scipy.optimize.least_squares`); ``max_nfev``: at most this many evaluations.
    ``together``: every evaluation runs the experiments' sensitivities too, which the optimiser's next Jacobian
    (at the same point, once the step is accepted) takes without a second run; worth it where the
    experiments' ``predict`` at a point where ``sensitivity`` has run costs nothing (they keep its prediction)
    and a run with sensitivities costs less than two without (the servo replays: 1.8), since a rejected step then
    costs a run with sensitivities.

    The Jacobian is exact when every experiment has a ``sensitivity`` function, else forward differences (which,
    through an integrator's error control, can be too noisy to move a parameter that starts at zero)."""
    experiments = list(experiments)
    if not experiments:
        raise DataError("calibrate: no experiments")
    free = list(free)
    names = [f.name for f in free]
    if not free or len(set(names)) != len(names):
        raise DataError(f"calibrate: free must name at least one parameter, each once; got {names}")
    if loss not in LOSSES:
        raise DataError(f"calibrate: loss must be one of {', '.join(map(repr, LOSSES))}, got {loss!r}")
    if not (isinstance(max_nfev, (int, np.integer)) and max_nfev >= 1 and f_scale > 0):
        raise DataError(f"calibrate: max_nfev must be a positive integer and f_scale positive, got {max_nfev!r} "
                        f"and {f_scale!r}")
    for e in experiments:
        for s in signals:
            if s not in e.measured:
                raise DataError(f"calibrate: experiment {e.name!r} has no measured signal {s!r}")
    weights = dict(weights or {})
    for k, w in weights.items():
        if k not in signals:
            close = difflib.get_close_matches(str(k), list(signals), n=1)
            raise DataError(f"calibrate: a weight is given for {k!r}, which is not a fitted signal"
                            + (f" (did you mean {close[0]!r}?)" if close else f"; fitted: {', '.join(signals)}"))
        if not (isinstance(w, (int, float, np.floating)) and np.isfinite(w) and w >= 0):
            raise DataError(f"calibrate: the weight of {k!r} must be a finite number >= 0, got {w!r}")
    if signals and all(weights.get(s, 1.0) == 0 for s in signals):
        raise DataError(f"calibrate: every fitted signal ({', '.join(signals)}) has weight 0: nothing would be "
                        "fitted; give at least one a positive weight")
    scales = dict(scales or noise_scales(experiments, signals))
    fixed = dict(fixed or {})
    xs = np.array([f.scale or (abs(f.start) or 1.0) for f in free])

    def values_of(z):
        return {**fixed, **{n: float(v) for n, v in zip(names, z * xs)}}

    exact = all(e.sensitivity is not None for e in experiments)
    ahead: dict = {}  # the Jacobian run with the last evaluation (together=True), by its point

    def fun(z):
        if together and exact:
            ahead.clear()
            ahead[z.tobytes()] = jacobian_matrix(experiments, values_of(z), names, signals, weights, scales) * xs
        return residual_vector(experiments, values_of(z), signals, weights, scales)

    def jac_fn(z):
        J = ahead.pop(z.tobytes(), None)
        return J if J is not None else jacobian_matrix(experiments, values_of(z), names, signals, weights, scales) * xs

    z0 = np.array([f.start for f in free]) / xs
    lo = np.array([f.lower for f in free]) / xs
    hi = np.array([f.upper for f in free]) / xs
    sol = least_squares(fun, z0, jac=jac_fn if exact else "2-point", bounds=(lo, hi), method="trf", x_scale=1.0,
                        max_nfev=max_nfev, loss=loss, f_scale=f_scale, diff_step=1e-6, xtol=tol, ftol=tol, gtol=tol)
    J = sol.jac * 1.0
    m, n = J.shape
    s2 = 2 * sol.cost / max(m - n, 1)
    try:
        white_z = s2 * np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        white_z = np.full((n, n), np.inf)
    cov_z, clusters = cluster_covariance(J, sol.fun, groups_of(experiments, signals), loss, f_scale)
    cov = cov_z * np.outer(xs, xs)
    values = values_of(sol.x)
    std = {k: float(np.sqrt(max(cov[i, i], 0.0))) for i, k in enumerate(names)}
    std_white = {k: float(np.sqrt(max(v, 0.0))) for k, v in zip(names, np.diag(white_z) * xs**2)}
    rmse_train, rmse_test, counts = {}, {}, {"train": {}, "test": {}}
    preds = {}
    for e in experiments:
        pred = preds[e.name] = _named(e, e.predict, values)
        for s in signals:
            for which, table in (("train", rmse_train), ("test", rmse_test)):
                msk = getattr(e, which)
                if msk.any():
                    table[(e.name, s)] = float(np.sqrt(np.mean((pred[s][msk] - e.measured[s][msk]) ** 2)))
                    counts[which][(e.name, s)] = int(msk.sum())
    cal = Calibration(names, {k: values[k] for k in names}, std, cov, float(sol.cost), int(sol.nfev),
                      bool(sol.success), str(sol.message), list(signals), rmse_train, rmse_test,
                      {f.name: f.start for f in free}, counts, std_white=std_white, clusters=clusters,
                      std_method=method(experiments))
    cal.warnings = _screen(experiments, preds, signals, scales, lambda e: e.period)
    return cal


def jacobian_matrix(experiments, values, names, signals, weights=None, scales=None, mask="train") -> np.ndarray:
    """Derivative of :func:`residual_vector` with respect to ``names`` (rows in the same order), from the
    experiments' exact ``sensitivity`` functions."""
    weights = weights or {}
    scales = scales or {s: 1.0 for s in signals}
    parts = []
    for e in experiments:
        m = getattr(e, _check_mask(mask))
        if not m.any():
            continue
        _, sens = _named(e, e.sensitivity, values, list(names))
        for s in signals:
            parts.append(np.sqrt(weights.get(s, 1.0)) * sens[s][:, m].T / scales[s])
    return np.concatenate(parts)


def jacobian(experiments, values, names, signals, scales, mask="train") -> np.ndarray:
    """Derivative of the unweighted :func:`residual_vector` with respect to ``names``: exact (the experiments'
    ``sensitivity`` functions, :func:`jacobian_matrix`) when every experiment has one, else by forward differences
    (relative step 1e-6, taken inwards where a parameter sits on an upper bound)."""
    ones = {s: 1.0 for s in signals}
    if all(e.sensitivity is not None for e in experiments):
        return jacobian_matrix(experiments, values, names, signals, ones, scales, mask)
    r0 = residual_vector(experiments, values, signals, ones, scales, mask)
    cols = []
    for n in names:
        h = 1e-6 * max(abs(values[n]), 1e-9)
        try:
            r1 = residual_vector(experiments, {**values, n: values[n] + h}, signals, ones, scales, mask)
        except AcausalError:  # at an upper bound (e.g. an efficiency of 1): step inwards
            h = -h
            r1 = residual_vector(experiments, {**values, n: values[n] + h}, signals, ones, scales, mask)
        cols.append((r1 - r0) / h)
    return np.stack(cols, axis=1)


def rmse_table(experiments, values: dict, signals, mask: str = "test") -> dict:
    """RMSE per (experiment, signal) of the predictions with ``values`` on the ``mask`` samples."""
    out = {}
    for e in experiments:
        pred = _named(e, e.predict, values)
        msk = getattr(e, _check_mask(mask))
        for s in signals:
            out[(e.name, s)] = float(np.sqrt(np.mean((pred[s][msk] - e.measured[s][msk]) ** 2)))
    return out
