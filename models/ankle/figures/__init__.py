"""The sections of ``acausal paper``'s report, one module per table or figure of the paper, each with
``main(out_dir, results=None, ...) -> dict`` (its title, markdown, figures, CSV and comparisons with the paper).
With the protocol's ``results`` a section plots them; without, it simulates what it needs itself.

They ship with the package, so the report runs from an installed wheel; ``examples/`` holds thin scripts that call
them, and ``python -m acausal.models.ankle.figures.table1`` runs one section into ``results/``.

Nothing is imported here: :func:`section` loads the one asked for.
"""
from __future__ import annotations

import importlib

#: the report's sections, in report order
SECTIONS = ("table1", "fig07_direct_drive", "fig08_power_chain", "fig09_12_losses", "fig13_tracking",
            "fig15_efficiency", "table2", "fig14_calibration", "fig16_17_design", "diagnosis_gear_losses")
#: the sections that simulate on their own (they need no protocol results): ``acausal paper`` runs them in its
#: process pool beside the protocol sweep, longest first, so their single-core work overlaps the sweep
SELF_CONTAINED = ("fig16_17_design", "diagnosis_gear_losses", "fig14_calibration")


def section(name: str):
    """The module of the report's section ``name`` (one of :data:`SECTIONS`)."""
    if name not in SECTIONS:
        raise KeyError(f"no report section {name!r}; the sections are {', '.join(SECTIONS)}")
    return importlib.import_module(f"{__name__}.{name}")


def run_section(name: str, out_dir: str, results=None) -> dict:
    """Section ``name``'s ``main`` in this process, and the parts of its output the report reads (a module-level
    function returning plain data, so a process pool can run it). Without ``results`` the section simulates on its
    own (``executor="serial"``: it already runs in a worker of the pool, beside the sweep); with them it plots the
    protocol's results. ``verdicts``: the rows of its caption's verdict sentences (:func:`.trends.verdict_rows`)."""
    from pathlib import Path

    from .trends import verdict_rows

    main = section(name).main
    out = main(Path(out_dir), executor="serial") if results is None else main(Path(out_dir), results)
    return {**{k: out[k] for k in ("title", "markdown", "figures", "csv", "comparisons") if k in out},
            "verdicts": verdict_rows(out.get("markdown", ""))}
