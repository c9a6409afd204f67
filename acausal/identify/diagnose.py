"""Diagnosis: calibrate a baseline model, show what it gets wrong, name the missing effect, extend, measure the gain.

Model-agnostic engine; a model supplies a :class:`Problem` (its experiments with and without candidate effects,
the baseline parameters to fit, the candidates, regressors for the residual analysis). The steps:

1. **Baseline**: calibrate the baseline parameters on the training strides (:func:`~.calibrate.calibrate`; a fit
   that stops at the problem's evaluation limit is continued to its optimum, as is every model named later; a
   named candidate is also refitted from its typical size and the better of the two optima kept, the other
   said: :func:`settled`).
2. **Fingerprints**: for every candidate, the exact sensitivity of the predicted signals to its parameter at the
   value where the effect vanishes (``Candidate.zero``; for a hard limit, which has no first-order effect there,
   the secant to ``Candidate.probe``), at the calibrated baseline, stacked over signals and
   samples in units of sensor noise. At ``zero`` the extended model is the baseline, so the baseline parameters'
   columns are computed once and each candidate adds only its own. The part the baseline parameters can absorb
   is projected out (they are refitted anyway), and what is left is compared with the baseline residual (cosine:
   ``match``). Two candidates
   whose projected fingerprints are nearly collinear (``|cos| >= Thresholds.confusable``), or that both count in
   the first step with correlated fingerprints (``|cos| >= Thresholds.related``), are *confusable*; each pair is
   reported with the evidence that separated them, or the statement that the data cannot
   (:func:`~.evidence.confusable`).
3. **Refit and score**: each candidate is added to the calibrated model and the extended model refitted on the
   training strides. (A candidate whose projected fingerprint explains so little of the residual that even the
   linearised best case gains less than ``Thresholds.screen`` is not refitted: it is scored by one Gauss-Newton
   step and marked ``screened``; so are those beyond the problem's ``max_refits`` most promising ones, ranked
   by the share of the residual their Gauss-Newton step explains once clipped to the candidate's bounds: an
   effect that can only act the other way cannot help at first order. A candidate significant in the step
   before is refitted whatever its rank: a second effect is named when it holds out of sample on top of the
   first.) Scores, all on residuals in units of
   sensor noise pooled over the signals:

   * ``heldout_rmse_gain = 1 - RMSE_extended / RMSE_before`` on the held-out strides;
   * leave-one-stride-out RMSE over the training strides (linearised, :func:`~.residuals.leave_one_group_out`)
     and a paired t statistic of the per-stride improvements;
   * ``delta_bic = N ln(RSS_ext / RSS_before) + delta_k ln N`` (Gaussian likelihood; negative favours the
     extension).

   A gain is *significant* when all of: held-out gain >= ``min_gain``, leave-one-stride-out gain >= ``min_gain``,
   the per-stride improvements are consistent (paired t >= ``min_t``, or, since a few strides with large errors
   make the t statistic small exactly when an effect removes them, a one-sided sign test of the improved strides
   with p <= ``max_sign_p``) and delta BIC <= ``max_delta_bic``. BIC alone is not enough with 10^5 samples and
   residuals that are not perfectly white (the smoothed replay has a small bias of its own): it would accept
   anything, so the practical thresholds decide. The defaults were tuned on clean and noise-only virtual-bench
   recordings (seeds 0-2), where every candidate stays below 1 % gain, and tested on others.
4. **Verdict**: the significant candidate with the largest held-out gain; greedy forward selection then repeats
   step 3 with that effect in the model, until no candidate is significant (the evidence stops the search; a
   ``max_effects`` count may stop it earlier, and the candidates it then leaves out are said). Where nothing is
   significant but a candidate gains held out and lowers BIC without consistent per-segment improvements, the
   search looks one step further on top of it: a second candidate significant there is named with it when the
   pair passes every test against the model before both (``named_by: "pair with ..."``; one effect can mask
   another). ``none`` when
   nothing is significant. A slow effect (a winding warming over a session) changes every sample only a little, so its
   held-out gain can stay small while the per-recording fit drifts plainly: a candidate that makes a drift of the
   final model go away, with a BIC fall and consistent per-stride improvements, is named too (``named_by:
   "drift"``).
5. **What it could not see** (:mod:`~.evidence`): every candidate's detection limit (the smallest size that would
   have been named at this data's noise and these thresholds, on top of the named effects), and the final model
   refitted on each recording with a trend test over the session (drift), pointing to the candidates that explain
   a drifting parameter.

Standard errors are cluster-robust, clustered by stride of each recording, or as the experiments say
(:mod:`~.uncertainty`).
"""
from __future__ import annotations

