"""The paper's results in one report: the conditions ``acausal paper`` runs, helpers the example scripts share
(pick a condition out of a sweep, run what is missing, compare with the paper, heat maps), and
:func:`write_report`, which assembles ``report.md`` and ``protocol.csv`` from the examples' outputs (tables and
CSV through :mod:`acausal.models.reporting.tables`).

The headline runs the ``paper_fit`` preset (:data:`HEADLINE`): the library's components with the parameters the
paper does not publish inferred from the numbers it does (:mod:`acausal.models.ankle.inference`; the claims its
record was fitted to are marked in ``claims.csv``); every other number is a prediction. The a-priori ``library`` preset (:data:`BESIDE`: datasheet motor,
catalogue gear efficiency, lossless linkage, the paper's measured driver draw and the assumptions listed in
:data:`ASSUMPTIONS`) runs the same grids beside it. Each grid condition runs twice: on the bench
(:data:`~acausal.models.ankle.protocol.BENCH`, the closed loop: what the paper measured) and replayed (the duty the
plan requires).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..reporting.tables import md_table, pct, write_csv
from .claims import (C11_GAIN, DRIVER_TOL, FRAGILE, IN_NAME_ONLY, NOT_TESTABLE, TARGET, TESTABLE, declared_targets,
                     evaluate as evaluate_claims)
from .fit_record import (NEAR_BOUND, bounds_markdown, fitted_claims, markdown as inference_markdown, near_bounds,
                         trials)
from .presets import MOTOR_DATASHEET, paper_fit_record
from .protocol import (BENCH, D_MAX, POINTS, PRECOMPRESSIONS, STRIDE_TIMES, Condition, StrideResult, as_grid,
                       run_condition, sweep)

#: every time series the examples plot (names a model lacks are skipped by ``run_condition``)
TRACES = ("arm_ref.y.value", "arm_angle.phi.value", "motor.i")


#: the reduced grid of ``acausal paper --quick`` (for tests)
QUICK_PRECOMPRESSIONS = [0.005, 0.008, 0.018]
QUICK_STRIDE_TIMES = [1.2, 2.0, 3.0]

#: the preset of the report's headline and the a-priori one shown beside it
HEADLINE, BESIDE = "paper_fit", "library"

#: Table 2's Eq. 4 presets (models/ankle/presets.py), in the paper's column order
TABLE2_PRESETS = ["paper_datasheet", "paper_estimated_total", "paper_optimized_total_as_printed",
                  "paper_optimized_total_arm_side"]

#: what neither the paper nor the inference fixes, and how the inference's choices act (named in the report where
#: sim and paper differ > 25 %); the driver's and the motor's, which depend on what the inference fitted, are
#: written from its record (:func:`assumptions`)
ASSUMPTIONS = {
    "gears": "the planetary's mesh efficiency and output drag are inferred (ranges: catalogue 55-75 %, 0-15 mN m at "
             "the motor); the helical stage's 90 % is assumed; the mesh efficiency is the same in every condition, "
             "so the gearing loss varies over the grid only through the drag",
    "maccepa": "the linkage friction grows with the spring force (FrictionalMaccepa, radius inferred); the planned "
               "trajectory inverts the lossless linkage, so the joint torque falls short by the friction torque, "
               "as the paper's about 10 % (4.1); bending and backlash of the real linkage are not modelled",
    "geometry": "the lever lengths A = 0.10 m, B = 0.06 m are assumptions (not published); the body mass scaling "
                "the gait torque is inferred from Table 1",
    "supply": "the supply is assumed 48 V (the motor's nominal; not stated in the paper); where the motor stops "
              "following (required duty > 0.9) is set by it and by the planner's inferred torque tolerance",
    "direct_drive": "the paper's direct drive, the bench's output motor, is modelled as a drive that imposes the gait "
                    "angle while the actuator pushes the joint; its drive train is not published and is guessed as "
                    "the actuator's own motor, driver and 860:1 gears (4.1: it delivered about 10 % less than the "
                    "target torque)",
    "first_experiment": "the paper's Fig. 7 comes from 'one of the first experiments' before the driver was tuned: "
                        "its 122 J/stride at 3 s is about twice Table 1's 64.5 J at 2 s, more than the constant "
                        "driver draw (12.5 W x 1 s = 12.5 J) explains, so the simulation is compared with it only "
                        "as an order of magnitude",
    "closed_loop": "the bench's controller is a PID (kp = 400, ki = 2000, kd = 2, assumed) with the velocity and "
                   "acceleration feed-forward of the paper's EPOS2 position mode (4.2.1), limited to 0.9 of the bus "
                   "voltage; its gains are not published, the feed-forward's fraction k_ff is inferred. Its lag "
                   "sets the bench's losses at high precompression and short strides",
}


def paper_conditions(quick: bool = False) -> list[Condition]:
    """Every condition ``acausal paper`` simulates, in the report's order (grids, direct drive, Table 2)."""
    Ps, Ts = (QUICK_PRECOMPRESSIONS, QUICK_STRIDE_TIMES) if quick else (PRECOMPRESSIONS, STRIDE_TIMES)
    pts = 101 if quick else 201
    conds = [Condition(P, T, model, p, points_per_stride=pts) for model in ("replay", BENCH)
             for p in (HEADLINE, BESIDE) for P in Ps for T in Ts]
    conds += [Condition(0.008, 3.0, m, p, points_per_stride=pts) for m in ("bench_output_motor", "direct_drive")
              for p in (HEADLINE, BESIDE)]
    conds += [Condition(0.008, 2.0, preset=p, points_per_stride=pts) for p in TABLE2_PRESETS]
    return conds


