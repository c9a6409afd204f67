"""What a diagnosis can and cannot see: detection limits, the evidence that separates confusable candidates, and
drift of the baseline across the recordings of a session.

* :func:`detection_limits`: for every candidate, the smallest size the diagnosis would have named at this data's
  noise and thresholds. Linearised: an effect of size ``s`` adds ``s f`` to the noise-scaled residual (``f``: the
  candidate's fingerprint with the baseline parameters projected out, :func:`~.diagnose.fingerprints`); a refit
  removes it, and what stays is the residual's part ``r_perp`` the fingerprint cannot explain. The held-out gain is
  then ``1 - sqrt(|r_perp|^2 / (|r_perp|^2 + s^2 |f|^2))`` (training samples stand in for the held-out ones: same
  noise, same model), and it reaches ``min_gain`` at

      s_gain = sqrt(q / (1 - q)) |r_perp| / |f|,   q = 1 - (1 - min_gain)^2;

  the BIC test gives ``s_bic = sqrt(exp((ln N - max_delta_bic) / N) - 1) |r_perp| / |f|``. The limit is the larger
  (the gain test binds on every realistic data set). An effect that the data shows in every stride passes the
  per-stride consistency tests long before it reaches this size, so they do not enter. A candidate whose
  fingerprint is zero at its vanishing point (its first-order effect is nil: e.g. a play that only matters once it
  is larger than the motion's reversals) has no first-order limit: ``size`` None, said so.
* :func:`confusable`: two candidates both significant in the first step, whose fingerprints correlate
  (``|cos| >= Thresholds.related``), or whose fingerprints are nearly collinear (``|cos| >= Thresholds.confusable``)
  whatever their scores. Each pair carries the evidence that separated them: the per-stride comparison of the two
  extended models (leave-one-stride-out errors: on how many strides one fits better, a sign test and a paired t) and,
  where the selection went on, whether the other still counts once the chosen one is in the model. Without such
  evidence the pair is reported as not separable by this data.
* :func:`drift`: the final model (the baseline and the named effects) refitted on each recording alone (two
  Gauss-Newton steps from the pooled fit on all of the recording's inner samples, truncated where one recording
  does not determine a parameter combination: :data:`RCOND`), and a straight-line trend of each parameter against
  the recording order (or elapsed session time, where the recordings say when they started): slope, its standard
  error from the scatter about the line, ``t`` and ``p`` (Student, ``n - 2`` degrees of freedom). A parameter
  drifts when ``p <= 0.01`` and it changes over the session by more than ``DRIFT_MIN`` of its value; the problem
  names the candidates that explain a drift of that parameter (``Problem.drift_causes``).
"""
from __future__ import annotations

import numpy as np
from scipy import stats
from scipy.stats import binom

from ..errors import AcausalError
from .calibrate import jacobian, residual_vector

#: a trend must change the parameter over the session by at least this fraction of its value to count as drift
DRIFT_MIN = 0.01
#: and be this unlikely without a trend (two-sided p of the slope)
DRIFT_P = 0.01
#: a per-recording refit leaves at the pooled value the parameter combinations whose singular value (columns scaled
#: by the parameters' values) is below this fraction of the largest: one recording does not determine them
RCOND = 1e-3


# ---------------------------------------------------------------------------------------------- detection limits
def detection_limits(problem, fp: dict, n: int, thresholds) -> dict:
    """``id -> {"size", "unit", "parameter", "value", "binding"}``: the smallest size of each candidate the
    diagnosis would have named (module docstring). ``fp``: :func:`~.diagnose.fingerprints` at the calibrated
    baseline (residual under key None); ``n``: training samples. ``value``: the parameter at that size on the side
    its bounds allow (``zero + size`` where both do)."""
    r = fp[None]
    q = 1.0 - (1.0 - thresholds.min_gain) ** 2
    bic = np.expm1((np.log(n) - thresholds.max_delta_bic) / n)
    out = {}
    for cid, f in fp.items():
        if cid is None:
            continue
        c = problem.candidates[cid]
        ff = float(f @ f)
        entry = {"unit": c.unit, "parameter": c.parameter}
        if not ff > 0:
            out[cid] = {**entry, "size": None, "value": None, "binding": "none",
                        "note": "no first-order effect at its vanishing point: not detectable by its fingerprint"}
            continue
        rr = max(float(r @ r) - float(f @ r) ** 2 / ff, 0.0)
        s_gain, s_bic = np.sqrt(q / (1.0 - q) * rr / ff), np.sqrt(bic * rr / ff)
        size = float(max(s_gain, s_bic))
        lo, hi = c.bounds
        value = c.sized(size)
        entry.update(size=size, value=float(value) if lo <= value <= hi else None,
                     binding="held-out gain" if s_gain >= s_bic else "BIC")
        if entry["value"] is None:
            entry["note"] = "larger than its fitting range allows"
        out[cid] = entry
    return out


