"""``acausal compare``: run registered ankle-actuator models over the gait cycle and put them side by side.

For every model and condition (stride time; precompression for the models that have one) the table holds the
energy per stride at the five measurement points (and the energy returned to the supply), the stage
efficiencies (each point over the previous one, and overall), the peak powers, and the motor's peak speed,
peak and rms current and peak voltage next to the motor's and driver's limits; an exceeded limit is flagged in
the ``limits_exceeded`` column and in bold in the markdown, never dropped. Written as ``compare.csv`` (one row
per run), ``compare.md`` (runs side by side) and one Sankey diagram per model (``sankey_<model>.png``, one
panel per condition).

API::

    results = run_models(["replay", "sea"], stride_times=[1.5, 2.0])   # StrideResult per run
    rows = records(results)                                            # the table, list of dicts
    table = compare(["replay", "sea"], stride_times=[1.5, 2.0])        # DataFrame if pandas, else records
    paths = write_outputs(results, "out")                              # CSV, markdown, Sankey PNGs

CLI (wired in ``acausal/cli.py`` through :func:`configure` and :func:`run`)::

    acausal compare MODEL [MODEL ...] [--stride-time S ...] [--precompression P ...] --out DIR
    acausal compare --list
"""
from __future__ import annotations

import math
import sys
import textwrap
import time
from concurrent.futures import Executor
from pathlib import Path

from acausal import ModelError
from acausal.cli.values import whole_number
from acausal.results.files import atomic_write_text
from acausal.simulation.sweep import process_pool

from ..ankle.presets import preset as preset_overrides
from ..ankle.protocol import POINTS, STAGES, Condition, StrideResult, sweep
from ..ankle.registry import MODELS, RPM, spec

DEFAULT_STRIDE_TIMES = (2.0,)  # s (the paper's Table 1 condition)
DEFAULT_PRECOMPRESSIONS = (0.008,)  # m
NO_SERIES_LINK = ("direct_drive", "parallel_elastic")  # their "link" point is the gear output at the joint


# ------------------------------------------------------------------------------------------------ running
def conditions(models, stride_times=DEFAULT_STRIDE_TIMES, precompressions=DEFAULT_PRECOMPRESSIONS,
               preset: str = "library", strides: int = 2, points_per_stride: int = 201,
               overrides: dict | None = None) -> list[Condition]:
    """The runs of a comparison, in order: each model at each stride time and (if it has one) precompression
    [m]. ``overrides``: ``{model: {parameter: value}}``. Unknown model names raise :class:`ModelError` listing
    the known ones."""
    models = list(models)
    if not models:
        raise ModelError(f"compare: no model given; known models: {', '.join(MODELS)}")
    for m in models:
        spec(m)
    if len(set(models)) != len(models):
        raise ModelError(f"compare: a model is named twice in {models}")
    preset_overrides(preset)  # an unknown preset lists the known ones
    overrides = overrides or {}
    for m in overrides:
        if m not in models:
            raise ModelError(f"compare: overrides for {m!r}, which is not among the compared models {models}")
    for T in stride_times:
        if not (isinstance(T, (int, float)) and math.isfinite(T) and T > 0):
            raise ModelError(f"compare: stride time must be a positive number of seconds, got {T!r}")
    for P in precompressions:
        if not (isinstance(P, (int, float)) and 0.0 <= P <= 0.018):
            raise ModelError(f"compare: precompression must be within 0-0.018 m (0-18 mm), got {P!r} m")
    out = []
    for m in models:
        Ps = precompressions if spec(m).uses_precompression else [float("nan")]
        out += [Condition(P, float(T), m, preset, strides, points_per_stride, dict(overrides.get(m, {})))
                for P in Ps for T in stride_times]
    return out


