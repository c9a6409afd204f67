"""Physical plausibility of a recording: the pieces a format's ``checks`` (:class:`~.recordings.RecordingFormat`)
are made of. Each returns what is wrong, naming the column and file line or the JSON key, or None. A value outside
the range a rig can produce is a unit slip (ms, mV, g, mm, degrees) or a broken sensor, not physics.
"""
from __future__ import annotations

import numpy as np


def line_of(mask) -> int:
    """The file line (header = 1) of the first row where ``mask`` holds."""
    return int(np.argmax(mask)) + 2


def sample_interval(t, bounds, sampled: str) -> str | None:
    """The median interval of the time column ``t`` against ``bounds`` [s]; ``sampled`` says what samples how
    (e.g. "a servo log is polled")."""
    if np.size(t) < 2:
        return None
    dt = float(np.median(np.diff(t)))
    lo, hi = bounds
    if lo <= dt <= hi:
        return None
    return (f"column 'time_s': the samples are {dt:.4g} s apart (median); {sampled} every {lo:g}-{hi:g} s: is the "
            "time in another unit (ms, us)?")


def column_range(columns: dict, name: str, bounds, unit: str, hint: str) -> str | None:
    """The first value of column ``name`` outside ``bounds`` [``unit``], with ``hint`` (what it likely is)."""
    v = columns[name]
    lo, hi = bounds
    bad = (v < lo) | (v > hi)
    if not bad.any():
        return None
    return f"line {line_of(bad)}, column {name!r}: {v[bad][0]:g} {unit}, outside {lo:g} to {hi:g}: {hint}"


def key_range(meta: dict, key: str, bounds, hint: str) -> str | None:
    """The JSON key ``key`` (where given) outside ``bounds``, with ``hint``."""
    lo, hi = bounds
    if key not in meta or lo <= meta[key] <= hi:
        return None
    return f"key {key!r} = {meta[key]:g}: outside {lo:g}-{hi:g} ({hint})"


def first(*findings) -> str | None:
    """The first finding that is not None."""
    return next((f for f in findings if f is not None), None)