import numpy as np
from scipy.stats import binom

from ..errors import AcausalError, DataError
from .calibrate import calibrate, jacobian, residual_vector
from .evidence import _cos, confusable, detection_limits, drift
from .analysis import residual_analysis  # noqa: F401  (part of this module's interface)
from .recordings import screening_warnings
from .residuals import leave_one_group_out
from .screening import screen as screen_fit
from .verdict import Candidate, CandidateScore, Diagnosis, Fit, Problem, Step, Thresholds  # noqa: F401  (interface)

#: the largest fingerprint entry (noise levels per unit of the candidate's parameter) whose products cannot
#: overflow a float: squared and summed over a million samples it stays below 1e300
HUGE = 1e144

#: a hard limit whose probe changes no training sample by more than this many noise levels is not reached there
UNREACHED = 1e-6
#: two fits of one model whose training costs differ by less than this fraction are taken for the same optimum
#: (a fit's own tolerance stops it short by up to about that much)
SAME_OPTIMUM = 1e-3


# ---------------------------------------------------------------------------------------------- fitting
def fit_model(problem: Problem, effects: tuple, start: dict, scales: dict, drift: bool = False) -> Fit:
    """The model extended with ``effects`` calibrated from ``start``; ``drift``: the fit that tests whether an
    effect explains a drift over the session (with the parameters :meth:`Problem.effect_free` adds for it)."""
    exps = problem.experiments(tuple(effects))
    free = list(problem.base_free(start))
    free += [problem.candidates[eid].free(start) for eid in effects]
    free += problem.effect_free(tuple(effects), start, drift)
    cal = calibrate(exps, free, problem.signals, scales=scales, loss=problem.loss, **problem.fit_options)
    return _assess(problem, tuple(effects), cal, exps, scales)


def converged(problem: Problem, fit: Fit, scales: dict, rounds: int = 3) -> Fit:
    """``fit`` continued from where it stopped while it stopped at the evaluation limit (``max_nfev`` of
    ``problem.fit_options``), at most ``rounds`` times and while a round lowers the cost by more than the fit's
    ``tol``: a model the diagnosis names, or builds on, is the optimum, not an iterate. (A candidate is scored on
    its refit within the limit, which can only understate its gain.)"""
    tol = problem.fit_options.get("tol", 1e-10)
    for _ in range(rounds):
        if fit.cal.success:
            break
        more = fit_model(problem, fit.effects, fit.values, scales)
        if more.cal.cost > fit.cal.cost * (1 - tol):  # at the optimum already, only slow to say so
            break
        fit = more
    return fit