def run_models(models, stride_times=DEFAULT_STRIDE_TIMES, precompressions=DEFAULT_PRECOMPRESSIONS, *,
               preset: str = "library", executor: Executor | None = None, jobs: int | None = None,
               progress: bool = False, overrides: dict | None = None, strides: int = 2,
               points_per_stride: int = 201) -> list[StrideResult]:
    """Run the comparison's conditions (see :func:`conditions`) through ``executor`` (default: a process pool
    of ``jobs`` workers, all cores if None) and return one :class:`StrideResult` per run, in order."""
    conds = conditions(models, stride_times, precompressions, preset, strides, points_per_stride, overrides)
    if executor is None and jobs is not None:
        with process_pool(min(int(jobs), len(conds))) as pool:
            return sweep(conds, executor=pool, progress=progress)
    return sweep(conds, executor=executor, progress=progress)


# ------------------------------------------------------------------------------------------------ the table
def _ratio(a: float, b: float) -> float:
    return a / b if b > 0 else float("nan")


def limits_of(r: StrideResult) -> dict:
    """The limits of the run's model: motor speed [rad/s], peak current [A] (driver), rms current [A] (the
    lower of the motor's nominal current and the driver's continuous rating), motor voltage [V] (the driver's
    largest duty times the supply voltage)."""
    lim = spec(r.condition.model).limits
    k, V = r.params["motor.k"], r.params["supply.V"]
    return {"speed": lim.motor_speed, "current_peak": lim.driver_current_peak,
            "current_rms": min(lim.nominal_torque / k, lim.driver_current_continuous),
            "voltage": lim.duty * V}


def exceeded(r: StrideResult) -> list[str]:
    """Names of the limits the run exceeds (``speed``, ``current_peak``, ``current_rms``, ``voltage``)."""
    lim = limits_of(r)
    got = {"speed": r.peak_motor_speed, "current_peak": r.peak_motor_current, "current_rms": r.rms_motor_current,
           "voltage": r.peak_motor_voltage}
    return [k for k in lim if got[k] > lim[k]]


def record(r: StrideResult) -> dict:
    """One run as a flat record (the CSV row)."""
    c, e = r.condition, r.energy
    uses_P = spec(c.model).uses_precompression
    row = {"model": c.model, "P_mm": c.P * 1e3 if uses_P else float("nan"), "stride_time_s": c.stride_time,
           "preset": c.preset}
    row.update({f"E_{k}_J": e[k] for k in POINTS})
    row["E_returned_J"] = r.returned
    row.update({f"eff_{s}": _ratio(e[b], e[a]) for s, a, b in STAGES})
    row["eff_total"] = _ratio(e["output"], e["source"])
    row.update({f"loss_{s}_J": e[a] - e[b] for s, a, b in STAGES})
    row["driver_loss_J"] = r.loss_energy.get("driver.loss_power", float("nan"))
    row.update({f"peak_{k}_W": r.peak_power[k] for k in POINTS})
    lim = limits_of(r)
    row.update(motor_speed_peak_rpm=r.peak_motor_speed / RPM, motor_speed_limit_rpm=lim["speed"] / RPM,
               current_peak_A=r.peak_motor_current, current_peak_limit_A=lim["current_peak"],
               current_rms_A=r.rms_motor_current, current_rms_limit_A=lim["current_rms"],
               voltage_peak_V=r.peak_motor_voltage, voltage_limit_V=lim["voltage"], duty_max=r.max_duty)
    bad = exceeded(r)
    row["limits_exceeded"] = ", ".join(bad) if bad else "none"
    row["balance_residual"] = r.balance_residual
    return row


def records(results) -> list[dict]:
    """The comparison table: one record per run (see :func:`record`)."""
    return [record(r) for r in results]


def as_table(rows: list[dict]):
    """``rows`` as a pandas DataFrame when pandas is installed, else the records themselves."""
    try:
        import pandas as pd
    except ImportError:
        return rows
    return pd.DataFrame(rows)


def compare(models, stride_times=DEFAULT_STRIDE_TIMES, precompressions=DEFAULT_PRECOMPRESSIONS, **kw):
    """Run the models (keywords as :func:`run_models`) and return the table (:func:`as_table` of
    :func:`records`)."""
    return as_table(records(run_models(models, stride_times, precompressions, **kw)))


