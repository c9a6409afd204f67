"""The ``acausal`` command.

::

    acausal paper --out DIR [--quick] [--jobs N]   reproduce the paper's results into DIR/report.md (+ PNG, CSV)

``bench``, ``fit``, ``diagnose`` and ``compare`` belong to the design (../shared/design.md) but are not
implemented yet: they exit with status 2 and say so. This module is the one place in ``acausal/`` that imports
``acausal.models`` (the CLI wires verbs to models; see the dependency rules in the design).
"""
from __future__ import annotations

import argparse
import importlib.util
import os
import sys
import time
from pathlib import Path

#: the example scripts ``acausal paper`` runs, in report order (examples/<name>.py, each with main(out_dir, results))
EXAMPLES = ["table1", "fig07_direct_drive", "fig08_power_chain", "fig09_12_losses", "fig13_tracking",
            "fig15_efficiency", "table2"]

#: verbs of the design that are not implemented yet: what they will do
PLANNED = {
    "bench": "virtual test bench: replay a recorded bench run through the model",
    "fit": "fit model parameters (e.g. Table 2's J, b, R) to measured currents and powers",
    "diagnose": "rank candidate explanations of a model-vs-measurement residual",
    "compare": "compare two result sets (simulation vs measurement, or two presets)",
}


def examples_dir() -> Path:
    return Path(__file__).resolve().parent.parent / "examples"


def load_example(name: str):
    """Import examples/<name>.py by path (the examples are scripts, not part of the installed package)."""
    path = examples_dir() / f"{name}.py"
    if not path.exists():
        raise FileNotFoundError(f"acausal paper: example script {path} not found (the examples ship with the "
                                "source tree; run from an editable install)")
    spec = importlib.util.spec_from_file_location(f"acausal_examples_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def cmd_paper(args) -> int:
    from concurrent.futures import ProcessPoolExecutor

    from acausal.models import report  # the CLI is the one module of acausal/ that wires to models/

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    conditions = report.paper_conditions(quick=args.quick)
    jobs = args.jobs or os.cpu_count() or 1
    print(f"acausal paper: {len(conditions)} conditions on {jobs} process(es)"
          f"{' (quick: reduced grid)' if args.quick else ''}", file=sys.stderr)
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        results = report.run_all(conditions, progress=not args.no_progress, executor=pool)
    t_sim = time.perf_counter() - t0
    outputs = []
    for name in EXAMPLES:
        outputs.append(load_example(name).main(out, results))
    elapsed = time.perf_counter() - t0
    path = report.write_report(out, results, outputs, quick=args.quick, elapsed=elapsed)
    print(f"acausal paper: simulated in {t_sim:.1f} s, figures and report in {elapsed - t_sim:.1f} s",
          file=sys.stderr)
    print(f"report: {path}")
    return 0


ISSUE = {"bench": 6, "fit": 6, "diagnose": 7, "compare": 8}


def _not_implemented(verb: str):
    def run(args) -> int:
        print(f"acausal {verb}: not implemented yet (issue {ISSUE[verb]}) - {PLANNED[verb]}. "
              "Today only `acausal paper` works.", file=sys.stderr)
        return 2
    return run


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="acausal", description="Modelica-style acausal modelling: the paper's "
                                "results and (later) bench, fitting and diagnosis verbs.")
    sub = p.add_subparsers(dest="verb", metavar="VERB")
    paper = sub.add_parser("paper", help="reproduce the CYBERLEGs paper's tables and figures into DIR/report.md")
    paper.add_argument("--out", required=True, help="output directory (created if missing)")
    paper.add_argument("--quick", action="store_true",
                       help="reduced grid (P in 5, 8, 18 mm x 1.2, 2, 3 s) and resolution, for tests")
    paper.add_argument("--jobs", type=int, default=None, help="worker processes (default: all cores)")
    paper.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    paper.set_defaults(run=cmd_paper)
    for verb, what in PLANNED.items():
        q = sub.add_parser(verb, help=f"{what} (not implemented yet)")
        q.add_argument("rest", nargs=argparse.REMAINDER, help=argparse.SUPPRESS)
        q.set_defaults(run=_not_implemented(verb))
    return p


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.verb is None:
        parser.print_help(sys.stderr)
        return 2
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