def settled(problem: Problem, fit: Fit, cid: str, scales: dict, notes: list) -> Fit:
    """The model with candidate ``cid`` just named: ``fit`` (its refit) continued to its optimum
    (:func:`converged`), and the same refit started once more with ``cid`` at its typical size
    (``Candidate.typical``), also continued; the lower training cost is kept. A calibration objective can have
    more than one optimum (a friction law that trades against the motor constant and the winding's resistance),
    and which one a single start reaches can turn on tolerance-level differences of the replays. Where the two
    starts end at different optima (costs apart by more than :data:`SAME_OPTIMUM`, sizes by more than a standard
    error), a sentence saying so (both sizes, how much worse the other fits) is appended to ``notes``. The second
    start is continued to its optimum only where it already does better than the first."""
    first = converged(problem, fit, scales)
    c = problem.candidates[cid]
    start = dict(fit.cal.start)
    if c.typical is None or c.parameter not in start or np.isclose(start[c.parameter], c.typical):
        return first
    try:
        other = fit_model(problem, fit.effects, {**start, c.parameter: c.typical}, scales)
        if other.cal.cost < first.cal.cost:  # only a start that does better is worth its continuation
            other = converged(problem, other, scales)
    except AcausalError:  # the second start leaves a parameter's range: the first stands
        return first
    p = c.parameter
    kept, left = (first, other) if first.cal.cost <= other.cal.cost else (other, first)
    apart = abs(other.values[p] - first.values[p]) > max(kept.cal.std.get(p, 0.0), 1e-12)
    worse = (left.cal.cost - kept.cal.cost) / kept.cal.cost
    if apart and worse > SAME_OPTIMUM and left.cal.success:  # two optima (not an iterate stopped short)
        notes.append(f"{cid}: the fit has more than one optimum: {p} = {kept.values[p]:.4g} (kept) and "
                     f"{p} = {left.values[p]:.4g} (training cost {100 * worse:.1f} % higher), reached from {p} = "
                     f"{start[p]:g} and {c.typical:g}; a single start can end at either")
    return kept


def _assess(problem, effects, cal, exps, scales) -> Fit:
    """Scores of a fitted model: training RSS, held-out MSE and RMSE, leave-one-stride-out MSE per stride (all
    from one prediction per experiment; residuals noise-scaled and stacked like :func:`residual_vector`)."""
    signals = problem.signals
    values = dict(cal.values)
    preds = [e.predict(values) for e in exps]
    train, test, groups, test_raw = [], [], [], {s: [] for s in signals}
    for k, (e, pred) in enumerate(zip(exps, preds)):
        stride = e.stride if e.stride is not None else np.zeros(e.t.size, dtype=int)
        for s in signals:
            r = pred[s] - e.measured[s]
            train.append(r[e.train] / scales[s])
            test.append(r[e.test] / scales[s])
            test_raw[s].append(r[e.test])
            if e.train.any():
                groups.append(np.stack([np.full(int(e.train.sum()), k), stride[e.train]], axis=1))
    r = np.concatenate(train)
    rt = np.concatenate(test)
    labels, group = np.unique(np.concatenate(groups), axis=0, return_inverse=True)
    loso = leave_one_group_out(jacobian(exps, values, cal.names, signals, scales), r, group.ravel())
    mse = np.bincount(group.ravel(), loso**2) / np.bincount(group.ravel())
    stride_mse = {(exps[k].name, int(st)): float(v) for (k, st), v in zip(labels, mse)}
    test_rmse = {s: float(np.sqrt(np.mean(np.concatenate(v) ** 2))) for s, v in test_raw.items()}
    test_mae = {s: float(np.mean(np.abs(np.concatenate(v)))) for s, v in test_raw.items()}
    return Fit(effects, cal, exps, values, float(r @ r), r.size, float(np.mean(rt**2)), test_rmse, stride_mse,
               test_mae)