def run_all(conditions, progress: bool = True, executor=None) -> list[StrideResult]:
    """One sweep over ``conditions`` keeping the traces every example plots; the results in the order of
    ``conditions``. The pool gets the Table 2 presets first: the as-printed one cannot follow (duty about 150) and
    is the longest run of all (2.3 s against at most 1 s); last in the queue, it kept one worker busy while the
    other had nothing left."""
    order = sorted(range(len(conditions)), key=lambda i: conditions[i].preset not in TABLE2_PRESETS)
    done = sweep([conditions[i] for i in order], executor=executor, progress=progress, traces=TRACES)
    results = [None] * len(conditions)
    for i, r in zip(order, done):
        results[i] = r
    return results


def _same(r: StrideResult, P, T, model, preset_name) -> bool:
    c = r.condition
    return (c.model == model and c.preset == preset_name and math.isclose(c.stride_time, T)
            and (model == "direct_drive" or math.isclose(c.P, P)))


def pick(results, P: float, T: float, model: str = "replay", preset: str = HEADLINE,
         traces: tuple = ()) -> StrideResult:
    """The result of one condition out of ``results`` (any list of StrideResult, or None); a condition that is
    missing (or lacks one of ``traces``) is simulated here."""
    for r in results or ():
        if _same(r, P, T, model, preset) and all(name in r.traces for name in traces):
            return r
    return run_condition(Condition(P, T, model, preset), traces=tuple(traces) or TRACES)


def grid(results, model: str = BENCH, preset: str = HEADLINE, progress: bool = True) -> list[StrideResult]:
    """The results of ``model`` (default the bench) over precompression x stride time found in ``results``; with
    none there, the paper's 36 conditions are run (one sweep)."""
    found = [r for r in results or () if r.condition.model == model and r.condition.preset == preset]
    if not found:
        found = run_all([Condition(P, T, model, preset) for P in PRECOMPRESSIONS for T in STRIDE_TIMES],
                        progress=progress)
    return found


def required_duty(results, preset: str = HEADLINE) -> dict:
    """{(P [m], T [s]): the duty the replay of that condition requires} (the replay grid, run if missing): where
    it exceeds the driver's 0.9 the motor cannot follow the plan at the bus voltage (C8)."""
    return {(r.condition.P, r.condition.stride_time): r.max_duty for r in grid(results, "replay", preset)}


def duty_of(r: StrideResult, duty: dict | None = None) -> float:
    """The duty the plan of ``r``'s condition requires: ``duty`` (as :func:`required_duty` gives it) at its
    precompression and stride time, or the result's own when None."""
    return r.max_duty if duty is None else duty[(r.condition.P, r.condition.stride_time)]


def followed(results, duty: dict) -> list[StrideResult]:
    """The results of the conditions where the motor can follow the plan (``duty`` as :func:`required_duty` gives
    it: the replay's required duty within the driver's limit)."""
    return [r for r in results if duty_of(r, duty) <= D_MAX]


def infeasible(results, preset: str = HEADLINE) -> list[StrideResult]:
    """Replay conditions (of one preset) whose required duty exceeds the driver's 0.9: the motor could not
    follow there."""
    return [r for r in results if r.condition.model == "replay" and r.condition.preset == preset
            and r.max_duty > D_MAX]


def rms(x) -> float:
    """rms over one periodic stride sampled at both ends (the last sample repeats the first)."""
    x = np.asarray(x, dtype=float)[:-1]
    return float(np.sqrt(np.mean(x**2)))


# ---------------------------------------------------------------------------------------------- files, tables

def comparison(quantity: str, sim: float, paper: float, unit: str, assumption=None, fmt: str = ".3g",
               note: str = "") -> dict:
    """One simulation-vs-paper number. ``assumption`` (a key of ASSUMPTIONS, or a list of keys) is named, with
    ``note``, when they differ by more than 25 %."""
    if abs(sim) < 1e-9 * max(1.0, abs(paper)):
        sim = 0.0  # round-off of a quantity that is zero in the model
    ratio = sim / paper if paper else float("nan")
    differs = (not paper and abs(sim) > 1e-9) or (paper and abs(ratio - 1.0) > 0.25)
    return dict(quantity=quantity, sim=float(sim), paper=float(paper), unit=unit, ratio=ratio,
                differs=bool(differs), assumption=assumption, fmt=fmt, note=note)


def _fmt(v, fmt, unit):
    if unit == "%":
        return pct(v)
    return f"{v:{fmt}} {unit}".rstrip()


def comparison_table(comps: list[dict]) -> str:
    rows = []
    for c in comps:
        ratio = "-" if math.isnan(c["ratio"]) else f"{c['ratio']:.2f}"
        flag = " **(> 25 %)**" if c["differs"] else ""
        rows.append([c["quantity"], _fmt(c["sim"], c["fmt"], c["unit"]), _fmt(c["paper"], c["fmt"], c["unit"]),
                     ratio + flag])
    return md_table(["quantity", "simulation", "paper", "ratio sim/paper"], rows)


def _in_range(u: dict) -> str:
    """An inferred value with its place in its range: ``"driver.R_on = 0.0255 (4 % of 0-0.5)"``."""
    frac = (u["value"] - u["lo"]) / (u["hi"] - u["lo"])
    return f"{u['parameter']} = {u['value']:.3g} ({100 * frac:.0f} % of {u['lo']:g}-{u['hi']:g})"