# ---------------------------------------------------------------------------------------------- confusable pairs
def confusable(ids, fp: dict, steps, thresholds) -> list:
    """The confusable pairs (module docstring) as dicts ``{"a", "b", "cos", "kind", "separated", "evidence"}``;
    ``fp``: first-step fingerprints; ``steps``: the diagnosis's :class:`~.diagnose.Step` list."""
    first = {s.id: s for s in steps[0].scores} if steps else {}
    out = []
    for i, a in enumerate(ids):
        for b in ids[i + 1:]:
            cos = abs(_cos(fp[a], fp[b]))
            sa, sb = first.get(a), first.get(b)
            both = bool(sa and sb and sa.significant and sb.significant)
            if not (cos >= thresholds.confusable or (both and cos >= thresholds.related)):
                continue
            kind = "both significant" if both else "collinear fingerprints"
            sep, words = _separation(a, b, sa, sb, steps, thresholds) if both else (
                False, f"fingerprints nearly collinear (|cos| = {cos:.2f}) once the baseline is refitted: the data "
                       "can hardly tell them apart")
            out.append({"a": a, "b": b, "cos": cos, "kind": kind, "separated": sep, "evidence": words})
    return out


def _separation(a, b, sa, sb, steps, th) -> tuple:
    """``(separated, sentence)`` for two significant candidates: per-stride comparison and the next step."""
    keys = sorted(set(sa.fit.loso_stride_mse) & set(sb.fit.loso_stride_mse))
    La = np.array([sa.fit.loso_stride_mse[k] for k in keys])
    Lb = np.array([sb.fit.loso_stride_mse[k] for k in keys])
    d = Lb - La  # > 0: a fits the stride better
    better, worse = (a, b) if np.sum(d) >= 0 else (b, a)
    d = d if better == a else -d
    wins = int(np.sum(d > 0))
    p = float(binom.sf(wins - 1, d.size, 0.5)) if d.size else 1.0
    sd = np.std(d, ddof=1) if d.size > 1 else np.inf
    t = float(np.mean(d) / (sd / np.sqrt(d.size))) if sd > 0 else 0.0
    words = (f"`{better}` fits {wins} of {d.size} strides (segments) better than `{worse}` (sign test p = {p:.2g}, "
             f"paired t = "
             f"{t:.1f}; held-out gains {100 * sa.heldout_rmse_gain:+.1f} % / {100 * sb.heldout_rmse_gain:+.1f} %)")
    strides_say = p <= th.max_sign_p or t >= th.min_t
    after = None
    if len(steps) > 1 and steps[0].chosen in (a, b):
        other = b if steps[0].chosen == a else a
        after = next((s for s in steps[1].scores if s.id == other), None)
    if after is not None:
        words += (f"; with `{steps[0].chosen}` in the model, `{after.id}` "
                  + ("still counts" if after.significant else "no longer counts")
                  + f" (held-out gain {100 * after.heldout_rmse_gain:+.1f} %)")
    # both still counting once one is in the model: two effects, each seen (separated); else the strides decide
    separated = (after is not None and after.significant) or strides_say
    if not separated:
        words += ": the data cannot tell them apart"
    return bool(separated), words


def _cos(a, b) -> float:
    den = np.linalg.norm(a) * np.linalg.norm(b)
    return float(a @ b / den) if den > 0 else 0.0


# ---------------------------------------------------------------------------------------------- drift
#: a parameter whose name holds this belongs to one experiment (``winding_excess@rec03``): fitted with the pooled
#: model, held at its pooled value when a recording is refitted alone, and no part of a trend
PER_EXPERIMENT = "@"


def drift(problem, fit, scales: dict, bounds: dict, order=None, steps: int = 2) -> dict:
    """The fit refitted per recording and its trend over the session (module docstring). ``fit``: the model to
    refit (a :class:`~.diagnose.Fit`: the diagnosis's final one); ``bounds``: parameter -> (lower, upper) the
    per-recording values are kept in; ``order``: ``(label, x)`` with ``x`` the recordings' positions in the
    session (default: their order).
    Returns ``{"axis", "recordings": [{"experiment", "x", params...}], "trends": {param: {...}}, "drifting":
    [param...], "explained_by": {param: [candidate ids]}, "units": {param: unit}}``."""
    keep = [i for i, n in enumerate(fit.cal.names) if PER_EXPERIMENT not in n]  # one recording's own: not a trend
    names = [fit.cal.names[i] for i in keep]
    exps = list(fit.exps)
    label, x = order if order is not None else ("recording order", np.arange(len(exps), dtype=float))
    x = np.asarray(x, dtype=float)
    prior = _prior(np.asarray(fit.cal.cov)[np.ix_(keep, keep)], len(exps))
    rows = []
    for e, xe in zip(exps, x):
        v = _refit_alone(problem, e, fit.values, names, scales, bounds, steps, prior)
        rows.append({"experiment": e.name, "x": float(xe), **{n: v[n] for n in names}})
    rows.sort(key=lambda row: row["x"])
    x = np.array([row["x"] for row in rows])
    trends, drifting = {}, []
    for n in names:
        y = np.array([row[n] for row in rows])
        tr = _trend(x, y)
        trends[n] = tr
        if tr["p"] is not None and tr["p"] <= DRIFT_P and abs(tr["change"]) >= DRIFT_MIN * abs(fit.values[n]):
            drifting.append(n)
    causes = getattr(problem, "drift_causes", {}) or {}
    return {"axis": label, "recordings": rows, "trends": trends, "drifting": drifting,
            "explained_by": {n: list(causes.get(n, ())) for n in drifting},
            "units": {n: problem.unit(n) if hasattr(problem, "unit") else "" for n in names}}


