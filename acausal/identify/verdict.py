"""The records of a diagnosis (:mod:`.diagnose`): what a model supplies (:class:`Problem`, its :class:`Candidate`
effects), the :class:`Thresholds` a candidate must pass, and what the diagnosis returns (:class:`Fit`,
:class:`CandidateScore`, :class:`Step`, :class:`Diagnosis`)."""
from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np

from .calibrate import Calibration, Free, noise_scales
from .recordings import screening_summary


@dataclass(frozen=True)
class Candidate:
    """An effect the diagnosis may add to a model: the one record of a candidate, from the model's table of effects
    (which extends it with how the effect is built) to the fit, the report and the verdict's JSON."""

    id: str
    parameter: str  # the parameter that sets the effect's size
    zero: float  # its value where the effect vanishes
    bounds: tuple
    scale: float  # typical magnitude (optimiser scaling)
    signal: str = ""  # the signal it shows in first (empty: the problem has one)
    unit: str = ""
    #: a size at which the effect shows for certain, for an effect with no first-order change at ``zero`` (a hard
    #: limit not reached there): its fingerprint is the secant from zero to the probe, and its refit starts there
    probe: float | None = None
    #: a realistic size of the effect (its source in the candidate's docstring); None: not known
    typical: float | None = None
    #: candidates this one cannot be combined with in one model (two plays in series with no inertia between them
    #: are one play, and the shaft between them has no defined position while both are open)
    excludes: tuple = ()
    doc: str = ""  # what the effect is, and where its typical size comes from

    def free(self, start: dict) -> Free:
        """The candidate's parameter to fit, started at its value in ``start`` (else at the probe, else at zero),
        clipped into its bounds."""
        first = self.zero if self.probe is None else self.probe
        value = float(np.clip(start.get(self.parameter, first), *self.bounds))
        return Free(self.parameter, value, self.bounds[0], self.bounds[1], self.scale)

    def combines(self, other: "Candidate") -> bool:
        """Whether this candidate and ``other`` can be in one model (neither excludes the other)."""
        return other.id not in self.excludes and self.id not in other.excludes

    def sized(self, size: float) -> float:
        """The parameter at effect size ``size``: ``zero + size``, or ``zero - size`` where the upper bound does
        not allow that (an effect that grows as its parameter falls, e.g. a limit below 1)."""
        return self.zero + size if self.zero + size <= self.bounds[1] else self.zero - size


@dataclass(frozen=True)
class Thresholds:
    min_gain: float = 0.03  # held-out and leave-one-stride-out RMSE gain, fraction
    min_t: float = 2.0  # paired t statistic of per-stride improvements
    max_sign_p: float = 0.01  # or: p value of a one-sided sign test of the per-stride improvements
    max_delta_bic: float = -10.0
    confusable: float = 0.9  # |cos| of projected fingerprints: confusable whatever their scores
    related: float = 0.3  # |cos| above which two candidates both significant in the first step are confusable
    screen: float = 0.005  # refit only candidates whose fingerprint alone could gain this much (linearised)
    outlier: float = 5.0  # a recording whose RMSE is this many times the median of the set is flagged
    misfit: float = 10.0  # a final model whose held-out RMSE is this many noise levels is flagged
    oversized: float = 5.0  # a named effect this many times its typical size is flagged