def score(before: Fit, after: Fit, candidate: Candidate, thresholds: Thresholds) -> CandidateScore:
    gain = 1.0 - np.sqrt(after.test_mse / before.test_mse) if before.test_mse > 0 else 0.0
    keys = sorted(before.loso_stride_mse)
    L0 = np.array([before.loso_stride_mse[k] for k in keys])
    L1 = np.array([after.loso_stride_mse.get(k, np.nan) for k in keys])
    loso_gain = 1.0 - np.sqrt(np.nansum(L1) / np.sum(L0))
    d = L0 - L1
    sd = np.nanstd(d, ddof=1) if d.size > 1 else np.inf
    t = float(np.nanmean(d) / (sd / np.sqrt(d.size))) if sd > 0 else (np.inf if np.nanmean(d) > 0 else 0.0)
    valid = d[np.isfinite(d)]
    sign_p = float(binom.sf(int(np.sum(valid > 0)) - 1, valid.size, 0.5)) if valid.size else 1.0
    n = before.n_train
    dk = len(after.cal.names) - len(before.cal.names)
    dbic = float(n * np.log(after.train_rss / before.train_rss) + dk * np.log(n))
    consistent = t >= thresholds.min_t or sign_p <= thresholds.max_sign_p
    sig = bool(gain >= thresholds.min_gain and loso_gain >= thresholds.min_gain and consistent
               and dbic <= thresholds.max_delta_bic)
    p = candidate.parameter
    return CandidateScore(candidate.id, p, after.values[p], after.cal.std.get(p, np.nan), dict(after.values),
                          float(gain), float(loso_gain), t, dbic,
                          {s: (before.test_rmse[s], after.test_rmse[s]) for s in before.test_rmse}, significant=sig,
                          fit=after, sign_p=sign_p)


# ---------------------------------------------------------------------------------------------- fingerprints
def fingerprints(problem: Problem, base: Fit, ids, scales: dict, probes: dict | None = None,
                 numeric: dict | None = None) -> dict:
    """Projected, noise-scaled fingerprint (training samples stacked) of each candidate at the calibrated
    ``base``; returns ``id -> vector``, and the base residual under key ``None``.

    A candidate vanishes at its ``zero``, where the extended model is the base model: the columns of the base
    parameters are the base model's, computed once, and each candidate adds its own column (a run with one
    sensitivity, or the secant to its ``probe``; where the sensitivity at zero cannot be integrated, the secant
    to its typical magnitude ``scale``). A hard limit that its probe does not reach on ``base`` (a current cap
    above every current the base model draws) is probed twice as far from zero, and again, up to its bound; the
    size its secant was taken to is put into ``probes`` (id -> value), where its refit starts. A fingerprint that
    is not finite, or so large (beyond :data:`HUGE` per unit) that its products overflow, is numerically out of
    range: the candidate gets no fingerprint (zeros: never ranked by it) and ``numeric`` (id -> sentence) says why."""
    signals = problem.signals
    ones = {s: 1.0 for s in signals}
    out = {None: residual_vector(base.exps, base.values, signals, ones, scales, "train")}
    base_names = list(base.cal.names)
    B = jacobian(base.exps, base.values, base_names, signals, scales)
    for cid in ids:
        c = problem.candidates[cid]
        exps = problem.experiments(tuple(base.effects) + (cid,))
        values = {**base.values, c.parameter: c.zero}
        f = None
        if c.probe is None:
            try:
                f = jacobian(exps, values, [c.parameter], signals, scales)[:, 0]
            except AcausalError:  # no derivative at zero after all (a hard limit not declared one): its secant
                pass
        if f is None:  # a hard limit: the secant from zero to the probe (or to its typical magnitude)
            to = c.probe if c.probe is not None else c.sized(c.scale or 1.0)
            r0 = residual_vector(exps, values, signals, ones, scales, "train")
            while True:
                r1 = residual_vector(exps, {**values, c.parameter: to}, signals, ones, scales, "train")
                further = c.zero + 2 * (to - c.zero)
                if np.max(np.abs(r1 - r0)) > UNREACHED or not c.bounds[0] <= further <= c.bounds[1]:
                    break
                to = further
            f = (r1 - r0) / (to - c.zero)
            if probes is not None and c.probe is not None:
                probes[cid] = to
        top = float(np.max(np.abs(f))) if f.size and np.all(np.isfinite(f)) else np.inf
        if not top <= HUGE:
            if numeric is not None:
                numeric[cid] = (f"`{cid}` is numerically out of range at {c.parameter} = {c.zero:g}: its fingerprint "
                                + ("is not finite" if not np.isfinite(top) else f"reaches {top:.3g} noise levels per "
                                   f"{c.unit or 'unit'}") + " (its sensitivity overflows there); it was not ranked by "
                                "its fingerprint: check its bounds, its scale and its zero")
            out[cid] = np.zeros_like(out[None])
            continue
        coef, *_ = np.linalg.lstsq(B, f, rcond=None)
        out[cid] = f - B @ coef
    return out


