"""Screening: is the data, or the fit to it, suspect? Sentences that say what looks wrong and its likely cause.

A calibration (:func:`~.calibrate.calibrate`, ``Calibration.warnings``) and a diagnosis
(:func:`~.diagnose.diagnose`, ``Diagnosis.warnings``) both screen their experiments with the fitted model's
predictions, so neither returns a tidy number with tight error bars on data its own model cannot follow:

* per experiment and signal: a **dead sensor** (the reading is constant while the prediction varies by more than
  three noise levels or 1 % of its size: the noise level of a sensor stuck in every recording is no yardstick), a
  **reversed sign** (reading and prediction anti-correlated, r < -0.5), and a recording **far off the others**
  (its RMSE ``outlier`` times the set's median: swapped columns, a wrong setting in its JSON, another rig; needs
  three experiments or more);
* per experiment with a cycle (``period``: the stride time): the readings must repeat with it. A recording whose
  readings clearly repeat (autocorrelation >= 0.9) at another period is named with both (a wrong stride time in its
  settings); one too short for two cycles, or not clearly periodic, is not judged;
* for the whole fit: a held-out RMSE ``misfit`` noise levels or more above the noise (the model misses something,
  or the data is wrong).

Noise levels are the fit's signal scales (by default estimated from the data, :func:`~.calibrate.noise_scales`).
"""
from __future__ import annotations

import numpy as np

#: a recording whose RMSE is this many times the set's median is flagged
OUTLIER = 5.0
#: a fit whose held-out RMSE is this many noise levels is flagged
MISFIT = 10.0
#: autocorrelation above which a recording counts as clearly periodic at a lag
PERIODIC = 0.9


def screen(exps, preds: dict, signals, scales: dict, outlier: float = OUTLIER, misfit: float = MISFIT,
           period=None, who: str = "the fitted model", misfit_hint: str = "the model misses an effect, or the data "
           "is wrong") -> list:
    """Warnings (sentences) about ``exps`` fitted with predictions ``preds`` (experiment name -> signal ->
    samples); ``period``: experiment -> its cycle in seconds or None (not judged); ``who`` and ``misfit_hint``
    word the misfit sentence. Empty when nothing looks wrong (see the module docstring)."""
    out = []
    for s in signals:
        rows = []
        for e in exps:
            inner = e.train | e.test
            m, p = np.asarray(e.measured[s])[inner], np.asarray(preds[e.name][s])[inner]
            rows.append((e, m, p, float(np.sqrt(np.mean((p - m) ** 2)))))
        median = float(np.median([r for *_, r in rows]))
        for e, m, p, rmse in rows:
            where = f"{e.name}, {s}"
            varies = np.std(p) > 3 * scales[s] or np.std(p) > 0.01 * np.sqrt(np.mean(p**2))
            if np.std(m) <= 1e-12 * max(1.0, abs(float(np.mean(m)))) and varies:
                out.append(f"{where}: the reading is constant while the model's varies by {np.std(p):.3g}: a dead "
                           "or disconnected sensor")
            elif np.std(m) > 0 and np.std(p) > 0 and np.corrcoef(m, p)[0, 1] < -0.5:
                out.append(f"{where}: reading and prediction are anti-correlated (r = {np.corrcoef(m, p)[0, 1]:.2f}): "
                           "a reversed sign (sensor or column)")
            elif len(rows) > 2 and rmse > outlier * median and rmse > 3 * scales[s]:
                out.append(f"{where}: RMSE {rmse:.3g} is {rmse / median:.1f} times the set's median {median:.3g}: "
                           "swapped columns, a wrong setting in its JSON, or another rig")
    if period is not None:
        for e in exps:
            T = period(e)
            if T is not None:
                msg = periodicity(e.name, e.t, {s: e.measured[s] for s in signals}, float(T))
                if msg:
                    out.append(msg)
    level, worst = max((heldout_rmse(exps, preds, s) / scales[s], s) for s in signals)
    if level > misfit:
        out.append(f"{who}'s held-out RMSE of {worst} is {level:.0f} times its noise level: {misfit_hint}")
    return out


def heldout_rmse(exps, preds: dict, signal: str) -> float:
    """RMSE of ``signal`` pooled over the held-out samples of all experiments (the training samples where no
    experiment holds any out)."""
    mask = "test" if any(e.test.any() for e in exps) else "train"
    r = np.concatenate([(np.asarray(preds[e.name][signal]) - np.asarray(e.measured[signal]))[getattr(e, mask)]
                        for e in exps])
    return float(np.sqrt(np.mean(r**2))) if r.size else 0.0


def periodicity(name: str, t, series: dict, period: float) -> str:
    """A sentence when the readings ``series`` (signal -> samples at times ``t``) clearly repeat at a period other
    than ``period`` (more than 2 % or two samples off), else ``""``. The repetition is the first lag, after the
    autocorrelation has dropped below 0.5, where it climbs back to :data:`PERIODIC` or more (its peak there), in
    0.3 to 3 periods (at most two thirds of the recording); the most periodic signal decides. Not judged (``""``):
    a recording shorter than 1.5 periods, and readings that do not clearly repeat."""
    t = np.asarray(t, dtype=float)
    if not (period > 0 and np.isfinite(period)) or t.size < 8:
        return ""
    dt = float(np.median(np.diff(t)))
    span = float(t[-1] - t[0]) + dt
    max_lag = int(min(3.0 * period, 2.0 * span / 3.0) / dt)
    if span < 1.5 * period or max_lag < 2:
        return ""
    best = None  # (peak autocorrelation, lag in samples, signal)
    for s, y in series.items():
        found = _repetition(np.asarray(y, dtype=float), max_lag, int(0.3 * period / dt))
        if found and (best is None or found[0] > best[0]):
            best = (*found, s)
    if best is None:
        return ""
    r, lag, s = best
    found_period = lag * dt
    if abs(found_period - period) <= max(0.02 * period, 2 * dt):
        return ""
    return (f"{name}: its readings repeat every {found_period:.4g} s ({s}: autocorrelation {r:.2f} at that lag), but "
            f"it is analysed with a cycle of {period:.4g} s: a wrong stride time (cycle) in its settings (JSON)")


def _repetition(y: np.ndarray, max_lag: int, min_lag: int):
    """``(autocorrelation, lag)`` of the first clear repetition of ``y`` (see :func:`periodicity`), or None."""
    y = y - y.mean()
    n = y.size
    var = float(y @ y) / n
    if var <= 0 or max_lag >= n:
        return None
    f = np.fft.rfft(y, 2 * n)
    acf = np.fft.irfft(f * np.conj(f))[: max_lag + 1] / (n - np.arange(max_lag + 1)) / var
    below = np.flatnonzero(acf < 0.5)
    if below.size == 0:
        return None
    start = max(int(below[0]), min_lag)
    above = np.flatnonzero(acf[start:] >= PERIODIC)
    if above.size == 0:
        return None
    first = start + int(above[0])
    end = first + (int(np.argmax(acf[first:] < PERIODIC)) if (acf[first:] < PERIODIC).any() else acf.size - first)
    lag = first + int(np.argmax(acf[first:end]))
    return float(acf[lag]), lag
