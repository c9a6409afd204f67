"""The diagnosis's own fits: a named model is the optimum, not the iterate where the evaluation limit stopped it
(:func:`~acausal.identify.diagnose.converged`), and a named effect far beyond its typical size is said
(:func:`~acausal.identify.diagnose.oversized`). A toy problem without an integrator: y = a exp(-k t) + c t^2
with the candidate ``c``."""
import numpy as np

from acausal.identify.calibrate import Experiment, Free
from acausal.identify.diagnose import Candidate, Problem, Thresholds, converged, diagnose, fit_model, oversized


class Decay(Problem):
    signals = ["y"]
    loss = "linear"

    def __init__(self, c_true, typical=0.1, max_nfev=100):
        rng = np.random.default_rng(7)
        self.t = np.linspace(0.0, 4.0, 400)
        self.y = 2.0 * np.exp(-1.3 * self.t) + c_true * self.t**2 + 0.01 * rng.standard_normal(self.t.size)
        self.candidates = {"c": Candidate("c", "c", 0.0, (0.0, 10.0), 0.1, "y", "V/s2", typical=typical)}
        self.fit_options = {"max_nfev": max_nfev, "tol": 1e-8}

    def experiments(self, effects):
        out = []
        for k in range(4):  # four pieces, the last one held out
            piece = (self.t >= k) & (self.t < k + 1) if k < 3 else self.t >= 3
            t, y = self.t[piece], self.y[piece]

            def predict(v, t=t, effects=effects):
                return {"y": v["a"] * np.exp(-v["k"] * t) + (v["c"] if "c" in effects else 0.0) * t**2}
            held = np.full(t.size, k == 3)
            out.append(Experiment(f"piece{k}", t, {"y": y}, predict, ~held, held,
                                  np.floor(10 * (t - t[0])).astype(int)))
        return out

    def base_free(self, start):
        return [Free("a", start.get("a", 1.5), 0.0, 10.0, 1.0), Free("k", start.get("k", 1.0), 0.0, 10.0, 1.0)]

    def period(self, exp):
        return None

    def noise_scales(self, exps):
        return {"y": 0.01}


def test_a_fit_stopped_by_its_evaluation_limit_is_continued_to_the_optimum():
    p = Decay(0.05, max_nfev=3)
    scales = p.noise_scales(None)
    stopped = fit_model(p, ("c",), {}, scales)
    assert not stopped.cal.success  # three evaluations do not reach it from a = 1.5, k = 1
    done = converged(p, stopped, scales, rounds=20)
    assert done.cal.cost < stopped.cal.cost
    full = fit_model(Decay(0.05, max_nfev=200), ("c",), {}, scales)
    assert full.cal.success
    for name in ("a", "k", "c"):
        assert abs(done.values[name] - full.values[name]) < 1e-5 * max(1.0, abs(full.values[name])), name
    assert converged(p, done, scales) is done  # a converged fit is left alone


def test_a_named_effect_far_beyond_its_typical_size_is_said():
    p = Decay(2.0, typical=0.1)
    d = diagnose(p)
    assert d.causes == ["c"] and abs(d.final.values["c"] - 2.0) < 0.01
    said = [w for w in d.warnings if w.startswith("c is named at c = ")]
    assert len(said) == 1 and "20.0 times its typical size (0.1)" in said[0], d.warnings
    # at its typical size nothing is said
    q = Decay(0.1, typical=0.1)
    assert oversized(q, fit_model(q, ("c",), {}, q.noise_scales(None)), ["c"], Thresholds()) == []