def _linearised(c: Candidate, r, f, cos) -> tuple:
    """``(value, share)``: the candidate's size after one Gauss-Newton step from its zero on the residual ``r``
    along its projected fingerprint ``f``, clipped to its bounds, and the share of the residual's sum of squares
    that clipped step explains (``cos^2`` where the step stays inside; none where the effect can only act the
    other way: zero on a bound that the step points out of)."""
    ff, fr, rr = float(f @ f), float(f @ r), float(r @ r)
    step = -fr / ff if ff > 0 else 0.0  # residual = predicted - measured
    lo, hi = c.bounds
    value = min(max(c.zero + step, lo), hi)
    s = value - c.zero
    share = -(2 * s * fr + s * s * ff) / rr if rr > 0 else 0.0
    return value, float(min(max(share, 0.0), cos * cos))


def _screened(base: Fit, c: Candidate, r, f, cos) -> CandidateScore:
    """A candidate whose fingerprint explains too little of the residual to reach the gain threshold even in the
    best case: scored by one linearised (Gauss-Newton) step instead of a refit."""
    value, frac = _linearised(c, r, f, cos)
    n = base.n_train
    gain = 1.0 - np.sqrt(1.0 - frac)
    return CandidateScore(c.id, c.parameter, value, float("nan"), {**base.values, c.parameter: value}, float(gain),
                          float(gain), float("nan"), float(n * np.log(max(1.0 - frac, 1e-300)) + np.log(n)),
                          {s: (v, v) for s, v in base.test_rmse.items()}, fingerprint_match=cos, screened=True)


