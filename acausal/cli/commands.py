"""The ``acausal`` command.

::

    acausal paper --out DIR [--quick] [--jobs N]   reproduce the paper's results into DIR/report.md (+ PNG, CSV)

    acausal bench --out DIR [--effect NAME=VALUE ...] [--seed N] [--body-mass KG]   virtual-bench recordings
    acausal fit DATA --params R,J,b --out DIR                      calibration (Table 2, Fig. 14)

    acausal diagnose DATA --out DIR [--json FILE]                  name what the Eq. 4 model misses
    acausal diagnose DATA --model servo_pendulum --out DIR         the same for a servo on a pendulum (BAM logs)
    acausal check DATA --model servo_pendulum                      what a set of servo recordings can show

    acausal compare MODEL [MODEL ...] [--stride-time S ...] [--precompression P ...] --out DIR [--html] | --list

    acausal export MODEL --fmu FILE.fmu [--preset NAME] [--set NAME=VALUE ...]   an FMI 2.0 Model Exchange FMU

    acausal info                                                   accelerators present, the default path, data

This module is the one place in ``acausal/`` that imports ``acausal.models`` (the CLI wires verbs to models;
see the dependency rules in the design).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from .values import (check_beside_report, check_bench_folder, check_file_input, check_file_output, check_outputs,
                     clear_completion_mark, number, pairs, whole_number)
from ..results.files import atomic_write_text


def cmd_paper(args) -> int:
    from ..simulation.sweep import process_pool

    from acausal.models.ankle import paper as report  # the CLI is the one module of acausal/ that wires to models/
    from acausal.models.ankle.figures import SECTIONS, SELF_CONTAINED, run_section

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    clear_completion_mark(out)
    t0 = time.perf_counter()
    conditions = report.paper_conditions(quick=args.quick)
    jobs = args.jobs or os.cpu_count() or 1
    print(f"acausal paper: {len(conditions)} conditions on {jobs} process(es)"
          f"{' (quick: reduced grid)' if args.quick else ''}", file=sys.stderr)
    with process_pool(jobs) as pool:
        early = {name: pool.submit(run_section, name, str(out)) for name in SELF_CONTAINED}
        results = report.run_all(conditions, progress=not args.no_progress, executor=pool)
        t_sim = time.perf_counter() - t0
        # the sections that plot the results, in the pool as well (their figures take seconds each)
        later = {name: pool.submit(run_section, name, str(out), results) for name in SECTIONS if name not in early}
        outputs = [(early[name] if name in early else later[name]).result() for name in SECTIONS]
    elapsed = time.perf_counter() - t0
    path = report.write_report(out, results, outputs, quick=args.quick, elapsed=elapsed)
    print(f"acausal paper: simulated in {t_sim:.1f} s, figures and report in {elapsed - t_sim:.1f} s",
          file=sys.stderr)
    print(f"report: {path}")
    return 0


def cmd_infer(args) -> int:
    from ..simulation.sweep import process_pool

    from acausal.models.ankle import fit_record, inference, presets  # the CLI wires verbs to models (design rule)

    out = Path(args.out)
    jobs = args.jobs or os.cpu_count() or 1

    def progress(n, values, cost):
        if not args.no_progress:
            shown = ", ".join(f"{k} = {v:.4g}" for k, v in values.items())
            print(f"  evaluation {n}: cost {cost:.3f} at {shown}", file=sys.stderr, flush=True)

    check_file_input(args.start_from, "--start-from", "a paper_fit.json that `acausal infer --out DIR` wrote")
    start = presets.paper_fit_record(Path(args.start_from))["preset"] if args.start_from else None
    inference.targets_without(args.without or ())  # an unknown claim refused before any run
    with process_pool(jobs) as pool:
        record = inference.infer(executor=pool, progress=progress, start=start, without=args.without or ())
    paths = [fit_record.write(record, out / "paper_fit.json"), fit_record.write_tables(record, out)]
    if args.install:
        paths.append(fit_record.write(record, presets.PAPER_FIT_RECORD))
    for p in paths:
        print(p)
    return 0


def cmd_bench(args) -> int:
    from acausal.models.bench import virtual as bench
    from acausal.models.ankle.effects import parse_effects

    effects = parse_effects(args.effect)
    sensors = bench.sensors_with(dict(pairs(args.sensor, "--sensor")))
    truth = {bench_name(k): number(v, f"--truth {k}={v}") for k, v in pairs(args.truth, "--truth")}
    if args.chain is not None and args.session is not None:
        from acausal import ModelError
        raise ModelError("--session records the Eq. (4) truth (its winding warms between recordings); it does not "
                         "take --chain")
    mass = bench.truth_body_mass(args.chain) if args.body_mass is None else args.body_mass
    conds = bench.default_conditions(strides=args.strides, body_mass=mass)
    if args.quick:
        conds = [bench.BenchCondition(P, T, args.strides, body_mass=mass)
                 for P in (0.005, 0.011, 0.018) for T in (1.2, 2.0, 3.0)]
    print(f"acausal bench: {len(conds)} recordings, effects: {effects or 'none'}", file=sys.stderr)
    check_bench_folder(args.out, args.force)
    if args.session is not None:
        paths = bench.run_session(args.out, conds, effects=effects, truth=truth, sensors=sensors, seed=args.seed,
                                  pause=args.session)
    else:
        paths = bench.run_bench(args.out, conds, effects=effects, truth=truth, sensors=sensors, seed=args.seed,
                                chain=args.chain)
    print(f"wrote {len(paths)} recordings to {args.out} (answer key in {Path(args.out) / 'README.md'})")
    return 0


def bench_name(short: str) -> str:
    from acausal.models.bench.calibration import SHORT
    return SHORT.get(short, short)


def cmd_fit(args) -> int:
    from acausal.models.bench import calibration
    from acausal.models.bench.fit_report import fit_outputs

    check_outputs(args.data, out=args.out)
    out = Path(args.out)
    weights = {k: number(v, f"--weight {k}={v}") for k, v in pairs(args.weight, "--weight")}
    signals = [s.strip() for s in args.signals.split(",") if s.strip()]
    clear_completion_mark(out)
    cal, exps = calibration.fit(args.data, args.params, signals=signals, weights=weights,
                                split=calibration.Split(holdout_every=args.holdout_every), strict=args.strict)
    res = fit_outputs(out, cal, exps, f"recordings in `{args.data}`")
    warned = "".join(f"- {w}\n" for w in cal.warnings)
    atomic_write_text(out / "report.md", f"# {res['title']}\n\n"  # written last: the folder's completion mark
                      + (f"**Warnings: the data or the fit is suspect.**\n\n{warned}\n" if warned else "")
                      + f"{res['markdown']}\n\n" + "\n".join(f"![{p.stem}]({p.name})" for p in res["figures"]) + "\n")
    for n in cal.names:
        print(f"{n} = {cal.values[n]:.6g} +- {cal.std[n]:.2g}")
    for w in cal.warnings:
        print(f"warning: {w}")
    print(f"report: {out / 'report.md'}")
    return 0


#: the models ``acausal diagnose --model`` knows (the ankle actuator's Eq. 4 model is the default)
DIAGNOSE_MODELS = ("ankle", "servo_pendulum")


def cmd_diagnose(args) -> int:
    check_outputs(args.data, out=args.out, json=args.json)
    check_file_output(args.json, "--json")
    check_beside_report(args.json, "--json", args.out)
    out = Path(args.out)
    candidates = None
    if args.candidates is not None:
        candidates = [c.strip() for c in args.candidates.split(",") if c.strip()]
        if not candidates:
            from acausal import DataError
            raise DataError(f"--candidates {args.candidates!r} names no candidate; leave it out to try them all")
    progress = None if args.no_progress else (lambda msg: print(f"  {msg}", file=sys.stderr, flush=True))
    clear_completion_mark(out)
    if args.model == "servo_pendulum":
        d = _diagnose_servo(args, out, candidates, progress)
    elif args.candidate or args.candidates_file:
        from acausal import DataError
        raise DataError("--candidate and --candidates-file are for --model servo_pendulum; the ankle's candidates "
                        "are its effects (acausal.models.ankle.effects)")
    elif args.split is not None or args.jobs is not None or args.bam:
        from acausal import DataError
        given = [o for o, v in (("--split", args.split), ("--jobs", args.jobs), ("--bam", args.bam))
                 if v not in (None, False)]
        raise DataError(f"{', '.join(given)}: for --model servo_pendulum only; the ankle's diagnosis holds out "
                        "strides (--holdout-every) and runs in this process")
    else:
        from acausal.models.bench import diagnosis
        from acausal.models.bench.diagnosis_report import write_json, write_report

        d, problem = diagnosis.run(args.data, split=diagnosis.Split(holdout_every=args.holdout_every),
                                   max_effects=args.max_effects, candidates=candidates, progress=progress,
                                   strict=args.strict)
        write_report(out, d, problem, f"recordings in `{args.data}`")
        if args.json:
            write_json(args.json, d)
    print(f"cause: {d.cause}" + (f" (causes: {', '.join(d.causes)})" if len(d.causes) > 1 else "")
          + (f"; suspected from a drift: {', '.join(d.suspects)}" if d.suspects else ""))
    for sig, sc in d.heldout_signals().items():
        b, e = sc["rmse"]
        print(f"  held-out RMSE of {sig}: baseline {b:.4g}, extended {e:.4g}"
              + (f" ({100 * (1 - e / b):+.1f} %)" if b else ""))
    for w in d.warnings:
        print(f"warning: {w}")
    dr = getattr(d, "drift", {}) or {}
    for n in dr.get("before", dr).get("drifting", []):
        print(f"drift: {n} over the session" + (f", explained by {dr['resolved_by'][n]}" if n in dr.get("resolved_by", {})
                                                 else ""))
    for s in d.candidates:
        print(f"  {s.id:26s} held-out gain {100 * s.heldout_rmse_gain:+6.1f} %  delta BIC {s.delta_bic:10.4g}"
              f"  {s.parameter} = {s.value:.4g}{'  significant' if s.significant else ''}")
    limits = [f"{cid} {x['size']:.3g} {x['unit']}" for cid, x in getattr(d, "detection_limits", {}).items()
              if x.get("size") is not None]
    if limits:
        print(("nothing named; unseen up to: " if not d.causes else "detection limits of the others: ")
              + "; ".join(limits))
    print(f"report: {out / 'report.md'}")
    return 0


def cmd_check(args) -> int:
    """What a set of recordings can show before anything is fitted (servo_pendulum)."""
    from acausal.models.servo import support  # the CLI wires verbs to models (design rule exception)

    print(support.report(support.survey(args.data, strict=args.strict)))
    return 0


def _diagnose_servo(args, out: Path, candidates, progress):
    from ..simulation.sweep import process_pool

    from acausal.models.servo import bam, problem as servo  # the CLI wires verbs to models (design rule exception)
    from acausal.models.servo.effects import load_candidates_file, parse_candidate
    from acausal.models.servo.report import write_json, write_report

    extra = [parse_candidate(c) for c in args.candidate]
    if args.candidates_file:
        extra += load_candidates_file(args.candidates_file)
    by, _, value = (args.split or "auto").partition("=")
    split = servo.Split(by=by.strip(), value=value.strip() or None)
    t0 = time.perf_counter()
    with process_pool(args.jobs or os.cpu_count() or 1) as pool:
        d, problem = servo.run(args.data, split=split, max_effects=args.max_effects, candidates=candidates,
                               progress=progress, executor=pool, extra=extra, strict=args.strict)
        bam_rows = bam.replay_all(problem.recordings, pool) if args.bam else None
        elapsed = time.perf_counter() - t0
        write_report(out, d, problem, f"recordings in `{args.data}`", bam_rows, elapsed=elapsed)  # replays too
    if args.json:
        write_json(args.json, d)
    ho = d.heldout()
    print(f"held-out {ho['signal']} MAE ({ho['split']}): baseline {ho['baseline']:.4g} {ho['unit']}, "
          f"extended {ho['extended']:.4g} {ho['unit']}")
    return d


def load_model_class(ref: str):
    """``MODULE:CLASS`` (an importable module) or ``FILE.py:CLASS`` -> the model class; a ModelError naming the
    reference when it cannot be found or is no Model."""
    from acausal import Model, ModelError
    from acausal.cli.references import load_class

    if ":" not in ref:
        raise ModelError(f"model {ref!r}: expected a registered name (acausal compare --list), MODULE:CLASS or "
                         "FILE.py:CLASS")
    return load_class(ref, Model, "model")


def build_user_model(ref: str, cls):
    """The user's model class ``cls`` (named by ``ref``) instantiated without arguments and compiled; what goes
    wrong in the user's code is a ModelError naming the reference, the exception and the user's file and line."""
    import inspect

    from acausal import AcausalError, ModelError, compile_model
    from acausal.cli.references import user_code_error

    required = [p.name for p in list(inspect.signature(cls).parameters.values())
                if p.default is p.empty and p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]
    if required:
        raise ModelError(f"model {ref!r}: the class must be buildable without arguments; its __init__ needs "
                         f"{', '.join(required)}")
    try:
        return compile_model(cls())
    except AcausalError:
        raise
    except Exception as exc:
        raise user_code_error(f"model {ref!r}: building it", exc) from None


def cmd_compare(args) -> int:
    """``acausal compare`` (:func:`acausal.models.drivetrains.compare.run`); with ``--html`` also its page,
    DIR/index.html (plotly checked before anything runs)."""
    from acausal.models.drivetrains import compare  # the CLI wires verbs to models (design rule exception)

    page = args.html and not args.list
    if page:
        from ..results.html import require_plotly
        require_plotly("acausal compare --html")
    code = compare.run(args)
    if code == 0 and page:
        from acausal.models.reporting.explorer import compare_page
        print(f"page: {compare_page(args.out, compare.MD_ROWS, compare.NO_SERIES_LINK)}")
    return code


def cmd_export(args) -> int:
    import inspect

    from acausal import ModelError
    from acausal.export import export_fmu

    sets = {}
    for name, value in pairs(args.set, "--set"):
        try:
            sets[name] = float(value)
        except ValueError:
            raise ModelError(f"--set {name}={value}: the value {value!r} is not a number (SI units)") from None
    if ":" in args.model:
        if args.preset is not None:
            raise ModelError(f"--preset {args.preset}: presets are for registered models (acausal compare --list); "
                             f"{args.model} takes its parameters from its class (and --set)")
        cls = load_model_class(args.model)
        from acausal.export.fmu import own_doc
        cm, doc, params = build_user_model(args.model, cls), own_doc(cls), {}
    else:
        from acausal.models.ankle.presets import preset  # the CLI wires verbs to models (design rule exception)
        from acausal.models.ankle.protocol import compiled
        from acausal.models.ankle.registry import spec

        s = spec(args.model)
        cm = compiled(args.model).sim
        doc = f"{s.summary}.\n\n{inspect.getdoc(type(s.build())) or ''}"
        params = {k: v for k, v in preset(args.preset or "library").items() if cm.has_parameter(k)}
        params.update(s.params)
    for name in sets:
        if not cm.has_parameter(name):
            raise ModelError(f"--set {name}: {cm.unknown_name_error(name, 'parameter', cm.param_names)}")
    params.update(sets)
    cm.param_vector(params)  # bounds and bindings checked before any C is written
    if not args.no_binary:  # the remedy in this command's options, not the Python call's
        from acausal.export.fmu import find_compiler
        find_compiler(args.compiler, remedy="give one with --compiler PATH or CC, or export with --no-binary for a "
                                            "source-only FMU (the importing tool compiles its sources/)")
    path = export_fmu(cm, args.fmu, params=params, doc=doc, binary=not args.no_binary, compiler=args.compiler,
                      identifier=args.identifier)
    print(f"{path}: FMI 2.0 Model Exchange, {len(cm.state_names)} states, {len(cm.param_names)} parameters, "
          f"{len(cm.names())} outputs, {len(cm.event_zeros)} event indicators"
          + ("" if args.no_binary else ", binary for this platform"))
    return 0


def shipped_data() -> dict:
    """The data sets that ship with the package: name -> (folder, what it is)."""
    from acausal.models.servo.recording_format import shipped_recordings  # the CLI wires verbs to models
    return {"xl330": (shipped_recordings(), "16 recordings of a Dynamixel XL330 on a pendulum (Rhoban/bam, Apache-2.0): "
                      "acausal diagnose DIR --model servo_pendulum")}


def cmd_info(args) -> int:
    from .accelerators import describe

    print(describe())
    print("\nshipped data sets:")
    for name, (folder, what) in shipped_data().items():
        print(f"  {name}: {folder}\n      {what}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="acausal", description="Modelica-style acausal modelling: the paper's "
                                "results, a virtual bench, calibration, diagnosis and drive-train comparison.")
    from .. import __version__
    p.add_argument("--version", action="version", version=f"acausal {__version__} (acausal info: the accelerators)")
    sub = p.add_subparsers(dest="verb", metavar="VERB")
    paper = sub.add_parser("paper", help="reproduce the CYBERLEGs paper's tables and figures into DIR/report.md")
    paper.add_argument("--out", required=True, help="output directory (created if missing)")
    paper.add_argument("--quick", action="store_true",
                       help="reduced grid (P in 5, 8, 18 mm x 1.2, 2, 3 s) and resolution, for tests")
    paper.add_argument("--jobs", type=whole_number("--jobs"), default=None,
                       help="worker processes (default: all cores)")
    paper.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    paper.set_defaults(run=cmd_paper)
    infer = sub.add_parser("infer", help="infer the paper's unpublished parameters from its published numbers "
                           "(the paper_fit preset; several minutes)")
    infer.add_argument("--out", required=True, help="output directory (paper_fit.json, inference.md)")
    infer.add_argument("--install", action="store_true", help="also replace the shipped paper_fit preset record")
    infer.add_argument("--start-from", metavar="RECORD", default=None,
                       help="start from an inference record's values (e.g. the shipped paper_fit.json after a change "
                            "of targets) instead of the a-priori ones")
    infer.add_argument("--without", action="append", metavar="CLAIM",
                       help="leave a claim's targets out of the fit (repeatable), to see whether it holds as a "
                            "prediction, e.g. --without C3")
    infer.add_argument("--jobs", type=whole_number("--jobs"), default=None,
                       help="worker processes (default: all cores)")
    infer.add_argument("--no-progress", action="store_true", help="no progress lines on stderr")
    infer.set_defaults(run=cmd_infer)
    bench = sub.add_parser("bench", help="virtual test bench: record the paper's protocol on a truth model")
    bench.add_argument("--out", required=True, help="folder for the recordings (NAME.csv + NAME.json)")
    bench.add_argument("--effect", action="append", metavar="NAME=VALUE",
                       help="hide an effect in the truth model (repeatable); names: see acausal.models.ankle.effects")
    bench.add_argument("--truth", action="append", metavar="PARAM=VALUE", help="truth parameter, e.g. R=0.8")
    bench.add_argument("--sensor", action="append", metavar="NAME=VALUE", help="sensor setting, e.g. "
                       "motor_current_noise=0.05")
    bench.add_argument("--seed", type=whole_number("--seed", least=0), default=0, help="noise seed (default 0)")
    bench.add_argument("--force", action="store_true", help="write into a folder that already holds files (its "
                       "files are deleted first)")
    bench.add_argument("--strides", type=whole_number("--strides"), default=6,
                       help="recorded strides per condition (default 6)")
    bench.add_argument("--quick", action="store_true", help="9 conditions instead of the paper's 36")
    bench.add_argument("--session", type=float, default=None, metavar="PAUSE_S",
                       help="record the conditions one after another as one session, PAUSE_S seconds apart: the "
                            "winding stays warm between recordings, each JSON says when it started")
    bench.add_argument("--body-mass", type=float, default=None, metavar="KG",
                       help="body mass the gait torque is scaled with (default 60 kg, or the --chain preset's)")
    bench.add_argument("--chain", default=None, metavar="PRESET",
                       help="record the whole component chain (driver, gears, linkage with their losses) with this "
                            "preset, e.g. paper_fit, instead of the Eq. (4) truth")
    bench.set_defaults(run=cmd_bench)
    fit = sub.add_parser("fit", help="calibrate model parameters on bench recordings (Table 2, Fig. 14)")
    fit.add_argument("data", help="folder of recordings")
    fit.add_argument("--params", default="R,J,b", help="parameters to fit (default R,J,b; also L, k, effect "
                     "parameters such as driver.P_q)")
    fit.add_argument("--signals", default="motor_current_A,supply_current_A",
                     help="recorded signals to fit (default motor_current_A,supply_current_A)")
    fit.add_argument("--weight", action="append", metavar="SIGNAL=W", help="weight of a signal (default 1)")
    fit.add_argument("--holdout-every", type=whole_number("--holdout-every"), default=3,
                     help="hold out every n-th stride (default 3)")
    fit.add_argument("--out", required=True, help="output folder (report.md, CSV, figures)")
    fit.add_argument("--strict", action="store_true", help="refuse a recording with a sample that cannot be physical (a dropout, a glitch, a "
                    "repeated time stamp, an empty cell), naming file, line and column; by default such samples "
                    "are masked, named in the report and left out of the fit")
    fit.set_defaults(run=cmd_fit)
    from acausal.models.drivetrains import compare  # the CLI wires verbs to models (design rule exception)
    cmp = sub.add_parser("compare", help="run alternative drive trains side by side (energy chain, limits, Sankey)")
    compare.configure(cmp)
    cmp.add_argument("--html", action="store_true", help="also write DIR/index.html: the runs' energy chains as an "
                     "interactive page read from compare.csv (needs plotly: pip install \"acausal[html]\")")
    cmp.set_defaults(run=cmd_compare)
    ex = sub.add_parser("export", help="write a model as an FMI 2.0 Model Exchange FMU (C code compiled into a "
                        "binary for this platform; runs in fmpy and Modelica tools)")
    ex.add_argument("model", metavar="MODEL", help="a registered model (acausal compare --list), MODULE:CLASS or "
                    "FILE.py:CLASS (a Model class built without arguments)")
    ex.add_argument("--fmu", required=True, help="the FMU file to write (ends in .fmu)")
    ex.add_argument("--preset", default=None, help="registered models: parameter preset (default: library)")
    ex.add_argument("--set", action="append", metavar="NAME=VALUE", help="a parameter's value in the FMU, in SI "
                    "units (its start value, still settable through FMI); repeatable")
    ex.add_argument("--identifier", help="the FMU's modelIdentifier (default: the model's class name)")
    ex.add_argument("--compiler", help="the C compiler (default: $CC, then cc, gcc, clang)")
    ex.add_argument("--no-binary", action="store_true", help="a source-only FMU (no compiler needed: the "
                    "importing tool compiles sources/)")
    ex.set_defaults(run=cmd_export)
    ck = sub.add_parser("check", help="say what a set of servo recordings can show (gains, trajectories, torque-off "
                        "segments, saturation, holds) before fitting")
    ck.add_argument("data", help="folder of recordings (NAME.csv + NAME.json)")
    ck.add_argument("--model", choices=("servo_pendulum",), default="servo_pendulum",
                    help="which model the recordings are of (servo_pendulum)")
    ck.add_argument("--strict", action="store_true", help="refuse a recording with a sample that cannot be physical (a dropout, a glitch, a "
                    "repeated time stamp, an empty cell), naming file, line and column; by default such samples "
                    "are masked, named in the report and left out of the fit")
    ck.set_defaults(run=cmd_check)
    dg = sub.add_parser("diagnose", help="calibrate a baseline model on recordings (the ankle's Eq. 4 model, or "
                        "--model servo_pendulum), show its residuals, name the missing effect, extend the model and "
                        "measure the gain on held-out data")
    dg.add_argument("data", help="folder of recordings")
    dg.add_argument("--out", required=True, help="output folder (report.md, CSV, figures)")
    dg.add_argument("--json", help="also write the machine-readable verdict to this file")
    dg.add_argument("--strict", action="store_true", help="refuse a recording with a sample that cannot be physical (a dropout, a glitch, a "
                    "repeated time stamp, an empty cell), naming file, line and column; by default such samples "
                    "are masked, named in the report and left out of the fit")
    dg.add_argument("--candidates", help="comma-separated candidate effects to try (default: all; your own "
                    "--candidate and --candidates-file ones are tried too)")
    dg.add_argument("--max-effects", type=whole_number("--max-effects"), default=None,
                    help="effects to name at most (default: as many as the evidence supports; a significant "
                    "candidate the limit leaves out is said)")
    dg.add_argument("--holdout-every", type=whole_number("--holdout-every"), default=3,
                    help="ankle: hold out every n-th stride (default 3)")
    dg.add_argument("--model", choices=DIAGNOSE_MODELS, default="ankle",
                    help="which model the recordings are of (default: ankle, the paper's actuator; servo_pendulum: "
                    "a position servo swinging a pendulum, BAM's log format)")
    dg.add_argument("--split", help="servo_pendulum: held-out recordings, kp[=VALUE] or trajectory[=NAME] "
                    "(default: every recording at the middle kp, else the middle trajectory)")
    dg.add_argument("--jobs", type=whole_number("--jobs"), default=None,
                    help="servo_pendulum: worker processes (default: all cores)")
    dg.add_argument("--bam", action="store_true", help="servo_pendulum: also replay BAM's published XL330 "
                    "parameter sets on the recordings (for XL330 data)")
    dg.add_argument("--candidate", action="append", default=[], metavar="SPEC",
                    help="servo_pendulum: a candidate of your own, id=NAME,slot=SLOT,component=MODULE:CLASS (or "
                    "FILE.py:CLASS),parameter=P,bounds=LO:HI[,zero=Z][,probe=X][,unit=U][,fixed=NAME:VALUE] "
                    "(repeatable; slots: goal, position, error, duty, bus, output)")
    dg.add_argument("--candidates-file", metavar="FILE.json",
                    help="servo_pendulum: a JSON list of your own candidates (the keys of --candidate)")
    dg.add_argument("--no-progress", action="store_true", help="no progress lines on stderr")
    dg.set_defaults(run=cmd_diagnose)

    info = sub.add_parser("info", help="which optional accelerators this machine has, the path a default run "
                          "takes, and where the shipped data sets are")
    info.set_defaults(run=cmd_info)
    return p


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.verb is None:
        parser.print_help(sys.stderr)
        return 2
    from ..errors import AcausalError
    try:
        return args.run(args)
    except AcausalError as e:
        print(f"acausal {args.verb}: {e}", file=sys.stderr)
        return 2
    except OSError as e:  # a path that cannot be read or written: the message names it
        print(f"acausal {args.verb}: {e.strerror or e}{': ' + str(e.filename) if e.filename else ''}",
              file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