#: the order the report lists the assumptions in
_ASSUMPTION_ORDER = ("driver", "gears", "maccepa", "geometry", "supply", "motor", "direct_drive", "first_experiment",
                     "closed_loop")
#: the motor's datasheet parameters the report names: (word, symbol, unit)
_MOTOR_WORDS = {"motor.R": ("resistance", "R", "ohm"), "motor.J": ("inertia", "J", "kg m2"),
                "motor.b": ("friction", "b", "N m s/rad")}


def assumptions(record: dict | None = None) -> dict:
    """:data:`ASSUMPTIONS` with the driver's and the motor's, written from the inference's ``record``
    (``paper_fit.json``): which of their values the inference fitted, where in its range each ended and whether the
    data identified it, and which are the datasheet's."""
    record = paper_fit_record() if record is None else record
    fitted = {u["parameter"]: u for u in record["unknowns"]}
    driver = [u for k, u in fitted.items() if k.startswith("driver.")]
    said = ("all unidentified" if driver and not any(u["identified"] for u in driver) else
            "identified: " + ", ".join(u["parameter"] for u in driver if u["identified"]))
    driver_text = ("the driver's constant draw (within the paper's measured 10-15 W), bridge resistance and "
                   "switching-loss coefficient are " + (f"inferred ({'; '.join(map(_in_range, driver))}; {said})"
                                                        if driver else "the library's")
                   + "; the rectifier returns nothing; the paper's driver was tuned near 8 mm (4.2.1), ours has no "
                   "tuning-dependent loss")
    sheet = [k for k in _MOTOR_WORDS if k not in fitted]
    motor_text = ("the motor's " + " and ".join(_MOTOR_WORDS[k][0] for k in sheet) + " are datasheet values at "
                  "25 degC (" + ", ".join(f"{_MOTOR_WORDS[k][1]} = {f'{MOTOR_DATASHEET[k]:g}'.replace('e-0', 'e-')} "
                                          f"{_MOTOR_WORDS[k][2]}" for k in sheet) + ")"
                  if sheet else "none of the motor's values are the datasheet's")
    inferred = [k for k in _MOTOR_WORDS if k in fitted]
    if inferred:
        motor_text += "; its " + " and ".join(_MOTOR_WORDS[k][0] for k in inferred) + " is inferred (" + "; ".join(
            _in_range(fitted[k]) for k in inferred) + ")"
    motor_text += ", with no winding heating and no cable resistance"
    written = {"driver": driver_text, "motor": motor_text}
    return {k: written.get(k, ASSUMPTIONS.get(k)) for k in _ASSUMPTION_ORDER}


def inferred_from(record: dict | None = None) -> str:
    """The claims whose numbers the inference fitted, each with the paper's section: ``"C1 (Table 1), ..."``."""
    from .claims import CLAIMS
    record = paper_fit_record() if record is None else record
    ids = sorted(fitted_claims(record), key=lambda c: int(c[1:]))
    where = {c.id: c.section for c in CLAIMS}
    return ", ".join(f"{c} ({where.get(c, 'the paper')})" for c in ids)


def explanations(comps: list[dict]) -> str:
    """A sentence per quantity that differs by more than 25 %, naming the assumption that drives it."""
    out = []
    for c in comps:
        if c["differs"] and c["assumption"]:
            keys = c["assumption"] if isinstance(c["assumption"], (list, tuple)) else [c["assumption"]]
            why = "; and ".join(assumptions()[k] for k in keys)
            note = f" {c['note']}" if c.get("note") else ""
            out.append(f"- *{c['quantity']}* differs by more than 25 % "
                       f"({_fmt(c['sim'], c['fmt'], c['unit'])} vs {_fmt(c['paper'], c['fmt'], c['unit'])}): "
                       f"{why}.{note}")
    return "\n".join(out)


# ---------------------------------------------------------------------------------------------- the report

