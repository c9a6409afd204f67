"""Inference of what the paper does not publish, from the numbers it does: the ``paper_fit`` preset.

The unknowns (:data:`UNKNOWNS`) are run-time parameters of the registered actuator, each bounded by a physically
plausible range with its source (``docs/parameters.md`` and the notes here). The targets
(:mod:`acausal.models.ankle.targets`) are the paper's own numbers and statements of claims C1 (Table 1: the five
energies at 8 mm, 2 s/stride), C2 (Fig. 9: the smallest and largest driver loss over the 6 x 6 grid), C10 (Fig. 8:
the driver output's dip at Table 1's point), C3 (4.2.1: the driver loss a bowl over stride time at the tuned 8 mm,
its loss per stride rising from 1.5 s/stride on) and C7 (Fig. 12: the output loss around 20 % on average and over
50 % at worst), all measured on the bench and so computed on the bench model
(:data:`~acausal.models.ankle.protocol.BENCH`), each with a standard deviation of a third of the tolerance its claim
is read with (:mod:`acausal.models.ankle.claims`), so a target met to 3 sigma is a claim that holds; "over" and
"rising" are one-sided (no residual once met). C6 (Fig. 11's gearing loss) and C9 (Fig. 7) are not targets (see
``targets.TARGETS``). Every other claim is a prediction of the fitted model. C8 (where the motor can follow) is
met by the planner's torque tolerance, chosen after the fit as the smallest one that satisfies it
(:func:`choose_tolerance`), the fit repeated with it (:func:`infer`).

Method: weighted least squares in the unknowns scaled to their ranges (``scipy.optimize.least_squares``, trust
region with bounds), each residual evaluation a handful of protocol runs (:func:`acausal.models.ankle.protocol.
run_condition`) through one executor. Grid targets (C2) are evaluated during the iterations on the grid conditions
where the extremes lie at the start, and the result is checked on the whole grid (``verified``). Uncertainty:
the linearised covariance ``(J^T J)^-1`` of the scaled Jacobian at the optimum; an unknown whose standard
deviation exceeds a quarter of its range, or that sits on a bound, is reported as not identified by these numbers
(its value is then the range's choice, not the data's).

``acausal infer --out DIR`` runs it and writes (:mod:`acausal.models.ankle.fit_record`) ``paper_fit.json`` (the
preset with ranges, sources, standard deviations, the targets met, the condition of the fit); ``--install`` also
replaces the shipped one
(:data:`acausal.models.ankle.presets.PAPER_FIT_RECORD`) that the ``paper_fit`` preset reads. ``--without CLAIM``
leaves a claim's targets out (:func:`targets_without`) to try it as a prediction; such trials are shipped beside the
record (:func:`acausal.models.ankle.fit_record.trials`) and the report says what they found.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from acausal import ModelError, SimulationError
from acausal.simulation.sweep import sweep

from .published import PAPER
from .protocol import D_MAX, Condition, compiled, follows_as_in_the_paper, run_condition
from .targets import (GRID, PLAN_GRID, TARGETS, WHOLE_GRID, driver_loss, grid_extreme, grid_mean, in_corner,
                      stage_loss)



@dataclass(frozen=True)
class Unknown:
    """A parameter the paper does not publish: its plausible range, the a-priori value the fit starts from, and
    where the range comes from."""

    name: str  # run-time parameter of the registered actuator
    lo: float
    hi: float
    start: float
    unit: str
    source: str
    #: why a fit may end at a bound of this range and the value still be physical (empty: it may not; the report
    #: flags a value within 5 % of a bound without one)
    bound_reason: str = ""


#: why the driver's current-dependent losses may end at the low ends of their ranges (C1, with the paper's 4.2.1)
_T1 = PAPER["table1_energy"]
DRIVER_LOSS_IS_CONSTANT = (f"the driver's loss at Table 1's point (C1: {_T1['source']:g} - {_T1['driver']:g} = "
                           f"{_T1['source'] - _T1['driver']:g} J per 2-s stride, "
                           f"{(_T1['source'] - _T1['driver']) / 2.0:g} W on average) is no more than the constant "
                           "consumption the paper measures (4.2.1: 'a constant energy consumption in the driver of "
                           "between 10 and 15 W'), so what the bridge loses with the current is a small rest of it")

UNKNOWNS = (
    Unknown("body_mass", 50.0, 90.0, 60.0, "kg",
            "the subject's mass scales the gait torque (gait data per kg); adult amputee users 50-90 kg; not "
            "published (parameters.md)"),
    Unknown("link.r_f", 0.0, 4e-3, 1e-3, "m",
            "MACCEPA bar and pivot friction radius = friction coefficient 0.1-0.4 (steel on bronze/polymer "
            "bushings) x pin and bar radius 4-10 mm; the paper measures about 20 % output loss (4.2.3)"),
    Unknown("planetary.tau_c", 0.0, 1.3, 0.0, "N.m",
            "drag of the gearhead at its output: 0-15 mN m at the motor side x 86 (the gearhead's no-load "
            "current, 0-0.5 A at 27.4 mN m/A); the paper measures >= 50 % gearing loss against a 70 % catalogue "
            "maximum (4.2.3)"),
    Unknown("planetary.eta", 0.55, 0.75, 0.7, "1",
            "mesh efficiency of the planetary gearhead at load: catalogue maximum 70 % (maxon GP 32 HP, 3 "
            "stages), 55 % at partial load"),
    Unknown("motor.J", 3.33e-6, 1.6e-5 - 0.7e-7, 3.33e-6, "kg.m2",
            "inertia on the motor shaft besides the gearhead's 0.7e-7 at its input: the datasheet rotor (3.33e-6) up "
            "to the paper's estimate of the whole actuator's (Table 2 'estimated total', 1.6e-5); at the upper end the "
            "bench's driver output dips to about -60 W at 8 mm, 2 s/stride (C10)",
            bound_reason="C10's dip pulls it up (the driver output's negative peak is the kinetic energy the rotor "
                         "returns): the upper bound is the paper's own estimate of the whole actuator's inertia (Table "
                         "2 'estimated total' 1.6e-5 kg m2, less the gearhead's 0.7e-7), so a value there is that "
                         "estimate; no source gives more"),
    Unknown("driver.P_q", 10.0, 15.0, 12.5, "W", "the driver's constant consumption, measured 10-15 W (paper 4.2.1)"),
    Unknown("driver.R_on", 0.02, 0.15, 0.05, "Ohm",
            "conduction resistance of the driver's H-bridge: two MOSFETs in series, 10-75 mOhm each for a 70 V, "
            "10 A bridge (EPOS2 70/10, parameters.md)",
            bound_reason=DRIVER_LOSS_IS_CONSTANT + ": the fit takes the conduction resistance to the low end, two "
                         "of the best MOSFETs a 70 V, 10 A bridge is built with (10 mOhm each)"),
    Unknown("driver.k_sw", 0.001, 0.01, 0.004, "1",
            "switching loss per |i| v_bus: (rise + fall time) x PWM frequency / 2 = 40-400 ns x 50 kHz / 2 (EPOS2: "
            "50 kHz PWM, parameters.md)",
            bound_reason=DRIVER_LOSS_IS_CONSTANT + ": the fit takes the switching loss to the low end, the fastest "
                         "switching of the range (40 ns at 50 kHz)"),
    Unknown("controller.k_ff", 0.0, 1.0, 1.0, "1",
            "the bench controller's velocity and acceleration feed-forward, as a fraction of what the unloaded motor "
            "needs (1: the motor's own back-EMF, friction and inertia, AnkleActuator.add_controller; 0: none); an "
            "EPOS2's feed-forward gains are its user's tuning, done near 8 mm on the paper's bench (4.2.1)",
            bound_reason="C7's worst case (over 50 % output loss) needs the arm to lag where the motor cannot "
                         "follow, which the bench controller does only with little feed-forward (feed_forward_trials: "
                         "the worst output loss against k_ff); the lower bound, 0, is a position controller without "
                         "feed-forward, a setting of the EPOS2 user's tuning"),
)

#: the planner's torque tolerance (N m) tried for C8, smallest first (paper 4.1: torque about 10 % of its 100 N m
#: peak below target)
TOLERANCES = (0.0, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0)


def conditions(keys, preset: str, overrides: dict) -> list[Condition]:
    """Protocol conditions for run keys, with the unknowns' values as overrides (a model gets those of its own
    parameters only: the direct drive has no linkage and no planner)."""
    out = []
    for model, P, T in keys:
        sim = compiled(model).sim
        ov = {k: v for k, v in overrides.items() if sim.has_parameter(k)}
        out.append(Condition(P, T, model, preset=preset, overrides=ov))
    return out


def _run(cond: Condition):
    """One protocol run; an integration failure (e.g. a bus that collapses under a demand the supply cannot
    meet) is returned as its message."""
    try:
        return run_condition(cond)
    except SimulationError as e:
        return f"{cond.model}, {cond.P * 1e3:g} mm, {cond.stride_time:g} s: {e}"


class Problem:
    """The residual function of the fit: unknowns scaled to [0, 1] over their ranges -> weighted residuals."""

    def __init__(self, unknowns=UNKNOWNS, targets=TARGETS, fixed: dict | None = None, preset: str = "library",
                 executor=None, targets_paper: dict | None = None):
        self.unknowns, self.targets, self.fixed = tuple(unknowns), tuple(targets), dict(fixed or {})
        self.preset, self.executor = preset, executor
        self.paper = {t.id: (targets_paper or {}).get(t.id, t.paper) for t in self.targets}
        self.keys = sorted({k for t in self.targets for k in t.keys})
        self.lo = np.array([u.lo for u in self.unknowns])
        self.hi = np.array([u.hi for u in self.unknowns])
        self.history: list = []

    def values(self, x) -> dict:
        return {**self.fixed, **{u.name: float(v) for u, v in zip(self.unknowns, self.lo + np.asarray(x)
                                                                   * (self.hi - self.lo))}}

    def scaled(self, values: dict) -> np.ndarray:
        return np.array([(values[u.name] - u.lo) / (u.hi - u.lo) for u in self.unknowns])

    def simulate(self, values: dict, keys=None) -> dict:
        """The runs of ``keys`` (default: the fit's) with parameter ``values``; a run whose integration fails is
        its error message instead of a result."""
        keys = list(keys if keys is not None else self.keys)
        results = sweep(_run, conditions(keys, self.preset, values), executor=self.executor)
        return dict(zip(keys, results))

    def simulated(self, runs: dict) -> dict:
        """Each target's value; NaN for a target whose runs failed (a grid target leaves failed runs out)."""
        ok = {k: r for k, r in runs.items() if not isinstance(r, str)}
        out = {}
        for t in self.targets:
            needed = [k for k in t.keys if k in runs]
            usable = all(k in ok for k in needed) or (t.keys == GRID and any(k in ok for k in needed))
            out[t.id] = float(t.value(ok)) if usable else float("nan")
        return out

    def residuals_of(self, sim: dict) -> np.ndarray:
        """Weighted residuals; a target whose runs failed counts as 30 sigma off (the fit steers away)."""
        return np.array([t.z(sim[t.id], self.paper[t.id]) if math.isfinite(sim[t.id]) else 30.0
                         for t in self.targets])

    def __call__(self, x) -> np.ndarray:
        sim = self.simulated(self.simulate(self.values(x)))
        r = self.residuals_of(sim)
        self.history.append((np.array(x), float(r @ r)))
        return r


@dataclass
class Fit:
    """The inferred values, their uncertainty and what the targets became."""

    values: dict  # unknown -> value (plus the fixed ones)
    sd: dict  # unknown -> linearised standard deviation
    identified: dict  # unknown -> bool
    simulated: dict  # target -> simulated value (on the whole grid for grid targets)
    paper: dict  # target -> the paper's value
    cost: float  # sum of squared weighted residuals
    evaluations: int
    singular_values: list
    unknowns: tuple
    targets: tuple
    failed: list  # runs of the final check whose integration failed (message each)

    def rows(self) -> list[dict]:
        """One row per unknown (value, range, sd, identified, source)."""
        return [dict(parameter=u.name, value=self.values[u.name], unit=u.unit, lo=u.lo, hi=u.hi, start=u.start,
                     sd=self.sd[u.name], identified=self.identified[u.name], source=u.source,
                     **({"bound_reason": u.bound_reason} if u.bound_reason else {}))
                for u in self.unknowns]

    def target_rows(self) -> list[dict]:
        return [dict(target=t.id, claim=t.claim, paper=self.paper[t.id], simulated=self.simulated[t.id],
                     sigma=t.sigma, relative=t.relative, bound=t.bound,
                     z=t.z(self.simulated[t.id], self.paper[t.id]))
                for t in self.targets]

    def preset(self) -> dict:
        """The parameter overrides of the ``paper_fit`` preset."""
        return {k: float(v) for k, v in self.values.items()}

    def to_json(self) -> dict:
        return dict(preset=self.preset(), unknowns=self.rows(), targets=self.target_rows(), cost=self.cost,
                    evaluations=self.evaluations, singular_values=self.singular_values, failed=self.failed)


def _uncertainty(problem: Problem, jac: np.ndarray, x: np.ndarray):
    """Standard deviations (in parameter units) and identifiability from the scaled Jacobian: the diagonal of
    ``(J^T J)^-1`` from its singular values, a direction with a (numerically) zero singular value giving an
    infinite deviation to every unknown that moves along it. An unknown on a bound is held there (the optimum's
    active constraint): the free unknowns' deviations are those with it fixed, and its own is that of the whole
    Jacobian (the deviation it would have were it free). The singular values are the whole Jacobian's."""
    span = problem.hi - problem.lo
    at_bound = (x <= 1e-3) | (x >= 1 - 1e-3)

    def deviations(columns):
        _, s, vt = np.linalg.svd(jac[:, columns], full_matrices=False)
        flat = s <= 1e-10 * s.max() if s.size and s.max() > 0 else np.ones_like(s, dtype=bool)
        v = vt.T  # columns: directions in the scaled unknowns
        finite = np.sum((v[:, ~flat] / s[~flat]) ** 2, axis=1)
        return np.where(np.any(np.abs(v[:, flat]) > 1e-6, axis=1), np.inf, np.sqrt(finite)), s

    sd_scaled, s = deviations(np.arange(x.size))
    free = np.flatnonzero(~at_bound)
    if free.size and free.size < x.size:
        sd_scaled[free] = deviations(free)[0]
    sd = {u.name: float(v * w) for u, v, w in zip(problem.unknowns, sd_scaled, span)}
    identified = {u.name: bool(v < 0.25 and not b) for u, v, b in zip(problem.unknowns, sd_scaled, at_bound)}
    return sd, identified, [float(v) for v in s]


#: the finite-difference step of the fit's Jacobian, in each unknown's scaled range [0, 1]
FD_STEP = 1e-3


def fit(unknowns=UNKNOWNS, targets=TARGETS, fixed: dict | None = None, start: dict | None = None,
        executor=None, reduce_grid: bool = True, max_nfev: int = 15, targets_paper: dict | None = None,
        progress: Callable | None = None) -> Fit:
    """Weighted least squares of ``targets`` over ``unknowns`` (module docstring). ``fixed``: other overrides held
    (e.g. the torque tolerance); ``start``: starting values (default each unknown's ``start``);
    ``targets_paper``: replace the paper's numbers (tests: numbers computed by the model itself)."""
    from scipy.optimize import least_squares

    problem = Problem(unknowns, targets, fixed, executor=executor, targets_paper=targets_paper)
    x0 = problem.scaled({u.name: (start or {}).get(u.name, u.start) for u in problem.unknowns})
    if reduce_grid and any(k in GRID for k in problem.keys) and not any(t.id in WHOLE_GRID for t in problem.targets):
        runs = problem.simulate(problem.values(x0))
        grid = {k: r for k, r in runs.items() if k in GRID and not isinstance(r, str)}
        keep = {min(grid, key=lambda k: driver_loss(grid[k])), max(grid, key=lambda k: driver_loss(grid[k]))}
        keep |= {k for t in problem.targets if t.keys != GRID for k in t.keys}
        problem.keys = sorted(k for k in problem.keys if k not in GRID or k in keep)

    last = {}

    def fun(x):
        r = problem(x)
        last.update(x=np.array(x, dtype=float), r=r)
        if progress:
            progress(len(problem.history), problem.values(x), float(r @ r))
        return r

    def jac(x):
        # forward differences with an absolute step of 1e-3 of each unknown's range, inward at a bound (scipy's
        # diff_step is relative to x: at an unknown starting on its bound, such as a friction torque at 0, the step
        # would be 1e-13 of the range and the difference all integration noise)
        x = np.asarray(x, dtype=float)
        r0 = last["r"] if "x" in last and np.array_equal(last["x"], x) else problem(x)
        J = np.empty((r0.size, x.size))
        for i in range(x.size):
            h = FD_STEP if x[i] + FD_STEP <= 1.0 else -FD_STEP
            xi = x.copy()
            xi[i] += h
            J[:, i] = (problem(xi) - r0) / h
        return J

    # max_nfev counts steps, not the Jacobian's finite differences (one evaluation per unknown each)
    sol = least_squares(fun, x0, jac=jac, bounds=(0.0, 1.0), x_scale=1.0, max_nfev=max_nfev, xtol=1e-4,
                        ftol=1e-5)
    values = problem.values(sol.x)
    sd, identified, sv = _uncertainty(problem, sol.jac, sol.x)
    check_keys = sorted({k for t in problem.targets for k in t.keys})  # the whole grid again
    runs = problem.simulate(values, check_keys)
    simulated = problem.simulated(runs)
    r = problem.residuals_of(simulated)
    return Fit(values, sd, identified, simulated, dict(problem.paper), float(r @ r), len(problem.history), sv,
               problem.unknowns, problem.targets, [r for r in runs.values() if isinstance(r, str)])


def feasibility(values: dict, tolerance: float, executor=None) -> dict:
    """Required duty over the replay grid with the planner's ``torque_tolerance`` (C8's reading)."""
    keys = list(PLAN_GRID)
    runs = sweep(_run, conditions(keys, "library", {**values, "torque_tolerance": tolerance}), executor=executor)
    # a run that failed did not follow
    duty = {(round(P * 1e3, 6), T): (math.inf if isinstance(r, str) else r.max_duty)
            for (_, P, T), r in zip(keys, runs)}
    return dict(tolerance=tolerance, **follows_as_in_the_paper(duty))


def choose_tolerance(values: dict, executor=None, tolerances=TOLERANCES) -> tuple[float, list]:
    """The smallest torque tolerance with which C8 holds (the last tried when none does), and every trial."""
    trials = []
    for tol in tolerances:
        trials.append(feasibility(values, tol, executor))
        if trials[-1]["holds"]:
            return tol, trials
    best = max(trials, key=lambda t: (t["duty_18mm_1p2s"] > D_MAX, t["follows"]))
    return best["tolerance"], trials


#: the bench controller's feed-forward fractions tried at the fitted values (what C6 and C7 trade against each other)
FEED_FORWARDS = (0.0, 0.25, 0.5, 0.75, 1.0)


def feed_forward_trials(values: dict, executor=None, fractions=FEED_FORWARDS) -> list[dict]:
    """The bench grid's gearing and output losses (Figs. 11-12: C6, C7) with the other fitted ``values`` and the
    controller's feed-forward fraction ``controller.k_ff`` set to each of ``fractions``: how the mean output loss
    and the corners' losses move together with the arm's tracking."""
    rows = []
    for k_ff in fractions:
        runs = {k: r for k, r in zip(GRID, sweep(_run, conditions(GRID, "library", {**values, "controller.k_ff": k_ff}),
                                                 executor=executor)) if not isinstance(r, str)}
        gearing, output = stage_loss("gearing"), stage_loss("output")
        rows.append(dict(k_ff=k_ff, runs=len(runs), output_loss_mean=grid_mean(output)(runs),
                         output_loss_worst=grid_extreme(max, output)(runs),
                         gearing_loss_min=grid_extreme(min, gearing)(runs),
                         gearing_loss_corner=grid_extreme(max, gearing, in_corner)(runs),
                         tracking_max_rad=max(r.tracking_max for r in runs.values())))
    return rows


#: the planner's torque tolerance of the first pass (N m), before C8 chooses it
FIRST_TOLERANCE = 3.0


#: what a record's targets are (written into every record; the history of the shipped one is in its own note)
CALIBRATION_SET = ("declared in acausal.models.ankle.claims (CALIBRATION: each claim a target, a testable prediction, a "
                   "prediction in name only or not testable from the published text, with the paper's sentence that "
                   "decides it); this record's targets and tolerance_trials are the fit of the declared targets")


def calibration_set(left_out=()) -> str:
    """What a record's targets are: the declared ones (:data:`CALIBRATION_SET`), or, for a trial, those less the
    targets of the claims ``left_out``."""
    if not left_out:
        return CALIBRATION_SET
    return CALIBRATION_SET + f" less those of {', '.join(left_out)} (a trial: acausal infer --without)"


def targets_without(claims=()) -> tuple:
    """The fit's targets (:data:`~acausal.models.ankle.targets.TARGETS`) less those of ``claims`` (e.g. ``("C3",)``:
    the fit that tries C3 as a prediction); a claim that is no fitted target is refused, naming the ones there are
    (C8 is met by the planner's tolerance, chosen after every fit)."""
    fitted = sorted({t.claim for t in TARGETS}, key=lambda c: int(c[1:]))
    for c in claims:
        if c not in fitted:
            raise ModelError(f"{c} is no target of the fit; its targets are those of {', '.join(fitted)} (C8 is met "
                             "by the planner's torque tolerance, chosen after every fit)")
    return tuple(t for t in TARGETS if t.claim not in set(claims))


def infer(executor=None, progress: Callable | None = None, max_nfev: int = 15, start: dict | None = None,
          without=()) -> dict:
    """The whole inference: fit at :data:`FIRST_TOLERANCE`, choose the planner's torque tolerance for C8 on the
    fitted values and, if it differs from the one fitted with, refit with it and choose again on the refitted values
    (a refit moves the duties a little), until the tolerance chosen is the one the values were fitted with (at
    most three rounds). ``start``: the values the first pass starts from (default each unknown's a-priori
    ``start``), e.g. an earlier record's preset after a change of targets; its ``torque_tolerance``, if any, is then
    the first pass's. ``without``: claims whose targets are left out (:func:`targets_without`), to see whether they
    hold as predictions. Returns the JSON record (``started_from``: "a priori" or "given values"; ``left_out``: the
    claims left out)."""
    start, targets = dict(start or {}), targets_without(without)
    first = fit(targets=targets, fixed={"torque_tolerance": start.pop("torque_tolerance", FIRST_TOLERANCE)},
                start=start or None, executor=executor, progress=progress, max_nfev=max_nfev)
    final, tried = first, []
    for _ in range(3):
        tol, trials = choose_tolerance(final.values, executor)
        tried += trials
        if tol == final.values["torque_tolerance"]:
            break  # C8's tolerance, checked on the values fitted with it
        final = fit(targets=targets, fixed={"torque_tolerance": tol}, start=final.values, executor=executor,
                    progress=progress, max_nfev=max_nfev)
    tol = final.values["torque_tolerance"]
    record = final.to_json()
    record["preset"]["torque_tolerance"] = tol
    record["tolerance_trials"] = tried
    record["feed_forward_trials"] = feed_forward_trials(final.values, executor)
    record["first_pass"] = first.to_json()
    record["started_from"] = "given values" if start else "a priori"
    record["left_out"] = sorted(without, key=lambda c: int(c[1:]))
    record["calibration_set"] = calibration_set(record["left_out"])
    return record