class Problem(ABC):
    """What a model supplies: its experiments, baseline parameters, candidates, cycle and regressors."""

    signals: list = []
    candidates: dict = {}  # id -> Candidate
    loss: str = "soft_l1"
    #: further options of every calibration (:func:`~.calibrate.calibrate`: ``max_nfev``, ``tol``)
    fit_options: dict = {}
    #: candidates refitted per step at most, in the order of their linearised gain (the share of the residual
    #: their projected fingerprint's Gauss-Newton step explains, clipped to their bounds); the others are scored
    #: by one Gauss-Newton step and marked ``screened``. None: every candidate above ``Thresholds.screen`` is
    #: refitted.
    max_refits: int | None = None

    @abstractmethod
    def experiments(self, effects: tuple) -> list:
        """The experiments (:class:`~.calibrate.Experiment`) of the model extended with ``effects``."""

    @abstractmethod
    def base_free(self, start: dict) -> list:
        """The baseline's parameters to fit, as :class:`Free`, starting at ``start`` where given."""

    def effect_free(self, effects: tuple, start: dict, drift: bool = False) -> list:
        """Further parameters an extension with ``effects`` brings beside the candidates' own (:class:`Free`);
        ``drift``: for the fit that tests whether an effect explains a drift over the session, which may add one
        start value per recording (named ``NAME@EXPERIMENT``: see :data:`~.evidence.PER_EXPERIMENT`); default
        none."""
        return []

    @abstractmethod
    def period(self, exp) -> float:
        """The cycle (e.g. stride) over which residuals are folded."""

    def regressors(self, exp, values: dict) -> dict:
        """Physically meaningful regressors (name -> samples) of one experiment for the residual analysis."""
        return {}

    def noise_scales(self, exps) -> dict:
        """Noise level of each signal (the unit residuals are counted in); default: estimated from the data
        (:func:`~.calibrate.noise_scales`)."""
        return noise_scales(exps, self.signals)

    #: baseline parameter -> candidates that explain a drift of it across a session (e.g. a resistance that rises
    #: from recording to recording: a winding that warms)
    drift_causes: dict = {}

    def session_order(self, exps):
        """``(label, positions)`` of the experiments in their session (e.g. elapsed time at each recording's
        start), or None: their order as given."""
        return None

    def heldout(self) -> dict:
        """How the held-out samples were chosen and which signal judges them: ``{"signal", "unit", "split"}``
        (the verdict's ``heldout`` block; default: the first signal)."""
        return {"signal": self.signals[0], "unit": "", "split": "held-out samples of each experiment"}

    def unit(self, name: str) -> str:
        """The SI unit of a fitted parameter (for tables and axes); default: a candidate's own unit, else ""."""
        for c in self.candidates.values():
            if c.parameter == name:
                return c.unit
        return ""

    def screening(self) -> dict:
        """What the screening of the problem's recordings masked and left out (:mod:`~.masking`): ``{"masked":
        [...], "left_out": [...]}``; default: from ``self.recordings`` and ``self.left_out`` where the problem has
        them."""
        return screening_summary(getattr(self, "recordings", []), getattr(self, "left_out", []))

    def confirm(self, candidate: str, exps) -> str:
        """What data would confirm ``candidate`` as the cause of a drift it explains but could not be named by
        (a sentence for the verdict)."""
        return "a longer session, or recordings that say when each was made, would show it directly"


@dataclass
class Fit:
    effects: tuple
    cal: Calibration
    exps: list
    values: dict  # all fitted values
    train_rss: float  # sum of squared noise-scaled residuals, training samples
    n_train: int
    test_mse: float  # mean squared noise-scaled residual, held-out samples
    test_rmse: dict  # signal -> held-out RMSE (signal units)
    loso_stride_mse: dict  # (experiment, stride) -> leave-one-stride-out mean squared scaled residual
    test_mae: dict = field(default_factory=dict)  # signal -> held-out mean absolute error (signal units)


@dataclass
class CandidateScore:
    id: str
    parameter: str
    value: float
    std: float
    params: dict
    heldout_rmse_gain: float
    loso_rmse_gain: float
    t_stat: float
    delta_bic: float
    heldout_rmse: dict  # signal -> (before, after)
    fingerprint_match: float = float("nan")
    significant: bool = False
    fit: Fit | None = None
    screened: bool = False  # not refitted: scores are the linearised prediction (training strides)
    failed: str = ""  # why the refit failed (scores are then the linearised prediction)
    why_screened: str = ""  # why it was not refitted: "weak" (fingerprint below Thresholds.screen), "ranked" (beyond
    # the problem's max_refits most promising), "failed" (the refit failed)
    sign_p: float = float("nan")  # one-sided sign test: P(at least this many strides improved | no effect)
    named_by: str = ""  # "drift": named because it explains a drift over the session (:func:`_named_by_drift`);
    # "pair with ID": named with ID as a pair that passes the tests together (:func:`_lookahead`)

    def refit_note(self, max_refits: int | None = None) -> str:
        """What an evidence table says of a candidate that was not refitted (``screened``), and why."""
        if self.why_screened == "failed" or self.failed:
            return f"refit failed: {self.failed}"
        if self.why_screened == "ranked":
            return f"not refitted (beyond the {max_refits} most promising)"
        return "not refitted (fingerprint too weak)"

    def summary(self) -> dict:
        return {"id": self.id, "heldout_rmse_gain": self.heldout_rmse_gain, "delta_bic": self.delta_bic,
                "params": dict(self.params), "loso_rmse_gain": self.loso_rmse_gain, "t_stat": _num(self.t_stat),
                "sign_p": _num(self.sign_p),
                "std": _num(self.std), "fingerprint_match": _num(self.fingerprint_match), "significant": self.significant,
                "screened": self.screened, "why_screened": self.why_screened or None, "failed": self.failed or None,
                "named_by": self.named_by or None,
                "heldout_rmse": {s: {"before": b, "after": a} for s, (b, a) in self.heldout_rmse.items()}}