# ---------------------------------------------------------------------------------------------- driver
def diagnose(problem: Problem, start: dict | None = None, thresholds: Thresholds = Thresholds(),
             max_effects: int | None = None, candidates=None, progress=None) -> Diagnosis:
    """Run the diagnosis (see the module docstring); ``candidates``: ids to try (default: all); ``max_effects``:
    effects to name at most (default None: as many as the evidence supports, each step adding the best
    significant candidate until none is). Candidates still significant when the count stops the search are
    named in ``Diagnosis.left_out`` and in a warning."""
    if max_effects is not None and (not isinstance(max_effects, int) or max_effects < 1):
        raise DataError(f"max_effects must be a whole number >= 1 (or None: by evidence), got {max_effects!r}")
    ids = list(candidates or problem.candidates)
    for cid in ids:
        if cid not in problem.candidates:
            raise DataError(f"unknown candidate {cid!r}; known: {', '.join(problem.candidates)}")
    say = progress or (lambda msg: None)
    exps0 = problem.experiments(())
    scales = problem.noise_scales(exps0)
    say("calibrating the baseline")
    base = converged(problem, fit_model(problem, (), dict(start or {}), scales), scales)
    baseline = base
    say("fingerprints")
    probes = {}  # where each hard limit's refit starts (a size its probe reaches on the current model)
    numeric: dict = {}  # candidates whose fingerprints are numerically out of range, with why
    fp = fingerprints(problem, base, ids, scales, probes, numeric)
    match = {cid: _cos(fp[None], fp[cid]) for cid in ids}
    limit = len(ids) if max_effects is None else max_effects
    steps, causes = [], []
    optima: list = []  # sentences: a named model whose fit has another optimum (settled)
    held = set()  # candidates significant in the step before: refitted again on top of what it named
    while len(causes) < limit:
        rest = _open(problem, ids, causes)
        fp_step = fp if not causes else fingerprints(problem, base, rest, scales, probes, numeric)
        scores = _scores(problem, base, causes, {k: fp_step[k] for k in [None, *rest]}, scales, thresholds, say,
                         probes, always=held)
        held = {s.id for s in scores if s.significant}
        best = next((s for s in scores if s.significant), None)
        if best is None and len(causes) + 2 <= limit:
            found = _lookahead(problem, base, causes, scores, rest, scales, thresholds, say, probes)
            if found is not None:  # a pair that passes every test together: both named, the search goes on
                first, later, second = found
                steps.append(Step(base, scores, first.id, "pair"))
                steps.append(Step(first.fit, later, second.id, "pair"))
                causes += [first.id, second.id]
                base = settled(problem, second.fit, second.id, scales, optima)
                continue
        steps.append(Step(base, scores, best.id if best else None))
        if best is None:
            break
        causes.append(best.id)
        base = settled(problem, best.fit, best.id, scales, optima)
    drifted = {}
    if len(baseline.exps) >= 3:
        say("per-recording fit (drift)")
        drifted = _drift(problem, base, causes, scales)
        if drifted["drifting"] and len(causes) < limit:  # a slow effect the per-sample gain cannot see
            base, drifted = _named_by_drift(problem, base, causes, steps, drifted, ids, scales, thresholds, say)
    else:
        drifted = {"axis": None, "recordings": [], "trends": {}, "drifting": [], "explained_by": {},
                   "note": "not judged: fewer than 3 recordings"}
    rest = _open(problem, ids, causes)
    if causes and rest and steps[-1].before is not base:  # fingerprints on top of the final model
        fp_step = fingerprints(problem, base, rest, scales, numeric=numeric)
    d = Diagnosis(causes, steps, baseline, base, confusable(ids, fp, steps, thresholds), thresholds, scales, match,
                  problem.heldout())
    # what the final model could still have seen: the limits of the candidates not named, on top of the named ones
    at_final = {k: v for k, v in fp_step.items() if k is None or k in rest} if causes else fp
    d.detection_limits = detection_limits(problem, at_final, base.n_train, thresholds)
    d.drift = drifted
    for param in d.drift.get("drifting", []):
        for cid in d.drift.get("explained_by", {}).get(param, ()):
            if cid not in causes and cid in ids:
                d.suspects.setdefault(cid, []).append(param)
    if len(causes) >= limit and steps and steps[-1].kind == "gain":
        d.left_out = [sc.id for sc in steps[-1].scores if sc.significant and sc.id not in causes]
    d.screening = problem.screening()
    d.warnings = (screening_warnings(d.screening) + screen(problem, d.final, scales, thresholds)
                  + oversized(problem, d.final, causes, thresholds) + optima + list(numeric.values()))
    for cid, params in d.suspects.items():
        d.warnings.append(f"{', '.join(params)} drift{'s' if len(params) == 1 else ''} over the session and "
                          f"{cid} explains such a drift, but it could not be named from these recordings: "
                          f"{problem.confirm(cid, base.exps)}")
    if d.left_out:
        d.warnings.append(f"max_effects = {limit} reached: {', '.join(d.left_out)} scored significant in the last "
                          "step but was not named; raise the limit (or leave it out: the evidence decides)")
    for w in d.warnings:
        say(f"warning: {w}")
    return d


