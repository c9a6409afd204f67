"""Sample screening: the samples of a recording that no sensor or motion can produce, found from what its format
declares, masked and named. The raw file is never touched.

The kinds, in the order they are looked for (each on the samples the earlier ones left):

* **time**: a row whose time repeats the row before's, or that is out of order (off the longest strictly
  increasing run of the time column: a late row, or one stamped far ahead), is left out whole;
* **not a number**: an empty, NaN or inf cell;
* **dropout**: a row where every channel of ``RecordingFormat.dropout`` that the file has reads exactly 0 (a logger
  that lost a read writes zeros): every declared column of the row is masked;
* **out of range**: a value outside its column's ``Column.bounds`` (a supply reading of 0 V between 7.3 V ones);
* **jump**: a sample farther from the straight line through its neighbours than the column's ``Column.max_accel``
  allows (plus six robust standard deviations of the column's own scatter about that line), or reached and left
  faster than its ``Column.max_rate`` (an encoder read error: exactly -pi between readings near 0). The worst is
  masked first and its neighbours judged again without it, so one glitch masks one sample; a reading that jumps
  and stays (more than :data:`GLITCH_RUN` samples) has stepped, and the recording is left out.

Glitches are few. Values out of range at more than ``RecordingFormat.max_masked`` of a column's samples, and any
other kind at more than half of them, are no glitches but the recording: the loader and the format's own checks
refuse it, naming file and column (degrees for radians, a dead supply, a column of text, a time column out of
order). A recording with more than ``max_masked`` of its rows masked in all, or whose reading jumps and stays, is
left out with the reason (:class:`LeftOut`); the set goes on without it. ``strict``: the first finding is a
:class:`~acausal.errors.DataError` naming the line and column, as before any screening.

A masked cell holds the unmasked sample before it (the one after, at the start): what a replay reads from an input
column is held across it; ``Recording.masks`` marks the masked cells, and a fitted signal's masked samples are left
out of the residual.
"""
from __future__ import annotations

from bisect import bisect_left
from dataclasses import dataclass

import numpy as np

from ..errors import DataError

#: the most samples in a row a glitch spans: a reading that stays off longer has stepped (masking more would make a
#: step look like fast motion across the masked samples)
GLITCH_RUN = 3
#: a jump is a deviation from the neighbours' line beyond the physical allowance plus this many robust standard
#: deviations (1.4826 x the median absolute deviation) of the column's deviations
SCATTER_SIGMAS = 6.0


@dataclass(frozen=True)
class MaskedSample:
    """One sample left out: the file ``line`` (header = 1), the ``column`` (empty for a dropout: the whole row's
    readings; the time column for a row left out), its time, its ``kind`` and why (a sentence)."""

    recording: str
    line: int
    column: str
    t: float
    kind: str  # "time", "not a number", "dropout", "out of range", "jump" or "gap" (a recording split there)
    why: str

    def sentence(self) -> str:
        if self.kind == "time":
            return f"{self.recording}, line {self.line}: {self.why}; the row is left out"
        if not self.column:
            return f"{self.recording}, line {self.line} (t = {self.t:.6g} s): {self.why}"
        return f"{self.recording}, line {self.line}, column {self.column!r} (t = {self.t:.6g} s): {self.why}"

    def to_dict(self) -> dict:
        return {"recording": self.recording, "line": self.line, "column": self.column, "t": self.t, "kind": self.kind,
                "why": self.why}


class LeftOut(DataError):
    """A recording too damaged to use: more than the format's share of it masked. :func:`~.recordings.
    load_recordings` leaves it out of the set and keeps the reason (``RecordingSet.left_out``)."""

    def __init__(self, recording: str, path, why: str):
        super().__init__(f"{path}: left out: {why}")
        self.recording, self.path, self.why = recording, path, why

    def to_dict(self) -> dict:
        return {"recording": self.recording, "file": str(self.path), "why": self.why}


@dataclass
class Screened:
    """What :func:`screen` found in one recording: the rows kept, the masked cells of each column (over the kept
    rows), and every masked sample named."""

    keep: np.ndarray
    masks: dict
    masked: list
    data: np.ndarray  # the rows kept, masked cells repaired
    #: why the recording is too damaged to use (the loader leaves it out after the format's checks, which refuse a
    #: recording wrong as a whole first); None: it is used
    left_out: str | None = None