def _num(x):
    """A float for JSON: None where not defined (NaN is not JSON)."""
    return None if x is None or not np.isfinite(x) else float(x)


@dataclass
class Step:
    before: Fit
    scores: list
    chosen: str | None
    kind: str = "gain"  # "gain": every candidate scored; "drift": one candidate tried on a drift it explains;
    # "pair": one of two steps named together (:func:`~.diagnose._lookahead`)
    drift: dict | None = None  # kind "drift": the drift check of the model with the candidate added


@dataclass
class Diagnosis:
    causes: list
    steps: list
    baseline: Fit
    final: Fit
    confusable: list  # dicts: a, b, cos, kind, separated, evidence (:func:`~.evidence.confusable`)
    thresholds: Thresholds
    scales: dict
    fingerprints: dict = field(default_factory=dict)  # id -> match with the baseline residual
    heldout_info: dict = field(default_factory=dict)  # Problem.heldout(): signal, unit, split
    warnings: list = field(default_factory=list)  # data and fit problems found by :func:`screen` (sentences)
    #: id -> smallest size that would have been named (:func:`~.evidence.detection_limits`)
    detection_limits: dict = field(default_factory=dict)
    #: the final model refitted per recording and its trend over the session (:func:`~.evidence.drift`)
    drift: dict = field(default_factory=dict)
    #: candidates significant in the last step but not named because ``max_effects`` was reached
    left_out: list = field(default_factory=list)
    #: candidate -> the parameters whose drift over the session it explains, for a drift the final model still
    #: has: the verdict's suspects, with what data would confirm them (:meth:`Problem.confirm`)
    suspects: dict = field(default_factory=dict)
    #: what the screening of the recordings masked and left out (:meth:`Problem.screening`)
    screening: dict = field(default_factory=dict)
    #: parameter -> how a model widened a named effect's standard error by the replay's own error (fitted, bias,
    #: sandwich, std), where it measured it; empty: the cluster-robust errors alone
    replay_bias: dict = field(default_factory=dict)

    def heldout(self) -> dict:
        """The verdict's held-out score: mean absolute error of the judging signal on the held-out samples, for
        the calibrated baseline and for the extended model."""
        info = dict(self.heldout_info)
        s = info.get("signal")
        return {"signal": s, "metric": "mae", "unit": info.get("unit", ""), "split": info.get("split", ""),
                "baseline": self.baseline.test_mae.get(s), "extended": self.final.test_mae.get(s),
                "signals": self.heldout_signals()}

    def heldout_signals(self) -> dict:
        """Held-out scores of every measured signal: ``{signal: {"mae": (baseline, extended), "rmse": (...)}}``,
        so an effect that shows in another signal than the judging one (a sensor's offset) shows its gain."""
        return {s: {"mae": [self.baseline.test_mae.get(s), self.final.test_mae.get(s)],
                    "rmse": [self.baseline.test_rmse.get(s), self.final.test_rmse.get(s)]}
                for s in self.baseline.test_rmse}

    @property
    def cause(self) -> str:
        return self.causes[0] if self.causes else "none"

    @property
    def candidates(self) -> list:
        return self.steps[0].scores

    def to_dict(self) -> dict:
        """The machine-readable verdict (``acausal diagnose --json``)."""
        return {"cause": self.cause, "causes": list(self.causes),
                "candidates": [s.summary() for s in self.candidates],
                "steps": [{"model": list(st.before.effects), "chosen": st.chosen, "kind": st.kind,
                           "candidates": [s.summary() for s in st.scores]} for st in self.steps],
                "baseline": {"params": dict(self.baseline.values), "heldout_rmse": dict(self.baseline.test_rmse)},
                "extended": {"effects": list(self.final.effects), "params": dict(self.final.values),
                             "std": {k: _num(v) for k, v in self.final.cal.std.items()},
                             "heldout_rmse": dict(self.final.test_rmse)},
                "heldout": self.heldout(), "warnings": list(self.warnings), "left_out": list(self.left_out),
                "screening": {k: [dict(x) for x in v] for k, v in self.screening.items()},
                "suspects": {k: list(v) for k, v in self.suspects.items()},
                "confusable": [dict(c) for c in self.confusable],
                "detection_limits": {k: dict(v) for k, v in self.detection_limits.items()},
                "drift": self.drift,
                "standard_errors": {"method": self.final.cal.std_method, "clusters": self.final.cal.clusters,
                                    "replay_bias": {k: dict(v) for k, v in self.replay_bias.items()}},
                "thresholds": vars(self.thresholds) if not hasattr(self.thresholds, "__dataclass_fields__")
                else {k: getattr(self.thresholds, k) for k in self.thresholds.__dataclass_fields__}}