def write_report(out_dir: Path, results: list[StrideResult], outputs: list[dict], quick: bool = False,
                 elapsed: float | None = None) -> Path:
    """Write ``out_dir/report.md`` (every table, every figure, simulation next to the paper) and
    ``out_dir/protocol.csv`` (one row per simulated condition). ``outputs`` are the dictionaries the example
    scripts' ``main`` return (keys ``title``, ``figures``, ``csv``, ``markdown``, ``comparisons``)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    write_csv(out_dir / "protocol.csv", [r.row() for r in results])
    traces = power_trace_rows(results)
    if traces:
        write_csv(out_dir / "power_traces.csv", traces)

    replays = [r for r in results if r.condition.model == "replay" and r.condition.preset == HEADLINE]
    Ps = sorted({r.condition.P for r in replays})
    Ts = sorted({r.condition.stride_time for r in replays})
    bad = infeasible(results)

    L = ["# CYBERLEGs ankle actuator: the paper's results in simulation", ""]
    L += ["Reproduces section 4 of *cyberlegs-maccepa-energetics* (Table 1, Figs. 7-17, Table 2) with "
          "`acausal.models.ankle.actuator` on the embedded healthy-gait data (Winter 1991), in two ways. What the "
          f"paper measured on its bench (Table 1, Figs. 8-12, 15) is simulated as the bench ran it ({BENCH}): the "
          "joint moved along the gait, the actuator's position controller tracking the planned moment-arm angle "
          "within the driver's voltage, so that where the motor cannot follow, the arm lags (Fig. 13). The replay "
          "(the paper's Simulink approach: joint and arm angles prescribed, the compiler derives the motor current, "
          "every voltage and every power) gives the duty the plan requires (where the motor can follow, C8), "
          "Fig. 7 and Table 2. The motor point is the power the paper computes from the motor current and speed, "
          "k i w (its Eq. 6): the rotor's friction counts in the gearing stage.", ""]
    L += [f"- grid: precompression {', '.join(f'{1e3 * P:g}' for P in Ps)} mm x stride time "
          f"{', '.join(f'{T:g}' for T in Ts)} s ({len(replays)} conditions, each on the bench and replayed"
          + ("; **quick mode: reduced grid and resolution, for tests**" if quick else "") + f"); "
          f"{len(results)} simulated conditions in all" + (f", {elapsed:.1f} s wall time" if elapsed else "") + ".",
          f"- parameters: the `{HEADLINE}` preset unless a section says otherwise: the library's components with "
          "the parameters the paper does not publish inferred from the numbers it does (claims "
          f"{', '.join(sorted(fitted_claims(paper_fit_record()), key=lambda c: int(c[1:])))}; "
          "section *Inferred parameters*), each inside its documented range. Every other number is a prediction. "
          f"The a-priori `{BESIDE}` preset (datasheet and catalogue values, lossless linkage, the assumptions "
          "below, nothing fitted) runs the same grids; Table 1, Fig. 7 and the claims show it beside.",
          "- the evaluated stride is the last one simulated (" + ", ".join(
              f"{m}: {n:g} strides" for m, n in sorted({(r.condition.model, r.condition.strides) for r in results}))
          + "), so the bus and, in closed loop, the controller have settled.", ""]
    record = paper_fit_record()
    claims = evaluate_claims(out_dir, HEADLINE, fitted_claims(record))
    beside = evaluate_claims(out_dir, BESIDE)
    write_csv(out_dir / "claims.csv", claims + beside)
    L += fair_bar(claims, record)
    L += [f"## Inferred parameters (`{HEADLINE}`)", "",
          f"What the paper does not publish, inferred from the numbers of claims {inferred_from(record)} by "
          "weighted least squares over the protocol (`acausal.models.ankle.inference`; rerun with `acausal infer "
          "--out DIR`):", "",
          inference_markdown(record), ""]
    L += ["## Assumptions (what neither the paper nor the inference fixes)", ""]
    L += [f"- **{k}**: {v}." for k, v in assumptions(record).items()]
    L += [""]

    comps = []
    for o in outputs:
        L += [f"## {o['title']}", ""]
        if o.get("markdown"):
            L += [o["markdown"], ""]
        for fig in o.get("figures", []):
            L += [f"![{Path(fig).stem}]({_rel(out_dir, fig)})", ""]
        if o.get("comparisons"):
            L += ["Simulation next to the paper:", "", comparison_table(o["comparisons"]), ""]
            why = explanations(o["comparisons"])
            if why:
                L += ["Where they differ by more than 25 %, the assumption that drives it:", "", why, ""]
            comps += o["comparisons"]
        if o.get("csv"):
            L += ["Data behind it: " + ", ".join(f"[`{_rel(out_dir, c)}`]({_rel(out_dir, c)})" for c in o["csv"]), ""]

    L += ["## Energy balance and feasibility", ""]
    lib = [r for r in results if r.condition.preset in (HEADLINE, BESIDE)]
    other = [r for r in results if r.condition.preset not in (HEADLINE, BESIDE)]
    worst = max(lib or results, key=lambda r: abs(r.balance_residual))
    L += [f"Energy balance per condition, (source - losses - output - stored change) / source over the evaluated "
          f"stride: the largest |residual| over the {len(lib)} `{HEADLINE}` and `{BESIDE}` conditions (bench and "
          f"replay grids, direct drive) is **{abs(worst.balance_residual):.1e}** ({_label(worst.condition)}).",
          ""]
    if other:
        w2 = max(other, key=lambda r: abs(r.balance_residual))
        L += [f"Over the {len(other)} Table 2 (Eq. 4) preset runs it is **{abs(w2.balance_residual):.1e}** "
              f"({_label(w2.condition)})"
              + (": above the 1e-6 target; their energies are good to about that fraction." if
                 abs(w2.balance_residual) > 1e-6 else "."), ""]
    if bad:
        L += [f"The replay needs more than the driver's duty limit {D_MAX} at 48 V in {len(bad)} of {len(replays)} "
              f"grid conditions: there the motor could not follow the planned trajectory (the paper's 'limit of "
              f"the motor velocity', 4.2.3; Fig. 13 shows it in closed loop). Their energies are what the "
              f"trajectory would cost, not what the bench could do; they are hatched in the figures.", ""]
        L += [md_table(["precompression [mm]", "stride time [s]", "required duty", "peak motor speed [rad/s]"],
                       [[f"{1e3 * r.condition.P:g}", f"{r.condition.stride_time:g}", f"{r.max_duty:.2f}",
                         f"{r.peak_motor_speed:.0f}"]
                        for r in sorted(bad, key=lambda r: (r.condition.P, r.condition.stride_time))]), ""]
    else:
        L += [f"The motor can follow in every replay condition (required duty <= {D_MAX}).", ""]

    n_diff = sum(c["differs"] for c in comps)
    L += ["## Summary of the comparison", "",
          f"{len(comps)} numbers compared with the paper; {n_diff} differ by more than 25 % (each with the "
          f"assumption that drives it, above).", ""]
    held = sum(c["holds"] == "yes" for c in claims)
    held_beside = sum(c["holds"] == "yes" for c in beside)
    unchecked = sum(c["holds"] == "not checked" for c in claims)
    L += ["## Claims", "",
          f"The paper's claims, each checked on the CSV files of this run (`acausal.models.ankle.claims`): "
          f"**{held} of {len(claims)} hold** with `{HEADLINE}`"
          + (f", {unchecked} not checked on this run" if unchecked else "")
          + f"; {held_beside} of {len(beside)} with the a-priori `{BESIDE}`. *fit*: the claim's numbers are "
          f"targets of the inference; every other claim is a prediction. A claim that does not hold says by how "
          "much; no parameter leaves its documented range to make one hold. Which of them are testable predictions, "
          "their margins and the fragile ones: the first section, *Calibration set and the bar*.", "",
          md_table(["id", "claim", "paper", f"`{HEADLINE}`", "holds", "fit", f"`{BESIDE}`", "holds",
                    "how it is read; what opposes it"],
                   [[c["id"], c["statement"], c["paper"], c["simulated"], f"**{c['holds']}**", c["used_in_fit"],
                     b["simulated"], b["holds"], c["note"]] for c, b in zip(claims, beside)]), ""]
    if not quick:
        L += c11_markdown(c11_readings(out_dir))
    L += ["## Files", "", "- [`protocol.csv`](protocol.csv): one row per simulated condition (energies at the "
          "five points, stage losses, peak powers, efficiency, balance residual, tracking error, required duty).",
          "- [`claims.csv`](claims.csv): the paper's claims, the simulated value and whether each holds."]
    L += ["- [`c11_readings.csv`](c11_readings.csv): C11's optimum under each reading of the efficiency."] \
        if not quick else []
    L += ["- [`power_traces.csv`](power_traces.csv): power at the five points over the evaluated stride, per bench "
          "condition of both presets."] if traces else []
    verdicts = [r for o in outputs for r in o.get("verdicts", [])]  # each section's (figures.run_section)
    if verdicts:
        write_csv(out_dir / "figure_verdicts.csv", verdicts)
        L += ["- [`figure_verdicts.csv`](figure_verdicts.csv): each trend the paper's text states about a figure, "
              "whether the model shows it and the caption's sentence (what the model gives; why, where it differs)."]
    from ..reporting.explorer import write_index  # the page reads the CSVs written above
    L += [write_index(out_dir)]
    for o in outputs:
        for f in [*o.get("figures", []), *o.get("csv", [])]:
            L += [f"- [`{_rel(out_dir, f)}`]({_rel(out_dir, f)})"]
    path = out_dir / "report.md"
    path.write_text("\n".join(L) + "\n")
    return path


def headline(claims: list[dict]) -> str:
    """"N of M testable predictions hold" over the claims rows of one preset (:func:`~acausal.models.ankle.claims.
    evaluate`), and whether that is at least half; the fragile ones among them named."""
    testable = [c for c in claims if c["role"] == TESTABLE]
    held = [c for c in testable if c["holds"] == "yes"]
    fragile = [c["id"] for c in held if c["fragile"] == "yes"]
    half = "at least half" if 2 * len(held) >= len(testable) else "fewer than half"
    return (f"**{len(held)} of {len(testable)} testable predictions hold** ({half}"
            + (f"; fragile: {', '.join(fragile)}" if fragile else "") + ")")


def fair_bar(claims: list[dict], record: dict) -> list[str]:
    """The report's first section: the calibration set (each claim's class with the paper's sentence that decides
    it), the value, the margin to the tightest of its limits and "fragile"; the headline; the fitted values near a
    bound of their range and the identifiability of each."""
    by_role = {role: [c["id"] for c in claims if c["role"] == role]
               for role in (TARGET, TESTABLE, IN_NAME_ONLY, NOT_TESTABLE)}
    targets_held = sum(c["holds"] == "yes" for c in claims if c["role"] == TARGET)
    fitted, declared = fitted_claims(record), declared_targets()
    agree = ("The record's targets (`paper_fit.json`: `targets`, and `tolerance_trials` for C8) are the declared ones."
             if fitted == declared else
             f"**The record's targets ({', '.join(sorted(fitted))}) are not the declared ones "
             f"({', '.join(sorted(declared))})**: the fit is of another calibration set.")
    L = [f"## Calibration set and the bar (`{HEADLINE}`)", "",
         f"{headline(claims)} with `{HEADLINE}`; {targets_held} of {len(by_role[TARGET])} targets hold (they were "
         f"fitted, so that they hold says the fit reached them, not that the model predicts them); "
         f"{len(by_role[IN_NAME_ONLY])} prediction in name only ({', '.join(by_role[IN_NAME_ONLY])}), "
         f"{len(by_role[NOT_TESTABLE])} not testable from the published text ({', '.join(by_role[NOT_TESTABLE])}).", "",
         "Each claim's class is declared in `acausal.models.ankle.claims` (`CALIBRATION`), with the paper's sentence "
         "that decides it: a *target* is fitted (`acausal.models.ankle.targets`); a *testable prediction* depends only "
         "on what the paper publishes; a claim is *not testable from the published text* where it rests on what the "
         "paper does not publish. " + agree
         + (f" The record: {record['calibration_set']}." if record.get("calibration_set") else ""), "",
         f"*margin*: the tightest of the claim's limits (its reading in `claims.py`), with the fraction of that "
         f"limit's tolerance to spare (a band's half width; a bound the paper states without a tolerance, its own "
         f"size; C3's bowl depth against the {100 * DRIVER_TOL:g} points C2 reads the driver loss with, C12's rise "
         f"against the mean efficiency at 1.2 s; C5 states a direction and has none); *fragile*: it holds with less "
         f"than {100 * FRAGILE:g} % of that tolerance to spare.", "",
         md_table(["id", "class", "the paper's sentence that decides it", "why", "value", "holds", "margin",
                   "fragile"],
                  [[c["id"], c["role"], f"\"{c['quote']}\"", c["why"], c["simulated"], f"**{c['holds']}**",
                    c["margin"], "**fragile**" if c["fragile"] == "yes" else c["fragile"]] for c in claims]), ""]
    L += trials_markdown(trials())
    near = near_bounds(record)
    unreasoned = [b["parameter"] for b in near if not b["reason"]]
    listed = ", ".join(f"`{b['parameter']}` at {100 * b['place']:.1f} % ({b['bound']}"
                       + ("" if b["reason"] else ": **on a bound, no reason**") + ")" for b in near)
    L += [f"Fitted values within {100 * NEAR_BOUND:g} % of a bound of their range: " + (listed or "none")
          + (f"; {len(near) - len(unreasoned)} with a physical reason in the record (`bound_reason`)" if near else "")
          + ". No range was widened to move one. Each fitted value, its place in its range and whether the "
          "numbers identify it (sd: linearised, from the weighted Jacobian; identified: sd below a quarter of the "
          "range and not on a bound):", "", bounds_markdown(record), ""]
    return L


def trials_markdown(tried: list[dict]) -> list[str]:
    """What the shipped trial fits (:func:`~acausal.models.ankle.fit_record.trials`) say of the calibration set:
    whether each claim left out of a trial held as a prediction of it, and how the predictions fared there."""
    if not tried:
        return []
    L = ["Tried as predictions (the trial fits shipped in `acausal/models/ankle/trials/`: each an `acausal infer "
         "--without CLAIM` record, and the claims of `acausal paper` run with it as `paper_fit`):", ""]

    def said(row):
        return f"{row['id']} **{'holds' if row['holds'] == 'yes' else 'does not hold'}** ({row['margin']})"

    for t in tried:
        left = [t["claims"][c] for c in t["left_out"]]
        others = [r for r in t["claims"].values() if r["role"] in (TESTABLE, IN_NAME_ONLY)]
        failed = [r["id"] for r in left if r["holds"] != "yes"]
        start = "the a-priori values" if t["started_from"] == "a priori" else t["started_from"]
        L.append(f"- without {', '.join(t['left_out'])}, started from {start} (cost "
                 f"{t['cost']:.2f}): " + "; ".join(said(r) for r in left)
                 + (f", so {', '.join(failed)} stays a target" if failed else ", so it could be a prediction")
                 + ". The predictions of that fit: " + "; ".join(f"{said(r)}, a {r['role']}" for r in others) + ".")
    return L + [""]


#: C11 (4.4, Fig. 16) at 1.2 s/stride, the design it compares with [N/m, m] and the inertia that stands for none
#: on the motor shaft (motor.J overridden; the gearhead's own input inertia is kept) [kg m2]
C11_STRIDE, C11_DESIGN, NO_INERTIA = 1.2, (130e3, 0.007), 1e-9


def _design_map(out_dir: Path, preset_name: str, stride_time: float):
    """The design map of ``preset_name`` at ``stride_time`` as the run's Figs. 16-17 wrote it (``design_maps.csv``),
    else computed (:func:`acausal.models.bench.design.efficiency_map`)."""
    from ..bench import design
    from .claims import read_csv
    path = Path(out_dir) / "design_maps.csv"
    rows = [r for r in read_csv(path) if r["preset"] == preset_name and math.isclose(r["stride_time_s"], stride_time)] \
        if path.exists() else []
    if not rows or "E_rectifier_J" not in rows[0]:
        return design.efficiency_map(stride_time, preset_name, executor="serial")
    ks, Ps = sorted({r["k_Npm"] for r in rows}), sorted({r["P_m"] for r in rows})
    keys = [k for k in rows[0] if k not in ("preset", "body_mass_kg", "stride_time_s", "k_Npm", "P_m")]
    values = {k: np.full((len(ks), len(Ps)), np.nan) for k in keys}
    for r in rows:
        a, b = ks.index(r["k_Npm"]), Ps.index(r["P_m"])
        for k in keys:
            values[k][a, b] = r[k]
    return design.DesignMap(stride_time, np.array(ks), np.array(Ps), values, preset_name)


#: the efficiencies C11 is read with (the paper's 4.4 does not say which Fig. 16 maps), each from the energies of a
#: design map or of :func:`~acausal.models.bench.design.evaluate_designs`: key -> (what it is, how it is computed;
#: None: the map's own column)
C11_EFFICIENCIES = {
    "efficiency": ("the chain's E_output / E_source", None),
    "regenerating": ("a regenerating supply: E_output / (E_source - what the rectifier burns)",
                     lambda v: v["E_output_J"] / (v["E_source_J"] - v["E_rectifier_J"])),
    "motor": ("the motor's own efficiency, E_motor / E_driver", lambda v: v["E_motor_J"] / v["E_driver_J"]),
}


def c11_row(dmap, key: str, reading: str, reference: tuple = C11_DESIGN, note: str = "",
            refined: tuple | None = None) -> dict:
    """One reading of C11 on a design map: its grid optimum among the designs the motor can follow, the refined
    optimum ``refined`` (k [N/m], P [m], value; from :func:`~acausal.models.bench.design.refine`, None: the grid's),
    the value at ``reference`` (k [N/m], P [m]) and the gain of the refined optimum, and whether it is C11's (softer
    than the reference, at least :data:`C11_GAIN` above it)."""
    k, P, best = dmap.optimum(key)
    kr, Pr, br = refined if refined is not None else (k, P, best)
    at = dmap.at(*reference, key)
    edge = [name for name, v, axis in (("k", k, dmap.k), ("P", P, dmap.P)) if v in (axis.min(), axis.max())]
    return dict(reading=reading, grid_optimum_kNpm=k / 1e3, grid_optimum_P_mm=P * 1e3, grid_efficiency=best,
                optimum_kNpm=kr / 1e3, optimum_P_mm=Pr * 1e3, efficiency=br,
                reference_kNpm=reference[0] / 1e3, reference_P_mm=reference[1] * 1e3, efficiency_at_reference=at,
                gain_points=100 * (br - at), lower_stiffness=kr < reference[0],
                as_c11=bool(kr < reference[0] and br - at >= C11_GAIN), on_grid_edge=", ".join(edge), note=note)


def c11_readings(out_dir: Path, preset_name: str = HEADLINE) -> list[dict]:
    """C11 under the readings the paper's text leaves open (4.4 does not say which efficiency Fig. 16 maps), on
    the chain of ``preset_name`` at 1.2 s/stride over the design grid of :mod:`acausal.models.bench.design`, each
    optimum refined from the grid's (:func:`~acausal.models.bench.design.refine`): the efficiencies of
    :data:`C11_EFFICIENCIES`; the chain's without inertia on the motor shaft; and the chain's measured from the
    model's own peak-power optimum (``design_optima.csv``) instead of the paper's 130 N/mm, 7 mm. Writes
    ``c11_readings.csv``."""
    from ..bench import design
    from .claims import read_csv
    T = C11_STRIDE
    m = _design_map(out_dir, preset_name, T)
    for key, (_, value) in C11_EFFICIENCIES.items():
        if value is not None:
            m.values[key] = value(m.values)
    peak = next((r for r in read_csv(Path(out_dir) / "design_optima.csv") if r["preset"] == preset_name
                 and math.isclose(r["stride_time_s"], T) and not r.get("variant")), None) \
        if (Path(out_dir) / "design_optima.csv").exists() else None
    # each map's refined optimum of each reading, once; the chain's own is the one Figs. 16-17 refined
    refined = {} if peak is None else {
        (id(m), "efficiency"): (1e3 * peak["refined_kNpm"], 1e-3 * peak["refined_P_mm"], peak["refined_efficiency"])}

    def row(dmap, key, reading, reference=C11_DESIGN, note=""):
        if (id(dmap), key) not in refined:
            refined[(id(dmap), key)] = design.refine(dmap, key=key, value=C11_EFFICIENCIES[key][1])
        return c11_row(dmap, key, reading, reference, note, refined=refined[(id(dmap), key)])

    rows = [row(m, key, label + (" (as C11 is checked)" if key == "efficiency" else ""))
            for key, (label, _) in C11_EFFICIENCIES.items()]
    inertia_free = design.efficiency_map(T, preset_name, overrides={"motor.J": NO_INERTIA}, executor="serial")
    rows.append(row(inertia_free, "efficiency", f"without inertia on the motor shaft (motor.J = {NO_INERTIA:g} kg m2)"))
    if peak is not None:
        rows.append(row(m, "efficiency", "the chain's, from the model's own peak-power optimum",
                        (1e3 * peak["peak_power_optimum_kNpm"], 1e-3 * peak["peak_power_optimum_P_mm"]),
                        "the paper's design criterion (minimum peak moment-arm power, exact plan) on this model"))
    write_csv(Path(out_dir) / "c11_readings.csv", rows)
    return rows


def c11_markdown(rows: list[dict]) -> list[str]:
    """The report's C11 section: the table of readings and the verdict read from it."""
    from ..bench import design
    c11 = [r for r in rows if r["as_c11"]]
    lower = [r["reading"] for r in rows if r["lower_stiffness"]]
    verdict = ("**reproduced** under " + "; ".join(r["reading"] for r in c11) if c11 else
               f"**not reproduced**: under no reading is the optimum softer than the reference design and at least "
               f"{100 * C11_GAIN:g} points above it")
    return ["## C11 under the readings the paper leaves open", "",
            f"Section 4.4 does not say which efficiency Fig. 16 maps. C11 at {C11_STRIDE:g} s/stride on the "
            f"`{HEADLINE}` chain, read several ways (grid {design.K_GRID[0] / 1e3:g}-{design.K_GRID[-1] / 1e3:g} "
            f"N/mm x {design.P_GRID[0] * 1e3:g}-{design.P_GRID[-1] * 1e3:g} mm, {design.K_GRID.size} x "
            f"{design.P_GRID.size} designs; each optimum among the designs the motor can follow, refined from the "
            "grid's by Nelder-Mead on the model; `c11_readings.csv`): C11 is " + verdict + "."
            + (f" The optimum is softer than the reference under: {'; '.join(lower)}." if lower else ""), "",
            md_table(["reading", "grid optimum", "refined optimum", "efficiency", "reference design",
                      "efficiency there", "gain", "grid optimum on the grid's edge"],
                     [[r["reading"], f"{r['grid_optimum_kNpm']:.0f} N/mm, {r['grid_optimum_P_mm']:.0f} mm",
                       f"{r['optimum_kNpm']:.0f} N/mm, {r['optimum_P_mm']:.1f} mm",
                       f"{100 * r['efficiency']:.1f} %",
                       f"{r['reference_kNpm']:.0f} N/mm, {r['reference_P_mm']:.0f} mm",
                       f"{100 * r['efficiency_at_reference']:.1f} %", f"{r['gain_points']:+.1f} points",
                       r["on_grid_edge"] or "no"] for r in rows]), ""]