def test_a_fit_with_sensitivities_run_together_takes_the_same_steps_with_one_run_per_evaluation():
    """``calibrate(together=True)``: each evaluation runs the sensitivities, and the optimiser's Jacobian at an
    accepted point takes them without a second run; the fit is the same as with separate runs."""
    from acausal.identify.calibrate import calibrate

    t = np.linspace(0.0, 3.0, 300)
    y = 2.0 * np.exp(-1.3 * t) + 0.01 * np.random.default_rng(3).standard_normal(t.size)
    runs = {"predict": 0, "sensitivity": 0}

    def predict(v):
        runs["predict"] += 1
        return {"y": v["a"] * np.exp(-v["k"] * t)}

    def sensitivity(v, names):
        runs["sensitivity"] += 1
        d = {"a": np.exp(-v["k"] * t), "k": -v["a"] * t * np.exp(-v["k"] * t)}
        return predict(v), {"y": np.stack([d[n] for n in names])}

    def fit(together):
        runs.update(predict=0, sensitivity=0)
        e = Experiment("decay", t, {"y": y}, predict, np.ones(t.size, bool), np.zeros(t.size, bool),
                       np.zeros(t.size, int), sensitivity=sensitivity)
        cal = calibrate([e], [Free("a", 1.0, 0.0, 10.0, 1.0), Free("k", 0.5, 0.0, 10.0, 1.0)], ["y"],
                        scales={"y": 0.01}, loss="linear", tol=1e-10, together=together)
        return cal, dict(runs)

    apart, runs_apart = fit(False)
    with_sens, runs_together = fit(True)
    for name in ("a", "k"):
        assert abs(apart.values[name] - with_sens.values[name]) < 1e-9
    assert apart.nfev == with_sens.nfev
    assert runs_together["sensitivity"] == with_sens.nfev  # one run with sensitivities per evaluation, no more
    assert runs_apart["sensitivity"] >= 2  # the Jacobians of the separate fit were runs of their own


class Wave(Decay):
    """y = a exp(-k t) + 0.5 sin(c t) with c = 6 hidden: from c = 0 the fit ends at another optimum; from the
    candidate's typical size 5.5 at the true one."""

    def __init__(self):
        rng = np.random.default_rng(11)
        self.t = np.linspace(0.0, 4.0, 800)
        self.y = 2.0 * np.exp(-1.3 * self.t) + 0.5 * np.sin(6.0 * self.t) + 0.01 * rng.standard_normal(self.t.size)
        self.candidates = {"c": Candidate("c", "c", 0.0, (0.0, 20.0), 1.0, "y", "rad/s", typical=5.5)}
        self.fit_options = {"max_nfev": 200, "tol": 1e-10}

    def experiments(self, effects):
        out = []
        for k in range(4):
            piece = (self.t >= k) & (self.t < k + 1) if k < 3 else self.t >= 3
            t, y = self.t[piece], self.y[piece]

            def predict(v, t=t, effects=effects):
                wave = 0.5 * np.sin(v["c"] * t) if "c" in effects else 0.0
                return {"y": v["a"] * np.exp(-v["k"] * t) + wave}
            held = np.full(t.size, k == 3)
            out.append(Experiment(f"piece{k}", t, {"y": y}, predict, ~held, held,
                                  np.floor(10 * (t - t[0])).astype(int)))
        return out


def test_a_named_fit_is_settled_from_a_second_start_and_two_optima_are_said():
    from acausal.identify.diagnose import settled

    p = Wave()
    scales = p.noise_scales(None)
    base = fit_model(p, (), {}, scales)
    from_zero = fit_model(p, ("c",), {**base.values, "c": 0.0}, scales)
    assert abs(from_zero.values["c"] - 6.0) > 0.5  # a single start from zero ends elsewhere
    notes = []
    kept = settled(p, from_zero, "c", scales, notes)
    assert abs(kept.values["c"] - 6.0) < 0.01 and kept.cal.cost < from_zero.cal.cost
    assert len(notes) == 1 and "more than one optimum" in notes[0] and "c = 6" in notes[0]
    # started where it ends anyway: one optimum, nothing said
    again = []
    assert abs(settled(p, kept, "c", scales, again).values["c"] - 6.0) < 0.01 and again == []


class Overflowing(Decay):
    """``Decay`` with a second candidate ``d`` whose sensitivity is 1e160 per unit: its fingerprint's products
    overflow a float."""

    def __init__(self):
        super().__init__(0.5)
        self.candidates = {**self.candidates,
                           "d": Candidate("d", "d", 0.0, (0.0, 1.0), 1e-170, "y", "1", typical=1e-170)}

    def experiments(self, effects):
        out = super().experiments(tuple(e for e in effects if e != "d"))
        if "d" in effects:
            for e in out:
                e.predict = (lambda v, f=e.predict, t=e.t: {"y": f(v)["y"] + v.get("d", 0.0) * 1e160 * t})
        return out


def test_a_fingerprint_that_overflows_is_a_finding_not_a_numpy_warning():
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a RuntimeWarning (overflow in matmul) would fail here
        d = diagnose(Overflowing())
    assert d.causes == ["c"]
    [said] = [w for w in d.warnings if w.startswith("`d` is numerically out of range")]
    assert "at d = 0" in said and "noise levels per 1" in said and "check its bounds" in said
