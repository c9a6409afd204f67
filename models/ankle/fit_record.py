"""The record of an inference (``paper_fit.json``, :mod:`acausal.models.ankle.inference`): writing it, its tables
(``inference.md``: unknowns, targets, the planner tolerance's and the feed-forward's trials) and the claims it was
fitted to. Readers of a record need nothing of the fit itself.
"""
from __future__ import annotations

import csv
import json
from pathlib import Path

from acausal.results.files import atomic_write_text


def write(record: dict, path: Path) -> Path:
    return atomic_write_text(path, json.dumps(record, indent=1, sort_keys=True) + "\n")  # never half a record


def markdown(record: dict) -> str:
    """The inferred parameters (value, standard deviation, range, identified, source) and the targets met, as
    markdown tables (the report's and README's "inferred parameters")."""
    from ..reporting.tables import md_table

    fixed = {k: v for k, v in record["preset"].items() if k not in {u["parameter"] for u in record["unknowns"]}}

    def span(u):
        return f"{u['lo']:g}-{u['hi']:g}" + (f" {u['unit']}" if u["unit"] != "1" else "")

    rows = [[f"`{u['parameter']}`", f"{u['value']:.4g}", f"{u['sd']:.2g}", span(u),
             f"{u['start']:g}", "yes" if u["identified"] else "**no**", u["source"]] for u in record["unknowns"]]
    rows += [[f"`{k}`", f"{v:.4g}", "-", "chosen for C8", "-", "-",
              "the smallest planner tolerance with which the motor follows where the paper says it does "
              "(trials below)"] for k, v in fixed.items()]
    targets = [[t["target"], f"{'> ' if t.get('bound') == 'lower' else ''}{t['paper']:.4g}", f"{t['simulated']:.4g}",
                f"{t['sigma']:g}{' (log)' if t['relative'] else ''}", f"{t['z']:+.1f}"] for t in record["targets"]]
    trials = [[f"{t['tolerance']:g}", f"{t['follows']}/36", f"{t['duty_18mm_1p2s']:.2f}", f"{t['duty_18mm_3s']:.2f}",
               "yes" if t["holds"] else "no"] for t in record.get("tolerance_trials", [])]
    out = ["Unknowns (standard deviation: linearised, from the weighted Jacobian; identified: sd below a quarter "
           "of the range and not on a bound):", "",
           md_table(["parameter", "value", "sd", "range", "a priori", "identified", "range's source"], rows), "",
           f"Targets (z = weighted residual; cost {record['cost']:.2f} after {record['evaluations']} evaluations, "
           f"started from: {record.get('started_from', 'a priori')}):",
           "", md_table(["target", "paper", "simulated", "sigma", "z"], targets)]
    if trials:
        out += ["", "Planner torque tolerance for C8 (required duty at 18 mm):", "",
                md_table(["tolerance [N m]", "follows", "1.2 s/stride", "3 s/stride", "C8 holds"], trials)]
    ff = record.get("feed_forward_trials", [])
    if ff:
        out += ["", "The bench controller's feed-forward fraction against the losses of Figs. 11-12 (the other values "
                "as fitted; paper: output loss about 20 % on average and over 50 % at worst, gearing loss never "
                "under 50 % and over 65 % at high precompression and short strides):", "",
                md_table(["k_ff", "output loss mean", "output loss worst", "gearing loss min",
                          "gearing loss corner", "largest arm lag [rad]"],
                         [[f"{t['k_ff']:g}", f"{100 * t['output_loss_mean']:.1f} %",
                           f"{100 * t['output_loss_worst']:.1f} %", f"{100 * t['gearing_loss_min']:.1f} %",
                           f"{100 * t['gearing_loss_corner']:.1f} %", f"{t['tracking_max_rad']:.3f}"] for t in ff])]
    return "\n".join(out) + "\n"


def write_tables(record: dict, out_dir: Path) -> Path:
    """``inference.md`` in ``out_dir``."""
    path = Path(out_dir) / "inference.md"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("# Inference of the unpublished parameters (`paper_fit`)\n\n" + markdown(record))
    return path


#: a fitted value closer than this fraction of its range to a bound needs a physical reason (``bound_reason``)
NEAR_BOUND = 0.05


def place(u: dict) -> float:
    """Where an unknown's value lies in its range: 0 at the lower bound, 1 at the upper."""
    return (u["value"] - u["lo"]) / (u["hi"] - u["lo"])


def near_bounds(record: dict) -> list[dict]:
    """The unknowns within :data:`NEAR_BOUND` of a bound of their range: parameter, place in the range, which
    bound, and the record's physical reason for it (``bound_reason``; "" where the record gives none)."""
    out = []
    for u in record["unknowns"]:
        f = place(u)
        if f < NEAR_BOUND or f > 1 - NEAR_BOUND:
            out.append(dict(parameter=u["parameter"], place=f, bound="lower" if f < 0.5 else "upper",
                            reason=u.get("bound_reason", "")))
    return out


def bounds_markdown(record: dict) -> str:
    """Every fitted value: its place in its range, whether it is within :data:`NEAR_BOUND` of a bound and the reason
    the record gives (else flagged "on a bound, no reason"), and its identifiability (``identified``, ``sd``)."""
    from ..reporting.tables import md_table

    near = {b["parameter"]: b for b in near_bounds(record)}

    def said(u):
        b = near.get(u["parameter"])
        if b is None:
            return "no"
        return f"{b['bound']}: " + (b["reason"] if b["reason"] else "**on a bound, no reason**")

    rows = [[f"`{u['parameter']}`", f"{u['value']:.4g}", f"{100 * place(u):.1f} %", said(u),
             "yes" if u["identified"] else "**no**", f"{u['sd']:.2g} ({100 * u['sd'] / (u['hi'] - u['lo']):.0f} % "
             "of the range)"] for u in record["unknowns"]]
    return md_table(["parameter", "value", "place in its range", f"within {100 * NEAR_BOUND:g} % of a bound",
                     "identified", "sd"], rows)


#: the trial fits shipped beside the record (``acausal infer --without CLAIM``): ``NAME.json``, the trial's record, and
#: ``NAME_claims.csv``, the claims of ``acausal paper`` run with it as ``paper_fit`` (its rows of that preset)
TRIALS = Path(__file__).with_name("trials")


def trials(folder: Path = TRIALS) -> list[dict]:
    """The shipped trial fits: each its ``name``, the claims it ``left_out``, where it ``started_from``, its
    ``cost`` and its ``claims`` (id -> the trial run's claims row, as text)."""
    out = []
    for path in sorted(Path(folder).glob("*.json")):
        record = json.loads(path.read_text())
        with path.with_name(f"{path.stem}_claims.csv").open(newline="") as f:
            rows = list(csv.DictReader(f))
        out.append(dict(name=path.stem, left_out=record.get("left_out", []), started_from=record["started_from"],
                        cost=record["cost"], record=record, claims={r["id"]: r for r in rows}))
    return out


def fitted_claims(record: dict) -> frozenset:
    """The ids of the claims an inference record was fitted to (its targets' claims, and C8 when it chose the
    planner's tolerance for it)."""
    return frozenset({t["claim"] for t in record["targets"]} | ({"C8"} if record.get("tolerance_trials") else set()))