def power_trace_rows(results) -> list[dict]:
    """One CSV row per output time of the evaluated stride of every bench condition (:data:`BENCH`) of the two
    presets: time [ms] from the stride's start and the power [W] at each of the five points."""
    return [dict(model=r.condition.model, preset=r.condition.preset, P_mm=1e3 * r.condition.P,
                 stride_time_s=r.condition.stride_time, time_ms=1e3 * t, **{f"P_{k}_W": r.power[k][i] for k in POINTS})
            for r in results if r.condition.model == BENCH and r.condition.preset in (HEADLINE, BESIDE)
            for i, t in enumerate(r.time)]


def _rel(out_dir: Path, path) -> str:
    """``path`` as a link relative to the report (files in subfolders keep their folder)."""
    try:
        return Path(path).resolve().relative_to(Path(out_dir).resolve()).as_posix()
    except ValueError:
        return Path(path).name


def _label(c: Condition) -> str:
    s = f"{c.model}, {c.stride_time:g} s/stride"
    if c.model != "direct_drive":
        s = f"{c.model}, {1e3 * c.P:g} mm, {c.stride_time:g} s/stride"
    return s + f", preset {c.preset}"


def points_table(r: StrideResult) -> list[dict]:
    """Energy chain of one result as rows (point, energy, efficiency vs source, loss vs previous point)."""
    eff, loss = r.efficiency, r.loss_fraction
    return [dict(point=k, energy_J=r.energy[k], efficiency=eff[k], loss_vs_previous=loss[k]) for k in POINTS]