# ------------------------------------------------------------------------------------------------ output
#: rows of the side-by-side markdown: (record key, label, format, limit key or None)
MD_ROWS = [("E_source_J", "energy at the source [J/stride]", ".2f", None),
           ("E_driver_J", "energy at the driver output [J/stride]", ".2f", None),
           ("E_motor_J", "energy at the motor (k i w) [J/stride]", ".2f", None),
           ("E_link_J", "energy at the moment arm (link) [J/stride]", ".2f", None),
           ("E_output_J", "energy at the joint (output) [J/stride]", ".2f", None),
           ("E_returned_J", "energy returned to the supply [J/stride]", ".2f", None),
           ("eff_driver", "efficiency driver (driver/source)", ".1%", None),
           ("eff_motor", "efficiency motor (motor/driver)", ".1%", None),
           ("eff_gearing", "efficiency gearing (link/motor)", ".1%", None),
           ("eff_output", "efficiency output (output/link)", ".1%", None),
           ("eff_total", "efficiency total (output/source)", ".1%", None),
           ("driver_loss_J", "driver's own loss [J/stride]", ".2f", None),
           ("peak_source_W", "peak power, source [W]", ".1f", None),
           ("peak_driver_W", "peak power, driver output [W]", ".1f", None),
           ("peak_motor_W", "peak power, motor (k i w) [W]", ".1f", None),
           ("peak_link_W", "peak power, moment arm [W]", ".1f", None),
           ("peak_output_W", "peak power, joint [W]", ".1f", None),
           ("motor_speed_peak_rpm", "peak motor speed [rpm]", ".0f", "motor_speed_limit_rpm"),
           ("current_peak_A", "peak motor current [A]", ".2f", "current_peak_limit_A"),
           ("current_rms_A", "rms motor current [A]", ".2f", "current_rms_limit_A"),
           ("voltage_peak_V", "peak motor voltage [V]", ".1f", "voltage_limit_V"),
           ("duty_max", "largest duty cycle", ".2f", None),
           ("balance_residual", "energy balance residual (relative)", ".1e", None)]


def _run_label(row: dict) -> str:
    P = "" if math.isnan(row["P_mm"]) else f"{row['P_mm']:g} mm, "
    return f"{row['model']}<br>{P}{row['stride_time_s']:g} s"


def _cell(row: dict, key: str, fmt: str, limit: str | None) -> str:
    v = row[key]
    if isinstance(v, float) and math.isnan(v):
        return "-"
    text = format(v, fmt)
    if limit is not None:
        if v > row[limit]:
            return f"**{text} > {format(row[limit], fmt)} (limit exceeded)**"
        return f"{text} (limit {format(row[limit], fmt)})"
    return text


def markdown(rows: list[dict]) -> str:
    """The runs side by side (a column per run), the models' summaries and the exceeded limits."""
    head = "| quantity | " + " | ".join(_run_label(r) for r in rows) + " |"
    lines = [head, "|---|" + "---|" * len(rows)]
    for key, label, fmt, limit in MD_ROWS:
        lines.append(f"| {label} | " + " | ".join(_cell(r, key, fmt, limit) for r in rows) + " |")
    models = list(dict.fromkeys(r["model"] for r in rows))
    lines += ["", "Models:", ""] + [f"- `{m}`: {spec(m).summary}" for m in models]
    bad = [r for r in rows if r["limits_exceeded"] != "none"]
    lines += ["", "Limits exceeded:" if bad else "No limit exceeded.", ""]
    for r in bad:
        lines.append(f"- {_run_label(r).replace('<br>', ' at ')}: {r['limits_exceeded']}")
    lines += ["", "Limits: motor speed 25 000 rpm (maxon); peak current 25 A (EPOS2 70/10); rms current: the motor's "
              "nominal current (nominal torque / k) or the driver's 10 A, whichever is lower; motor voltage: 0.9 "
              "of the supply (EPOS2 output). Energies are integrated over the last simulated stride."]
    return "\n".join(lines) + "\n"


