"""What a calibrated model still gets wrong: statistics of the residual ``measured - predicted`` of one signal.

All functions take plain arrays, so they serve any model:

* :func:`phase_profile`: the residual folded over a period (the gait cycle): mean and spread per phase bin over
  the cycles. A model error repeats every cycle and shows in the mean; sensor noise averages out.
* :func:`whiteness`: the normalised autocorrelation up to ``max_lag`` and the Ljung-Box statistic. White noise
  keeps about 95 % of the autocorrelations inside the band ``+-1.96 / sqrt(N)``; an unmodelled effect makes the
  residual smooth, so its autocorrelation stays high over many lags.
* :func:`cross_correlations`: the correlation of the residual with physically meaningful regressors (sign of the
  motor speed, current squared, elapsed time, ...), with the same significance band. A Coulomb friction left out
  shows as a residual correlated with ``sign(w)``; a heating winding as one correlated with elapsed time.
* :func:`leave_one_group_out`: leave-one-group-out (e.g. leave-one-stride-out) residuals of a least-squares fit,
  from its Jacobian, without refitting (exact for a linear model, the usual linearisation otherwise).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from ..errors import DataError


@dataclass
class PhaseProfile:
    phase: np.ndarray  # bin centres in [0, 1)
    mean: np.ndarray  # mean residual per bin over the cycles
    std: np.ndarray  # spread (standard deviation) per bin
    count: np.ndarray  # samples per bin


def phase_profile(t, residual, period: float, t0: float | None = None, bins: int = 50) -> PhaseProfile:
    """Residual folded over ``period`` (phase = ((t - t0) / period) mod 1), ``bins`` equal phase bins."""
    t = np.asarray(t, dtype=float)
    r = np.asarray(residual, dtype=float)
    if t.shape != r.shape:
        raise DataError(f"phase_profile: time has {t.size} samples, the residual {r.size}")
    if not period > 0:
        raise DataError(f"phase_profile: the period must be positive, got {period}")
    _check_count(bins, "phase_profile: bins", 1)
    t0 = t[0] if t0 is None else t0
    phase = np.mod((t - t0) / period, 1.0)
    k = np.minimum((phase * bins).astype(int), bins - 1)
    count = np.bincount(k, minlength=bins).astype(float)
    s1 = np.bincount(k, r, minlength=bins)
    s2 = np.bincount(k, r * r, minlength=bins)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(count > 0, s1 / count, np.nan)
        var = np.where(count > 1, (s2 - count * mean**2) / np.maximum(count - 1, 1), np.nan)
    return PhaseProfile((np.arange(bins) + 0.5) / bins, mean, np.sqrt(np.maximum(var, 0.0)), count)


def autocorrelation(residual, max_lag: int) -> np.ndarray:
    """Normalised autocorrelation ``rho[0..max_lag]`` (``rho[0] = 1``) of the mean-removed residual."""
    _check_count(max_lag, "autocorrelation: max_lag", 0)
    r = np.asarray(residual, dtype=float)
    r = r - r.mean()
    n = r.size
    if n < 2:
        raise DataError("autocorrelation: need at least two samples")
    max_lag = int(min(max_lag, n - 1))
    f = np.fft.rfft(r, 2 * n)
    acov = np.fft.irfft(f * np.conj(f))[: max_lag + 1]
    return acov / acov[0] if acov[0] > 0 else np.zeros(max_lag + 1)


@dataclass
class Whiteness:
    acf: np.ndarray  # autocorrelation at lags 0..max_lag
    band: float  # 95 % band of a white residual, 1.96 / sqrt(N)
    fraction_outside: float  # share of lags 1..max_lag outside the band (about 0.05 when white)
    q: float  # Ljung-Box statistic over lags 1..max_lag
    p_value: float  # chance of a Q at least this large from white noise

    @property
    def white(self) -> bool:
        return self.p_value > 0.01


def whiteness(residual, max_lag: int = 50) -> Whiteness:
    r = np.asarray(residual, dtype=float)
    n = r.size
    acf = autocorrelation(r, max_lag)
    h = acf.size - 1
    lags = np.arange(1, h + 1)
    q = float(n * (n + 2) * np.sum(acf[1:] ** 2 / (n - lags))) if h else 0.0
    band = 1.96 / np.sqrt(n)
    return Whiteness(acf, band, float(np.mean(np.abs(acf[1:]) > band)) if h else 0.0, q,
                     float(stats.chi2.sf(q, h)) if h else 1.0)


@dataclass
class Correlation:
    name: str
    r: float  # correlation coefficient at lag 0
    band: float  # 95 % band for no correlation, 1.96 / sqrt(N_eff)

    @property
    def significant(self) -> bool:
        return abs(self.r) > self.band


def correlation(a, b) -> float:
    """Pearson correlation; 0 when either has no variation."""
    a = np.asarray(a, dtype=float) - np.mean(a)
    b = np.asarray(b, dtype=float) - np.mean(b)
    den = np.sqrt(np.sum(a * a) * np.sum(b * b))
    return float(np.sum(a * b) / den) if den > 0 else 0.0


def cross_correlations(residual, regressors: dict, max_lag: int = 50) -> list:
    """Correlation of the residual with each regressor (name -> samples of the same length), strongest first.

    The band accounts for the residual's own autocorrelation (effective sample size ``N / (1 + 2 sum rho)``
    over ``max_lag`` lags), so a smooth residual does not make every regressor look significant."""
    r = np.asarray(residual, dtype=float)
    acf = autocorrelation(r, max_lag)
    n_eff = r.size / max(1.0, 1.0 + 2.0 * float(np.sum(acf[1:])))
    band = 1.96 / np.sqrt(max(n_eff, 1.0))
    out = []
    for name, x in regressors.items():
        x = np.asarray(x, dtype=float)
        if x.shape != r.shape:
            raise DataError(f"cross_correlations: regressor {name!r} has {x.size} samples, the residual {r.size}")
        out.append(Correlation(name, correlation(r, x), band))
    return sorted(out, key=lambda c: -abs(c.r))


def _check_count(value, what: str, least: int) -> None:
    """An integer option of at least ``least``; a DataError naming it (``what``) otherwise."""
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < least:
        raise DataError(f"{what} must be an integer of at least {least}, got {value!r}")


def leave_one_group_out(jac, residual, groups) -> np.ndarray:
    """Residuals each group would have if it were left out of a least-squares fit with Jacobian ``jac`` (rows =
    samples, scaled like ``residual``): ``r_(-g) = (I - H_gg)^-1 r_g`` with the hat matrix
    ``H = J (J^T J)^-1 J^T``, by the Woodbury identity ``(I - J_g A J_g^T)^-1 = I + J_g (A^-1 - J_g^T J_g)^-1 J_g^T``
    (``A = (J^T J)^-1``): a small solve per group instead of a refit."""
    J = np.asarray(jac, dtype=float)
    r = np.asarray(residual, dtype=float)
    g = np.asarray(groups)
    if J.shape[0] != r.size or g.size != r.size:
        raise DataError(f"leave_one_group_out: {J.shape[0]} Jacobian rows, {r.size} residuals, {g.size} group labels")
    JtJ = J.T @ J
    out = np.empty_like(r)
    for label in np.unique(g):
        m = g == label
        Jg = J[m]
        M = JtJ - Jg.T @ Jg  # A^-1 - J_g^T J_g: the normal matrix without the group
        try:
            corr = Jg @ np.linalg.solve(M, Jg.T @ r[m])
        except np.linalg.LinAlgError:
            corr = Jg @ np.linalg.lstsq(M, Jg.T @ r[m], rcond=None)[0]
        out[m] = r[m] + corr
    return out