# ---------------------------------------------------------------------------------------------- plotting

def grid_axes(ax, Ps, Ts) -> None:
    """The axes of a (precompression x stride time) map: one tick per condition, in mm and s/stride."""
    ax.set_xticks(range(len(Ts)), [f"{T:g}" for T in Ts])
    ax.set_yticks(range(len(Ps)), [f"{1e3 * P:g}" for P in Ps])
    ax.set_xlabel("stride time [s/stride]")
    ax.set_ylabel("precompression P [mm]")


def on_dark(im, v) -> bool:
    """Whether value ``v``'s cell of image ``im`` is dark (its luminance below half: white text reads there)."""
    rgb = im.cmap(im.norm(v))[:3]
    return 0.299 * rgb[0] + 0.587 * rgb[1] + 0.114 * rgb[2] < 0.5


def heatmap(ax, results, value, label: str, cmap: str = "viridis", fmt: str = "{:.1f}", mark=None,
            vmin=None, vmax=None, duty: dict | None = None):
    """Values over precompression (rows) x stride time (columns), one annotated cell per condition; conditions
    where the motor cannot follow (the replay's required duty > 0.9: ``duty`` as :func:`required_duty` gives it,
    default the results' own) are hatched. ``mark`` = (P, T, text) marks one cell with a paper value. Returns the
    colour bar."""
    from matplotlib.patches import Patch, Rectangle

    Ps, Ts, grid = as_grid(results, value)
    _, _, duty = as_grid(results, lambda r, required=duty: duty_of(r, required))
    im = ax.imshow(grid, origin="lower", aspect="auto", cmap=cmap, vmin=vmin, vmax=vmax)
    grid_axes(ax, Ps, Ts)
    for i in range(len(Ps)):
        for j in range(len(Ts)):
            v = grid[i, j]
            if np.isnan(v):
                continue
            hatched = duty[i, j] > D_MAX
            if hatched:
                ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, hatch="///", edgecolor="0.45",
                                       lw=0.0))
            box = dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.8) if hatched else None
            ax.text(j, i, fmt.format(round(float(v), 6) + 0.0), ha="center", va="center", fontsize=8,
                    color="white" if on_dark(im, v) and not hatched else "black", bbox=box)
    handles = [Patch(facecolor="none", edgecolor="0.45", hatch="///",
                     label=f"motor cannot follow at 48 V\n(replay needs duty > {D_MAX})")]
    if mark is not None:
        P, T, text = mark
        if any(math.isclose(P, p) for p in Ps) and any(math.isclose(T, t) for t in Ts):
            i = int(np.argmin(np.abs(Ps - P)))
            j = int(np.argmin(np.abs(Ts - T)))
            ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, edgecolor="red", lw=2.0))
            handles.append(Patch(facecolor="none", edgecolor="red", lw=2.0, label=text))
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.16), fontsize=8, ncol=2,
              frameon=False)
    cb = ax.figure.colorbar(im, ax=ax)
    cb.set_label(label)
    return cb


def grid_rows(results, columns: dict, duty: dict | None = None) -> list[dict]:
    """One CSV row per grid condition: model, preset, P, stride time, ``columns`` (name -> function of the result),
    the duty the replay requires (``duty`` as :func:`required_duty` gives it, default the results' own) and whether
    the motor can follow."""
    rows = []
    for r in sorted(results, key=lambda r: (r.condition.P, r.condition.stride_time)):
        row = dict(model=r.condition.model, preset=r.condition.preset, P_mm=1e3 * r.condition.P,
                   stride_time_s=r.condition.stride_time)
        row.update({k: f(r) for k, f in columns.items()})
        d = duty_of(r, duty)
        row.update(max_duty=d, motor_can_follow=d <= D_MAX)
        rows.append(row)
    return rows