def _prior(cov, n_exps):
    """The precision of what one of ``n_exps`` recordings adds to the pooled fit whose covariance is ``cov``:
    ``(n_exps cov)^-1`` (None where the covariance is not finite)."""
    cov = np.asarray(cov, dtype=float)
    if not np.all(np.isfinite(cov)):
        return None
    try:
        return np.linalg.inv(n_exps * cov)
    except np.linalg.LinAlgError:
        return None


def _refit_alone(problem, e, values, names, scales, bounds, steps, prior=None) -> dict:
    """The baseline parameters fitted on recording ``e`` alone (all inner samples), Gauss-Newton from ``values``.
    ``prior``: the precision :func:`_prior` of one recording's share of the pooled fit; combinations the recording
    hardly determines then stay near the pooled values (a maximum a posteriori step), as they do without it by
    the truncation :data:`RCOND`."""

    inner = e.train | e.test
    view = _View(e.solo() if e.solo is not None else e, inner)
    v = dict(values)
    ones = {s: 1.0 for s in problem.signals}
    r = residual_vector([view], v, problem.signals, ones, scales)
    for _ in range(steps):
        J = jacobian([view], v, names, problem.signals, scales)
        scale = np.array([max(abs(v[n]), 1e-12) for n in names])
        Js = J * scale
        if prior is not None:  # min |r + J dv|^2 + (v + dv - v0)^T P (v + dv - v0), in scaled units
            Ps = prior * np.outer(scale, scale)
            off = np.array([v[n] - values[n] for n in names]) / scale
            try:
                dz = np.linalg.solve(Js.T @ Js + Ps, -(Js.T @ r + Ps @ off))
            except np.linalg.LinAlgError:
                dz, *_ = np.linalg.lstsq(Js, -r, rcond=RCOND)
        else:  # directions one recording hardly determines (singular values below RCOND of the largest, in
            # relative units) stay at the pooled fit instead of wandering to a bound
            dz, *_ = np.linalg.lstsq(Js, -r, rcond=RCOND)
        cost = _cost(r, v, values, names, prior)
        for _ in range(HALVINGS + 1):  # a step that does not lower the cost (a nonlinear model) is halved
            trial = {**v, **{n: float(np.clip(v[n] + d * s, *bounds.get(n, (-np.inf, np.inf))))
                             for n, d, s in zip(names, dz, scale)}}
            try:
                r_trial = residual_vector([view], trial, problem.signals, ones, scales)
            except AcausalError:  # the model cannot run there: a shorter step
                r_trial = None
            if r_trial is not None and _cost(r_trial, trial, values, names, prior) < cost:
                v, r = trial, r_trial  # the next step starts from this residual
                break
            dz = dz / 2
        else:
            break  # no step lowers the cost: this is the recording's fit
    return {n: v[n] for n in names}


#: halvings of a per-recording Gauss-Newton step that does not lower the cost before the refit stops there
HALVINGS = 6


def _cost(r, v, values, names, prior) -> float:
    """Squared residual plus the prior's term (:func:`_prior`) of the per-recording refit at ``v``."""
    c = float(r @ r)
    if prior is not None:
        off = np.array([v[n] - values[n] for n in names])
        c += float(off @ prior @ off)
    return c


class _View:
    """An experiment with all its inner samples marked for fitting (a per-recording refit uses every stride)."""

    def __init__(self, e, inner):
        self._e, self.train, self.test = e, inner, np.zeros_like(inner)

    def __getattr__(self, name):
        return getattr(self._e, name)


def _trend(x, y) -> dict:
    n = x.size
    if n < 3 or np.ptp(x) == 0:
        return {"slope": None, "std": None, "t": None, "p": None, "change": 0.0, "first": float(y[0]),
                "last": float(y[-1])}
    A = np.stack([x - x.mean(), np.ones(n)], axis=1)
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    res = y - A @ coef
    s2 = float(res @ res) / (n - 2)
    se = np.sqrt(s2 / float(np.sum((x - x.mean()) ** 2)))
    slope = float(coef[0])
    t = slope / se if se > 0 else (np.inf if slope else 0.0)
    p = float(2 * stats.t.sf(abs(t), n - 2)) if np.isfinite(t) else 0.0
    return {"slope": slope, "std": float(se), "t": float(t) if np.isfinite(t) else None, "p": p,
            "change": slope * float(np.ptp(x)), "first": float(y[0]), "last": float(y[-1])}
