"""CSV files and markdown tables for every report (``acausal paper``, ``fit``, ``diagnose``, ``compare``)."""
from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np

from acausal.results.files import atomic_write_text


def write_csv(path: Path, rows: list[dict]) -> Path:
    """Rows of dictionaries (same keys) as CSV; floats with enough digits to re-plot."""
    buf = io.StringIO(newline="")
    w = csv.DictWriter(buf, fieldnames=list(rows[0]))
    w.writeheader()
    for row in rows:
        w.writerow({k: (f"{v:.9g}" if isinstance(v, (float, np.floating)) else v) for k, v in row.items()})
    return atomic_write_text(path, buf.getvalue())  # an interrupted run leaves the old table, never half of one


def write_verdict(path, diagnosis) -> Path:
    """A diagnosis's machine-readable verdict (:meth:`~acausal.identify.diagnose.Diagnosis.to_dict`) as JSON."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(diagnosis.to_dict(), indent=2, default=float, allow_nan=False) + "\n")
    return path


def write_columns(path: Path, columns: dict, constants: dict | None = None) -> Path:
    """Equal-length columns (time series) as CSV, after ``constants`` (columns with one value, e.g. the preset)."""
    keys = list(columns)
    n = len(columns[keys[0]])
    return write_csv(path, [{**(constants or {}), **{k: float(columns[k][i]) for k in keys}} for i in range(n)])


def md_table(header: list, rows: list[list]) -> str:
    """A markdown table; numbers with 4 significant digits, strings as they are."""
    def cell(v):
        return v if isinstance(v, str) else f"{v:.4g}"
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in rows]
    return "\n".join(lines)


def pct(v: float, digits: int = 1) -> str:
    """A fraction as percent, without a '-0.0 %' for round-off."""
    v = 0.0 if abs(v) < 0.5 * 10 ** -(digits + 2) else v
    return f"{100 * v:.{digits}f} %"