def _scores(problem, base: Fit, causes, fp_step: dict, scales, thresholds, say, probes=None, always=()) -> list:
    """Every candidate of ``fp_step`` (id -> projected fingerprint at ``base``; the residual under None) scored on
    top of ``base`` (the model with ``causes``): the most promising refitted (a hard limit from the size in
    ``probes`` its fingerprint was taken to), and those of ``always`` (significant in the step before: a second
    effect that holds out of sample on top of the first is refitted there, not left to the ranking), the rest
    screened (step 3 of the module docstring); sorted by held-out gain."""
    rest = [cid for cid in fp_step if cid is not None]
    r = fp_step[None]
    cosines = {cid: _cos(r, fp_step[cid]) for cid in rest}
    share = {cid: _linearised(problem.candidates[cid], r, fp_step[cid], cosines[cid])[1] for cid in rest}
    order = sorted(rest, key=lambda cid: -share[cid])
    refit = set(order if problem.max_refits is None else order[:problem.max_refits]) | (set(always) & set(rest))
    scores = []
    for cid in order:
        cos = cosines[cid]
        weak = 1.0 - np.sqrt(max(1.0 - share[cid], 0.0)) < thresholds.screen
        if cid not in refit or weak:
            sc = _screened(base, problem.candidates[cid], r, fp_step[cid], cos)
            sc.why_screened = "weak" if weak else "ranked"
            scores.append(sc)
            continue
        say(f"refitting with {cid}" + (f" on top of {', '.join(causes)}" if causes else ""))
        try:
            start = {**base.values, **({problem.candidates[cid].parameter: probes[cid]} if cid in (probes or {})
                                       else {})}
            ext = fit_model(problem, tuple(causes) + (cid,), start, scales)
        except AcausalError as err:  # e.g. a parameter leaving its range: the candidate cannot be scored
            say(f"{cid}: refit failed: {err}")
            sc = _screened(base, problem.candidates[cid], r, fp_step[cid], cos)
            sc.failed, sc.significant, sc.why_screened = str(err), False, "failed"
            scores.append(sc)
            continue
        sc = score(base, ext, problem.candidates[cid], thresholds)
        sc.fingerprint_match = cos
        scores.append(sc)
    scores.sort(key=lambda s: -s.heldout_rmse_gain)
    return scores


def _open(problem, ids, causes) -> list:
    """The candidates of ``ids`` that can still be added to a model with ``causes``: not named, not excluded by
    (and not excluding) a named one (:meth:`Candidate.combines`)."""
    named = [problem.candidates[c] for c in causes]
    return [cid for cid in ids if cid not in causes and all(problem.candidates[cid].combines(n) for n in named)]


def _lookahead(problem, base: Fit, causes, scores, rest, scales, thresholds, say, probes=None):
    """One step further where nothing is significant: a candidate that the held-out data and BIC favour but whose
    per-segment improvements are not consistent (one effect can mask another: a supply sag refitted while a loop
    delay is missing helps some segments and hurts others) is added provisionally, the others are scored on top
    of it, and the best one significant there is named with it when the pair, scored against ``base`` with both
    parameters counted, passes every test. Returns ``(first, scores on top of it, second)`` or None."""
    first = next((s for s in scores if s.fit is not None and not s.screened and not s.failed
                  and s.heldout_rmse_gain >= thresholds.min_gain and s.delta_bic <= thresholds.max_delta_bic), None)
    others = [] if first is None else _open(problem, [cid for cid in rest if cid != first.id], [first.id])
    if not others:
        return None
    say(f"{first.id} gains held out but not consistently per segment: scoring the others on top of it")
    with_first = list(causes) + [first.id]
    fp2 = fingerprints(problem, first.fit, others, scales, probes)
    later = _scores(problem, first.fit, with_first, fp2, scales, thresholds, say, probes)
    second = next((s for s in later if s.significant), None)
    if second is None:
        return None
    both = score(base, second.fit, problem.candidates[second.id], thresholds)
    if not both.significant:
        return None
    first.named_by, second.named_by = f"pair with {second.id}", f"pair with {first.id}"
    return first, later, second


def _drift(problem, fit, causes, scales) -> dict:
    """:func:`~.evidence.drift` of ``fit`` (the baseline and ``causes``), in the problem's session order."""
    bounds = {f.name: (f.lower, f.upper) for f in problem.base_free(fit.values)}
    bounds.update({problem.candidates[c].parameter: problem.candidates[c].bounds for c in causes})
    return drift(problem, fit, scales, bounds, problem.session_order(fit.exps))


