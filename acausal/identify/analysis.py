"""What a fitted model still gets wrong, per signal (:func:`residual_analysis`): the numbers behind a diagnosis
report's residual tables and figures."""
from __future__ import annotations

import numpy as np

from ..errors import DataError
from .residuals import cross_correlations, phase_profile, structure_test, whiteness


def residual_analysis(problem, fit, bins: int = 50, max_lag: int = 50) -> dict:
    """What the fitted model gets wrong, per signal: RMSE per experiment (training and held-out), the residual over
    the cycle (mean and spread over cycles, pooled), per experiment the structure test at the model's time scale
    (:func:`~.residuals.structure_test`, blocks of 1/20 cycle: passes on sensor noise, filtered or not, and on the
    replay's own high-frequency error; fails on a missed effect) and the sample-level Ljung-Box whiteness (which a
    replayed recording fails even when nothing is missed), and cross-correlation with the problem's regressors
    (pooled over experiments). ``problem``: a :class:`~.diagnose.Problem`; ``fit``: one of its
    :class:`~.diagnose.Fit` s."""
    out = {}
    preds = {e.name: e.predict(fit.values) for e in fit.exps}
    regs = {e.name: problem.regressors(e, fit.values) for e in fit.exps}
    for s in problem.signals:
        rows, white, structure, folded, res_all, reg_all = [], [], [], [], [], {}
        for e in fit.exps:
            r = e.measured[s] - preds[e.name][s]
            inner = e.train | e.test
            rows.append({"experiment": e.name,
                         "rmse_train": float(np.sqrt(np.mean(r[e.train] ** 2))) if e.train.any() else float("nan"),
                         "rmse_heldout": float(np.sqrt(np.mean(r[e.test] ** 2))) if e.test.any() else float("nan"),
                         "mae": float(np.mean(np.abs(r[inner])))})
            white.append(whiteness(r[inner], max_lag))
            structure.append(_structure(r[inner], e.t[inner], problem.period(e)))
            folded.append((e.t[inner], r[inner], problem.period(e)))
            res_all.append(r[inner])
            for k, v in regs[e.name].items():
                reg_all.setdefault(k, []).append(np.asarray(v)[inner])
        phase = np.concatenate([np.mod((t - t[0]) / T, 1.0) for t, _, T in folded])
        prof = phase_profile(phase, np.concatenate([r for _, r, _ in folded]), 1.0, 0.0, bins)
        r_all = np.concatenate(res_all)
        cc = cross_correlations(r_all, {k: np.concatenate(v) for k, v in reg_all.items()}, max_lag) if reg_all else []
        out[s] = {"rows": rows, "whiteness": white, "structure": structure, "phase": prof, "correlations": cc,
                  "rmse": float(np.sqrt(np.mean(r_all**2)))}
    return out


def _structure(r, t, period):
    """:func:`~.residuals.structure_test` of one experiment's residual at blocks of 1/20 of its cycle (None where
    the experiment has no cycle or is too short for two blocks)."""
    if not period or r.size < 4:
        return None
    try:
        return structure_test(r, period=float(period), rate=1.0 / float(np.median(np.diff(t))))
    except DataError:
        return None