def screen(path, name: str, header: list, data: np.ndarray, fmt, strict: bool = False) -> Screened:
    """Screen the parsed rows ``data`` (one column per ``header`` name; NaN where a cell was empty) of recording
    ``name`` in file ``path`` against format ``fmt`` (see the module docstring)."""
    n = data.shape[0]
    limit = max(1, int(fmt.max_masked * n))  # more masked in all: the recording is left out
    whole = n // 2  # more of one kind in one column: the recording is wrong as a whole, and refused
    col = {h: j for j, h in enumerate(header)}
    found: list = []

    def refuse_or_keep(sample: MaskedSample):  # strict: dropouts and jumps (the loader refuses the other kinds)
        if strict:
            where = f", column {sample.column!r}" if sample.column else ""
            raise DataError(f"{path}, line {sample.line}{where}: {sample.why} (--strict: a sample "
                            "that cannot be physical refuses the recording; without it, it is masked and named)")
        found.append(sample)

    # time: left out whole (strict: the loader refuses it, naming the line, as it always has)
    tj = col[fmt.time_column]
    t = data[:, tj]
    lines = np.arange(n) + 2
    keep = np.isfinite(t)
    order = _increasing(t, keep)
    if not (keep & order).all() and (strict or n - (keep & order).sum() > whole):
        return Screened(np.ones(n, dtype=bool), {}, [], data)  # not glitches (or strict): the loader refuses it
    if not (keep & order).all():
        for r in np.flatnonzero(~keep):
            found.append(MaskedSample(name, int(lines[r]), fmt.time_column, float("nan"), "time",
                                      f"time {_cell(t[r])} is not a number"))
        on = np.flatnonzero(order)
        for r in np.flatnonzero(keep & ~order):
            j = int(np.searchsorted(on, r)) - 1  # the row before it that stays
            before = float(t[on[j]]) if j >= 0 else float("nan")
            what = ("repeats" if t[r] == before else "goes back" if t[r] < before else
                    "jumps ahead of the rows after it")
            found.append(MaskedSample(name, int(lines[r]), fmt.time_column, float(t[r]), "time",
                                      f"time {what} ({float(t[r])!r} after {before!r})"))
        keep &= order
    data = data[keep]
    lines, t = lines[keep], data[:, tj]
    declared = [c for c in fmt.columns if c.name != fmt.time_column]
    masks = {h: np.zeros(t.size, dtype=bool) for h in header if h != fmt.time_column}

    def mask(column: str, rows, kind: str, why):
        for r in rows:
            masks[column][r] = True
            refuse_or_keep(MaskedSample(name, int(lines[r]), column, float(t[r]), kind, why(r)))

    for h in masks if not strict else ():  # not a number (strict, or beyond the share: the loader refuses it)
        v = data[:, col[h]]
        bad = np.flatnonzero(~np.isfinite(v))
        if 0 < bad.size <= whole:
            mask(h, bad, "not a number", lambda r, v=v: f"{_cell(v[r])} is not a number")
    present = [h for h in fmt.dropout if h in col]
    if present:
        zero = np.all(data[:, [col[h] for h in present]] == 0.0, axis=1)
        if 0 < zero.sum() <= whole:
            reads = ", ".join(present)
            for r in np.flatnonzero(zero):
                for c in declared:
                    masks[c.name][r] = True
                refuse_or_keep(MaskedSample(name, int(lines[r]), "", float(t[r]), "dropout",
                                            f"a logging dropout ({reads} read 0 together): the row's readings are "
                                            "masked"))
    for c in declared if not strict else ():  # strict: the format's checks refuse it, as they always have
        if c.bounds is None:
            continue
        v, lo, hi = data[:, col[c.name]], *c.bounds
        out = np.flatnonzero(((v < lo) | (v > hi)) & ~masks[c.name])
        if 0 < out.size <= limit:  # more: a unit slip or a dead sensor, which the format's checks refuse
            mask(c.name, out, "out of range",
                 lambda r, v=v, c=c: f"{v[r]:g} {c.unit} outside {c.bounds[0]:g} to {c.bounds[1]:g}, where the rest "
                                     "of the column is")
    reason = None
    for c in declared:
        if c.max_accel is None and c.max_rate is None:
            continue
        rows, why, step = _jumps(t, data[:, col[c.name]], masks[c.name], c, limit)
        if step is not None:
            reason = (f"column {c.name!r} jumps near line {lines[step]} (t = {t[step]:.6g} s) and does not come back "
                      f"within {GLITCH_RUN} samples: a step no motion within its {_limits(c)} makes (a re-zeroed or "
                      "slipping sensor, a cut in the file); not a glitch")
        elif len(rows) > limit:
            reason = (f"column {c.name!r} jumps by more than its {_limits(c)} allow at more than "
                      f"{fmt.max_masked:.0%} of its samples (the first at line {lines[rows[0]]}): not glitches but the "
                      "recording; check the sensor and the column's unit")
        else:
            mask(c.name, rows, "jump", lambda r, why=why: why[r])
    rows = np.zeros(t.size, dtype=bool)
    for c in declared:
        rows |= masks[c.name]
    dropped = int(n - keep.sum())
    if reason is None and dropped + rows.sum() > limit:  # each kind within its share, too many in all
        reason = (f"{dropped + int(rows.sum())} of its {n} rows masked ({'; '.join(sorted({s.kind for s in found}))}):"
                  f" more than the format's {fmt.max_masked:.0%}")
    for c, m in masks.items():
        if m.any():
            _repair(data[:, col[c]], m)
    return Screened(keep, {c: m for c, m in masks.items() if m.any()}, found, data, reason)