def write_sankeys(results, out_dir: Path) -> list[Path]:
    """One PNG per model (``sankey_<model>.png``), a panel per condition, all on one scale."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from acausal.results.sankey import sankey

    from ..reporting.sankey import LABELS, loss_names_from_groups

    paths = []
    scale = 1.0 / max(max(r.energy["source"] for r in results), 1e-9)
    for m in dict.fromkeys(r.condition.model for r in results):
        runs = [r for r in results if r.condition.model == m]
        fig, axes = plt.subplots(1, len(runs), figsize=(7 * len(runs), 5.2), squeeze=False)
        link = "parallel spring" if m == "parallel_elastic" else "series link"
        names = loss_names_from_groups(runs[0].stages, link=link)
        for ax, r in zip(axes[0], runs):
            c, e = r.condition, r.energy
            where = (f"{c.P * 1e3:g} mm, " if spec(m).uses_precompression else "") + f"{c.stride_time:g} s/stride"
            labels = LABELS if m not in NO_SERIES_LINK else {**LABELS, "link": "gear output (link)"}
            sankey(ax, e, scale=scale, labels=labels, loss_names=names,
                   lossless_note=f"output loss 0 J\n({link}\nconservative)" if e["output"] > 0 else "",
                   title=f"{m} ({where}):\n{e['source']:.1f} J from the source, {e['output']:.1f} J to the joint")
        # wrapped: a title wider than the figure was cut at its edges
        fig.suptitle(textwrap.fill(f"{m}: {spec(m).summary} (arrow widths proportional to J per stride)",
                                   width=int(16 * len(runs) + 40)), fontsize=10)
        fig.tight_layout()
        path = Path(out_dir) / f"sankey_{m}.png"
        fig.savefig(path, dpi=100)
        plt.close(fig)
        paths.append(path)
    return paths


def settings(results) -> str:
    """What the runs were made with, read from their conditions: the preset and each model's ``--set`` values (so
    that a table can be reproduced from its own file)."""
    presets = sorted({r.condition.preset for r in results})
    lines = [f"Preset: {', '.join(f'`{p}`' for p in presets)}."]
    sets = {}
    for r in results:
        sets.setdefault(r.condition.model, dict(r.condition.overrides))
    given = {m: o for m, o in sets.items() if o}
    if given:
        lines += [f"- `--set {m}:{k}={v:g}`" for m, o in given.items() for k, v in sorted(o.items())]
    else:
        lines.append("No `--set` values: every parameter at the preset's value.")
    return "\n".join(lines) + "\n\n"


def write_outputs(results, out_dir) -> dict:
    """Write ``compare.csv``, ``compare.md`` and the Sankey PNGs into ``out_dir``; returns their paths."""
    from ..reporting.tables import write_csv

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = records(results)
    csv_path = write_csv(out_dir / "compare.csv", rows)
    md_path = atomic_write_text(out_dir / "compare.md", "# acausal compare\n\n" + settings(results) + markdown(rows))
    return {"csv": csv_path, "markdown": md_path, "sankey": write_sankeys(results, out_dir)}


# ------------------------------------------------------------------------------------------------ CLI
def configure(parser) -> None:
    """Add the ``compare`` verb's arguments to ``parser`` (an argparse (sub)parser) and set ``run``."""
    parser.add_argument("models", nargs="*", metavar="MODEL", help="registered model names (see --list)")
    parser.add_argument("--stride-time", dest="stride_times", nargs="+", type=float, metavar="S",
                        default=None, help=f"stride times in s (default: {DEFAULT_STRIDE_TIMES[0]:g})")
    parser.add_argument("--precompression", dest="precompressions", nargs="+", type=float, metavar="P",
                        default=None, help="MACCEPA precompressions in mm, 0-18 (default: 8); models without "
                        "a precompression run once per stride time")
    parser.add_argument("--preset", default="library", help="parameter preset (default: library)")
    parser.add_argument("--set", dest="sets", action="append", default=[], metavar="[MODEL:]NAME=VALUE",
                        help="set a parameter, in SI units (m, s, ohm, ...; the only mm here is --precompression), "
                        "for every compared model that has it, or for MODEL only; repeatable")
    parser.add_argument("--out", help="output directory (created if missing); required unless --list")
    parser.add_argument("--jobs", type=whole_number("--jobs"), default=None, help="worker processes (default: all "
                        "cores)")
    parser.add_argument("--list", action="store_true", help="list the known models and exit")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    parser.set_defaults(run=run)