def _named_by_drift(problem, base, causes, steps, drifted, ids, scales, thresholds, say) -> tuple:
    """A drift of the per-recording fit over the session that a candidate explains: the candidate is named when,
    added and refitted, the drift is gone (no parameter it explains drifts any more), its BIC falls by at least
    ``max_delta_bic`` and its per-stride improvements are consistent (paired t or sign test), even if its held-out
    gain is small (a slow effect changes every sample a little; the per-recording trend sees what the pooled
    residual does not). Returns the (possibly extended) fit and its drift."""
    tried = []
    for param in drifted["drifting"]:
        for cid in drifted["explained_by"].get(param, ()):
            if cid in causes or cid not in _open(problem, ids, causes) or cid in tried:
                continue
            tried.append(cid)
            say(f"refitting with {cid}: does it explain the drift of {param}?")
            try:
                ext = fit_model(problem, tuple(causes) + (cid,), base.values, scales, drift=True)
            except AcausalError as err:
                say(f"{cid}: refit failed: {err}")
                continue
            sc = score(base, ext, problem.candidates[cid], thresholds)
            after = _drift(problem, ext, tuple(causes) + (cid,), scales)
            gone = not any(p in after["drifting"] for p, by in drifted["explained_by"].items() if cid in by)
            consistent = sc.t_stat >= thresholds.min_t or sc.sign_p <= thresholds.max_sign_p
            sc.named_by = "drift" if gone and consistent and sc.delta_bic <= thresholds.max_delta_bic else ""
            sc.significant = bool(sc.named_by)
            steps.append(Step(base, [sc], cid if sc.significant else None, "drift", after))
            if sc.significant:
                causes.append(cid)
                after["before"] = {"drifting": drifted["drifting"], "trends": drifted["trends"],
                                   "recordings": drifted["recordings"]}
                after["resolved_by"] = {p: cid for p in drifted["drifting"] if p not in after["drifting"]}
                return ext, after
    return base, drifted


def screen(problem: Problem, fit: Fit, scales: dict, thresholds: Thresholds = Thresholds()) -> list:
    """What is wrong with the data or the fit, as sentences (empty when nothing is): per recording and signal, a
    dead sensor (the reading is constant while the model's varies), a reversed sign (reading and prediction
    anti-correlated), a recording far off the others (RMSE ``outlier`` times the set's median: swapped columns, a
    wrong setting in its JSON such as the stride time, another rig), readings that repeat at another cycle than
    ``problem.period`` (a wrong stride time); and for the whole fit, a held-out RMSE many noise levels
    (``misfit``) above the noise: the model misses something no candidate covers, or the data is wrong
    (:func:`~.screening.screen`). A verdict is never a silent ``none`` on data its own model cannot follow."""
    preds = {e.name: e.predict(fit.values) for e in fit.exps}
    hint = ("no candidate explains it; the model misses an effect outside the candidates, or the data is wrong"
            if not fit.effects else "the named effects do not explain everything")
    return screen_fit(fit.exps, preds, problem.signals, scales, thresholds.outlier, thresholds.misfit,
                      period=problem.period, who="the final model", misfit_hint=hint)


def oversized(problem: Problem, fit: Fit, causes, thresholds: Thresholds = Thresholds()) -> list:
    """Sentences about named candidates fitted at ``Thresholds.oversized`` times their typical size or more
    (``Candidate.typical``): the data wants the effect, but at a size the physics it stands for rarely has, so it
    may stand in for another effect (one outside the candidates) rather than be what its name says."""
    out = []
    for cid in causes:
        c = problem.candidates[cid]
        if not c.typical:
            continue
        ratio = abs(fit.values[c.parameter] - c.zero) / abs(c.typical - c.zero)
        if ratio >= thresholds.oversized:
            out.append(f"{cid} is named at {c.parameter} = {fit.values[c.parameter]:.4g} {c.unit}".rstrip() +
                       f", {ratio:.1f} times its typical size ({c.typical:g}): it may stand in for an effect "
                       "outside the candidates; compare it with the range its component's docstring gives")
    return out