def _cell(v: float) -> str:
    return "empty or NaN" if np.isnan(v) else repr(float(v))


def _increasing(t: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """The rows of the longest strictly increasing run of ``t`` over the rows ``ok`` (a row repeating the time
    of the row before it is never on it: the later of two is left out)."""
    idx = np.flatnonzero(ok)
    if idx.size and np.all(np.diff(t[idx]) > 0):
        return ok.copy()
    idx = np.array([i for k, i in enumerate(idx) if k == 0 or t[i] != t[idx[k - 1]]], dtype=int)
    tails, tail_at, back = [], [], np.full(idx.size, -1)
    for k, i in enumerate(idx):
        p = bisect_left(tails, t[i])
        if p == len(tails):
            tails.append(t[i])
            tail_at.append(k)
        else:
            tails[p], tail_at[p] = t[i], k
        back[k] = tail_at[p - 1] if p else -1
    on = np.zeros(t.size, dtype=bool)
    k = tail_at[-1] if tail_at else -1
    while k >= 0:
        on[idx[k]] = True
        k = back[k]
    return on


def _jumps(t, v, masked, c, limit) -> tuple:
    """The samples of column ``c`` (values ``v``, already masked ``masked``) that jump (module docstring), worst
    first, each judged against its unmasked neighbours; stops past ``limit``, or at a run of more than
    :data:`GLITCH_RUN` masked samples in a row. Returns (rows, row -> why, the first row of such a run or None)."""
    live = ~masked & np.isfinite(v)
    rows, why = [], {}
    scatter = None
    while len(rows) <= limit:
        k = np.flatnonzero(live)
        if k.size < 4:
            break
        tk, vk = t[k], v[k]
        # neighbours: both sides inside; the two on the inner side at the ends
        i = np.r_[1, np.arange(k.size - 2), k.size - 3]
        j = np.r_[2, np.arange(2, k.size), k.size - 2]
        ti, tj, vi, vj = tk[i], tk[j], vk[i], vk[j]
        line = vi + (vj - vi) * (tk - ti) / (tj - ti)
        dev = np.abs(vk - line)
        if scatter is None:
            d = vk - line
            scatter = SCATTER_SIGMAS * 1.4826 * float(np.median(np.abs(d - np.median(d))))
        excess = np.zeros(k.size)
        if c.max_accel is not None:
            excess = np.maximum(excess, dev / (c.max_accel * np.abs(tk - ti) * np.abs(tk - tj) / 2 + scatter))
        if c.max_rate is not None:
            rin, rout = (vk - vi) / (tk - ti), (vj - vk) / (tj - tk)
            inner = np.r_[False, np.ones(k.size - 2, dtype=bool), False]
            spike = inner & (np.sign(rin) != np.sign(rout))
            excess = np.maximum(excess, np.where(spike, np.minimum(np.abs(rin), np.abs(rout)) / c.max_rate, 0.0))
        w = int(np.argmax(excess))
        if excess[w] <= 1.0:
            break
        r = int(k[w])
        rows.append(r)
        why[r] = (f"{v[r]:g} {c.unit}, {dev[w]:.3g} {c.unit} off the line through its neighbours: a jump no motion "
                  f"within the column's {_limits(c)} makes")
        live[r] = False
        lo, hi = r, r
        while lo > 0 and not live[lo - 1] and np.isfinite(v[lo - 1]):
            lo -= 1
        while hi < v.size - 1 and not live[hi + 1] and np.isfinite(v[hi + 1]):
            hi += 1
        if hi - lo + 1 > GLITCH_RUN:  # the reading does not come back: a step, not a glitch
            return sorted(rows), why, lo
    return sorted(rows), why, None


def _limits(c) -> str:
    parts = ([f"acceleration of {c.max_accel:g} {c.unit}/s^2"] if c.max_accel is not None else []) + \
        ([f"speed of {c.max_rate:g} {c.unit}/s"] if c.max_rate is not None else [])
    return " and ".join(parts)


def _repair(v, masked):
    """``v`` at the ``masked`` samples replaced by the unmasked sample before (after, at the start), in place: a
    real reading, so a reading's step (the smallest change between samples) is never made smaller."""
    good = np.flatnonzero(~masked)
    before = np.searchsorted(good, np.flatnonzero(masked)) - 1
    v[masked] = v[good[np.maximum(before, 0)]]