def parse_sets(sets: list, models: list) -> dict:
    """``--set [MODEL:]NAME=VALUE`` arguments as ``{model: {parameter: value}}``: each for every model among
    ``models`` that has the parameter (or for MODEL only); a ModelError naming the argument when it is malformed,
    its model is not compared, or no compared model has the parameter."""
    from ..ankle.protocol import compiled

    out: dict = {}
    seen: dict = {}
    for item in sets:
        target, sep, value = item.partition("=")
        model, _, name = target.rpartition(":") if ":" in target else ("", "", target)
        if not sep or not name:
            raise ModelError(f"--set {item!r}: expected [MODEL:]NAME=VALUE, e.g. --set motor.R=0.4")
        if (model, name) in seen:
            raise ModelError(f"--set {target}: given twice ({seen[model, name]!r} and {item!r}); give each once")
        seen[model, name] = item
        try:
            number = float(value)
        except ValueError:
            raise ModelError(f"--set {item!r}: the value {value!r} is not a number (SI units)") from None
        if model and model not in models:
            raise ModelError(f"--set {item!r}: model {model!r} is not among the compared models {models}")
        targets = [model] if model else list(models)
        having = [m for m in targets if compiled(m).sim.has_parameter(name)]
        if not having:
            sim = compiled(targets[0]).sim
            raise ModelError(f"--set {item!r}: {sim.unknown_name_error(name, 'parameter', sim.param_names)}")
        for m in having:
            compiled(m).sim.param_vector({name: number})  # its bounds, and not bound to other parameters
            out.setdefault(m, {})[name] = number
    return out


def list_models() -> str:
    width = max(len(n) for n in MODELS)
    return "\n".join(f"{n:<{width}}  {s.summary}" for n, s in MODELS.items())


def run(args) -> int:
    """Run ``acausal compare`` from parsed arguments; 0 on success, 2 on bad input (message on stderr)."""
    if args.list:
        print(list_models())
        return 0
    try:
        if not args.models:
            raise ModelError(f"acausal compare: name at least one model; known models: {', '.join(MODELS)}")
        if not args.out:
            raise ModelError("acausal compare: --out DIR is required")
        Ps_mm = args.precompressions or [DEFAULT_PRECOMPRESSIONS[0] * 1e3]
        for P in Ps_mm:
            if not 0.0 <= P <= 18.0:
                raise ModelError(f"acausal compare: --precompression is in mm (0-18), got {P:g}")
            if 0.0 < P < 0.1:
                raise ModelError(f"acausal compare: --precompression is in mm (0-18), got {P:g}: did you mean "
                                 f"{P * 1e3:g} mm?")
        Ts = args.stride_times or list(DEFAULT_STRIDE_TIMES)
        conditions(args.models, Ts, [P * 1e-3 for P in Ps_mm], args.preset)  # validate before starting workers
        overrides = parse_sets(args.sets, args.models)
        t0 = time.perf_counter()
        results = run_models(args.models, Ts, [P * 1e-3 for P in Ps_mm], preset=args.preset, jobs=args.jobs,
                             progress=not args.no_progress, overrides=overrides)
        paths = write_outputs(results, args.out)
    except ModelError as exc:
        print(f"acausal compare: {exc}" if not str(exc).startswith("acausal compare") else str(exc),
              file=sys.stderr)
        return 2
    rows = records(results)
    bad = [r for r in rows if r["limits_exceeded"] != "none"]
    print(f"acausal compare: {len(results)} runs in {time.perf_counter() - t0:.1f} s; "
          f"{len(bad)} exceed a limit" + (" (flagged in the table)" if bad else ""), file=sys.stderr)
    print(f"table: {paths['markdown']}")
    return 0
