"""What a calibrated model still gets wrong: statistics of the residual ``measured - predicted`` of one signal.

All functions take plain arrays, so they serve any model:

* :func:`phase_profile`: the residual folded over a period (the gait cycle): mean and spread per phase bin over
  the cycles. A model error repeats every cycle and shows in the mean; sensor noise averages out.
* :func:`whiteness`: the normalised autocorrelation up to ``max_lag`` and the Ljung-Box statistic. White noise
  keeps about 95 % of the autocorrelations inside the band ``+-1.96 / sqrt(N)``; an unmodelled effect makes the
  residual smooth, so its autocorrelation stays high over many lags.
* :func:`structure_test`: whiteness at the time scale the model lives on, not the sensor's (see below). This is the
  test to read as "clean or not": at 1 kHz the sample-scale :func:`whiteness` rejects almost any recording, because a
  replay's prediction has a small coloured error of its own and current sensors are often low-pass filtered.
* :func:`cross_correlations`: the correlation of the residual with physically meaningful regressors (sign of the
  motor speed, current squared, elapsed time, ...), with the same significance band. A Coulomb friction left out
  shows as a residual correlated with ``sign(w)``; a heating winding as one correlated with elapsed time.
* :func:`leave_one_group_out`: leave-one-group-out (e.g. leave-one-stride-out) residuals of a least-squares fit,
  from its Jacobian, without refitting (exact for a linear model, the usual linearisation otherwise).

What :func:`structure_test` tests. The residual ``r`` (N samples) is cut into ``n_eff = N // B`` consecutive blocks
of ``B`` samples (the tail is dropped) and the block means ``m_j`` are compared with the noise level that the
residual's short-time-scale content implies. That level is the long-run variance per sample ``s2`` estimated from
adjacent means over the shorter scale ``b`` (default ``B // 4``; an Allan variance): with ``a_t`` the mean of
``r[t], ..., r[t + b - 1]``, ``F(b) = b * mean((a_{t+b} - a_t)^2) / 2``. For white noise of variance sigma^2,
``F(b) = sigma^2``; for noise correlated over much less than ``b`` samples (a low-pass filtered sensor) it is about
that noise's long-run variance, the one that governs block means. Its bias for such noise goes as ``1 / b``, so when
``F(2b) > F(b)`` the level is extrapolated to what the block means of that noise would have,
``s2 = 2 F(2b) - F(b) - 4b / (3B) (F(2b) - F(b))``; otherwise ``s2 = F(b)``. The differences cancel a constant
offset and nearly cancel anything smooth at the scale ``B``, so a missed effect does not raise the level it is
compared with.
Under the null hypothesis, "at the time scale of B samples the residual is zero-mean noise with the level its
short-scale content implies", the block means are independent with variance ``s2 / B``, and
``X = B * sum(m_j^2) / s2`` is chi-square with ``n_eff`` degrees of freedom; ``p_value = P(chi2(n_eff) >= X)``.
``excess = X / n_eff`` is about 1 for noise and grows with the squared size of a smooth error (an offset, a
friction torque or a standby power left out, an efficiency, a drift). Any excess error at scales near ``b`` (a
replay's smoothing error at the spline's knot spacing) raises ``s2`` and makes the test conservative, never
anti-conservative; error at scales longer than ``B`` counts as structure whatever its cause, so a replay whose
smoothing error reaches the tested scale would be reported, and ``B`` should be the shortest time scale on which the
model is meant to be right (e.g. 1/20 of the gait cycle: :func:`block_length`).
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
class Structure:
    """Result of :func:`structure_test` (the module docstring says what it tests)."""

    p_value: float  # chance of an excess at least this large from noise at the level the short scale implies
    statistic: float  # X = B * sum(block mean^2) / s2, chi-square with n_eff degrees of freedom when white
    excess: float  # X / n_eff: variance of the block means over the noise's share (about 1 when white)
    n_eff: int  # effective sample size: the number of block means tested
    block: int  # B, samples per block (the tested time scale)
    fine: int  # b, samples of the shorter scale the noise level is estimated on
    noise_std: float  # sqrt(s2): the noise's long-run standard deviation per sample, in the residual's unit
    structure_rms: float  # RMS of the block means beyond the noise's share, in the residual's unit (0 if none)
    alpha: float  # significance level of ``white``

    @property
    def white(self) -> bool:
        """No structure at the tested time scale (``p_value > alpha``)."""
        return self.p_value > self.alpha

    def describe(self) -> str:
        verdict = "no structure" if self.white else "structure"
        return (f"{verdict} at {self.block}-sample blocks: block-mean variance {self.excess:.2f}x the noise's "
                f"({self.n_eff} blocks, p = {self.p_value:.2g}), smooth error RMS {self.structure_rms:.3g}, "
                f"noise {self.noise_std:.3g}")


def block_length(period: float, rate: float, per_cycle: int = 20) -> int:
    """Samples per block for :func:`structure_test`: ``period / per_cycle`` seconds (the cycle, e.g. a stride,
    ``period`` in s; the sample rate ``rate`` in Hz), at least one sample."""
    if not (period > 0 and rate > 0):
        raise DataError(f"block_length: period and rate must be positive, got {period!r} s and {rate!r} Hz")
    _check_count(per_cycle, "block_length: per_cycle", 1)
    return max(1, int(round(period * rate / per_cycle)))


def structure_test(residual, block: int | None = None, *, period: float | None = None, rate: float | None = None,
                   per_cycle: int = 20, fine: int | None = None, alpha: float = 0.01) -> Structure:
    """Is the residual white at the time scale of ``block`` samples (see the module docstring)? Give ``block``, or
    ``period`` [s] and ``rate`` [Hz] for ``block_length(period, rate, per_cycle)``. ``fine``: samples of the scale
    the noise level is estimated on (default ``block // 4``, at least 1). Needs at least two blocks."""
    if block is None:
        if period is None or rate is None:
            raise DataError("structure_test: give block (samples), or period (s) and rate (Hz)")
        block = block_length(period, rate, per_cycle)
    _check_count(block, "structure_test: block", 1)
    fine = max(1, block // 4) if fine is None else fine
    _check_count(fine, "structure_test: fine", 1)
    if not 0.0 < alpha < 1.0:
        raise DataError(f"structure_test: alpha must lie in (0, 1), got {alpha!r}")
    r = np.asarray(residual, dtype=float).ravel()
    if not np.all(np.isfinite(r)):
        raise DataError("structure_test: the residual has NaN or infinite samples")
    n_eff = r.size // block
    if n_eff < 2 or r.size < 2 * fine + 1:
        raise DataError(f"structure_test: {r.size} samples are fewer than two blocks of {block} "
                        f"(and 2 * fine + 1 = {2 * fine + 1})")
    m = r[: n_eff * block].reshape(n_eff, block).mean(axis=1)
    c = np.concatenate([[0.0], np.cumsum(r - r.mean())])  # centred: the differences do not need the mean
    f1, f2 = _allan_level(c, fine), _allan_level(c, 2 * fine) if r.size >= 4 * fine + 1 else 0.0
    # noise correlated over a few samples (a sensor filter) makes F(b) ~ L - 3 S / b and B var(block mean) ~
    # L - 2 S / B (L: long-run variance, S: sum of k * autocovariance(k)); F(2b) > F(b) measures S
    s2 = 2 * f2 - f1 - 4 * fine / (3 * block) * (f2 - f1) if f2 > f1 else f1
    ms = float(np.mean(m * m))
    if s2 > 0:
        x = block * float(np.sum(m * m)) / s2
        p = float(stats.chi2.sf(x, n_eff))
    else:  # no short-scale variation at all: any non-zero block mean is structure
        x, p = (0.0, 1.0) if ms == 0 else (float("inf"), 0.0)
    return Structure(p, x, x / n_eff, n_eff, int(block), int(fine), float(np.sqrt(s2)),
                     float(np.sqrt(max(ms - s2 / block, 0.0))), float(alpha))


def _allan_level(c: np.ndarray, b: int) -> float:
    """``F(b) = b * mean((a_{t+b} - a_t)^2) / 2`` with ``a_t`` the mean of ``b`` samples from ``t`` (``c``: the
    cumulative sum with a leading 0): the long-run variance per sample for noise correlated over much less than b."""
    a = (c[b:] - c[:-b]) / b
    d = a[b:] - a[:-b]
    return b * float(np.mean(d * d)) / 2.0


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
